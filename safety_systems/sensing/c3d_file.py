"""C3D files of markers (or rigid-body centres exported as points), read with ``ezc3d``.

Every labelled point (``POINT:LABELS``) is a body, with its position only (C3D holds no
orientation; the rotations are NaN) and no streaming id. Units from ``POINT:UNITS``
(``mm``, ``cm`` or ``m``; when the parameter is missing, millimetres, the format's
convention). Sample times from ``POINT:RATE``. A point is untracked in a frame where
ezc3d gives a NaN coordinate or a negative residual (the format's "invalid" mark).
"""

from pathlib import Path

import numpy as np

from safety_systems.files.documents import read_input
from safety_systems.files.input_error import InputError
from safety_systems.sensing.recording import Recording, check_recording

UNITS = {"mm": 0.001, "cm": 0.01, "m": 1.0}
MAX_BYTES = 512 * 1024 * 1024


def _parameter(c3d, name: str) -> list:
    point = c3d["parameters"]["POINT"]
    return list(point[name]["value"]) if name in point else []


def read_c3d(path: str | Path) -> Recording:
    """Reads a C3D file's points (see the module docstring); raises InputError."""
    import ezc3d

    file = str(path)
    read_input(path, max_bytes=MAX_BYTES)  # readable, not too large, and remembered
    try:
        c3d = ezc3d.c3d(file)
    except Exception as e:  # noqa: BLE001 - ezc3d's own message, as one line
        raise InputError("<file>", " ".join(str(e).split()) or type(e).__name__,
                         "a C3D file", file=file) from None
    labels = [str(x).strip() for x in _parameter(c3d, "LABELS")]
    units = [str(x).strip() for x in _parameter(c3d, "UNITS")] or ["mm"]
    if units[0] not in UNITS:
        raise InputError("POINT:UNITS", units[0], " | ".join(UNITS), file=file)
    rate = [float(x) for x in _parameter(c3d, "RATE")]
    if not rate or not np.isfinite(rate[0]) or not 0.0 < rate[0] <= 100_000.0:
        raise InputError("POINT:RATE", rate[:1], "a frame rate in Hz, 0 < rate <= 100000",
                         file=file)
    points = np.asarray(c3d["data"]["points"], dtype=float)  # (4, n, T)
    n, frames = points.shape[1], points.shape[2]
    if len(labels) != n:
        raise InputError("POINT:LABELS", len(labels), f"one label per point ({n})", file=file)
    positions = np.transpose(points[:3], (2, 1, 0)) * UNITS[units[0]]  # (T, n, 3)
    residuals = c3d["data"]["meta_points"].get("residuals")
    if residuals is not None and np.size(residuals) == n * frames:
        invalid = np.transpose(np.asarray(residuals, dtype=float).reshape(n, frames)) < 0.0
        positions[invalid] = np.nan
    positions[~np.all(np.isfinite(positions), axis=2)] = np.nan
    times = np.arange(frames) / rate[0]
    return check_recording(Recording(file, times, tuple(labels), (0,) * n, positions,
                                     np.full((frames, n, 4), np.nan)))
