import numpy as np
import pytest

from safety_systems.ssm import directed_speeds, monitor_protective_distances, separation_distances
from safety_systems.systems.separation_monitor import SeparationMonitor

ARGS = dict(reaction_time=0.1, stopping_time=0.3, stopping_distance=0.2)


def _fixed(monitor, p_R, v_R, p_B, v_B, status, std, unseen=None):
    c = monitor.CreateDefaultContext()
    unseen = np.zeros(len(status)) if unseen is None else unseen
    for name, value in dict(ee_position=p_R, ee_velocity=v_R, positions_estimated=p_B.ravel(),
                            velocities_estimated=v_B.ravel(), track_status=status,
                            position_std=std, unseen_time=unseen).items():
        monitor.GetInputPort(name).FixValue(c, np.asarray(value, float))
    return c


def test_monitor_matches_plain_functions():
    rng = np.random.default_rng(3)
    n = 5
    p_R, v_R = rng.normal(size=3), rng.normal(size=3)
    p_B, v_B = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    std = rng.uniform(0, 0.01, n)
    for mode in ("estimated", "iso", "estimated_with_floor"):
        m = SeparationMonitor(num_bodies=n, human_speed=mode, human_uncertainty=0.01,
                              human_uncertainty_sigmas=3.0, **ARGS)
        c = _fixed(m, p_R, v_R, p_B, v_B, np.ones(n), std)
        v_h, v_r = directed_speeds(p_R, v_R, p_B, v_B)
        s = monitor_protective_distances(v_h, v_r, mode=mode, human_uncertainty=0.01 + 3 * std,
                                         **ARGS)
        np.testing.assert_allclose(m.GetOutputPort("distances").Eval(c),
                                   separation_distances(p_R, p_B))
        np.testing.assert_allclose(m.GetOutputPort("protective_distances").Eval(c), s)
        np.testing.assert_allclose(m.GetOutputPort("human_directed_speeds").Eval(c), v_h)
        np.testing.assert_allclose(m.GetOutputPort("robot_directed_speeds").Eval(c), v_r)


def test_hand_computed_case_and_untracked_bodies_are_nan():
    m = SeparationMonitor(num_bodies=2, **ARGS)
    c = _fixed(m, [0.5, 0, 0.3], [0.2, 0, 0], np.array([[1.5, 0, 0.3], [2, 2, 2]]),
               np.array([[-1.0, 0, 0], [0, 0, 0]]), [1, 0], [0, 0])
    d = m.GetOutputPort("distances").Eval(c)
    s = m.GetOutputPort("protective_distances").Eval(c)
    assert d[0] == pytest.approx(1.0)
    assert s[0] == pytest.approx(1.0 * 0.4 + 0.2 * 0.1 + 0.2)
    assert np.isnan(d[1]) and np.isnan(s[1])


def test_bad_arguments_rejected():
    with pytest.raises(ValueError, match="human_speed"):
        SeparationMonitor(num_bodies=1, human_speed="fast", **ARGS)
    with pytest.raises(ValueError, match="reaction_time"):
        SeparationMonitor(num_bodies=1, reaction_time=-1, stopping_time=0.3, stopping_distance=0)


def test_hidden_body_is_a_ball_growing_at_the_occlusion_speed():
    # Body 0 hidden for 0.2 s (last estimate moving at 1 m/s); body 1 seen in the last frame.
    p_B = np.array([[1.5, 0, 0.3], [0, 1.5, 0.3]])
    v_B = np.array([[0.0, 1.0, 0.0], [0, 0, 0]])
    args = ([0.5, 0, 0.3], [0, 0, 0], p_B, v_B, [2, 1], [0, 0])
    plain = SeparationMonitor(num_bodies=2, **ARGS)
    grown = SeparationMonitor(num_bodies=2, occlusion_speed=2.0, **ARGS)
    outputs = []
    for monitor in (plain, grown):
        c = _fixed(monitor, *args, [0.2, 0])
        outputs.append([monitor.GetOutputPort(n).Eval(c)
                        for n in ("distances", "protective_distances")])
    (d_plain, s_plain), (d_grown, s_grown) = outputs
    # The ball's radius, 2.0 m/s * 0.2 s, comes off the hidden body's d; S is unchanged.
    np.testing.assert_allclose(d_plain - d_grown, [0.4, 0.0])
    np.testing.assert_array_equal(s_grown, s_plain)
    with pytest.raises(ValueError, match="occlusion_speed"):
        SeparationMonitor(num_bodies=1, occlusion_speed=-1.0, **ARGS)
