"""Deliberately broken configurations are falsified; their unbroken forms are not.

Each variant breaks one thing safety relies on; every counterexample is confirmed in the
Drake diagram by ``verify``. First the issue's demonstrations on the whole-cell default
space (``models/spaces/default.yaml``): the previous behaviour (the tool point, tracks
ended by time or by distance from the base, no gate) is falsified by an occluded
approach and by an approach to the elbow, where the iso configuration is safe; and
mutants of a proved configuration are falsified: a capsule too small, the gate off,
tracks ended after 0.5 s hidden. Then older variants: the reaction time left out of S,
a latency the configuration does not know, weaker brakes, a sign error in Eqs. 6-7.

Every operator here is tracked by a motion-capture suit (all ten body points): the
monitor's envelopes are then the segments themselves (plus the tracking allowance), as
the three balls were the bodies. With gloves and a helmet only, the envelopes of the
untracked arms and trunk are 0.5 to 0.85 m wide: a margin the true body almost never
fills, which hides breaks of these sizes from a search (the proofs still reject them:
they take the envelope, not the body, at its word).
"""

import dataclasses
import types

import numba
import numpy as np
import pytest

import safety_systems.ssm.separation as separation_module
import verification.search.evaluate_batch as batch_module
from safety_systems.cell.human_body import POINTS
from safety_systems.outputs.metrics import true_pairs
from safety_systems.cell.robot_geometry import CAPSULE_NAMES, segments_pair
from safety_systems.config.scenario import load_controller_config, load_scenario
from safety_systems.diagrams.simulation import simulate
from verification.search.evaluate_drake import robustness_of_run
from verification.proof.theorems import prove
from verification.spaces.box import Range
from verification.spaces.space import load_space, space_cell
from verification.verify import verify

SUIT = list(POINTS)  # every body point tracked
DEFAULT = dataclasses.replace(load_space("models/spaces/default.yaml"), tracked=SUIT)
FLANGE = dataclasses.replace(load_space("models/spaces/flange.yaml"), tracked=SUIT)
ISO = load_controller_config("models/configs/iso.yaml")
# iso.yaml's terms for "stopped before contact" alone: the Z_r that the separation
# invariant asks for taken out (models/configs/iso.yaml says why it is there). Mutants of
# the contact property are made of it, where the contact margin is tight.
ISO_CONTACT = dataclasses.replace(ISO, safety=dataclasses.replace(ISO.safety,
                                                                  robot_uncertainty=0.0))
PREVIOUS = load_controller_config("models/configs/iso_previous.yaml")
SEED = load_controller_config("models/configs/seed_estimated.yaml")


def _space(space=DEFAULT, **ranges):
    return dataclasses.replace(space, parameters=dataclasses.replace(
        space.parameters, **{k: Range(*v) for k, v in ranges.items()}))


def _verify(config, space, tmp_path, budget=1000, seed=0, candidates=2048, properties="contact"):
    return verify(config, space, tmp_path, budget=budget, workers=1, seed=seed,
                  stop_at_first=True, candidates=candidates, properties=properties)


def _assert_falsified(outcome):
    assert outcome.verdict == "falsified"
    assert outcome.counterexamples and outcome.unconfirmed == []
    for c in outcome.counterexamples:
        assert c["drake_robustness"] < 0.0 and c["robustness"] < 0.0
    return outcome.counterexamples[0]


def _replay(counterexample):
    """The counterexample's scenario file through the simulate pipeline: its run and
    the capsule nearest to a body at the moment of contact while moving."""
    run = simulate(load_scenario(counterexample["scenario"]))
    rho = robustness_of_run(run)
    until = counterexample["drake_stopped_at"]  # a confirmation stops after the contact
    shown = run.time <= (np.inf if until is None else until + 1e-9)
    early = dataclasses.replace(run, time=run.time[shown],
                                signals={k: v[shown] for k, v in run.signals.items()})
    assert robustness_of_run(early).stopped_before_contact == pytest.approx(
        counterexample["drake_robustness"], abs=1e-12)
    assert rho.stopped_before_contact <= counterexample["drake_robustness"]
    clearance = true_pairs(run)[0]
    moving = np.flatnonzero(np.any(np.abs(run["v"]) > 0.0, axis=1))
    worst = moving[np.nanargmin(np.nanmin(clearance[moving], axis=(1, 2)))]
    capsule = CAPSULE_NAMES[int(np.nanargmin(np.nanmin(clearance[worst], axis=0)))]
    return run, rho, capsule


# Sub-boxes of the default space (files, so ``safety-systems verify`` shows each kind of
# counterexample apart).
OCCLUDED = load_space("models/spaces/occluded_approach.yaml")
ELBOW = load_space("models/spaces/elbow_approach.yaml")
assert OCCLUDED.tracked == ELBOW.tracked == SUIT  # the files' operators wear suits


