"""SeparationMonitor: Eqs. 6-11 between tracked bodies (spheres) and the robot's capsules."""

import numpy as np
import pytest

from safety_systems.cell.robot_geometry import capsule_ends, robot_capsules, tool_point
from safety_systems.ssm.separation import pair_figures
from safety_systems.ssm.formulas import (
    directed_speeds,
    monitor_protective_distances,
    separation_distances,
)
from safety_systems.systems.separation_monitor import SeparationMonitor

ARGS = dict(reaction_time=0.1, stopping_time=0.3, stopping_distance=0.2)
CAPSULES = robot_capsules(payload_radius=0.06, tool_length=0.1)
OUTPUTS = ("distances", "protective_distances", "human_directed_speeds",
           "robot_directed_speeds", "nearest_capsule")


def _fixed(monitor, ends, end_v, p_B, v_B, status, std, unseen=None):
    c = monitor.CreateDefaultContext()
    unseen = np.zeros(len(status)) if unseen is None else unseen
    for name, value in dict(capsule_ends=np.ravel(ends), capsule_velocities=np.ravel(end_v),
                            positions_estimated=p_B.ravel(), velocities_estimated=v_B.ravel(),
                            track_status=status, position_std=std, unseen_time=unseen).items():
        monitor.GetInputPort(name).FixValue(c, np.asarray(value, float))
    return c


def _outputs(monitor, context):
    return [monitor.GetOutputPort(n).Eval(context).copy() for n in OUTPUTS]


def test_monitor_is_the_pairs_smallest_clearance_and_largest_s():
    rng = np.random.default_rng(3)
    n = 5
    r_B = rng.uniform(0.03, 0.12, n)
    for _ in range(5):
        q, dq = rng.uniform(-np.pi, np.pi, 6), rng.normal(size=6)
        ends, end_v = capsule_ends(q, CAPSULES, dq)
        p_B, v_B = rng.normal(size=(n, 3)) * 0.8, rng.normal(size=(n, 3))
        std = rng.uniform(0, 0.01, n)
        for mode in ("estimated", "iso", "estimated_with_floor"):
            m = SeparationMonitor(num_bodies=n, capsule_radii=CAPSULES.radius, body_radii=r_B,
                                  human_speed=mode, human_uncertainty=0.01,
                                  human_uncertainty_sigmas=3.0, **ARGS)
            d, s, v_h, v_r, nearest = _outputs(m, _fixed(m, ends, end_v, p_B, v_B, np.ones(n),
                                                         std))
            clearance, h, r = pair_figures(ends, end_v, CAPSULES.radius, p_B, v_B, r_B)
            s_pairs = monitor_protective_distances(
                h, r, mode=mode, human_uncertainty=(0.01 + 3 * std)[:, None], **ARGS)
            j = clearance.argmin(axis=1)
            rows = np.arange(n)
            np.testing.assert_array_equal(d, clearance[rows, j])
            np.testing.assert_array_equal(s, s_pairs.max(axis=1))
            np.testing.assert_array_equal(v_h, h[rows, j])
            np.testing.assert_array_equal(v_r, r[rows, j])
            np.testing.assert_array_equal(nearest, j)


def test_fastest_point_robot_speed_is_each_capsules_faster_end():
    # robot_speed: fastest_point: S of a pair takes the speed of its capsule's faster end,
    # whatever its direction, for v_R (Eq. 11); d and the human speed are as before.
    rng = np.random.default_rng(13)
    n = 4
    r_B = rng.uniform(0.03, 0.12, n)
    for _ in range(5):
        q, dq = rng.uniform(-np.pi, np.pi, 6), rng.normal(size=6)
        ends, end_v = capsule_ends(q, CAPSULES, dq)
        p_B, v_B = rng.normal(size=(n, 3)) * 0.8, rng.normal(size=(n, 3))
        m = SeparationMonitor(num_bodies=n, capsule_radii=CAPSULES.radius, body_radii=r_B,
                              human_speed="iso", robot_speed="fastest_point", **ARGS)
        d, s, v_h, v_r, nearest = _outputs(m, _fixed(m, ends, end_v, p_B, v_B, np.ones(n),
                                                     np.zeros(n)))
        clearance, h, _ = pair_figures(ends, end_v, CAPSULES.radius, p_B, v_B, r_B)
        fastest = np.linalg.norm(end_v, axis=-1).max(axis=-1)  # (K,)
        s_pairs = monitor_protective_distances(h, np.broadcast_to(fastest, h.shape),
                                               mode="iso", **ARGS)
        j = clearance.argmin(axis=1)
        rows = np.arange(n)
        np.testing.assert_array_equal(d, clearance[rows, j])
        np.testing.assert_array_equal(s, s_pairs.max(axis=1))
        np.testing.assert_array_equal(v_r, fastest[j])
        # Never below the directed speed's S: a robot moving away earns no credit.
        directed = SeparationMonitor(num_bodies=n, capsule_radii=CAPSULES.radius,
                                     body_radii=r_B, human_speed="iso", **ARGS)
        assert np.all(s >= _outputs(directed, _fixed(directed, ends, end_v, p_B, v_B,
                                                     np.ones(n), np.zeros(n)))[1])


