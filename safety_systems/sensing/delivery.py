"""How a motion-capture frame is delivered, written once (seed 000, Section 4).

Captures happen at t = k period. A capture inside a dropped-frame interval [start, end)
does not happen. A frame captured at t_c reaches the tracker at t_c + latency, and the
newest frame that has arrived is the one the sensor shows. A capture's noise depends
only on the sensor's seed and the capture's index. The MocapSensor system and the
batched evaluator both call these functions.
"""

import math

import numba
import numpy as np

TIME_TOL = 1e-9  # s; absorbs rounding in capture time + latency comparisons


def unit_noise(seed: int, frame: int, n: int) -> np.ndarray:
    """The unit noise of capture ``frame`` of n bodies (3 n,): standard normal draws of a
    generator seeded by (seed, frame)."""
    return np.random.default_rng([seed, frame]).standard_normal(3 * n)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def captured(t, drops):
    """Whether a capture at time t happens: t lies in none of the dropped intervals
    ``drops`` (J, 2) of [start, end) (inf rows pad)."""
    inside = False
    for j in range(drops.shape[0]):
        if drops[j, 0] <= t < drops[j, 1]:
            inside = True
    return not inside


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def delivered_frame(u, latency, period, drops):
    """The index k of the frame shown at time u: the newest capture at least ``latency``
    old that was not dropped (``drops`` (J, 2)); -1 before the first one."""
    now = u + TIME_TOL - latency
    i = math.floor(now / period)
    if (i + 1) * period <= now:
        i += 1
    if i * period > now:
        i -= 1
    for _ in range(drops.shape[0] + 1):  # step back over dropped captures
        t = i * period
        first = i
        for j in range(drops.shape[0]):
            if drops[j, 0] <= t < drops[j, 1]:
                first = min(first, math.ceil(drops[j, 0] / period - 1e-9) - 1)
        i = first
    return max(i, -1)
