"""The recording readers by file extension: each reader module imports
``safety_systems.sensing.recording`` (the :class:`Recording` it gives and its checks),
and only this module imports the readers, so a new format is one reader and one entry
in :data:`READERS`."""

from collections.abc import Collection
from pathlib import Path

from safety_systems.files.input_error import InputError
from safety_systems.sensing.bvh_file import UNITS, read_bvh
from safety_systems.sensing.c3d_file import read_c3d
from safety_systems.sensing.motive_csv import read_motive_csv
from safety_systems.sensing.recording import Recording
from safety_systems.sensing.ros_bag import read_bag
from safety_systems.sensing.run_log import is_run_log, read_run_recording


def _read_mcap(path, bodies=None, *, truncated: str = "refuse") -> Recording:
    """An MCAP file: a segment of a live run's log (its Header names this project's
    writer) or a rosbag2 bag's (anything else: its reader says what it needs)."""
    reader = read_run_recording if is_run_log(path) else read_bag
    return reader(path, bodies, truncated=truncated)


FOLDER = "/"  # the key of a recording that is a folder (a rosbag2 bag)
# extension (lower case) -> (reader, what the file is, in words)
READERS = {
    ".csv": (read_motive_csv, "a Motive CSV export (.csv)"),
    ".c3d": (read_c3d, "a C3D file (.c3d)"),
    ".bvh": (read_bvh, "a BVH file (.bvh)"),
    ".mcap": (_read_mcap, "a ROS bag (a rosbag2 folder, .mcap, .db3 or .bag) or a "
                          "segment of a live run's log (.mcap)"),
    ".db3": (read_bag, "a ROS bag (a rosbag2 folder, .mcap, .db3 or .bag)"),
    ".bag": (read_bag, "a ROS bag (a rosbag2 folder, .mcap, .db3 or .bag)"),
    FOLDER: (read_bag, "a ROS bag (a rosbag2 folder, .mcap, .db3 or .bag)"),
}
UNITLESS = (".bvh",)  # formats that state no length unit: the caller gives it
LENGTH_UNITS = tuple(UNITS)  # the units a caller may give them


def read_recording(path: str | Path, bodies: Collection[str] | None = None, *,
                   truncated: str = "refuse", units: str = "") -> Recording:
    """A recording by its file's extension (:data:`READERS`); raises InputError.
    ``bodies``: the names to read (None: all), so that the limits on bodies and their
    names apply to those only; ``truncated``: what a file cut short gives ("refuse", or
    "use" its frames, with a warning), where the format says how long it should be;
    ``units``: the length unit of a format that states none (:data:`UNITLESS`), and
    only there."""
    suffix = FOLDER if Path(path).is_dir() else Path(path).suffix.lower()
    reader = READERS.get(suffix)
    if reader is None:
        raise InputError("path", str(path), "a recording: " + " or ".join(
            sorted({what for _, what in READERS.values()})))
    if suffix in UNITLESS:
        return reader[0](path, bodies, truncated=truncated, units=units)
    if units:
        raise InputError("units", units, f"empty for {reader[1]}: it states its own unit",
                         file=str(path))
    return reader[0](path, bodies, truncated=truncated)
