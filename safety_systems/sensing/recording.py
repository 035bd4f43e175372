"""Recorded motion: rigid bodies (or markers) captured over time, and how a recording is
played back as true positions.

A :class:`Recording` is what a reader gives (``safety_systems.sensing.motive_csv`` for
OptiTrack Motive's CSV export, ``safety_systems.sensing.c3d_file`` for C3D; the readers
by file extension: ``safety_systems.sensing.recording_files``): sample times,
body names and streaming ids, positions in the capture frame in metres (NaN where the
body was not tracked) and orientations as unit quaternions (x, y, z, w; NaN where not
tracked or not recorded, as for markers).

Playback (:func:`recorded_state_one`, compiled, the one rule for every user): a body's
true position at recording time tau is the linear interpolation between the samples
around tau, its velocity the slope of that segment (the first sample's at and before
it, the last's after). Where the body was not tracked, the truth is taken as the
straight line between the samples around the gap (the best estimate there is; the
sensor does not see the body then, see :func:`gaps`). A body is present from its first
tracked sample to its last one.

Capture glitches (:func:`flips`): a run of one to ``MAX_FLIP_FRAMES`` tracked samples
that leaves the body's track and comes back to it faster than any body moves (a joint of
a BVH file flipped for a frame, a marker swapped for two) is not motion: the mapping's
reader takes those samples as untracked, as the tracker's gate rejects such an entry
live, so that neither the played truth nor the fastest-body premise moves with them.
"""

import dataclasses
import math

import numba
import numpy as np

from safety_systems.files.input_error import InputError

MAX_SAMPLES = 2_000_000  # rows of a recording (about 4.6 h at 120 Hz)
MAX_BODIES = 64
TRUNCATED = ("refuse", "use")  # what a recording cut short of its stated length gives
MAX_FLIP_FRAMES = 3  # samples: the longest run out of a track taken as a capture glitch
FLIP_WIDTH = 0.05  # m: the glitch rule's allowance for noise (the tracker gate's default)


@dataclasses.dataclass(frozen=True, eq=False)
class Recording:
    """Samples of B bodies at T times (see the module docstring)."""

    file: str
    times: np.ndarray  # (T,) s, strictly increasing, from the first sample's 0
    names: tuple[str, ...]  # (B,)
    ids: tuple[int, ...]  # (B,) streaming ids; 0 where the file gives none
    positions: np.ndarray  # (T, B, 3) m, capture frame; NaN where not tracked
    rotations: np.ndarray  # (T, B, 4) unit quaternions (x, y, z, w); NaN where unknown
    format: str = ""  # what the file is, in its own words ('C3D (DEC processor, ...)')

    @property
    def rate_hz(self) -> float:
        """The recording's frame rate, from its median sample spacing."""
        return float(1.0 / np.median(np.diff(self.times))) if self.times.size > 1 else 0.0

    def body(self, name: str) -> int:
        """The index of body ``name``; raises KeyError."""
        return self.names.index(name)


def check_recording(rec: Recording) -> Recording:
    """The checks every reader's result passes (raises InputError naming the file)."""
    t = rec.times
    if t.ndim != 1 or t.size < 2:
        raise InputError("<frames>", t.size, "2 or more frames", file=rec.file)
    if t.size > MAX_SAMPLES:
        raise InputError("<frames>", t.size, f"at most {MAX_SAMPLES:,} frames", file=rec.file)
    if not np.all(np.isfinite(t)):
        raise InputError("time", "a non-finite time", "finite seconds", file=rec.file)
    bad = np.flatnonzero(np.diff(t) <= 0.0)
    if bad.size:
        raise InputError(f"frame {bad[0] + 1}: time", float(t[bad[0] + 1]),
                         f"later than the previous frame's ({t[bad[0]]:g} s)", file=rec.file)
    if not 1 <= len(rec.names) <= MAX_BODIES:
        raise InputError("<bodies>", len(rec.names), f"1 to {MAX_BODIES} rigid bodies or "
                         "markers", file=rec.file)
    if len(set(rec.names)) != len(rec.names):
        twice = next(n for n in rec.names if rec.names.count(n) > 1)
        raise InputError("<bodies>", twice, "each body named once", file=rec.file)
    p = rec.positions
    if np.any(np.isinf(p)) or np.any(np.abs(p[np.isfinite(p)]) > 1e3):
        raise InputError("position", "beyond 1000 m", "positions of a capture volume",
                         file=rec.file)
    return rec


