"""Speed of the workcell simulation and of the SSM maths, measured in one run.

    python benchmarks/bench_simulate.py [--duration S] [--repeats N]

Prints the real-time factor of the inspection scenario (the seed's, inspection_seed.yaml) in kinematic and dynamic mode
(simulated seconds per wall-clock second, best of N runs; building the diagram is not
timed), and of its first ten seconds in kinematic mode, the length of a scenario the
verifier confirms in the diagram (goal 25x, about half of Drake's floor below, so that a
confirmation takes well under a second), with its ratio to that floor, and the cost of
one control tick's envelopes + monitor + override for 10 tracked bodies (five operators
with two gloves each: 60 segments) against the iso configuration's 7 robot capsules,
through the compiled functions the OperatorEnvelopes, SeparationMonitor and
SpeedOverride call (``human_body.envelope_rows``, ``separation.separation_rows``,
``ssm.speed_override_command``; the tool point's one capsule beside it), each beside its
goal (the envelopes change only with a frame; a tick that follows no frame costs less). Beside the real-time
factors it prints Drake's own floor on this machine: the same 500 Hz clock driving one,
two and four chained Python LeafSystems that do nothing (one periodic update and one
output each), which bounds what any diagram of Python systems at 500 Hz can reach (the
control loop has four such parts at 500 Hz: RobotCapsules, SeparationMonitor,
SpeedOverride, PathFollower), and the dynamic mode's UR5e plant with its
inverse-dynamics controller alone (no Python system) and beside four idle Python systems
at 500 Hz, which bound the dynamic mode.
Run it pinned to one core for the one-core figure (e.g.
``taskset -c 0 python benchmarks/bench_simulate.py``).
"""

import argparse
import dataclasses
import json
import os
import time
import timeit
from pathlib import Path

import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource

from safety_systems.cell.human_body import envelope_rows
from safety_systems.ssm import separation
from safety_systems.config.resolved_cell import ResolvedCell, resolve
from safety_systems.cell.joint_path import default_joint_path, joint_path_state
from safety_systems.cell.robot_geometry import Capsules, capsule_ends, tool_point
from safety_systems.config.scenario import load_controller_config, load_scenario
from safety_systems.ssm.formulas import HUMAN_SPEED_MODES, speed_override_command
from safety_systems.sensing.tracks import TRACK_TRACKING
from safety_systems.diagrams.workcell import AddUr5eWithInverseDynamics, MakeWorkcell

ROOT = Path(__file__).parents[1]
SCENARIO = ROOT / "models" / "scenarios" / "inspection_seed.yaml"
ISO = ROOT / "models" / "configs" / "iso.yaml"
GOALS = {"kinematic": 100.0, "dynamic": 15.0}  # x real time
CONFIRM_GOAL = 25.0  # x real time: a ten-second scenario, kinematic (a Drake confirmation)
MONITOR_GOAL_US = 20.0


def _best_factor(diagram, duration: float, repeats: int) -> float:
    """Simulated over wall-clock seconds of ``diagram``, best of ``repeats`` runs from a
    fresh context (building and initialising are not timed)."""
    best = np.inf
    for _ in range(repeats):
        simulator = Simulator(diagram)
        simulator.Initialize()
        start = time.perf_counter()
        simulator.AdvanceTo(duration)
        best = min(best, time.perf_counter() - start)
    return duration / best


def real_time_factor(mode: str, duration: float, repeats: int) -> float:
    scenario = load_scenario(SCENARIO)
    scenario = dataclasses.replace(scenario, robot=dataclasses.replace(scenario.robot, mode=mode))
    return _best_factor(MakeWorkcell(scenario).diagram, duration, repeats)


class _Idle(LeafSystem):
    """A system that does nothing at 500 Hz: one discrete state, one periodic update
    copying its input (or its state) forward, one output."""

    def __init__(self, chained: bool):
        super().__init__()
        self._state = self.DeclareDiscreteState(1)
        self._input = self.DeclareVectorInputPort("u", 1) if chained else None
        self.DeclarePeriodicDiscreteUpdateEvent(0.002, 0.0, self._update)
        self.DeclareVectorOutputPort("y", 1, self._output)

    def _update(self, context, discrete):
        source = self._input.Eval(context) if self._input else context.get_discrete_state(
            self._state).value()
        discrete.set_value(self._state, source)

    def _output(self, context, output):
        output.SetFromVector(context.get_discrete_state(self._state).value())


def _idle_chain(builder: DiagramBuilder, systems: int) -> None:
    previous = None
    for _ in range(systems):
        system = builder.AddSystem(_Idle(chained=previous is not None))
        if previous is not None:
            builder.Connect(previous.get_output_port(), system.get_input_port())
        previous = system


def idle_floor(systems: int, duration: float, repeats: int) -> float:
    """Real-time factor of ``systems`` chained do-nothing Python systems at 500 Hz."""
    builder = DiagramBuilder()
    _idle_chain(builder, systems)
    return _best_factor(builder.Build(), duration, repeats)


def plant_floor(duration: float, repeats: int, systems: int = 0) -> float:
    """Real-time factor of the dynamic mode's plant and inverse-dynamics controller,
    holding the first waypoint (all C++), beside ``systems`` chained idle Python systems
    at 500 Hz."""
    builder = DiagramBuilder()
    _, control = AddUr5eWithInverseDynamics(builder, 0.002)
    q0 = joint_path_state(default_joint_path(), 0.0)[0]
    state = builder.AddSystem(ConstantVectorSource(np.r_[q0, np.zeros(6)]))
    acceleration = builder.AddSystem(ConstantVectorSource(np.zeros(6)))
    builder.Connect(state.get_output_port(), control.get_input_port_desired_state())
    builder.Connect(acceleration.get_output_port(),
                    control.get_input_port_desired_acceleration())
    _idle_chain(builder, systems)
    return _best_factor(builder.Build(), duration, repeats)