@pytest.mark.parametrize("sub", [OCCLUDED, ELBOW], ids=["occluded", "elbow"])
def test_demonstration_spaces_are_sub_boxes_of_the_default_space(sub):
    # the same cell and robot as the default space, its operators tracked by a suit
    assert dataclasses.replace(sub, name=DEFAULT.name, parameters=DEFAULT.parameters) == DEFAULT
    for name, bounds in dataclasses.asdict(sub.parameters).items():
        whole = getattr(DEFAULT.parameters, name)
        assert whole.min <= bounds["min"] <= bounds["max"] <= whole.max, name


def test_previous_behaviour_falsified_by_an_occluded_approach(tmp_path):
    # Every body of the operator hidden for 1-2 s from 1.8-2.5 m out, going for the tool:
    # the old rule ends the tracks after 0.5 s (their estimates lie beyond 2.5 m of the
    # base) and the robot runs on at full speed towards someone it cannot see.
    space = OCCLUDED
    worst = _assert_falsified(_verify(PREVIOUS, space, tmp_path / "previous"))
    run, rho, _ = _replay(worst)
    assert rho.stopped_before_contact < 0.0  # contact while moving, in the Drake diagram
    hidden = run["tracker.track_status"] != 1
    assert hidden.all(axis=1).any()  # at some instant no body was tracked at all
    # The whole-cell configuration keeps the hidden bodies as growing balls: safe.
    assert prove(space_cell(ISO, space), space).proved
    outcome = _verify(ISO, space, tmp_path / "iso", budget=20)
    assert outcome.verdict == "proved" and outcome.log.robustness.min() > 0.0


def test_previous_behaviour_falsified_by_an_approach_to_the_elbow(tmp_path):
    # No occlusion, no outliers: a hand reaching for the elbow, which the tool point
    # does not see.
    space = ELBOW
    worst = _assert_falsified(_verify(PREVIOUS, space, tmp_path / "previous"))
    _, rho, capsule = _replay(worst)
    assert rho.stopped_before_contact < 0.0
    assert capsule in ("upper_arm", "forearm")  # the contact is at the elbow, not the tool
    outcome = _verify(ISO, space, tmp_path / "iso", budget=20)
    assert outcome.verdict == "proved" and outcome.log.robustness.min() > 0.0


def test_iso_is_proved_and_the_previous_one_falsified_on_the_whole_space(tmp_path):
    assert prove(space_cell(ISO, DEFAULT), DEFAULT).proved
    assert not prove(space_cell(PREVIOUS, DEFAULT), DEFAULT).proved
    _assert_falsified(_verify(PREVIOUS, DEFAULT, tmp_path / "previous"))


def _mutant(config=ISO, **tracker):
    return dataclasses.replace(config, tracker=dataclasses.replace(config.tracker, **tracker))


@pytest.mark.parametrize("base, properties", [(ISO, "both"), (ISO_CONTACT, "contact")],
                         ids=["iso_both", "iso_contact_terms_contact"])
def test_mutant_gate_off_is_falsified(tmp_path, base, properties):
    # The operators' bodies reported 1-2 m farther back for a few frames: taken as truth,
    # the robot resumes towards them. iso.yaml's Z_r (the separation invariant's
    # allowance) keeps it clear of contact, but not outside S_true; without it, contact.
    worst = _assert_falsified(_verify(_mutant(base, gate=False), DEFAULT, tmp_path,
                                      properties=properties))
    assert worst["parameters"]["outlier_frames"] >= 1


def test_mutant_tracks_ended_after_half_a_second_hidden_is_falsified(tmp_path):
    # An operator whose tracks end while some of its bodies are still seen is lost (the
    # robot stops); the break shows when every body of an operator is hidden at once.
    mutant = _mutant(hidden_bodies="expire", max_coast_time=0.5, exit_radius=1e-6)
    space = _space(DEFAULT, occluded_bodies=(len(SUIT), len(SUIT)))
    worst = _assert_falsified(_verify(mutant, space, tmp_path))
    assert worst["parameters"]["occluded_bodies"] == len(SUIT)  # nobody of it in view
    assert worst["parameters"]["occlusion"] > 0.5


def test_mutant_capsule_too_small_is_falsified(tmp_path):
    # A proved configuration keeps real clearance to spare (its proof's worst case
    # combines a robot moving away, in S, with one moving towards the body, while
    # braking): iso.yaml's is about 0.5 m in this cell, so a capsule only a few
    # centimetres too small changes nothing a search could find (the proof rejects it).
    # Take the tightest configuration the proof allows (T_r 0.1 s instead of 0.2 s,
    # about 0.4 m to spare: the whole operator's hands are 0.13 m balls, not 0.05 m) and a
    # real payload 1.3 m across that the configuration still models as a 0.1 m sphere.
    space = dataclasses.replace(DEFAULT, robot=dataclasses.replace(DEFAULT.robot,
                                                                   payload_radius=0.65))
    tight = dataclasses.replace(ISO_CONTACT, safety=dataclasses.replace(
        ISO_CONTACT.safety, reaction_time=0.1, payload_radius=0.65))
    proof = prove(space_cell(tight, space), space)
    assert proof.proved and proof.margin_at_worst_corner < 0.02
    mutant = dataclasses.replace(tight, safety=dataclasses.replace(tight.safety,
                                                                   payload_radius=0.05))
    assert not prove(space_cell(mutant, space), space).proved
    _assert_falsified(_verify(mutant, space, tmp_path / "mutant", budget=40, candidates=8192))
    outcome = _verify(tight, space, tmp_path / "tight", budget=20, candidates=8192)
    assert outcome.verdict == "proved" and outcome.log.robustness.min() > 0.0


