"""The two C3D readers, each as a :class:`Reading` of the same figures: ``ezc3d`` (C++,
pyomeca) and ``c3d`` (py-c3d, pure Python, EmbodiedCognition), independent
implementations of the format. ``safety_systems.sensing.c3d_file`` holds them to the
file's size and to each other.

Neither reader's analog values are used, so neither may refuse a file over them: py-c3d
is read without its analog scaling (which fails on an ``ANALOG:OFFSET`` of another type
than the format's 16-bit integers) and without its header-against-parameters assertions
(the checks are made by ``c3d_file``, naming the file and both figures). ezc3d refuses
SGI/MIPS files and float analog offsets outright; py-c3d reads them.
"""

import dataclasses
import re
import warnings

import numpy as np

from safety_systems.sensing.c3d_header import Layout

LIBRARIES = ("ezc3d", "c3d")  # the readers, by their package names
MAX_LABEL_PARAMETERS = 99  # POINT:LABELS, LABELS2, ... (the format's continuation)


@dataclasses.dataclass(frozen=True, eq=False)
class Reading:
    """What one reader reads from a C3D file."""

    library: str
    layout: Layout  # the data as this reader lays it out (stated frames)
    frames_read: int  # the frames it read (fewer than stated: the file ran out)
    how: str  # the parameters that gave its layout, in words
    labels: tuple[str, ...]  # POINT:LABELS (and LABELS2, ...), every entry, stripped
    units: str  # POINT:UNITS, stripped ('' where not given)
    rate: float  # Hz: POINT:RATE (or the header's, where the reader falls back to it)
    scale: float  # POINT:SCALE as the reader applies it to integers (its sign: storage)
    positions: np.ndarray  # (T, points, 3) in the file's units; NaN where invalid
    vendor: str  # MANUFACTURER:COMPANY, SOFTWARE, VERSION_LABEL, where given
    has_point_group: bool


def _message(e: Exception) -> str:
    """A library's error as one short line, without advice no user can follow (ezc3d's
    'set ignoreBadFormatting to true', 'please open a GitHub issue')."""
    text = " ".join(str(e).split()) or type(e).__name__
    text = re.sub(r"\s*If you want to ignore this error, set ignoreBadFormatting to true",
                  "", text)
    text = re.sub(r",? please open a GitHub issue.*$", "", text)
    return text[:160]


def read_ezc3d(file: str) -> Reading | str:
    """ezc3d's reading of ``file``, or its error in one line."""
    import ezc3d

    try:
        c = ezc3d.c3d(file)
    except Exception as e:  # noqa: BLE001 - the library's own message, as one line
        return _message(e)
    groups = c["parameters"]
    point = groups.get("POINT", {})

    def value(group: dict, name: str) -> list:
        return list(group[name]["value"]) if name in group and "value" in group[name] else []

    labels = [_clean(x) for k in _label_names() for x in value(point, k)]
    pts = np.asarray(c["data"]["points"], dtype=float)  # (4, P, T)
    analogs = np.asarray(c["data"]["analogs"])  # (1, channels, T * samples per frame)
    frames, count = pts.shape[2], pts.shape[1]
    per_frame = analogs.shape[2] // frames if frames else 0
    head = c["header"]["points"]
    stated = int(head["last_frame"]) - int(head["first_frame"]) + 1
    scale = value(point, "SCALE")
    word = 4 if scale and float(scale[0]) < 0.0 else 2
    positions = np.transpose(pts[:3], (2, 1, 0)).copy()
    residuals = c["data"]["meta_points"].get("residuals")
    if residuals is not None and np.size(residuals) == count * frames:
        invalid = np.transpose(np.asarray(residuals, dtype=float).reshape(count, frames)) < 0
        positions[invalid] = np.nan
    rate = value(point, "RATE") or [c["header"]["points"]["frame_rate"]]
    units = value(point, "UNITS")
    maker = groups.get("MANUFACTURER", {})
    vendor = " ".join(_clean(x) for k in ("COMPANY", "SOFTWARE", "VERSION_LABEL")
                      for x in value(maker, k)[:1] if _clean(x))
    how = (f"POINT:USED {count}, {analogs.shape[1]} analog channels x {per_frame} samples "
           "per frame")
    return Reading("ezc3d", Layout(count, analogs.shape[1] * per_frame, stated, word),
                   frames, how, tuple(labels), _clean(units[0]) if units else "",
                   float(rate[0]), float(scale[0]) if scale else 1.0,
                   _nan_invalid(positions), vendor, "POINT" in groups)


def _clean(text) -> str:
    """A C3D string without its padding (spaces, and the NULs some writers pad with)."""
    return str(text).strip(" \x00\t\r\n")


def _label_names() -> list[str]:
    return ["LABELS"] + [f"LABELS{i}" for i in range(2, MAX_LABEL_PARAMETERS + 1)]


def _nan_invalid(positions: np.ndarray) -> np.ndarray:
    positions[~np.all(np.isfinite(positions), axis=2)] = np.nan
    return positions


def read_py_c3d(file: str) -> Reading | str:
    """py-c3d's reading of ``file`` (the ``c3d`` package), or its error in one line."""
    import c3d

    class _Reader(c3d.Reader):
        def _check_metadata(self):  # made by c3d_file, naming the file and both figures
            pass

        def get_analog_transform(self):  # analog values are not used
            return 1.0, 0.0

    try:
        with open(file, "rb") as handle, warnings.catch_warnings():
            warnings.simplefilter("ignore")  # its notes on the file come back as checks
            r = _Reader(handle)
            count, rate = int(r.point_used), float(r.point_rate)
            channels, per_frame = int(r.analog_used), int(r.analog_per_frame)
            stated = int(r.last_frame) - int(r.first_frame) + 1
            scale = float(r.point_scale)
            word = 4 if scale < 0.0 else 2
            frames = [p[:, :4].copy() for _, p, _ in r.read_frames(copy=False)]
            labels = [s for k in _label_names() for s in _strings(r, f"POINT:{k}")]
            units = _strings(r, "POINT:UNITS")
            vendor = " ".join(s for k in ("COMPANY", "SOFTWARE", "VERSION_LABEL")
                              for s in _strings(r, f"MANUFACTURER:{k}")[:1] if s)
            has_point = r.get("POINT") is not None
    except Exception as e:  # noqa: BLE001 - the library's own message, as one line
        return _message(e)
    data = np.array(frames, dtype=float).reshape(len(frames), count, 4)
    positions = data[:, :, :3].copy()
    positions[data[:, :, 3] == -1.0] = np.nan  # the format's invalid mark
    how = (f"POINT:USED {count}, {channels} analog channels x {per_frame} samples per "
           "frame")
    return Reading("c3d", Layout(count, channels * per_frame, stated, word), len(frames),
                   how, tuple(labels), units[0] if units else "", rate, scale,
                   _nan_invalid(positions), vendor, has_point)


def _strings(reader, name: str) -> list[str]:
    """A character parameter's strings, stripped ([] where it is not in the file)."""
    param = reader.get(name)
    if param is None or param.num_elements == 0:
        return []
    if len(param.dimensions) <= 1:
        return [_clean(param.string_value)]
    return [_clean(s) for s in np.ravel(param.string_array)]
