"""MocapSensor: an OptiTrack-like motion-capture sensor (seed Section 4)."""

import math
from collections.abc import Sequence

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    LeafSystem,
    ValueProducer,
)

from safety_systems.cell.operators import MAX_BODIES_PER_OPERATOR, MAX_OPERATORS
from safety_systems.sensing.delivery import TIME_TOL, captured, delivered_frame, unit_noise
from safety_systems.sensing.sensor_faults import FAULT_COLUMNS, apply_to_frame

MIN_PERIOD_SEC = 1.0 / 1000.0  # OptiTrack frame rates: 20 Hz up to 1000 Hz (seed Sec. 4.1)
MAX_PERIOD_SEC = 1.0 / 20.0


def _intervals(name: str, rows: Sequence, width: int) -> np.ndarray:
    array = np.asarray(list(rows), dtype=float).reshape(-1, width)
    if np.any(np.isnan(array)) or np.any(array[:, -1] < array[:, -2]):
        raise ValueError(f"{name}={list(rows)!r}: each needs t_start <= t_end, no NaN")
    return array


MAX_BODY_SLOTS = MAX_OPERATORS * MAX_BODIES_PER_OPERATOR


class MocapSensor(LeafSystem):
    """Samples the present, non-occluded bodies every period and delivers frames late.

    Every ``period_sec`` (captures at t = k period) the sensor measures the bodies that
    are present and not occluded, adding Gaussian noise of ``noise_std`` per axis
    (deterministic: drawn from a generator seeded by (seed, k)). A frame captured at t_c
    is delivered at t_c + latency_sec; the outputs show the newest delivered frame. During
    a dropped-frame interval no frame is captured, so the last delivered frame stays on
    the outputs and its ``sample_time`` goes stale (the tracker detects that). Before the
    first delivery every body is invalid, ``sample_time`` is -inf and ``frame_number``
    -1.

    Each frame carries its frame number k (as a motion-capture stream does) and, per
    entry, the id of the body it reports (entry i: id i + 1). ``faults`` (a table of
    ``safety_systems.sensing.sensor_faults``) corrupt the frames captured in their intervals:
    outliers, marker swaps, non-finite positions, unknown ids, repeated or earlier
    capture times.

    The last frames live in the discrete state as a ring of ceil(latency / period) + 1
    slots, oldest first; each slot is [frame number, capture time carried, positions
    (3N), valid (N), ids (N)]. Occlusion, drop and fault intervals are half-open
    [t_start, t_end).

    .. pydrake_system::

        name: MocapSensor
        input_ports:
        - positions_true
        - present
        output_ports:
        - positions_measured
        - valid
        - sample_time
        - frame_number
        - body_ids

    Args:
        num_bodies: number of body slots N (1 to ``MAX_BODY_SLOTS``, 50: five operators
            of ten tracked body points).
        period_sec: capture period, seconds (1/1000 to 1/20).
        noise_std: standard deviation of the position noise per axis, metres (>= 0;
            OptiTrack accuracy 0.2 mm, seed Sec. 4.1).
        latency_sec: delay from capture to delivery, seconds (>= 0).
        occlusions: (body_index, t_start, t_end) rows, seconds: body not seen.
        dropped_frames: (t_start, t_end) rows, seconds: no frame at all is captured.
        faults: a fault table (``safety_systems.sensing.sensor_faults.fault_table``).
        seed: noise seed (integer >= 0).
        pivots: (N, 3) where each body is reported from its true position, metres (a
            rigid body's pivot left off the point it marks: ``sensing.pivots``; None: 0).
    """

    def __init__(
        self,
        *,
        num_bodies: int,
        period_sec: float = 0.05,
        noise_std: float = 0.0002,
        latency_sec: float = 0.0,
        occlusions: Sequence[tuple[int, float, float]] = (),
        dropped_frames: Sequence[tuple[float, float]] = (),
        faults: np.ndarray | None = None,
        seed: int = 0,
        pivots: np.ndarray | None = None,
    ) -> None:
        super().__init__()
        if not (isinstance(num_bodies, int) and 1 <= num_bodies <= MAX_BODY_SLOTS):
            raise ValueError(f"num_bodies={num_bodies!r}: must be an integer in "
                             f"1..{MAX_BODY_SLOTS}")
        if not MIN_PERIOD_SEC - 1e-15 <= period_sec <= MAX_PERIOD_SEC + 1e-15:
            raise ValueError(
                f"period_sec={period_sec}: allowed {MIN_PERIOD_SEC} to {MAX_PERIOD_SEC} s"
            )
        if not (math.isfinite(noise_std) and noise_std >= 0.0):
            raise ValueError(f"noise_std={noise_std}: must be finite and >= 0")
        if not (math.isfinite(latency_sec) and latency_sec >= 0.0):
            raise ValueError(f"latency_sec={latency_sec}: must be finite and >= 0")
        if not (isinstance(seed, int) and seed >= 0):
            raise ValueError(f"seed={seed!r}: must be an integer >= 0")
        occ = _intervals("occlusions", occlusions, 3)
        if np.any((occ[:, 0] < 0) | (occ[:, 0] >= num_bodies) | (occ[:, 0] % 1 != 0)):
            raise ValueError(
                f"occlusions={list(occlusions)!r}: body_index must be in 0..{num_bodies - 1}"
            )
        self._occ_body = occ[:, 0].astype(int)
        self._occ_start, self._occ_end = occ[:, 1], occ[:, 2]
        self._drops = np.ascontiguousarray(_intervals("dropped_frames", dropped_frames, 2))
        faults = np.zeros((0, FAULT_COLUMNS)) if faults is None else np.asarray(faults, float)
        bodies = faults[:, 1:3]
        if faults.ndim != 2 or faults.shape[1] != FAULT_COLUMNS or np.any(
                (bodies < -1) | (bodies >= num_bodies) | (bodies % 1 != 0)):
            raise ValueError(f"faults: a ({FAULT_COLUMNS})-column fault table with body "
                             f"indices in -1..{num_bodies - 1}")
        self._faults = np.ascontiguousarray(faults)
        pivots = np.zeros((num_bodies, 3)) if pivots is None else np.array(pivots, dtype=float)
        if pivots.shape != (num_bodies, 3) or not np.all(np.isfinite(pivots)):
            raise ValueError(f"pivots: got shape {pivots.shape}; allowed: ({num_bodies}, 3) "
                             "finite metres")
        self._pivots = pivots.reshape(-1) if np.any(pivots != 0.0) else None

        n = num_bodies
        self._n = n
        self._period = float(period_sec)
        self._noise_std = float(noise_std)
        self._latency = float(latency_sec)
        self._seed = seed
        self._slot = 2 + 5 * n
        self._num_slots = math.ceil(latency_sec / period_sec - TIME_TOL) + 1
        empty = np.r_[-1.0, -np.inf, np.full(3 * n, np.nan), np.zeros(n), np.arange(1.0, n + 1)]
        self._frames_index = self.DeclareDiscreteState(np.tile(empty, self._num_slots))

        self._positions_true = self.DeclareVectorInputPort("positions_true", 3 * n)
        self._present = self.DeclareVectorInputPort("present", n)
        self.DeclarePeriodicDiscreteUpdateEvent(
            period_sec=period_sec, offset_sec=0.0, update=self._capture
        )
        # The delivered frame, computed once for the three outputs. It depends on time
        # only through the latency: with one slot (no latency) the newest frame is the
        # delivered one, so it changes only at captures and is not recomputed every time
        # a downstream system asks at a new time.
        deps = {self.xd_ticket()}
        if self._num_slots > 1:
            deps.add(self.time_ticket())
        self._frame = self.DeclareCacheEntry(
            description="delivered frame",
            value_producer=ValueProducer(
                allocate=AbstractValue.Make(np.zeros(self._slot)).Clone,
                calc=self._calc_frame,
            ),
            prerequisites_of_calc=deps,
        )
        ticket = {self._frame.ticket()}
        self.DeclareVectorOutputPort(
            "positions_measured", BasicVector(3 * n), self._calc_positions, ticket
        )
        self.DeclareVectorOutputPort("valid", BasicVector(n), self._calc_valid, ticket)
        self.DeclareVectorOutputPort("sample_time", BasicVector(1), self._calc_time, ticket)
        self.DeclareVectorOutputPort("frame_number", BasicVector(1), self._calc_number, ticket)
        self.DeclareVectorOutputPort("body_ids", BasicVector(n), self._calc_ids, ticket)

    @property
    def num_slots(self) -> int:
        """Number of frames kept in the discrete state."""
        return self._num_slots

    def _capture(self, context: Context, discrete_state: DiscreteValues) -> None:
        t = context.get_time()
        if not captured(t, self._drops):
            return  # network/sensor fault: no frame this period
        k = round(t / self._period)
        valid = self._present.Eval(context) > 0.5
        occluded = (self._occ_start <= t) & (t < self._occ_end)
        valid[self._occ_body[occluded]] = False
        positions = np.array(self._positions_true.Eval(context), dtype=float)
        if self._pivots is not None:
            positions += self._pivots
        if self._noise_std > 0.0:
            positions += self._noise_std * unit_noise(self._seed, k, self._n)
        positions.reshape(-1, 3)[~valid] = np.nan
        z, seen, ids = positions.reshape(-1, 3), valid.astype(float), np.arange(1.0, self._n + 1)
        carried = apply_to_frame(self._faults, k, self._period, TIME_TOL, z, seen, ids)
        frames = discrete_state.get_mutable_value(self._frames_index)
        frames[: -self._slot] = frames[self._slot :].copy()  # drop the oldest slot
        frames[-self._slot :] = np.r_[k, carried, positions, seen, ids]

    def _delivered(self, context: Context) -> np.ndarray:
        """The slot of the frame shown now (``delivery.delivered_frame``), or the empty
        oldest slot before the first delivery."""
        frames = context.get_discrete_state(self._frames_index).get_value()
        k = delivered_frame(context.get_time(), self._latency, self._period, self._drops)
        for start in range((self._num_slots - 1) * self._slot, -1, -self._slot):
            if k >= 0 and frames[start] == k:
                return frames[start : start + self._slot]
        return frames[: self._slot]

    def _calc_frame(self, context: Context, value: AbstractValue) -> None:
        value.get_mutable_value()[:] = self._delivered(context)

    def _calc_positions(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._frame.Eval(context)[2 : 2 + 3 * self._n])

    def _calc_valid(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._frame.Eval(context)[2 + 3 * self._n : 2 + 4 * self._n])

    def _calc_time(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._frame.Eval(context)[1:2])

    def _calc_number(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._frame.Eval(context)[:1])

    def _calc_ids(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._frame.Eval(context)[2 + 4 * self._n :])
