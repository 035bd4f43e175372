"""C3D files of markers (or rigid-body centres exported as points), read with ``ezc3d``.

Every labelled point (``POINT:LABELS``) is a body, with its position only (C3D holds no
orientation; the rotations are NaN) and no streaming id. Units from ``POINT:UNITS``
(``mm``, ``cm`` or ``m``; when the parameter is missing, millimetres, the format's
convention). Sample times from ``POINT:RATE``. A point is untracked in a frame where
ezc3d gives a NaN coordinate, a negative residual (the format's "invalid" mark) or a
position of exactly (0, 0, 0) (how several vendors store a drop-out).
"""

from collections.abc import Collection
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


def read_c3d(path: str | Path, bodies: Collection[str] | None = None, *,
             truncated: str = "refuse") -> Recording:
    """Reads a C3D file's points (see the module docstring); raises InputError.
    ``bodies``: the labels to read (None: every point), so that the limit on bodies and
    the rule that each is named once apply to those only (real files repeat labels of
    points nobody maps). ``truncated`` is not used: a C3D's frame count is its data's."""
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
    # A point at exactly the origin is a drop-out (ART, Motion Analysis and others store
    # a lost point as 0, 0, 0, with or without an invalid residual), not a position.
    positions[np.all(positions == 0.0, axis=2)] = np.nan
    wanted = None if bodies is None else set(bodies)
    keep = [i for i, x in enumerate(labels) if wanted is None or x in wanted]
    if not keep:
        raise InputError("POINT:LABELS", f"no point named {sorted(bodies or ())}",
                         f"labels of the file: {labels[:20]}", file=file)
    times = np.arange(frames) / rate[0]
    return check_recording(Recording(file, times, tuple(labels[i] for i in keep),
                                     (0,) * len(keep), positions[:, keep],
                                     np.full((frames, len(keep), 4), np.nan)))
