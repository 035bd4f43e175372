"""A self-contained Meshcat recording of a run: the robot, the bodies and their S spheres."""

import logging
from pathlib import Path

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from safety_systems.files.output_files import write_text
from safety_systems.diagrams.simulation import Run
from safety_systems.cell.ur5e import AddUr5e

FRAMES_PER_SECOND = 30.0
BODY_RADIUS = 0.05  # m, drawn size of a tracked body
_COLORS = ((0.1, 0.5, 0.1), (0.4, 0.8, 0.3), (0.1, 0.3, 0.8), (0.4, 0.7, 1.0), (0.8, 0.4, 0.1))


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


def replay_html(run: Run, *, meshcat: Meshcat | None = None) -> str:
    """Records the run at ``FRAMES_PER_SECOND`` and returns Meshcat's static HTML.

    Each body is a small sphere at its true position (hidden while absent); a
    translucent sphere of radius S_i (the monitor's protective distance) surrounds its
    tracked position while it has a track (SSM override only).
    """
    meshcat = meshcat or _quiet_meshcat()
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    AddUr5e(plant)
    plant.Finalize()
    visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    visualizer_context = visualizer.GetMyContextFromRoot(context)

    true_p = run.bodies("operators.positions_true")
    est_p = run.bodies("tracker.positions_estimated")
    present = run["operators.present"] > 0.5
    s = run.signals.get("monitor.protective_distances",
                        np.full((len(run.time), len(run.body_names)), np.nan))
    for i, name in enumerate(run.body_names):
        r, g, b = _COLORS[(i // 2) % len(_COLORS)]
        meshcat.SetObject(f"bodies/{name}/body", Sphere(BODY_RADIUS), Rgba(r, g, b, 1.0))
        meshcat.SetObject(f"bodies/{name}/S", Sphere(1.0), Rgba(r, g, b, 0.15))

    times = np.arange(0.0, run.time[-1] + 1e-9, 1.0 / FRAMES_PER_SECOND)
    rows = np.minimum(np.searchsorted(run.time, times), len(run.time) - 1)
    visualizer.StartRecording(set_transforms_while_recording=False)
    animation = visualizer.get_mutable_recording()
    for t, row in zip(times, rows):
        context.SetTime(t)
        plant.SetPositions(plant_context, run["q"][row])
        visualizer.ForcedPublish(visualizer_context)
        frame = animation.frame(t)
        for i, name in enumerate(run.body_names):
            seen = bool(present[row, i])
            animation.SetProperty(frame, f"bodies/{name}/body", "visible", seen)
            if seen:
                animation.SetTransform(frame, f"bodies/{name}/body",
                                       RigidTransform(true_p[row, i]))
            tracked = bool(np.isfinite(s[row, i]) and s[row, i] > 0.0)
            animation.SetProperty(frame, f"bodies/{name}/S", "visible", tracked)
            if tracked:
                animation.SetTransform(frame, f"bodies/{name}/S", RigidTransform(est_p[row, i]))
                animation.SetProperty(frame, f"bodies/{name}/S", "scale", [s[row, i]] * 3)
    visualizer.StopRecording()
    visualizer.PublishRecording()
    return meshcat.StaticHtml()


def write_replay(run: Run, path: Path) -> None:
    write_text(path, replay_html(run))