# The older variants, on the previous envelope (the flange, a tool-point monitor), where
# the iso terms are tight: single hands walking in from outside S at 1.6 to 2.0 m/s.
ISO_POINT = dataclasses.replace(ISO_CONTACT, safety=dataclasses.replace(
    ISO_CONTACT.safety, robot_geometry="tool_point"))
FROM_OUTSIDE = dict(start_distance=(1.5, 2.5), peak_speed=(1.6, 2.0), acceleration=(2.0, 10.0),
                    retreat_distance=(0.0, 0.0), operators=(1, 1), dropout=(0.0, 0.0),
                    occlusion=(0.0, 0.0), elevation_deg=(-10.0, 10.0))


def test_reaction_time_left_out_of_s(tmp_path):
    space = _space(FLANGE, **FROM_OUTSIDE)
    assert prove(space_cell(ISO_POINT, space), space).proved
    broken = dataclasses.replace(ISO_POINT, safety=dataclasses.replace(ISO_POINT.safety,
                                                                       reaction_time=0.0))
    _assert_falsified(_verify(broken, space, tmp_path))


def test_latency_larger_than_the_configuration_assumes(tmp_path):
    # The data arrives 0.25-0.3 s late; the configuration assumes 0.02 s and was given
    # a frame timeout that tolerates the delay, so the stale frames are used.
    space = _space(FLANGE, **FROM_OUTSIDE, latency=(0.25, 0.3))
    _assert_falsified(_verify(_mutant(ISO_POINT, frame_timeout=0.4), space,
                              tmp_path / "tolerant"))
    # With its own timeout the iso configuration stops on the stale frames instead.
    assert prove(space_cell(ISO_POINT, space), space).proved


def test_braking_weaker_than_the_stopping_data_says(tmp_path):
    space = _space(FLANGE, **FROM_OUTSIDE, braking_time_scale=(1.5, 2.0))
    assert not prove(space_cell(ISO_POINT, space), space).proved
    _assert_falsified(_verify(ISO_POINT, space, tmp_path))


def _rebuilt(function, **names):
    """A compiled function rebuilt from its own source with some globals replaced."""
    source = function.py_func
    return numba.njit(types.FunctionType(source.__code__, {**source.__globals__, **names}))


@pytest.fixture
def flipped_sign(monkeypatch):
    """Eqs. 6-7 with the wrong sign: closing in counts as moving away. The product's
    compiled monitor pair (``separation.pair_speeds`` and ``pair_separation``) is rebuilt
    with the pair's speeds flipped, and so are the functions that inline it:
    ``segment_separation``, the diagram's SeparationMonitor (through
    ``separation.separation_rows``) and the batched evaluator's ticks (both its seams,
    ``monitor_segment`` and ``monitor_pair``)."""

    @numba.njit(inline="always")
    def flipped_pair(P, Q, vP, vQ, A, B, v_A, v_B):
        d, v_h, v_r = segments_pair(P, Q, vP, vQ, A, B, v_A, v_B)
        return d, -v_h, -v_r

    speeds = _rebuilt(separation_module.pair_speeds, segments_pair=flipped_pair)
    pair = _rebuilt(separation_module.pair_separation, pair_speeds=speeds)
    segment = _rebuilt(separation_module.segment_separation, pair_separation=pair)
    monkeypatch.setattr(separation_module, "separation_rows",
                        _rebuilt(separation_module.separation_rows, segment_separation=segment))

    @numba.njit(inline="always")
    def monitor_segment(h, r_H, z_d, ends, end_velocities, radius, monitor):
        return segment(h, r_H, z_d, ends, end_velocities, radius, monitor)

    @numba.njit(inline="always")
    def monitor_pair(h, r_H, z_d, ends, end_velocities, radius, j, monitor):
        return pair(h, r_H, z_d, ends, end_velocities, radius, j, monitor)

    monkeypatch.setattr(batch_module, "_advance",
                        _rebuilt(batch_module._advance, monitor_segment=monitor_segment,
                                 monitor_pair=monitor_pair))


GENTLE = dict(start_distance=(1.0, 2.5), peak_speed=(0.5, 1.2), acceleration=(1.0, 3.0),
              retreat_distance=(0.0, 0.0), operators=(1, 1), dropout=(0.0, 0.0),
              occlusion=(0.0, 0.0))


def test_seed_configuration_passes_gentle_approaches_to_the_flange(tmp_path):
    # The previous envelope (the flange only): the seed's configuration is safe there.
    outcome = _verify(SEED, _space(FLANGE, **GENTLE), tmp_path, budget=20)
    assert outcome.verdict == "passed" and outcome.log.robustness.min() > 0.0


def test_directed_speed_sign_flipped(tmp_path, flipped_sign):
    _assert_falsified(_verify(SEED, _space(FLANGE, **GENTLE), tmp_path, budget=400))
