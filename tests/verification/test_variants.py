"""Deliberately broken configurations are falsified; their unbroken forms are not.

Each variant breaks one thing the protective distance relies on. The search runs over
a box of approaches that starts outside S (for the iso variants) or of gentle
approaches (for the sign flip), and every counterexample is confirmed in the Drake
diagram by ``verify``.
"""

import dataclasses
import types

import numba
import pytest

import safety_systems.systems.separation_monitor as monitor_module
import verification.evaluate_batch as batch_module
from safety_systems.scenario import load_controller_config
from safety_systems.ssm import separation_and_directed_speeds, separation_pair
from verification.proof import prove
from verification.space import Range, load_space
from verification.verify import verify

DEFAULT = load_space("models/spaces/default.yaml")
ISO = load_controller_config("models/configs/iso.yaml")
SEED = load_controller_config("models/configs/seed_estimated.yaml")


def _space(**ranges):
    return dataclasses.replace(DEFAULT, parameters=dataclasses.replace(
        DEFAULT.parameters, **{k: Range(*v) for k, v in ranges.items()}))


# Single hands walking in from outside S at 1.6 to 2.0 m/s.
FROM_OUTSIDE = dict(start_distance=(1.5, 2.5), peak_speed=(1.6, 2.0), acceleration=(2.0, 10.0),
                    retreat_distance=(0.0, 0.0), operators=(1, 1), dropout=(0.0, 0.0),
                    occlusion=(0.0, 0.0), elevation_deg=(-10.0, 10.0))


def _verify(config, space, tmp_path, budget=40, seed=0):
    return verify(config, space, tmp_path, budget=budget, workers=1, seed=seed,
                  stop_at_first=True)


def _assert_falsified(outcome):
    assert outcome.verdict == "falsified"
    assert outcome.counterexamples and outcome.unconfirmed == []
    for c in outcome.counterexamples:
        assert c["drake_robustness"] < 0.0 and c["robustness"] < 0.0


def test_reaction_time_left_out_of_s(tmp_path):
    space = _space(**FROM_OUTSIDE)
    assert prove(ISO, space).proved
    broken = dataclasses.replace(ISO, safety=dataclasses.replace(ISO.safety, reaction_time=0.0))
    _assert_falsified(_verify(broken, space, tmp_path))


def test_latency_larger_than_the_configuration_assumes(tmp_path):
    # The data arrives 0.25-0.3 s late; the configuration assumes 0.02 s and was given
    # a frame timeout that tolerates the delay, so the stale frames are used.
    space = _space(**FROM_OUTSIDE, latency=(0.25, 0.3))
    tolerant = dataclasses.replace(ISO, tracker=dataclasses.replace(ISO.tracker,
                                                                    frame_timeout=0.4))
    _assert_falsified(_verify(tolerant, space, tmp_path / "tolerant"))
    # With its own timeout the iso configuration stops on the stale frames instead.
    assert prove(ISO, space).proved


def test_braking_weaker_than_the_stopping_data_says(tmp_path):
    space = _space(**FROM_OUTSIDE, braking_time_scale=(1.5, 2.0))
    assert not prove(ISO, space).proved
    _assert_falsified(_verify(ISO, space, tmp_path))


@pytest.fixture
def flipped_sign(monkeypatch):
    """Eqs. 6-7 with the wrong sign: closing in counts as moving away. The diagram's
    SeparationMonitor calls the Python function; the batched evaluator's compiled ticks
    are rebuilt from their own source with the monitor's pair flipped."""

    def flipped(*args):
        d, v_h, v_r = separation_and_directed_speeds(*args)
        return d, -v_h, -v_r

    monkeypatch.setattr(monitor_module, "separation_and_directed_speeds", flipped)

    @numba.njit(inline="always")
    def flipped_pair(p_R, v_R, p_B, v_B):
        d, v_h, v_r = separation_pair(p_R, v_R, p_B, v_B)
        return d, -v_h, -v_r

    source = batch_module._advance.py_func
    rebuilt = types.FunctionType(source.__code__, {**source.__globals__,
                                                   "monitor_pair": flipped_pair})
    monkeypatch.setattr(batch_module, "_advance", numba.njit(rebuilt))


GENTLE = dict(start_distance=(1.0, 2.5), peak_speed=(0.5, 1.2), acceleration=(1.0, 3.0),
              retreat_distance=(0.0, 0.0), operators=(1, 1), dropout=(0.0, 0.0),
              occlusion=(0.0, 0.0))


def test_seed_configuration_passes_gentle_approaches(tmp_path):
    outcome = _verify(SEED, _space(**GENTLE), tmp_path, budget=20)
    assert outcome.verdict == "passed" and outcome.log.robustness.min() > 0.0


def test_directed_speed_sign_flipped(tmp_path, flipped_sign):
    _assert_falsified(_verify(SEED, _space(**GENTLE), tmp_path, budget=20))