def test_tool_point_is_the_seeds_eq8_bit_for_bit():
    rng = np.random.default_rng(4)
    n = 4
    p_R, v_R = rng.normal(size=3), rng.normal(size=3)
    p_B, v_B = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    m = SeparationMonitor(num_bodies=n, capsule_radii=tool_point().radius, human_speed="iso",
                          **ARGS)
    d, s, v_h, v_r, nearest = _outputs(m, _fixed(m, [p_R, p_R], [v_R, v_R], p_B, v_B,
                                                 np.ones(n), np.zeros(n)))
    want_h, want_r = directed_speeds(p_R, v_R, p_B, v_B)
    np.testing.assert_array_equal(d, separation_distances(p_R, p_B))
    np.testing.assert_array_equal(v_h, want_h)
    np.testing.assert_array_equal(v_r, want_r)
    np.testing.assert_array_equal(s, monitor_protective_distances(want_h, want_r, mode="iso",
                                                                  **ARGS))
    np.testing.assert_array_equal(nearest, 0)


def test_hand_computed_case_and_untracked_bodies_are_nan():
    # One capsule along x from (0, 0, 0.3) to (1, 0, 0.3), radius 0.05, moving at 0.2 m/s
    # along +x; body 0 (radius 0.05) at (0.5, 1.0, 0.3) coming at 1 m/s along -y.
    m = SeparationMonitor(num_bodies=2, capsule_radii=[0.05], body_radii=[0.05, 0.05], **ARGS)
    ends = [[0, 0, 0.3], [1, 0, 0.3]]
    c = _fixed(m, ends, [[0.2, 0, 0]] * 2, np.array([[0.5, 1.0, 0.3], [2, 2, 2]]),
               np.array([[0, -1.0, 0], [0, 0, 0]]), [1, 0], [0, 0])
    d, s, v_h, v_r, nearest = _outputs(m, c)
    assert d[0] == pytest.approx(1.0 - 0.05 - 0.05)
    assert v_h[0] == pytest.approx(1.0) and v_r[0] == pytest.approx(0.0)
    assert s[0] == pytest.approx(1.0 * 0.4 + 0.0 * 0.1 + 0.2)
    assert np.isnan(d[1]) and np.isnan(s[1]) and nearest[1] == -1


def test_hidden_body_is_a_ball_growing_at_the_occlusion_speed():
    # Body 0 hidden for 0.2 s; body 1 seen in the last frame.
    ends, end_v = [[0.5, 0, 0.3]] * 2, [[0, 0, 0]] * 2
    p_B = np.array([[1.5, 0, 0.3], [0, 1.5, 0.3]])
    v_B = np.array([[0.0, 1.0, 0.0], [0, 0, 0]])
    args = (ends, end_v, p_B, v_B, [2, 1], [0, 0])
    outputs = []
    for speed in (0.0, 2.0):
        m = SeparationMonitor(num_bodies=2, occlusion_speed=speed, **ARGS)
        outputs.append(_outputs(m, _fixed(m, *args, [0.2, 0]))[:2])
    (d_plain, s_plain), (d_grown, s_grown) = outputs
    # The ball's radius, 2.0 m/s * 0.2 s, comes off the hidden body's d; S is unchanged.
    np.testing.assert_allclose(d_plain - d_grown, [0.4, 0.0])
    np.testing.assert_array_equal(s_grown, s_plain)


def test_a_nan_input_stops_through_nan_outputs():
    m = SeparationMonitor(num_bodies=1, capsule_radii=CAPSULES.radius, body_radii=[0.05], **ARGS)
    ends, end_v = capsule_ends(np.zeros(6), CAPSULES, np.zeros(6))
    end_v[3, 1, 0] = np.nan  # one capsule end's velocity unknown (before the first tick)
    d, s, _, _, nearest = _outputs(m, _fixed(m, ends, end_v, np.ones((1, 3)), np.zeros((1, 3)),
                                             [1], [0]))
    assert np.isnan(d[0]) and np.isnan(s[0]) and nearest[0] == -1


@pytest.mark.parametrize("kwargs, match", [
    (dict(human_speed="fast"), "human_speed"),
    (dict(reaction_time=-1), "reaction_time"),
    (dict(occlusion_speed=-1.0), "occlusion_speed"),
    (dict(capsule_radii=[]), "capsule_radii"),
    (dict(capsule_radii=[-0.1]), "capsule_radii"),
    (dict(body_radii=[0.05, 0.05]), "body_radii"),
    (dict(body_radii=[np.nan]), "body_radii"),
])
def test_bad_arguments_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SeparationMonitor(num_bodies=1, **(ARGS | kwargs))
