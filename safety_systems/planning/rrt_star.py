"""RRT* (the seed's sampling-based baseline, Section 3) through OMPL's Python bindings.

The tool point moves in the workspace box of ``task_space.workspace_bounds``; a state
is valid where it keeps ``planner.clearance`` from every obstacle, and a motion where
every point of the straight segment does: segments are checked in one vectorised call
at most CHECK_SPACING apart, against the clearance plus the largest dip between checks
(CHECK_SPACING^2 / (8 clearance), as in ``safety_systems.planning.path_optimisation``), so the
returned polyline keeps the bound everywhere, not only at its vertices. The objective
is OMPL's default, path length; the answer is the best path found within the time
budget (or ``planner.rrt_max_iterations``), unsimplified.

Seeding: ``ompl.util.RNG.setSeed(planner.seed + 1)`` (OMPL ignores a seed of 0) before
the run creates its samplers and planner. OMPL logs that a
seed set after its first random numbers "will not lead to deterministic sampling";
runs with the same seed and an iteration cap still repeat (tested), and a run cut by
the time budget depends on how many iterations fit in it.
"""

import time

import numpy as np

from safety_systems.planning.planners import PlannedPath
from safety_systems.planning.task_space import TaskScene, clearance, obstacle_set, workspace_bounds

CHECK_SPACING = 0.002  # m between the points checked along a motion


def _ompl():
    try:
        from ompl import base, geometric, util
    except ImportError as e:  # pragma: no cover - depends on the installation
        raise RuntimeError(f"RRT* needs OMPL's Python bindings (pip install ompl): {e}") from e
    return base, geometric, util


def plan_rrt_star(scene: TaskScene) -> PlannedPath:
    """OMPL's RRT* from start to goal; see the module docstring."""
    ob, og, ou = _ompl()
    began = time.perf_counter()
    p = scene.planner
    obstacles = obstacle_set(scene.obstacles)
    bound = p.clearance + CHECK_SPACING**2 / (8.0 * p.clearance)
    low, high = workspace_bounds(scene)
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    ou.RNG.setSeed(p.seed + 1)  # OMPL ignores 0; before any sampler or planner is made
    ou.setLogLevel(level)
    space = ob.RealVectorStateSpace(3)
    limits = ob.RealVectorBounds(3)
    for k in range(3):
        limits.setLow(k, float(low[k]))
        limits.setHigh(k, float(high[k]))
    space.setBounds(limits)
    setup = og.SimpleSetup(space)

    def valid(state) -> bool:
        return bool(clearance(np.array([[state[0], state[1], state[2]]]), obstacles)[0]
                    >= bound)

    class SegmentValidator(ob.MotionValidator):
        def checkMotion(self, a, b, *_) -> bool:
            pa = np.array([a[0], a[1], a[2]])
            pb = np.array([b[0], b[1], b[2]])
            count = max(2, int(np.ceil(np.linalg.norm(pb - pa) / CHECK_SPACING)) + 1)
            points = pa + np.linspace(0.0, 1.0, count)[:, None] * (pb - pa)
            return bool(clearance(points, obstacles).min() >= bound)

    setup.setStateValidityChecker(valid)
    info = setup.getSpaceInformation()
    validator = SegmentValidator(info)
    info.setMotionValidator(validator)
    start, goal = space.allocState(), space.allocState()
    for k in range(3):
        start[k] = float(scene.start[k])
        goal[k] = float(scene.goal[k])
    setup.setStartAndGoalStates(start, goal)
    planner = og.RRTstar(info)
    planner.setRange(p.rrt_range)
    setup.setPlanner(planner)
    ou.setLogLevel(ou.LOG_NONE)
    try:
        deadline = ob.timedPlannerTerminationCondition(p.rrt_time)
        if p.rrt_max_iterations is None:
            setup.solve(deadline)
        else:
            calls = [0]

            def enough() -> bool:
                calls[0] += 1
                return calls[0] > p.rrt_max_iterations

            setup.solve(ob.plannerOrTerminationCondition(
                deadline, ob.PlannerTerminationCondition(enough)))
    finally:
        ou.setLogLevel(level)
    reached = bool(setup.haveExactSolutionPath())
    if setup.haveSolutionPath():
        states = setup.getSolutionPath().getStates()
        points = np.array([[s[0], s[1], s[2]] for s in states])
    else:
        points = np.array([scene.start], dtype=float)
    iterations = int(planner.numIterations())
    del setup, planner, validator, info, space
    return PlannedPath("RRT*", points, time.perf_counter() - began, reached,
                       iterations=iterations,
                       note="" if reached else "no exact solution within the budget")
