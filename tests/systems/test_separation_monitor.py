"""SeparationMonitor: Eqs. 6-11 between operator segments (capsules) and the robot's capsules.

A segment is given by its axis' two ends, their velocities and a radius (the
OperatorEnvelopes' outputs); a point body is a segment whose ends coincide, and then the
monitor is the former body-sphere monitor bit for bit."""

import numpy as np
import pytest

from safety_systems.cell.human_body import envelope_recipe
from safety_systems.cell.robot_geometry import (
    capsule_ends,
    nearest_capsule_one,
    robot_capsules,
    tool_point,
)
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_LOST, TRACK_NONE, TRACK_TRACKING
from safety_systems.ssm.separation import pair_figures
from safety_systems.ssm.formulas import (
    directed_speeds,
    monitor_protective_distances,
    separation_distances,
)
from safety_systems.systems.operator_envelopes import OperatorEnvelopes
from safety_systems.systems.separation_monitor import SeparationMonitor

ARGS = dict(reaction_time=0.1, stopping_time=0.3, stopping_distance=0.2)
CAPSULES = robot_capsules(payload_radius=0.06, tool_length=0.1)
OUTPUTS = ("distances", "protective_distances", "human_directed_speeds",
           "robot_directed_speeds", "nearest_capsule")


def _points(p, v):
    """Point bodies (n, 3) as segments: (n, 2, 3) ends and velocities, both ends alike."""
    p, v = np.asarray(p, float), np.asarray(v, float)
    return np.stack([p, p], axis=1), np.stack([v, v], axis=1)


def _fixed(monitor, ends, end_v, h_ends, h_v, h_radius, status, std):
    c = monitor.CreateDefaultContext()
    for name, value in dict(capsule_ends=np.ravel(ends), capsule_velocities=np.ravel(end_v),
                            segment_ends=np.ravel(h_ends), segment_velocities=np.ravel(h_v),
                            segment_radii=h_radius, segment_status=status,
                            segment_std=std).items():
        monitor.GetInputPort(name).FixValue(c, np.asarray(value, float))
    return c


def _outputs(monitor, context):
    return [monitor.GetOutputPort(n).Eval(context).copy() for n in OUTPUTS]


