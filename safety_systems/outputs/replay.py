"""A self-contained Meshcat recording of a run: the robot, each operator's true segments
as capsules, and the monitor's S about each operator's nearest segment."""

import dataclasses
import logging
from pathlib import Path

import numpy as np
from pydrake.geometry import (
    Cylinder,
    Meshcat,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    Rgba,
    Role,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from safety_systems.cell.robot_plant import AddRobot
from safety_systems.config.configuration import robot_model_of, truth_recipe
from safety_systems.diagrams.simulation import Run
from safety_systems.files.output_files import write_text
from safety_systems.ssm.true_measures import true_segments

FRAMES_PER_SECOND = 30.0
_COLORS = ((0.1, 0.5, 0.1), (0.1, 0.3, 0.8), (0.8, 0.4, 0.1), (0.5, 0.2, 0.6), (0.6, 0.5, 0.1))
_SAME = 1e-9  # m: ends closer than this are one point; a capsule this short a ball


def _quiet_meshcat() -> Meshcat:
    """A Meshcat for recording only: Drake's "listening for connections" line is not
    printed, since nothing connects to it (the recording is written as a file)."""
    logger = logging.getLogger("drake")
    level = logger.level
    logger.setLevel(max(level, logging.WARNING))
    try:
        return Meshcat()
    finally:
        logger.setLevel(level)


def _held(values: np.ndarray, shown: np.ndarray) -> np.ndarray:
    """``values`` (F, ...) with the frames not ``shown`` (F,) holding the nearest shown
    frame's value before them (after them before the first), so that hidden frames add
    no motion; unchanged where none is shown."""
    if not shown.any():
        return values
    index = np.where(shown, np.arange(shown.size), -1)
    index = np.maximum.accumulate(index)
    index[index < 0] = np.flatnonzero(shown)[0]
    return values[index]


def _key_frames(values: np.ndarray) -> np.ndarray:
    """Frames (of F) where a track of ``values`` (F, ...) needs a key frame so that
    Meshcat's linear interpolation between key frames replays every frame: the first and
    the last, and each frame where the value changes from the frame before or to the
    frame after (a still stretch keeps only its ends)."""
    f = values.shape[0]
    if f <= 2:
        return np.arange(f)
    flat = values.reshape(f, -1)
    change = np.any(np.abs(np.diff(flat, axis=0)) > 1e-12, axis=1)
    keep = np.zeros(f, dtype=bool)
    keep[[0, -1]] = True
    keep[1:] |= change
    keep[:-1] |= change
    return np.flatnonzero(keep)


def _switches(on: np.ndarray) -> np.ndarray:
    """Frames where a visibility track changes (and the first)."""
    return np.flatnonzero(np.r_[True, on[1:] != on[:-1]])


def _axis_poses(a: np.ndarray, b: np.ndarray) -> tuple[list, np.ndarray]:
    """Per frame the pose of a unit cylinder's frame on the axis from ``a`` to ``b``
    (F, 3): at the midpoint, z along the axis (a fixed one where it has no length); and
    the axis lengths (F,)."""
    axis = b - a
    length = np.linalg.norm(axis, axis=1)
    poses, last = [], np.array([0.0, 0.0, 1.0])
    for p, q, u, l in zip(a, b, axis, length):
        if l > _SAME:
            last = u / l
        poses.append(RigidTransform(RotationMatrix.MakeFromOneVector(last, 2), (p + q) / 2))
    return poses, length


def _capsule_track(animation, frames: np.ndarray, path: str, a: np.ndarray, b: np.ndarray,
                   radius: np.ndarray, shown: np.ndarray, *, ends: tuple[bool, bool],
                   axis: bool) -> None:
    """Key frames of one capsule drawn as a unit cylinder (``path``/axis) and unit balls
    at its ends (``path``/a, ``path``/b), scaled by its radius and length: ends ``a``,
    ``b`` (F, 3), radius (F,), visible where ``shown`` (F,); ``ends`` and ``axis`` say
    which of the parts are drawn (a ball that another capsule's larger one holds is
    not). Values while hidden hold the last shown (no key frames)."""
    if not shown.any():
        for name, drawn in (("a", ends[0]), ("b", ends[1]), ("axis", axis)):
            if drawn:
                animation.SetProperty(int(frames[0]), f"{path}/{name}", "visible", False)
        return
    a, b, radius = _held(a, shown), _held(b, shown), _held(radius, shown)
    parts = [(name, centre) for name, centre, drawn in (("a", a, ends[0]), ("b", b, ends[1]))
             if drawn]
    for name, centre in parts:
        track = np.column_stack([centre, radius])
        for f in _switches(shown):
            animation.SetProperty(int(frames[f]), f"{path}/{name}", "visible", bool(shown[f]))
        for f in _key_frames(track):
            animation.SetTransform(int(frames[f]), f"{path}/{name}", RigidTransform(centre[f]))
            animation.SetProperty(int(frames[f]), f"{path}/{name}", "scale", [radius[f]] * 3)
    if axis:
        visible = shown & (np.linalg.norm(b - a, axis=1) > _SAME)
        track = np.column_stack([a, b, radius])
        keys = _key_frames(track)
        poses, length = _axis_poses(a[keys], b[keys])
        for f in _switches(visible):
            animation.SetProperty(int(frames[f]), f"{path}/axis", "visible", bool(visible[f]))
        for f, pose, l in zip(keys, poses, length):
            animation.SetTransform(int(frames[f]), f"{path}/axis", pose)
            animation.SetProperty(int(frames[f]), f"{path}/axis", "scale",
                                  [radius[f], radius[f], max(l, _SAME)])


def _set_capsule(meshcat: Meshcat, path: str, rgba: Rgba, *, ends: tuple[bool, bool],
                 axis: bool) -> None:
    """The unit parts :func:`_capsule_track` moves."""
    for name, drawn in zip("ab", ends):
        if drawn:
            meshcat.SetObject(f"{path}/{name}", Sphere(1.0), rgba)
    if axis:
        meshcat.SetObject(f"{path}/axis", Cylinder(1.0, 1.0), rgba)


def _drawn_parts(ends: np.ndarray, radius: np.ndarray, present: np.ndarray,
                 operator: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which end balls (M, 2) and axes (M,) of segments (ends (F, M, 2, 3), radius (F, M),
    present (F, M), ``operator`` (M,)) need drawing: a ball is left out where another
    end of its operator's segments is at the same point in every frame with a radius at
    least as large (the larger first, then the earlier), since the union of the
    capsules is drawn; an axis where the segment is a ball in every frame."""
    m = radius.shape[1]
    draw = np.ones((m, 2), dtype=bool)
    keys = [(i, e) for i in range(m) for e in range(2)]
    for i, e in keys:
        rows = present[:, i]  # an operator's segments are present together
        for j, g in keys:
            if (j, g) == (i, e) or operator[j] != operator[i] or not draw[j, g]:
                continue
            gap = np.linalg.norm(ends[rows, i, e] - ends[rows, j, g], axis=1)
            if not np.all(gap <= _SAME):
                continue
            if np.all(radius[rows, j] > radius[rows, i]) or (
                    np.all(radius[rows, j] >= radius[rows, i]) and (j, g) < (i, e)):
                draw[i, e] = False
                break
    length = np.linalg.norm(ends[:, :, 1] - ends[:, :, 0], axis=-1)
    axis = np.where(present, length, 0.0).max(axis=0, initial=0.0) > _SAME
    return draw, axis


def true_capsules(run: Run, rows: np.ndarray) -> tuple:
    """(recipe, ends (F, M, 2, 3), radius (F, M), present (F, M)) of the operators' true
    segments at the logged ``rows`` (``configuration.truth_recipe``), with the body's
    radii also where the scenario's ``contact_geometry`` is the tool point (whose truth
    measures to the segments' axes, radius 0): the replay draws the body."""
    recipe = truth_recipe(dataclasses.replace(run.scenario, contact_geometry="capsules"))
    ends, _, radius, present = true_segments(
        recipe, run["operators.points_true"][rows], run["operators.point_velocities_true"][rows],
        run["operators.operators_present"][rows])
    return recipe, ends, radius, present


def replay_html(run: Run, *, meshcat: Meshcat | None = None) -> str:
    """Records the run at ``FRAMES_PER_SECOND`` and returns Meshcat's static HTML.

    Each operator's true segments (``safety_systems.cell.human_body``, as the truth
    takes them, :func:`true_capsules`) are capsules in the operator's colour at their
    true positions (hidden while the operator is absent); with the SSM monitor
    a translucent capsule about each operator's nearest monitored segment (its envelope,
    ``envelopes.segment_ends``) of the envelope's radius plus that segment's S (as the
    override used it, ``operator_figures.monitor_protective_distances``), shown while that S is
    positive: the robot's monitored capsules (the tool point, on ``robot_geometry:
    tool_point``) stay outside it while the override lets the robot move. The robot (the
    scenario's model) is drawn as Drake's visualizer draws it: its visual geometry, or
    its collision geometry where its URDF has none (the Panda's). Key frames are written only where a part
    moves (Meshcat interpolates between them), so a long run stays small and quick.
    """
    meshcat = meshcat or _quiet_meshcat()
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    AddRobot(plant, robot_model_of(run.scenario.robot))
    plant.Finalize()
    inspector = scene_graph.model_inspector()
    drawn = Role.kIllustration if inspector.NumGeometriesWithRole(Role.kIllustration) else (
        Role.kProximity)
    visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat,
                                                MeshcatVisualizerParams(role=drawn))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    visualizer_context = visualizer.GetMyContextFromRoot(context)

    times = np.arange(0.0, run.time[-1] + 1e-9, 1.0 / FRAMES_PER_SECOND)
    rows = np.minimum(np.searchsorted(run.time, times), len(run.time) - 1)
    visualizer.StartRecording(set_transforms_while_recording=False)
    animation = visualizer.get_mutable_recording()
    frames = np.array([animation.frame(t) for t in times], dtype=int)
    for t, row in zip(times, rows):
        context.SetTime(t)
        plant.SetPositions(plant_context, run["q"][row])
        visualizer.ForcedPublish(visualizer_context)

    recipe, ends, radius, present = true_capsules(run, rows)
    balls, axes = _drawn_parts(ends, radius, present, recipe.operator)
    for i, name in enumerate(recipe.names):
        r, g, b = _COLORS[int(recipe.operator[i]) % len(_COLORS)]
        path = f"operators/{name}"
        _set_capsule(meshcat, path, Rgba(r, g, b, 1.0), ends=tuple(balls[i]), axis=bool(axes[i]))
        _capsule_track(animation, frames, path, ends[:, i, 0], ends[:, i, 1], radius[:, i],
                       present[:, i], ends=tuple(balls[i]), axis=bool(axes[i]))
    if "monitor.distances" in run.signals:
        _protective_capsules(run, meshcat, animation, frames, rows)
    visualizer.StopRecording()
    visualizer.PublishRecording()
    return meshcat.StaticHtml()


def _protective_capsules(run: Run, meshcat: Meshcat, animation, frames: np.ndarray,
                         rows: np.ndarray) -> None:
    """Per operator the translucent capsule of :func:`replay_html` (S about its nearest
    monitored segment's envelope)."""
    from safety_systems.outputs.operator_figures import (
        monitor_protective_distances,
        nearest_segment,
        operator_segments,
        run_monitor_recipe,
    )

    recipe = run_monitor_recipe(run)
    m = recipe.radius.size
    d = run["monitor.distances"][rows]
    s = monitor_protective_distances(run)[rows]
    env = run["envelopes.segment_ends"][rows].reshape(len(rows), m, 2, 3)
    env_radius = run["envelopes.segment_radii"][rows]
    every = np.arange(len(rows))
    for k, columns in enumerate(operator_segments(recipe.operator, len(run.scenario.operators))):
        _, nearest = nearest_segment(d, columns)
        j = np.maximum(nearest, 0)
        grown = env_radius[every, j] + s[every, j]
        shown = (nearest >= 0) & np.isfinite(grown) & (s[every, j] > 0.0)
        r, g, b = _COLORS[k % len(_COLORS)]
        path = f"protective/{run.scenario.operators[k].name}"
        _set_capsule(meshcat, path, Rgba(r, g, b, 0.15), ends=(True, True), axis=True)
        _capsule_track(animation, frames, path, env[every, j, 0], env[every, j, 1],
                       np.where(shown, grown, 0.0), shown, ends=(True, True), axis=True)


def write_replay(run: Run, path: Path) -> None:
    write_text(path, replay_html(run))