def gaps(times: np.ndarray, tracked: np.ndarray) -> list[tuple[float, float]]:
    """The open intervals (recording time) over which a body with these ``tracked``
    flags (T,) is not seen between its first and last tracked samples: from the last
    tracked sample before each run of untracked ones to the first tracked one after."""
    idx = np.flatnonzero(tracked)
    if idx.size == 0:
        return []
    jumps = np.flatnonzero(np.diff(idx) > 1)
    return [(float(times[idx[j]]), float(times[idx[j + 1]])) for j in jumps]


def flips(times: np.ndarray, points: np.ndarray, speed: float,
          width: float = FLIP_WIDTH) -> np.ndarray:
    """(T, n) bool: the capture glitches of ``points`` (T, n, 3; NaN where untracked),
    see the module docstring. A run of tracked samples i..j (1 to ``MAX_FLIP_FRAMES``)
    between tracked samples a (before) and z (after) is one when the step a -> i and the
    step j -> z are each longer than a body moving at ``speed`` m/s could go in their
    time plus ``width`` m, while a -> z is not. A body's first and last tracked samples
    have no neighbour on one side and are never taken as glitches."""
    out = np.zeros(points.shape[:2], dtype=bool)
    for b in range(points.shape[1]):
        idx = np.flatnonzero(np.all(np.isfinite(points[:, b]), axis=1))
        if idx.size < 3:
            continue
        p, t = points[idx, b], times[idx]

        def far(i, j):  # the step i -> j (tracked indices) faster than the rule allows
            return np.linalg.norm(p[j] - p[i], axis=-1) > speed * (t[j] - t[i]) + width

        leaves = np.flatnonzero(far(np.arange(idx.size - 1), np.arange(1, idx.size))) + 1
        after = 0
        for k in leaves:  # sample k left the track of k - 1
            if k < after:
                continue
            for z in range(k + 1, min(k + MAX_FLIP_FRAMES, idx.size - 1) + 1):
                if far(z - 1, z) and not far(k - 1, z):
                    out[idx[k:z], b] = True
                    after = z + 1
                    break
    return out


def span(times: np.ndarray, tracked: np.ndarray) -> tuple[float, float]:
    """(first, last) recording time at which a body is tracked; (inf, -inf) if never."""
    idx = np.flatnonzero(tracked)
    if idx.size == 0:
        return math.inf, -math.inf
    return float(times[idx[0]]), float(times[idx[-1]])


@numba.njit(cache=True)
def recorded_state_one(times, points, tracked_times, tau, p, v, present):
    """Bodies (n of them) at recording time ``tau``, compiled, by the module docstring's
    rule from ``times`` (T,) and ``points`` (T, n, 3) whose untracked samples were filled
    by :func:`fill_gaps`: positions into p (n, 3), velocities into v (n, 3; per second
    of recording time) and whether each is present into ``present`` (n,): within its
    first and last tracked times ``tracked_times`` (n, 2). An absent body's p and v are
    those of the filled samples (held at its first or last tracked position)."""
    T = times.size
    i = np.searchsorted(times, tau, side="right") - 1  # times[i] <= tau < times[i + 1]
    i = min(max(i, 0), T - 2)
    dt = times[i + 1] - times[i]
    w = min(max((tau - times[i]) / dt, 0.0), 1.0)
    rate = 1.0 / dt if times[0] <= tau <= times[T - 1] else 0.0  # held outside the samples
    for b in range(points.shape[1]):
        present[b] = 1.0 if tracked_times[b, 0] <= tau <= tracked_times[b, 1] else 0.0
        for k in range(3):
            a, c = points[i, b, k], points[i + 1, b, k]
            p[b, k] = a + w * (c - a)
            v[b, k] = (c - a) * rate


def fill_gaps(times: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(T, n, 3) ``points`` with each body's untracked samples (NaN) between tracked ones
    filled on the straight line between them, and before its first (after its last)
    tracked sample held at that sample (it is absent there, but the arithmetic stays
    finite)."""
    out = np.array(points, dtype=float)
    for b in range(out.shape[1]):
        ok = np.all(np.isfinite(out[:, b]), axis=1)
        if not ok.any():
            out[:, b] = 0.0
            continue
        for k in range(3):
            out[:, b, k] = np.interp(times, times[ok], out[ok, b, k])
    return out