def monitor_and_override_us(capsules: Capsules, cell: ResolvedCell, operators: int = 5,
                            number: int = 5000) -> float:
    """Microseconds of one tick's envelopes (every segment from the tracked bodies),
    separation (Eqs. 5-11 over every segment and capsule) and override (Eq. 12 and the
    stop rules) for ``operators`` operators of two tracked gloves each (12 segments each,
    the body model of the resolved ``cell``'s configuration), best of 5 x ``number``."""
    rng = np.random.default_rng(0)
    q = joint_path_state(default_joint_path(), 0.3)[0]
    ends, end_v = capsule_ends(q, capsules, rng.normal(size=6) * 0.5)
    recipe = cell.recipe_for([["hand_right", "hand_left"]] * operators)
    n, m = 2 * operators, recipe.radius.size
    centre = rng.normal(size=(operators, 3)) + [0.0, 0.0, 1.0]
    p_B = np.repeat(centre, 2, axis=0) + np.tile([[0.0, -0.2, 0.0], [0.0, 0.2, 0.0]],
                                                 (operators, 1))
    v_B = rng.normal(size=(n, 3))
    status = np.full(n, float(TRACK_TRACKING))
    std, unseen = np.full(n, 0.01), np.zeros(n)
    z_d_terms = (0.1, 2.0)
    monitor = (HUMAN_SPEED_MODES.index("estimated"), 0.53 + 0.1, 0.1, 0.26 + 0.1 + 0.02,
               1.6, 0.0, 0)  # (the seed's directed robot speed)
    h_ends, h_v = np.empty((m, 2, 3)), np.empty((m, 2, 3))
    h_radius, h_status, h_std = np.empty(m), np.empty(m), np.empty(m)
    out, nearest = np.empty((4, m)), np.empty(m, dtype=np.int64)

    def once():
        envelope_rows(recipe.regions, recipe.candidates, recipe.radius, recipe.operator,
                      recipe.slots, p_B, v_B, status, std, unseen, 0.01, 1.6, h_ends, h_v,
                      h_radius, h_status, h_std)
        separation.separation_rows(ends, end_v, capsules.radius, h_ends, h_v, h_radius,
                                   h_status, h_std, z_d_terms, monitor, out, nearest)
        return speed_override_command(out[0], out[1], h_status, 0.0)

    once()  # compiled code loaded (not timed)
    return min(timeit.repeat(once, number=number, repeat=5)) / number * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", type=Path, default=None,
                        help="also write the figures printed to this JSON file")
    args = parser.parse_args()
    figures: dict = {"duration": args.duration, "repeats": args.repeats,
                     "load_1min": os.getloadavg()[0]}
    print(f"inspection scenario, {args.duration:g} s simulated, best of {args.repeats}")
    print(f"{'measure':44s} {'figure':>10s} {'goal':>10s} {'figure/goal':>12s}")
    for mode, goal in GOALS.items():
        rtf = real_time_factor(mode, args.duration, args.repeats)
        figures[f"real_time_{mode}"] = rtf
        print(f"{'real-time factor, ' + mode + ' mode':44s} {rtf:9.1f}x {goal:9.0f}x "
              f"{rtf / goal:12.2f}")
    ten = real_time_factor("kinematic", 10.0, args.repeats)
    figures["real_time_kinematic_10s"] = ten
    print(f"{'real-time factor, kinematic, 10 s':44s} {ten:9.1f}x {CONFIRM_GOAL:9.0f}x "
          f"{ten / CONFIRM_GOAL:12.2f}")
    for systems in (1, 2, 4):  # four: the control loop's parts at 500 Hz
        rtf = idle_floor(systems, args.duration, args.repeats)
        figures[f"floor_idle_{systems}"] = rtf
        print(f"{f'  floor: {systems} idle Python system(s) at 500 Hz':44s} {rtf:9.1f}x "
              f"{'':>10s} {rtf / GOALS['kinematic']:12.2f}")
        if systems == 4:
            print(f"{'  kinematic 10 s / this floor':44s} {ten / rtf:9.2f}x")
    for systems in (0, 4):
        rtf = plant_floor(args.duration, args.repeats, systems)
        figures[f"floor_plant_{systems}"] = rtf
        what = f"+ {systems} idle Python" if systems else "alone"
        print(f"{'  floor: plant + inverse dyn. ' + what:44s} {rtf:9.1f}x "
              f"{'':>10s} {rtf / GOALS['dynamic']:12.2f}")
    cell = resolve(load_controller_config(ISO))
    for name, capsules in (("7 capsules", cell.capsules), ("tool point", tool_point())):
        us = monitor_and_override_us(capsules, cell)
        figures[f"monitor_us_{name.replace(' ', '_')}"] = us
        what = f"env. + monitor + override, 60 segm. x {name}"
        print(f"{what:44s} {us:8.1f}us {MONITOR_GOAL_US:8.0f}us {us / MONITOR_GOAL_US:12.2f}")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(figures, indent=1) + "\n")

if __name__ == "__main__":
    main()
