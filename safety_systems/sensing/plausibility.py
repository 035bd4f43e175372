"""Whether recorded bodies move as a person can: the check every recording's mapped
bodies pass before they replay (``recording_mapping.recorded_bodies``).

A body's samples are implausible where it moves faster than ``max_speed`` between two
tracked samples (across a gap too: the played truth crosses it on the straight line),
or accelerates harder than ``max_acceleration`` over a 50 ms baseline (the second
difference of its positions at t, t + h and t + 2h, over h squared), after allowing each
sample ``noise`` metres of capture noise (2 noise per step, 4 per second difference).
The bounds are a person's, generous: the fastest markers on people in this project's
real files (tests/data, and the c3d.org sample files of 12 vendors) move at 9.7 m/s (a
foot marker in gait, BTS, 100 Hz) and accelerate at 104 m/s^2 over 50 ms (a dancer,
PhoeniX, 65 Hz); hands in the KTH handover reach 2.7 m/s; a golf club (22.6 m/s, 443
m/s^2), a foot of Xsens' basketball model (14.2 m/s, 230 m/s^2) or a misread file (an
EVaRT file read at the wrong offset: 105 m/s at the 99th percentile) is beyond them.

A run of samples held exactly still and then left faster than ``max_speed`` (a body
frozen, then jumping to where it really is: Motive exports bodies so when a rigid body
is lost and found again) is not motion: :func:`held_before_jumps` finds those samples,
which a mapping may read as untracked (``implausible: untracked``, said with a
warning); whatever is still implausible refuses the recording.
"""

import dataclasses

import numpy as np

MAX_SPEED = 10.0  # m/s
MAX_ACCELERATION = 150.0  # m/s^2
NOISE = 0.005  # m: capture noise allowed per sample
BASELINE = 0.05  # s: the acceleration's baseline h
IMPLAUSIBLE = ("refuse", "untracked")  # what a mapping does with held-then-jumping samples


@dataclasses.dataclass(frozen=True)
class Implausible:
    """The first implausible sample of a recording: body ``body`` at frame ``frame`` (a
    sample index) moving at ``figure`` (m/s, or m/s^2 for ``what`` = 'acceleration')."""

    body: int
    frame: int
    what: str  # 'speed' | 'acceleration'
    figure: float


def first_implausible(times: np.ndarray, points: np.ndarray, *, max_speed: float = MAX_SPEED,
                      max_acceleration: float = MAX_ACCELERATION, noise: float = NOISE
                      ) -> Implausible | None:
    """The earliest implausible sample of ``points`` (T, n, 3; NaN where untracked) at
    ``times`` (T,), see the module docstring; None where every body is plausible."""
    found = []
    for b in range(points.shape[1]):
        speed = _step_speeds(times, points[:, b], noise)
        if speed is not None:
            idx, v = speed
            over = np.flatnonzero(v > max_speed)
            if over.size:
                found.append(Implausible(b, int(idx[over[0] + 1]), "speed", float(v[over[0]])))
        acc = _accelerations(times, points[:, b], noise)
        over = np.flatnonzero(acc > max_acceleration)
        if over.size:  # named at the window's last sample, where it is first complete
            found.append(Implausible(b, int(over[0]) + 2 * _stride(times), "acceleration",
                                     float(acc[over[0]])))
    return min(found, key=lambda x: (x.frame, x.body)) if found else None


def _step_speeds(times, p, noise):
    """(tracked indices, speeds between consecutive tracked samples less 2 noise)."""
    idx = np.flatnonzero(np.all(np.isfinite(p), axis=1))
    if idx.size < 2:
        return None
    d = np.linalg.norm(np.diff(p[idx], axis=0), axis=1)
    return idx, np.maximum(d - 2.0 * noise, 0.0) / np.diff(times[idx])


def _accelerations(times, p, noise) -> np.ndarray:
    """(T,) the second difference over the baseline at each sample t (of t, t + h,
    t + 2h), less 4 noise, over h squared; NaN where a sample is untracked."""
    out = np.full(p.shape[0], np.nan)
    if p.shape[0] < 3:
        return out
    k = _stride(times)
    if p.shape[0] <= 2 * k:
        return out
    h = times[2 * k:] - times[k:-k]
    second = p[2 * k:] - 2.0 * p[k:-k] + p[:-2 * k]
    with np.errstate(invalid="ignore"):
        out[:-2 * k] = np.maximum(np.linalg.norm(second, axis=1) - 4.0 * noise, 0.0) / h**2
    return out


def _stride(times: np.ndarray) -> int:
    """The acceleration's baseline in samples (at least 1)."""
    step = float(np.median(np.diff(times))) if times.size > 1 else BASELINE
    return max(1, round(BASELINE / step))


def held_before_jumps(times: np.ndarray, points: np.ndarray, *, max_speed: float = MAX_SPEED,
                      noise: float = NOISE) -> np.ndarray:
    """(T, n) bool: the held samples of runs held exactly still (2 or more equal tracked
    samples in a row, all but the run's first) whose next step is faster than
    ``max_speed`` (see the module docstring)."""
    out = np.zeros(points.shape[:2], dtype=bool)
    for b in range(points.shape[1]):
        speed = _step_speeds(times, points[:, b], noise)
        if speed is None:
            continue
        idx, v = speed
        p = points[idx, b]
        same = np.all(p[1:] == p[:-1], axis=1)  # tracked sample k + 1 equals sample k
        for k in np.flatnonzero(v > max_speed):  # the step idx[k] -> idx[k + 1] is too fast
            first = k
            while first > 0 and same[first - 1]:
                first -= 1
            if first < k:
                out[idx[first + 1:k + 1], b] = True
    return out
