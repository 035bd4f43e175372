"""Ground truth: run a scenario in the Drake diagram and measure both properties."""

import gc

import numpy as np

from safety_systems.config.configuration import contact_capsules
from safety_systems.config.resolved_cell import ResolvedCell, scenario_cell
from safety_systems.outputs.metrics import (
    command_signal,
    commanded,
    robot_contact_state,
    robot_speed,
    run_true_segments,
    true_pairs,
    true_protective_distances,
    true_rate,
)
from safety_systems.config.scenario import Scenario
from safety_systems.pfl.contact_limits import lasting_contact
from safety_systems.pfl.speed_caps import CLAMP_GAP, capsule_links, clampable_segments
from safety_systems.ssm.true_measures import moving, permitted, ssm_permitted
from safety_systems.diagrams.simulation import Run, simulate_workcell
from safety_systems.diagrams.workcell import MakeWorkcell
from verification.properties import (
    PROPERTIES,
    Robustness,
    permitted_contact,
    permitted_contact_of,
    separation_invariant,
    stopped_before_contact,
)

LOGGED = ("q", "v", "operators.points_true", "operators.point_velocities_true",
          "operators.operators_present", "follower.path_state", "tracker.rejected_frames")


def robustness_of_run(run: Run) -> Robustness:
    """Every property from a run's logs (``properties``; under ``safety.mode: ssm_pfl``
    the separation invariant over the ticks each segment's cap in force, logged as
    ``override.segment_caps``, is exceeded), under the cell the run was simulated with
    (``Run.cell``: the robot's own stops, power and force limiting's terms)."""
    scenario, cell = run.scenario, run.cell
    speed = robot_speed(robot_contact_state(run)[1])
    clearance, v_h, v_r = true_pairs(run)
    dt = 1.0 / scenario.robot.control_rate_hz
    rho = stopped_before_contact(clearance.min(axis=-1), speed, scenario.contact_distance)
    allowed = permitted(commanded(run))
    if _capped(scenario):
        allowed = ssm_permitted(commanded(run), run[CAPS_SIGNAL])
    separation, time = separation_invariant(
        clearance, true_protective_distances(scenario, v_h, v_r, true_rate(run), cell=cell),
        allowed, dt)
    pfl = cell.pfl
    m = clearance.shape[1]
    per = max(m // pfl.limits.size, 1)
    limits = np.tile(pfl.limits, per) if m else np.zeros(0)
    ends, _, radius, _ = run_true_segments(run)
    if _capped(scenario):  # contacts that last (pfl.contact_limits), on any clamping
        c_ends, c_velocities = robot_contact_state(run)
        capsules = contact_capsules(scenario.robot, scenario.contact_geometry)
        figures, _ = lasting_contact(
            ends, radius, clearance, v_r, c_ends, c_velocities, capsules.radius,
            capsule_links(capsules), pfl.boxes, scenario.contact_distance, CLAMP_GAP,
            moving(speed), limits, np.tile(pfl.compressions, (per, 1)), pfl.detection_time,
            pfl.window, dt)
        contact = permitted_contact_of(figures, rho)
    else:
        clamped = clampable_segments(ends, radius, pfl.boxes)
        contact = permitted_contact(clearance, v_r, speed, limits, clamped,
                                    scenario.contact_distance)
    return Robustness(rho, rho + scenario.contact_distance, separation, time, contact)


CAPS_SIGNAL = "override.segment_caps"


def _capped(scenario: Scenario) -> bool:
    """Whether the scenario's SpeedOverride runs with power and force limiting's caps."""
    c = scenario.controller
    return c.type == "ssm_override" and c.safety.mode == "ssm_pfl"


def evaluate_drake(scenario: Scenario, *, stop_on: str | None = None,
                   margin: float = 0.25, cell: ResolvedCell | None = None
                   ) -> tuple[Robustness, Run]:
    """Simulates ``scenario`` in the diagram (only the signals the properties need are
    logged) and returns its robustness and the run. ``cell``: the scenario's
    configuration resolved (a verification's, ``spaces.space.space_cell``; None: resolved
    here, once, ``resolved_cell.resolve_scenario``); it must be the scenario's
    configuration's and robot's (``ResolvedCell.check_scenario``).

    ``stop_on``: a property's name (``properties.PROPERTIES``): the run stops ``margin``
    seconds after the logs first show it violated (checked every quarter second), as a
    confirmation needs no more; the figures are then those of the run so far (the
    violated property's can only fall further; another property's, not yet violated,
    says nothing of the whole run: ``cut_short`` tells)."""
    cell = scenario_cell(scenario, cell, "evaluate_drake")
    try:
        return _evaluate(scenario, stop_on, margin, cell)
    finally:
        collect_diagram_garbage()


def collect_diagram_garbage() -> None:
    """Collects, here on the calling thread, the reference cycles a diagram's building
    leaves (its builder, plant, scene graph and diagram, unreachable once the run is
    over). Left to the automatic collector they may be freed on whatever thread next
    allocates enough: a process pool's queue feeder thread, for one, and destroying
    them there aborted the process (seen under pytest-xdist, every time, when a
    Runner's pool started after a Drake replay)."""
    gc.collect()


def _evaluate(scenario: Scenario, stop_on: str | None, margin: float, cell: ResolvedCell
              ) -> tuple[Robustness, Run]:
    logged = LOGGED + (command_signal(scenario.controller.type),) + (
        (CAPS_SIGNAL,) if _capped(scenario) else ())
    until = None
    if stop_on is not None:
        field = PROPERTIES[stop_on]

        def until(run: Run) -> bool:
            return getattr(robustness_of_run(run), field) < 0.0

    diagram = MakeWorkcell(scenario, logged=logged, cell=cell)
    run = simulate_workcell(diagram, until=until, margin=margin)
    return robustness_of_run(run), run


def cut_short(run: Run) -> bool:
    """Whether a run stopped before its scenario's end (``evaluate_drake``'s stop_on)."""
    dt = 1.0 / run.scenario.robot.control_rate_hz
    return bool(run.time.size == 0 or run.time[-1] < run.scenario.duration - 1.5 * dt)


def robustness_values(results: list[Robustness]) -> np.ndarray:
    return np.array([r.stopped_before_contact for r in results])
