"""BVH files (Biovision hierarchy: CMU's motion-capture library and its conversions),
read with ``bvhio``.

A BVH file holds a skeleton (joints, each an offset from its parent and rotation
channels, the root also position channels) and one row of channel values per frame.
Every joint is a body, at its world position (``bvhio`` composes the hierarchy's offsets
and rotations in the file's channel order); its orientation is not read (NaN, as a
marker's: the runtime and the monitor use positions); an ``End Site`` is not a joint
and is not read. Times are frame number times ``Frame Time``. A BVH file
states no length unit: the caller gives it (``units``: a mapping's ``units``, m, cm, mm
or in; CMU's conversions are commonly in inches times a scale the converter chose, so
check a known length, such as a forearm, before trusting one).
"""

import math
from collections.abc import Collection
from pathlib import Path

import numpy as np

from safety_systems.files.documents import read_input
from safety_systems.files.input_error import InputError
from safety_systems.sensing.recording import MAX_SAMPLES, Recording, check_recording

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254}
MAX_BYTES = 512 * 1024 * 1024


def read_bvh(path: str | Path, bodies: Collection[str] | None = None, *,
             truncated: str = "refuse", units: str = "") -> Recording:
    """Reads a BVH file's joints (see the module docstring; ``bodies``: the joint names to
    read, None: all); raises InputError. ``truncated`` is not used: a BVH file's
    ``Frames:`` line is checked against its rows by the library."""
    try:
        return _read_bvh(str(path), bodies, units)
    except InputError as e:  # the format named in every refusal
        field = e.field if e.field.startswith("BVH") else f"BVH: {e.field}"
        raise InputError(field, e.value, e.allowed, file=e.file) from None


def _read_bvh(file: str, bodies: Collection[str] | None, units: str) -> Recording:
    import bvhio

    path = file
    if units not in UNITS:
        raise InputError("units", units or "missing", "the BVH file's length unit (a BVH "
                         "file states none): " + " | ".join(UNITS), file=file)
    read_input(path, max_bytes=MAX_BYTES)  # readable, not too large, and remembered
    try:
        container = bvhio.readAsBvh(file)
        root = bvhio.readAsHierarchy(file)
    except Exception as e:  # noqa: BLE001 - the library's own message, as one line
        raise InputError("<file>", " ".join(str(e).split())[:200] or type(e).__name__,
                         "a BVH file", file=file) from None
    frames, step = int(container.FrameCount), float(container.FrameTime)
    if not (math.isfinite(step) and 0.0 < step <= 10.0):
        raise InputError("Frame Time", step, "seconds per frame, above 0 and at most 10",
                         file=file)
    if not 2 <= frames <= MAX_SAMPLES:
        raise InputError("Frames", frames, f"2 to {MAX_SAMPLES:,} frames", file=file)
    joints = [j for j, _, _ in root.layout()]
    names = [j.Name for j in joints]
    wanted = None if bodies is None else set(bodies)
    keep = [i for i, n in enumerate(names) if wanted is None or n in wanted]
    if not keep:
        raise InputError("HIERARCHY", f"no joint named {sorted(bodies or ())}",
                         f"joints of the file: {names[:20]}", file=file)
    positions = np.empty((frames, len(keep), 3))
    for f in range(frames):
        root.loadPose(f)
        for k, i in enumerate(keep):
            positions[f, k] = tuple(joints[i].PositionWorld)
    positions *= UNITS[units]
    positions[~np.all(np.isfinite(positions), axis=2)] = np.nan
    return check_recording(Recording(file, np.arange(frames) * step,
                                     tuple(names[i] for i in keep), (0,) * len(keep),
                                     positions, np.full((frames, len(keep), 4), np.nan),
                                     "BVH"))
