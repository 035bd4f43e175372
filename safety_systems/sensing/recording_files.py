"""The recording readers by file extension: each reader module imports
``safety_systems.sensing.recording`` (the :class:`Recording` it gives and its checks),
and only this module imports the readers, so a new format is one reader and one entry
in :data:`READERS`."""

from collections.abc import Collection
from pathlib import Path

from safety_systems.files.input_error import InputError
from safety_systems.sensing.c3d_file import read_c3d
from safety_systems.sensing.motive_csv import read_motive_csv
from safety_systems.sensing.recording import Recording

# extension (lower case) -> (reader, what the file is, in words)
READERS = {
    ".csv": (read_motive_csv, "a Motive CSV export (.csv)"),
    ".c3d": (read_c3d, "a C3D file (.c3d)"),
}


def read_recording(path: str | Path, bodies: Collection[str] | None = None, *,
                   truncated: str = "refuse") -> Recording:
    """A recording by its file's extension (:data:`READERS`); raises InputError.
    ``bodies``: the names to read (None: all), so that the limits on bodies and their
    names apply to those only; ``truncated``: what a file cut short gives ("refuse", or
    "use" its frames, with a warning), where the format says how long it should be."""
    reader = READERS.get(Path(path).suffix.lower())
    if reader is None:
        raise InputError("path", str(path), "a recording: " + " or ".join(
            what for _, what in READERS.values()))
    return reader[0](path, bodies, truncated=truncated)
