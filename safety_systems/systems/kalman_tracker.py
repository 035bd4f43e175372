"""KalmanTracker: one constant-velocity Kalman filter per tracked body (seed Eqs. 2-4)."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    LeafSystem,
    ValueProducer,
)

from safety_systems.sensing.tracks import (
    TRACK_SLOT,
    estimate_rows,
    frame_step,
    make_regions,
    tracker_fault,
)


class KalmanTracker(LeafSystem):
    """Tracks every registered body from the sensor's frames and flags sensor faults.

    At each of its updates (every sensor period, ``processing_time`` after a frame is
    due to be delivered) it takes the newest delivered frame, if its frame number is
    new, through ``safety_systems.sensing.tracks.frame_step``: the rules of which entries to
    use (ids, finite positions, the gate), the Kalman step, hidden bodies and exits are
    written there once. Outputs are the estimates at the frame's capture time.

    ``fault`` is a stop reason (``safety_systems.sensing.stops``): the newest processed frame's
    own fault (a repeated or earlier capture time, an unknown body id, a non-finite
    position, a position outside the gate) until a clean frame comes, else
    ``stale_frame`` when the newest good frame is older than ``frame_timeout`` (a
    missing frame, or no frame yet), else 0. A stale frame is never extrapolated.
    ``rejected_frames`` counts the rejected measurements since the start by cause
    (``stops.REJECT_CAUSES``: non-finite, time, unknown id, gate).

    .. pydrake_system::

        name: KalmanTracker
        input_ports:
        - positions_measured
        - valid
        - sample_time
        - frame_number
        - body_ids
        output_ports:
        - positions_estimated
        - velocities_estimated
        - track_status
        - position_std
        - unseen_time
        - fault
        - rejected_frames

    Untracked slots (status none) output NaN positions and velocities; a hidden body
    keeps its last accepted estimate (the centre of its ball). ``position_std`` is the
    track's position standard deviation per axis, metres; ``unseen_time`` the seconds
    from a hidden body's last accepted measurement to the newest good frame.

    Args:
        num_bodies: body slots N (the bodies with ids 1..N).
        period_sec: the sensor's capture period, seconds.
        latency_sec: the sensor's delivery latency, seconds.
        processing_time: seconds from delivery to the tracker's update (> 0).
        frame_timeout: seconds after capture after which a frame is stale.
        rules: ``safety_systems.sensing.tracks.make_rules`` (noise, gate, hidden bodies).
        regions: ``safety_systems.sensing.tracks.make_regions`` (cell walls and exits); None:
            no walls, no exits.
    """

    def __init__(self, *, num_bodies: int, period_sec: float, latency_sec: float,
                 processing_time: float, frame_timeout: float, rules: np.ndarray,
                 regions: np.ndarray | None = None) -> None:
        super().__init__()
        for name, value in dict(period_sec=period_sec, processing_time=processing_time,
                                frame_timeout=frame_timeout).items():
            if not (np.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: got {value}; allowed: a finite number > 0")
        if not (np.isfinite(latency_sec) and latency_sec >= 0.0):
            raise ValueError(f"latency_sec: got {latency_sec}; allowed: a finite number >= 0")
        n = self._n = num_bodies
        self._timeout = float(frame_timeout)
        self._rules = np.asarray(rules, dtype=float)
        self._regions = make_regions() if regions is None else np.asarray(regions, dtype=float)
        # Tracks, then: last frame number, newest good capture time, fault, 4 counts.
        self._state = self.DeclareDiscreteState(
            np.r_[np.zeros(n * TRACK_SLOT), -1.0, -np.inf, 0.0, np.zeros(4)])
        self._z = self.DeclareVectorInputPort("positions_measured", 3 * n)
        self._valid = self.DeclareVectorInputPort("valid", n)
        self._time = self.DeclareVectorInputPort("sample_time", 1)
        self._number = self.DeclareVectorInputPort("frame_number", 1)
        self._ids = self.DeclareVectorInputPort("body_ids", n)
        self.DeclarePeriodicDiscreteUpdateEvent(
            period_sec=period_sec, offset_sec=latency_sec + processing_time, update=self._update)
        self._out = self.DeclareCacheEntry(
            description="estimates",
            value_producer=ValueProducer(allocate=AbstractValue.Make(np.zeros((9, n))).Clone,
                                         calc=self._calc_estimates),
            prerequisites_of_calc={self.xd_ticket()},
        )
        for name, rows in (("positions_estimated", slice(0, 3)),
                           ("velocities_estimated", slice(3, 6)), ("track_status", 6),
                           ("position_std", 7), ("unseen_time", 8)):
            size = 3 * n if isinstance(rows, slice) else n
            self.DeclareVectorOutputPort(
                name, size,
                lambda c, o, r=rows: o.SetFromVector(np.ravel(self._out.Eval(c)[r], "F")),
                prerequisites_of_calc={self._out.ticket()},
            )
        self.DeclareVectorOutputPort("fault", 1, self._calc_fault,
                                     prerequisites_of_calc={self.xd_ticket(), self.time_ticket()})
        self.DeclareVectorOutputPort(
            "rejected_frames", 4,
            lambda c, o: o.SetFromVector(c.get_discrete_state(self._state).get_value()[-4:]),
            prerequisites_of_calc={self.xd_ticket()})

    def _update(self, context: Context, discrete_state: DiscreteValues) -> None:
        number = self._number.Eval(context)[0]
        state = context.get_discrete_state(self._state).get_value()
        n = self._n
        n_tail = n * TRACK_SLOT
        if number < 0.0 or number == state[n_tail]:
            return  # no new frame: nothing to process (the fault output sees the age)
        new = state.copy()
        new[n_tail] = number
        tracks = new[:n_tail].reshape(n, TRACK_SLOT)
        good = new[n_tail + 1:n_tail + 2]  # views: frame_step writes into them
        counts = new[n_tail + 3:]
        new[n_tail + 2] = frame_step(
            tracks, 0, n, float(self._time.Eval(context)[0]),
            np.asarray(self._z.Eval(context)).reshape(n, 3), np.asarray(self._valid.Eval(context)),
            np.asarray(self._ids.Eval(context)), good, counts, self._rules, self._regions)
        discrete_state.set_value(self._state, new)

    def _calc_estimates(self, context: Context, value: AbstractValue) -> None:
        state = context.get_discrete_state(self._state).get_value()
        n, tail = self._n, self._n * TRACK_SLOT
        out = value.get_mutable_value()
        p, v = np.empty((n, 3)), np.empty((n, 3))
        estimate_rows(state[:tail].reshape(n, TRACK_SLOT), 0, n, state[tail + 1], p, v, out[6],
                      out[7], out[8])
        out[0:3], out[3:6] = p.T, v.T

    def _calc_fault(self, context: Context, output: BasicVector) -> None:
        state = context.get_discrete_state(self._state).get_value()
        tail = self._n * TRACK_SLOT
        output.SetAtIndex(0, tracker_fault(state[tail + 2], context.get_time(), state[tail + 1],
                                    self._timeout))
