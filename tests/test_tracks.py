"""The tracker's rules (safety_systems.sensing.tracks): the Kalman step, hidden bodies, exits,
the gate and rejected frames."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from safety_systems.sensing import stops
from kalman_reference import predict
from kalman_reference import update as kf_update
from safety_systems.sensing.kalman import initial_covariance, process_noise, transition_matrix
from safety_systems.sensing.tracks import (
    _POS_VAR,
    _STATUS,
    _T_SEEN,
    TRACK_HIDDEN,
    TRACK_LOST,
    TRACK_NONE,
    TRACK_SLOT,
    TRACK_TRACKING,
    estimates,
    frame_update,
    gate_radius,
    make_regions,
    make_rules,
)

FIXED = settings(derandomize=True, deadline=None, max_examples=40)
PERIOD = 0.05
RULES = dict(measurement_std=0.01, velocity_process_noise=4.0, initial_velocity_std=2.0,
             period=PERIOD)
NAN3 = [np.nan] * 3


def _rules(**kw):
    return make_rules(**(RULES | kw))


class Tracker:
    """frame_update with its state (tracks, newest good time, counts) kept."""

    def __init__(self, n, regions=None, **kw):
        self.tracks, self.t_good = np.zeros((n, TRACK_SLOT)), -np.inf
        self.rules, self.regions, self.counts = _rules(**kw), regions, np.zeros(4)

    def frame(self, t, z, valid, ids=None):
        self.tracks, fault, counts, self.t_good = frame_update(
            self.tracks, t, np.array(z, float), np.array(valid, float),
            None if ids is None else np.array(ids, float), rules=self.rules,
            regions=self.regions, t_good=self.t_good)
        self.counts += counts
        return fault

    @property
    def status(self):
        return list(self.tracks[:, _STATUS])

    def estimates(self):
        return estimates(self.tracks, self.t_good)


def test_first_frame_starts_tracks_at_rest():
    tr = Tracker(3)
    assert tr.frame(0.2, [[1, 0, 1], NAN3, [2, 2, 1]], [1, 0, 1]) == stops.STOP_NONE
    assert tr.status == [TRACK_TRACKING, TRACK_NONE, TRACK_TRACKING]
    p, v, _, std, _ = tr.estimates()
    np.testing.assert_array_equal(p[[0, 2]], [[1, 0, 1], [2, 2, 1]])
    np.testing.assert_array_equal(v[[0, 2]], 0.0)
    assert np.all(np.isnan(p[1])) and np.all(np.isnan(v[1]))
    np.testing.assert_allclose(std, [0.01, 0.0, 0.01])
    np.testing.assert_array_equal(tr.tracks[[0, 2], _T_SEEN], 0.2)
    assert not np.any(tr.tracks[1])


@FIXED
@given(seed=st.integers(0, 2**32 - 1))
def test_agrees_with_the_reference_filter_while_seen(seed):
    # Seen in every frame: Eqs. 2-4 as filterpy's 6-D filter runs them (the position
    # block of its covariance is the one axis' p times I3). The noise is wild (1 m), so
    # without the gate.
    rng = np.random.default_rng(seed)
    times = np.arange(30) * PERIOD + rng.uniform(0, 1)
    z = rng.normal(size=(30, 3)) + times[:, None] * [1.0, -0.5, 0.0]
    tr = Tracker(1, gate=False)
    x = P = None
    for t, zk in zip(times, z):
        tr.frame(t, [zk], [1])
        if x is None:
            x, P, last = np.r_[zk, 0, 0, 0], initial_covariance(0.01, 2.0), t
        else:
            x, P = predict(x, P, transition_matrix(t - last), process_noise(t - last, 4.0))
            x, P = kf_update(x, P, zk, np.eye(3) * 1e-4)
            last = t
        np.testing.assert_allclose(tr.tracks[0, :6], x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(tr.tracks[0, _POS_VAR], P[0, 0], rtol=1e-9)
        np.testing.assert_allclose(P[:3, :3], P[0, 0] * np.eye(3), rtol=1e-9, atol=1e-15)
        assert tr.status == [TRACK_TRACKING]


def _moving_track(tr, speed=1.0):
    """A body seen at x = speed t for t = 0 .. 0.5 s."""
    for k in range(11):
        tr.frame(k * PERIOD, [[speed * k * PERIOD, 0, 1]], [1])


@pytest.mark.parametrize("hidden_for", [0.1, 2.0, 1000.0])
def test_hidden_body_stays_a_hazard_at_its_last_estimate(hidden_for):
    tr = Tracker(1)
    _moving_track(tr)
    last = tr.tracks[0, :6].copy()
    frames = np.arange(0.55, 0.5 + hidden_for + 1e-9, PERIOD)
    for t in frames:
        assert tr.frame(t, [NAN3], [0]) == stops.STOP_NONE  # hidden is not a fault
    assert tr.status == [TRACK_HIDDEN]  # never ends because time passed
    p, v, _, _, unseen = tr.estimates()
    np.testing.assert_array_equal(np.r_[p[0], v[0]], last)  # frozen: the ball's centre
    assert unseen[0] == pytest.approx(frames[-1] - 0.5)


def test_seen_again_the_filter_restarts_at_the_measurement():
    tr = Tracker(1)
    _moving_track(tr)
    tr.frame(0.55, [NAN3], [0])
    tr.frame(0.60, [[0.6, 0, 1]], [1])
    assert tr.status == [TRACK_TRACKING]
    np.testing.assert_array_equal(tr.tracks[0, :6], [0.6, 0, 1, 0, 0, 0])
    assert tr.tracks[0, _POS_VAR] == 1e-4 and tr.estimates()[4][0] == 0.0
    # A dropped frame (no frame at all) is a gap too.
    tr2 = Tracker(1)
    _moving_track(tr2)
    tr2.frame(0.60, [[0.6, 0, 1]], [1])
    np.testing.assert_array_equal(tr2.tracks[0, :6], [0.6, 0, 1, 0, 0, 0])


def test_previous_rule_coasts_through_gaps_and_expires():
    # hidden_bodies: expire continues the filter across a gap (one prediction step).
    tr = Tracker(1, hidden_bodies="expire")
    _moving_track(tr)
    x, cov = tr.tracks[0, :6].copy(), tr.tracks[0, _POS_VAR:_POS_VAR + 3].copy()
    tr.frame(0.55, [NAN3], [0])
    tr.frame(0.60, [[0.6, 0, 1]], [1])
    P = np.zeros((6, 6))
    P[:3, :3], P[3:, 3:], P[:3, 3:], P[3:, :3] = (cov[0] * np.eye(3), cov[2] * np.eye(3),
                                                  cov[1] * np.eye(3), cov[1] * np.eye(3))
    want, _ = predict(x, P, transition_matrix(0.1), process_noise(0.1, 4.0))
    want, _ = kf_update(want, _, np.array([0.6, 0, 1]), np.eye(3) * 1e-4)
    np.testing.assert_allclose(tr.tracks[0, :6], want, rtol=1e-9, atol=1e-12)
    # Bodies at 3 m (outside the 2.5 m exit radius), 1 m (inside) and at 2.4 m walking
    # out at 1 m/s: after max_coast_time unseen the first and third end, the second is lost.
    tr = Tracker(3, hidden_bodies="expire", max_coast_time=0.5, exit_radius=2.5)
    tr.frame(0.0, [[3, 0, 1], [0, 1, 1], [2.4, 0, 1]], [1, 1, 1])
    tr.tracks[2, 3] = 1.0
    tr.frame(0.5, [NAN3] * 3, [0, 0, 0])
    assert tr.status == [TRACK_HIDDEN] * 3
    tr.frame(0.55, [NAN3] * 3, [0, 0, 0])
    assert tr.status == [TRACK_NONE, TRACK_LOST, TRACK_NONE]  # judged on the coasted estimate


def test_track_ends_only_when_seen_leaving():
    # An exit region at x >= 3 m; the cell's walls at |y| <= 2 m.
    regions = make_regions(([-5, -2, -1], [5, 2, 3]), [([3, -2, -1], [5, 2, 3])])
    tr = Tracker(4, regions=regions)
    z = [[3.5, 0, 1], [2.9, 0, 1], [0, 2.5, 1], [0.5, 0, 1]]  # exit, near it, beyond a wall
    tr.frame(0.0, z, [1, 1, 1, 1])
    tr.frame(0.05, [NAN3, NAN3, NAN3, z[3]], [0, 0, 0, 1])
    assert tr.status == [TRACK_NONE, TRACK_HIDDEN, TRACK_NONE, TRACK_TRACKING]
    for k in range(2, 200):  # no other way to end: not time, not distance
        tr.frame(k * PERIOD, [NAN3] * 3 + [z[3]], [0, 0, 0, 1])
    assert tr.status == [TRACK_NONE, TRACK_HIDDEN, TRACK_NONE, TRACK_TRACKING]


def test_bad_time_rejects_the_whole_frame():
    tr = Tracker(2)
    tr.frame(0.0, [[1, 0, 1], [0, 1, 1]], [1, 1])
    before = tr.tracks.copy()
    for t in (0.0, -0.05, np.nan, np.inf):  # repeated, earlier, unknown
        assert tr.frame(t, [[1.1, 0, 1], [0, 1.1, 1]], [1, 1]) == stops.STOP_BAD_TIME
        np.testing.assert_array_equal(tr.tracks, before)
        assert tr.t_good == 0.0
    assert list(tr.counts) == [0, 4, 0, 0]
    assert tr.frame(0.05, [[1.01, 0, 1], [0, 1.01, 1]], [1, 1]) == stops.STOP_NONE


def test_unknown_and_doubly_claimed_ids_are_rejected():
    tr = Tracker(3)
    z = [[1, 0, 1], [0, 1, 1], [0, 0, 2]]
    tr.frame(0.0, z, [1, 1, 1])
    # Entry 0 carries an unregistered id; entries 1 and 2 both claim body 3.
    assert tr.frame(0.05, z, [1, 1, 1], ids=[1000, 3, 3]) == stops.STOP_UNKNOWN_ID
    assert tr.status == [TRACK_HIDDEN, TRACK_HIDDEN, TRACK_HIDDEN]
    assert list(tr.counts) == [0, 0, 3, 0]
    # Ids 0, 2.5 and 4 are not registered either; body 2 is still seen (as id 2).
    assert tr.frame(0.10, z, [1, 1, 1], ids=[0, 2, 2.5]) == stops.STOP_UNKNOWN_ID
    assert tr.status == [TRACK_HIDDEN, TRACK_TRACKING, TRACK_HIDDEN]
    assert tr.frame(0.15, z, [1, 1, 1]) == stops.STOP_NONE  # clean again


def test_non_finite_entry_is_rejected_the_others_used():
    tr = Tracker(2)
    tr.frame(0.0, [[1, 0, 1], [0, 1, 1]], [1, 1])
    assert tr.frame(0.05, [[np.nan, 0, 1], [0, 1.05, 1]], [1, 1]) == stops.STOP_NON_FINITE
    assert tr.status == [TRACK_HIDDEN, TRACK_TRACKING]
    assert list(tr.counts) == [1, 0, 0, 0]
    # Not flagged seen: an occlusion, no fault.
    assert tr.frame(0.10, [[np.nan, 0, 1], [0, 1.1, 1]], [0, 1]) == stops.STOP_NONE


@FIXED
@given(elapsed_frames=st.integers(1, 40), distance=st.floats(0.0, 5.0),
       direction=st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda u: np.linalg.norm(u) > 0.1),
       z_d=st.sampled_from([0.0, 0.05]))
def test_gate_accepts_inside_and_rejects_outside(elapsed_frames, distance, direction, z_d):
    tr = Tracker(1, gate_speed=2.0, gate_width=0.05, human_uncertainty=z_d)
    tr.frame(0.0, [[0.5, 0.5, 1]], [1])
    centre = tr.tracks[0, :3].copy()
    for k in range(1, elapsed_frames):  # hidden meanwhile
        tr.frame(k * PERIOD, [NAN3], [0])
    t = elapsed_frames * PERIOD
    u = np.array(direction) / np.linalg.norm(direction)
    z = centre + distance * u
    radius = 2.0 * t + 0.05 + z_d
    if abs(np.linalg.norm(z - centre) - radius) < 1e-9:
        return  # on the boundary to rounding
    fault = tr.frame(t, [z], [1])
    inside = np.linalg.norm(z - centre) <= radius
    assert gate_radius(tr.rules, t) == pytest.approx(radius)
    assert (fault == stops.STOP_NONE) == inside
    assert tr.status == ([TRACK_TRACKING] if inside else [TRACK_HIDDEN])
    assert tr.counts[stops.REJECT_GATE] == (0 if inside else 1)
    if not inside:  # rejected: the ball keeps its centre
        np.testing.assert_array_equal(tr.tracks[0, :3], centre)


def test_gate_catches_swapped_ids_and_can_be_switched_off():
    z = [[1, 0, 1], [-1, 0, 1]]
    for gate, want in ((True, stops.STOP_GATE), (False, stops.STOP_NONE)):
        tr = Tracker(2, gate=gate)
        tr.frame(0.0, z, [1, 1])
        assert tr.frame(0.05, z, [1, 1], ids=[2, 1]) == want
        if gate:
            assert tr.status == [TRACK_HIDDEN, TRACK_HIDDEN] and tr.counts[3] == 2
        else:  # taken as truth: each track jumps to the other body
            assert tr.tracks[0, 0] < 0.0 < tr.tracks[1, 0]


@pytest.mark.parametrize("name, value", [
    ("velocity_process_noise", 0.0), ("initial_velocity_std", math.nan), ("period", -1.0),
    ("gate_width", -0.1), ("gate_speed", math.inf), ("hidden_bodies", "forget"),
])
def test_bad_rules_are_rejected(name, value):
    with pytest.raises(ValueError, match=name):
        _rules(**{name: value})