def _random_segments(rng, n):
    """n segments: the first half points (ends alike), the rest capsules up to ~0.6 m long
    whose ends move differently (a limb turning)."""
    p, v = rng.normal(size=(n, 3)) * 0.8, rng.normal(size=(n, 3))
    h_ends, h_v = _points(p, v)
    for i in range(n // 2, n):
        h_ends[i, 1] = h_ends[i, 0] + rng.normal(size=3) * 0.35
        h_v[i, 1] = rng.normal(size=3)
    return h_ends, h_v


def test_monitor_is_the_pairs_smallest_clearance_and_largest_s():
    rng = np.random.default_rng(3)
    n = 6
    r_H = rng.uniform(0.03, 0.2, n)
    for _ in range(5):
        q, dq = rng.uniform(-np.pi, np.pi, 6), rng.normal(size=6)
        ends, end_v = capsule_ends(q, CAPSULES, dq)
        h_ends, h_v = _random_segments(rng, n)
        std = rng.uniform(0, 0.01, n)
        for mode in ("estimated", "iso", "estimated_with_floor"):
            m = SeparationMonitor(num_segments=n, capsule_radii=CAPSULES.radius,
                                  human_speed=mode, human_uncertainty=0.01,
                                  human_uncertainty_sigmas=3.0, **ARGS)
            d, s, v_h, v_r, nearest = _outputs(m, _fixed(m, ends, end_v, h_ends, h_v, r_H,
                                                         np.ones(n), std))
            clearance, h, r = pair_figures(ends, end_v, CAPSULES.radius, h_ends, h_v, r_H)
            s_pairs = monitor_protective_distances(
                h, r, mode=mode, human_uncertainty=(0.01 + 3 * std)[:, None], **ARGS)
            j = clearance.argmin(axis=1)
            rows = np.arange(n)
            np.testing.assert_array_equal(d, clearance[rows, j])
            np.testing.assert_array_equal(s, s_pairs.max(axis=1))
            np.testing.assert_array_equal(v_h, h[rows, j])
            np.testing.assert_array_equal(v_r, r[rows, j])
            np.testing.assert_array_equal(nearest, j)


def test_point_segments_are_the_body_spheres_bit_for_bit():
    # A point body (ends and velocities alike) gives what the former per-body monitor gave:
    # robot_geometry.nearest_capsule_one, the smallest clearance of a sphere to the
    # capsules and that pair's speeds, bit for bit.
    rng = np.random.default_rng(5)
    n = 5
    r_B = rng.uniform(0.03, 0.12, n)
    m = SeparationMonitor(num_segments=n, capsule_radii=CAPSULES.radius, **ARGS)
    for _ in range(5):
        q, dq = rng.uniform(-np.pi, np.pi, 6), rng.normal(size=6)
        ends, end_v = capsule_ends(q, CAPSULES, dq)
        p_B, v_B = rng.normal(size=(n, 3)) * 0.8, rng.normal(size=(n, 3))
        d, _, v_h, v_r, nearest = _outputs(m, _fixed(m, ends, end_v, *_points(p_B, v_B), r_B,
                                                     np.ones(n), np.zeros(n)))
        for i in range(n):
            want = nearest_capsule_one(tuple(p_B[i]), tuple(v_B[i]), r_B[i], ends, end_v,
                                       CAPSULES.radius)
            assert (d[i], v_h[i], v_r[i], nearest[i]) == want


def test_fastest_point_robot_speed_is_each_capsules_faster_end():
    # robot_speed: fastest_point: S of a pair takes the speed of its capsule's faster end,
    # whatever its direction, for v_R (Eq. 11); d and the human speed are as before.
    rng = np.random.default_rng(13)
    n = 4
    r_H = rng.uniform(0.03, 0.12, n)
    for _ in range(5):
        q, dq = rng.uniform(-np.pi, np.pi, 6), rng.normal(size=6)
        ends, end_v = capsule_ends(q, CAPSULES, dq)
        h_ends, h_v = _random_segments(rng, n)
        m = SeparationMonitor(num_segments=n, capsule_radii=CAPSULES.radius,
                              human_speed="iso", robot_speed="fastest_point", **ARGS)
        d, s, v_h, v_r, nearest = _outputs(m, _fixed(m, ends, end_v, h_ends, h_v, r_H,
                                                     np.ones(n), np.zeros(n)))
        clearance, h, _ = pair_figures(ends, end_v, CAPSULES.radius, h_ends, h_v, r_H)
        fastest = np.linalg.norm(end_v, axis=-1).max(axis=-1)  # (K,)
        s_pairs = monitor_protective_distances(h, np.broadcast_to(fastest, h.shape),
                                               mode="iso", **ARGS)
        j = clearance.argmin(axis=1)
        rows = np.arange(n)
        np.testing.assert_array_equal(d, clearance[rows, j])
        np.testing.assert_array_equal(s, s_pairs.max(axis=1))
        np.testing.assert_array_equal(v_r, fastest[j])
        # Never below the directed speed's S: a robot moving away earns no credit.
        directed = SeparationMonitor(num_segments=n, capsule_radii=CAPSULES.radius,
                                     human_speed="iso", **ARGS)
        assert np.all(s >= _outputs(directed, _fixed(directed, ends, end_v, h_ends, h_v, r_H,
                                                     np.ones(n), np.zeros(n)))[1])


def test_tool_point_is_the_seeds_eq8_bit_for_bit():
    rng = np.random.default_rng(4)
    n = 4
    p_R, v_R = rng.normal(size=3), rng.normal(size=3)
    p_B, v_B = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    m = SeparationMonitor(num_segments=n, capsule_radii=tool_point().radius,
                          human_speed="iso", **ARGS)
    d, s, v_h, v_r, nearest = _outputs(m, _fixed(m, [p_R, p_R], [v_R, v_R],
                                                 *_points(p_B, v_B), np.zeros(n),
                                                 np.ones(n), np.zeros(n)))
    want_h, want_r = directed_speeds(p_R, v_R, p_B, v_B)
    np.testing.assert_array_equal(d, separation_distances(p_R, p_B))
    np.testing.assert_array_equal(v_h, want_h)
    np.testing.assert_array_equal(v_r, want_r)
    np.testing.assert_array_equal(s, monitor_protective_distances(want_h, want_r, mode="iso",
                                                                  **ARGS))
    np.testing.assert_array_equal(nearest, 0)


# One robot capsule along x from (0, 0, 0.3) to (1, 0, 0.3), radius 0.05.
LINK = [[0, 0, 0.3], [1, 0, 0.3]]


def test_hand_computed_point_case_and_unusable_segments_are_nan():
    # The capsule moves at 0.2 m/s along +x; segment 0, a point body of radius 0.05 at
    # (0.5, 1.0, 0.3), comes at 1 m/s along -y. Segment 1 is untracked (status none),
    # segment 2 lost: NaN on every output, index -1, whatever their (finite) inputs.
    m = SeparationMonitor(num_segments=3, capsule_radii=[0.05], **ARGS)
    h_ends, h_v = _points([[0.5, 1.0, 0.3], [2, 2, 2], [0.5, 0.5, 0.3]],
                          [[0, -1.0, 0], [0, 0, 0], [0, 0, 0]])
    c = _fixed(m, LINK, [[0.2, 0, 0]] * 2, h_ends, h_v, [0.05] * 3,
               [TRACK_TRACKING, TRACK_NONE, TRACK_LOST], [0, 0, 0])
    d, s, v_h, v_r, nearest = _outputs(m, c)
    assert d[0] == pytest.approx(1.0 - 0.05 - 0.05)
    assert v_h[0] == pytest.approx(1.0) and v_r[0] == pytest.approx(0.0)
    assert s[0] == pytest.approx(1.0 * 0.4 + 0.0 * 0.1 + 0.2)
    assert nearest[0] == 0
    for i in (1, 2):
        assert np.isnan([d[i], s[i], v_h[i], v_r[i]]).all() and nearest[i] == -1


def test_hand_computed_capsule_case_is_between_the_nearest_points_of_the_axes():
    # The capsule moves at 0.3 m/s along +y (towards the segments). Segment 0, radius 0.1,
    # stands upright from (0.7, 0.5, -0.2) to (0.7, 0.5, 1.2): the axes' nearest points
    # are (0.7, 0, 0.3) and (0.7, 0.5, 0.3), both inside their axes, 0.5 m apart (its ends
    # are 0.71 m and 1.0 m from the link's axis). Its lower end comes at 0.4 m/s along -y,
    # its upper end at 1.2 m/s: the human speed is the faster end's, 1.2 m/s.
    # Segment 1, radius 0.06, lies along y from (0.3, 0.4, 0.3) to (0.3, 1.4, 0.3): its
    # nearest point is its end (0.3, 0.4, 0.3), 0.4 m from (0.3, 0, 0.3); both ends still.
    m = SeparationMonitor(num_segments=2, capsule_radii=[0.05], **ARGS)
    h_ends = [[[0.7, 0.5, -0.2], [0.7, 0.5, 1.2]], [[0.3, 0.4, 0.3], [0.3, 1.4, 0.3]]]
    h_v = [[[0, -0.4, 0], [0, -1.2, 0]], [[0, 0, 0], [0, 0, 0]]]
    c = _fixed(m, LINK, [[0, 0.3, 0]] * 2, h_ends, h_v, [0.1, 0.06],
               [TRACK_TRACKING, TRACK_TRACKING], [0, 0])
    d, s, v_h, v_r, nearest = _outputs(m, c)
    np.testing.assert_allclose(d, [0.5 - 0.05 - 0.1, 0.4 - 0.05 - 0.06], atol=1e-12)
    np.testing.assert_allclose(v_h, [1.2, 0.0], atol=1e-12)
    np.testing.assert_allclose(v_r, [0.3, 0.3], atol=1e-12)
    # S = v_h (T_r + T_s) + v_r T_r + B
    np.testing.assert_allclose(s, [1.2 * 0.4 + 0.3 * 0.1 + 0.2, 0.3 * 0.1 + 0.2], atol=1e-12)
    np.testing.assert_array_equal(nearest, [0, 0])


def test_a_hidden_segment_is_measured_as_given():
    # Status hidden is usable: the monitor measures the envelope it is given, as for a
    # tracked one (the hidden body's growing ball is inside the envelope already).
    m = SeparationMonitor(num_segments=1, capsule_radii=[0.05], **ARGS)
    h_ends, h_v = _points([[0.5, 1.0, 0.3]], [[0, -1.0, 0]])
    out = [_outputs(m, _fixed(m, LINK, [[0.2, 0, 0]] * 2, h_ends, h_v, [0.3], [status],
                              [0.0])) for status in (TRACK_TRACKING, TRACK_HIDDEN)]
    for tracked, hidden in zip(*out):
        np.testing.assert_array_equal(hidden, tracked)
    assert out[1][0][0] == pytest.approx(1.0 - 0.05 - 0.3)


def test_a_hidden_body_grows_its_envelope_at_the_occlusion_speed():
    # A helmet (the operator's only body) hidden for 0.2 s, through OperatorEnvelopes into
    # the monitor: the head's envelope grows by occlusion_speed x 0.2 s, which comes off
    # the head segment's d; S is unchanged (the estimate's velocity is the same).
    recipe = envelope_recipe([["head"]])
    head = recipe.names.index("0/head")
    ends, end_v = [[0.5, 0, 0.3]] * 2, [[0, 0, 0]] * 2
    outputs = []
    for speed in (0.0, 2.0):
        env = OperatorEnvelopes(num_bodies=1, recipe=recipe, tracking_allowance=0.01,
                                occlusion_speed=speed)
        ec = env.CreateDefaultContext()
        for name, value in dict(positions_estimated=[1.5, 0, 1.6],
                                velocities_estimated=[0, 1.0, 0], track_status=[TRACK_HIDDEN],
                                position_std=[0.0], unseen_time=[0.2]).items():
            env.GetInputPort(name).FixValue(ec, np.asarray(value, float))
        seg = [env.GetOutputPort(n).Eval(ec) for n in ("segment_ends", "segment_velocities",
                                                          "segment_radii", "segment_status",
                                                          "segment_std")]
        m = SeparationMonitor(num_segments=recipe.radius.size, **ARGS)
        outputs.append(_outputs(m, _fixed(m, ends, end_v, *seg))[:2])
    (d_plain, s_plain), (d_grown, s_grown) = outputs
    assert np.all(np.isfinite(d_plain)) and np.all(np.isfinite(d_grown))
    assert d_plain[head] - d_grown[head] == pytest.approx(0.4)
    # every segment's envelope derives from the hidden helmet, so every one comes nearer
    # (those from two regions about it, ellipsoids, by more than the ball's radius)
    assert np.all(d_plain - d_grown > 0.0)
    np.testing.assert_array_equal(s_grown, s_plain)


def test_a_nan_input_stops_through_nan_outputs():
    m = SeparationMonitor(num_segments=1, capsule_radii=CAPSULES.radius, **ARGS)
    ends, end_v = capsule_ends(np.zeros(6), CAPSULES, np.zeros(6))
    bad = end_v.copy()
    bad[3, 1, 0] = np.nan  # one capsule end's velocity unknown (before the first tick)
    d, s, _, _, nearest = _outputs(m, _fixed(m, ends, bad, *_points(np.ones((1, 3)),
                                                                    np.zeros((1, 3))),
                                             [0.05], [1], [0]))
    assert np.isnan(d[0]) and np.isnan(s[0]) and nearest[0] == -1
    # A NaN end of a tracked segment (an envelope from a NaN estimate) stops too.
    h_ends, h_v = _points(np.ones((1, 3)), np.zeros((1, 3)))
    h_ends[0, 1, 2] = np.nan
    d, s, _, _, nearest = _outputs(m, _fixed(m, ends, end_v, h_ends, h_v, [0.05], [1], [0]))
    assert np.isnan(d[0]) and np.isnan(s[0]) and nearest[0] == -1


@pytest.mark.parametrize("kwargs, match", [
    (dict(human_speed="fast"), "human_speed"),
    (dict(robot_speed="slowest"), "robot_speed"),
    (dict(reaction_time=-1), "reaction_time"),
    (dict(human_uncertainty_sigmas=np.nan), "human_uncertainty_sigmas"),
    (dict(capsule_radii=[]), "capsule_radii"),
    (dict(capsule_radii=[-0.1]), "capsule_radii"),
    (dict(num_segments=-1), "num_segments"),
])
def test_bad_arguments_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SeparationMonitor(**(dict(num_segments=1) | ARGS | kwargs))
