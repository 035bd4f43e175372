import numpy as np
import pytest

from safety_systems.sensing import stops
from safety_systems.ssm.formulas import overall_speed_override
from safety_systems.sensing.stops import (
    STOP_LOST_TRACK,
    STOP_NONE,
    STOP_SEPARATION,
    STOP_STALE_FRAME,
)
from safety_systems.systems.speed_override import SpeedOverride


def _eval(d, s, status, fault=0.0, **kw):
    o = SpeedOverride(num_bodies=len(d), **kw)
    c = o.CreateDefaultContext()
    o.GetInputPort("distances").FixValue(c, np.asarray(d, float))
    o.GetInputPort("protective_distances").FixValue(c, np.asarray(s, float))
    o.GetInputPort("track_status").FixValue(c, np.asarray(status, float))
    o.GetInputPort("fault").FixValue(c, [fault])
    return [o.GetOutputPort(n).Eval(c)[0]
            for n in ("path_speed_commanded", "max_protective_distance", "stop_reason")]


def test_matches_plain_function():
    rng = np.random.default_rng(1)
    for _ in range(20):
        d, s = rng.uniform(0, 3, 4), rng.uniform(0, 1.5, 4)
        k, s_max, _ = _eval(d, s, [1, 2, 1, 1])
        k_ref, s_ref = overall_speed_override(d, s, np.ones(4, bool))
        assert k == pytest.approx(k_ref)
        assert s_max == pytest.approx(s_ref)


def test_reasons():
    assert _eval([3.0], [1.0], [1]) == [1.0, 1.0, STOP_NONE]
    assert _eval([0.5], [1.0], [1])[::2] == [0.0, STOP_SEPARATION]
    # A tracker fault is its own stop reason; NaN or an unknown code counts as stale.
    for code in range(STOP_STALE_FRAME, len(stops.STOP_REASONS)):
        assert _eval([3.0], [1.0], [1], fault=float(code))[::2] == [0.0, code]
    for fault in (float("nan"), 1.0, 99.0, -2.0):
        assert _eval([3.0], [1.0], [1], fault=fault)[::2] == [0.0, STOP_STALE_FRAME]
    assert _eval([3.0, np.nan], [1.0, np.nan], [1, 3])[::2] == [0.0, STOP_LOST_TRACK]
    # A hidden body counts as a tracked one; no tracked body: full speed.
    assert _eval([0.5, np.nan], [1.0, np.nan], [2, 0])[::2] == [0.0, STOP_SEPARATION]
    assert _eval([np.nan], [np.nan], [0])[0] == 1.0


def test_bad_parameters():
    with pytest.raises(ValueError, match="delta_s"):
        SpeedOverride(num_bodies=1, delta_s=0.5)
    with pytest.raises(ValueError, match="d_min"):
        SpeedOverride(num_bodies=1, d_min=-0.1)
