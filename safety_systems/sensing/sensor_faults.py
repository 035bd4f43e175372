"""Faults a motion-capture frame can carry, injected into captures: the rule written once.

Used by the MocapSensor and the batched verifier, so a scenario's faults reach the
tracker the same way in both. A fault acts on the captures at times t with
start <= t < end:

- ``outlier``: the body's entry, while it is seen, is displaced by ``offset`` (m): a
  reflection, or a marker solved onto the wrong rigid body;
- ``swap``: the entries of the body and of ``other`` carry each other's ids (a marker
  swap: each position is reported as the other body's);
- ``non_finite``: the present body's entry is flagged seen with a NaN position;
- ``unknown_id``: the body's entry carries an id that is not registered;
- ``time_duplicate``: the frame carries the previous capture's time;
- ``time_backwards``: the frame carries the time of the capture before the previous one.

A fault table has one row per fault: kind (index in ``FAULT_KINDS``), body index,
other body index (-1 if none), start, end, offset x, y, z.
"""

import numba
import numpy as np

FAULT_KINDS = ("outlier", "swap", "non_finite", "unknown_id", "time_duplicate",
               "time_backwards")
BODY_FAULTS = FAULT_KINDS[:4]
OUTLIER, SWAP, NON_FINITE, UNKNOWN_ID, TIME_DUPLICATE, TIME_BACKWARDS = range(6)
UNKNOWN_ID_BASE = 1000.0  # ids carried by entries under ``unknown_id`` (1000 + slot)
FAULT_COLUMNS = 8


def fault_table(faults) -> np.ndarray:
    """(F, 8) rows of (kind, body, other, start, end, offset x, y, z) from tuples
    (kind name, body index, other index or -1, start, end, offset (3,))."""
    table = np.empty((len(faults), FAULT_COLUMNS))
    for j, (kind, body, other, start, end, offset) in enumerate(faults):
        if kind not in FAULT_KINDS:
            raise ValueError(f"fault kind: got {kind!r}; allowed: {' | '.join(FAULT_KINDS)}")
        table[j, :5] = FAULT_KINDS.index(kind), body, other, start, end
        table[j, 5:] = offset
    return table


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def apply_faults(faults, k, period, tol, z, valid, ids):
    """Applies the faults active at capture k (time k period, ``tol`` s of rounding) to
    one frame's entries z (N, 3), valid (N,) and ids (N,) in place; returns the capture
    time the frame carries."""
    t = k * period
    reported = t
    for j in range(faults.shape[0]):
        if not (faults[j, 3] <= t + tol and t + tol < faults[j, 4]):
            continue
        kind, i = int(faults[j, 0]), int(faults[j, 1])
        if kind == OUTLIER:
            if valid[i] != 0.0:
                for a in range(3):
                    z[i, a] += faults[j, 5 + a]
        elif kind == SWAP:
            other = int(faults[j, 2])
            ids[i], ids[other] = ids[other], ids[i]
        elif kind == NON_FINITE:
            if valid[i] != 0.0:
                z[i, 0] = np.nan
        elif kind == UNKNOWN_ID:
            ids[i] = UNKNOWN_ID_BASE + i
        elif kind == TIME_DUPLICATE:
            reported = (k - 1) * period
        elif kind == TIME_BACKWARDS:
            reported = (k - 2) * period
    return reported


@numba.njit(cache=True)
def _apply(faults, k, period, tol, z, valid, ids):
    return apply_faults(faults, k, period, tol, z, valid, ids)


def apply_to_frame(faults: np.ndarray, k: int, period: float, tol: float, z: np.ndarray,
                   valid: np.ndarray, ids: np.ndarray) -> float:
    """:func:`apply_faults` from Python (arrays changed in place)."""
    if faults.shape[0] == 0:
        return k * period
    return float(_apply(faults, int(k), float(period), float(tol), z, valid, ids))

