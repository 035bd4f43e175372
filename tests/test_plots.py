"""The figures keep their legends off the data and explain what needs explaining; the
run's figure shows each operator's distances, k on its own axis and the hidden bodies;
the replay draws each operator's segments as capsules that follow the run."""

import base64
import re
from pathlib import Path

import matplotlib
import numpy as np
import pytest

from safety_systems.cell import human_body
from safety_systems.config.configuration import truth_recipe
from safety_systems.config.scenario import load_scenario, scenario_from_text
from safety_systems.diagrams.simulation import simulate
from safety_systems.outputs import replay
from safety_systems.outputs.compare import comparison_figure, controller_metrics
from safety_systems.outputs.metrics import hidden, run_true_segments
from safety_systems.outputs.operator_figures import operator_figures
from safety_systems.outputs.run_files import D_NOTE, S_NOTE, run_figure

matplotlib.use("Agg")
SCENARIOS = Path(__file__).parents[1] / "models" / "scenarios"


@pytest.fixture(scope="module")
def inspection():
    return simulate(load_scenario(SCENARIOS / "inspection_seed.yaml"), duration=36.0)


def _legends_off_the_axes(fig) -> int:
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), legend.get_texts()[0]
    return len(legends)


@pytest.mark.parametrize("name, duration, notes", [("inspection", 36.0, [D_NOTE, S_NOTE]),
                                                    ("ewaste_sorting", 12.0, [])])
def test_run_figure_legends_stand_beside_the_data(name, duration, notes, inspection):
    run = inspection if name == "inspection" else simulate(
        load_scenario(SCENARIOS / f"{name}.yaml"), duration=duration)
    fig = run_figure(run)
    assert _legends_off_the_axes(fig) == 3  # speeds, distances, k
    # Inspection's monitored d goes below 0 while the technician works beside the robot
    # (the lower trunk's envelope, bounded from gloves and a helmet, overlaps it: about
    # 21 s), and its S while the technician walks away (about 34 s).
    text = "" if fig._supxlabel is None else fig._supxlabel.get_text()
    assert " ".join(text.split()) == " ".join(" ".join(notes).split())
    if notes:  # each note where what it explains shows
        (middle,) = [a for a in fig.axes if a.get_ylabel() == "distance [m]"]
        lines = _lines(middle)
        assert np.nanmin(lines["d technician (monitored, nearest segment)"]) < 0.0
        assert np.nanmin(lines["S technician (of that segment)"]) < 0.0


def _lines(axis) -> dict:
    return {line.get_label(): line.get_ydata() for line in axis.get_lines()}


def test_run_figure_shows_each_operator_and_k_on_its_own_axis(inspection):
    fig = run_figure(inspection)
    assert len(fig.axes) == 3  # no twin axis: k does not share the distances' axis
    _, distances, k_axis = fig.axes
    op = operator_figures(inspection)[0]
    lines = _lines(distances)
    np.testing.assert_array_equal(lines["d_true technician (nearest segment)"], op["d_true"])
    np.testing.assert_array_equal(lines["d technician (monitored, nearest segment)"],
                                  op["d_measured"])
    np.testing.assert_array_equal(lines["S technician (of that segment)"], op["S"])
    assert set(_lines(k_axis)) == {"k (commanded speed / nominal)"}
    assert k_axis.get_ylim() == pytest.approx((-0.05, 1.05))
    assert distances.get_ylabel() == "distance [m]" and k_axis.get_ylabel() == "k"
    # The distance axis reaches down to what it draws (the trunk's envelope overlaps the
    # robot's capsule near the desk: the monitored d is below 0).
    assert distances.get_ylim()[0] <= np.nanmin(op["d_measured"]) < 0.0


def test_two_bodies_moving_together_are_both_seen_in_the_speed_panel(inspection):
    """The technician's gloves move as one (a rigid walk): the left glove's speed is
    drawn as a wide pale band under the right's, and its legend says so; a body whose
    trace differs keeps a line of its own."""
    from safety_systems.outputs.run_files import SAME_SPEED, _same_trace

    speeds, _, _ = run_figure(inspection).axes
    labels = list(_lines(speeds))
    left = next(label for label in labels if "left_glove" in label)
    assert "(estimate; as right_glove's, within 0.01 m/s)" in left
    band = next(line for line in speeds.get_lines() if line.get_label() == left)
    assert band.get_linewidth() > 2.0 and band.get_alpha() < 1.0
    right = next(line for line in speeds.get_lines() if "right_glove" in line.get_label())
    assert right.get_linewidth() == 1.0 and "within" not in right.get_label()
    v = np.zeros((5, 2))
    v[:, 1] = [0.0, 0.0, SAME_SPEED * 1.5, 0.0, 0.0]
    assert _same_trace(v, [0], 1) is None
    v[2, 1] = SAME_SPEED
    assert _same_trace(v, [0], 1) == 0
    v[0, 1] = np.nan  # seen at other ticks: not the same trace
    assert _same_trace(v, [0], 1) is None


HIDDEN = """
name: hidden_bodies
duration: 4.0
controller:
  sensor:
    occlusions:
    - {body: op/right, start: 1.0, end: 2.0}
    - {body: op/head, start: 1.5, end: 3.0}
operators:
- name: op
  bodies:
  - {name: right, point: hand_right, offset: [0.0, -0.2, 0.0]}
  - {name: left, point: hand_left, offset: [0.0, 0.2, 0.0]}
  - {name: head, point: head, offset: [0.3, 0.0, 0.45]}
  waypoints:
  - {time: 0.0, position: [2.5, 0.0, 0.3]}
"""


def test_run_figure_shades_each_body_while_hidden():
    run = simulate(scenario_from_text(HIDDEN))
    fig = run_figure(run)
    distances = fig.axes[1]
    spans = {}
    for patch in distances.patches:
        spans.setdefault(patch.get_label(), []).append(patch)
    is_hidden = hidden(run)
    for i, body in enumerate(run.body_names):
        drawn = spans.get(f"{body} hidden", [])
        assert bool(drawn) == bool(is_hidden[:, i].any())
        if drawn:  # one span each, where the track is hidden, in its own hatch
            (a, b), = [(p.get_x(), p.get_x() + p.get_width()) for p in drawn]
            on = run.time[is_hidden[:, i]]
            assert a == pytest.approx(on.min()) and b == pytest.approx(on.max(), abs=0.003)
    assert len({p.get_hatch() for name, ps in spans.items() if name.endswith(" hidden")
                for p in ps}) == 2  # right, head


def test_comparison_figure_has_time_on_its_axis_and_its_legend_beside():
    scenario = load_scenario(SCENARIOS / "erga_positive.yaml")
    run = simulate(scenario, duration=1.0)
    rows = [{"scenario": scenario.name, "controller": "erga", **controller_metrics(run)}]
    fig = comparison_figure(rows)
    assert _legends_off_the_axes(fig) == 1
    assert fig.axes[1].get_xlabel() == "time [s] (a sample every 0.1 s)"
    line = fig.axes[1].get_lines()[0]
    assert line.get_xdata()[1] == pytest.approx(0.1)


def test_comparison_figure_shows_controllers_that_share_a_trace_and_names_di_1():
    """Two controllers with the same speed trace (both at the pre-programmed speed before
    they act): the one drawn first is wider, so the one on top of it does not hide it; the
    DI = 1 line is named and drawn in no controller's colour."""
    scenario = load_scenario(SCENARIOS / "erga_positive.yaml")
    row = {"scenario": scenario.name, **controller_metrics(simulate(scenario, duration=1.0))}
    fig = comparison_figure([dict(row, controller="erga"), dict(row, controller="none")])
    danger, speed = fig.axes[:2]
    erga, none = speed.get_lines()
    np.testing.assert_array_equal(erga.get_ydata(), none.get_ydata())
    assert erga.get_linewidth() > none.get_linewidth() and erga.get_color() != none.get_color()
    threshold = [line for line in danger.get_lines() if line.get_label().startswith("DI = 1")]
    assert len(threshold) == 1 and threshold[0].get_color() not in (erga.get_color(),
                                                                     none.get_color())


# The replay ---------------------------------------------------------------------------

class _Animation:
    """Records key frames as Drake's MeshcatAnimation takes them."""

    def __init__(self):
        self.keys = {}

    def SetTransform(self, frame, path, pose):
        self.keys.setdefault((path, "pose"), {})[frame] = pose.GetAsMatrix4()

    def SetProperty(self, frame, path, name, value):
        self.keys.setdefault((path, name), {})[frame] = np.array(value, dtype=float)


def _replayed(keys: dict, frames: np.ndarray) -> np.ndarray:
    """The value at every frame under linear interpolation between key frames, where
    that is unambiguous: between two key frames of equal value, or at a key frame (the
    tests' frames between keys that differ are none)."""
    at = sorted(keys)
    out = []
    for f in frames:
        if f in keys:
            out.append(keys[f])
            continue
        before = max(k for k in at if k < f)
        after = min(k for k in at if k > f)
        np.testing.assert_array_equal(keys[before], keys[after])
        out.append(keys[before])
    return np.array(out)


def test_key_frames_replay_every_frame():
    rng = np.random.default_rng(3)
    still = np.repeat(rng.normal(size=(6, 3)), [5, 1, 7, 2, 9, 4], axis=0)  # still stretches
    keys = replay._key_frames(still)
    assert keys.size < len(still) and keys[0] == 0 and keys[-1] == len(still) - 1
    got = _replayed({int(f): still[f] for f in keys}, np.arange(len(still)))
    np.testing.assert_array_equal(got, still)
    assert replay._key_frames(np.zeros((40, 3))).tolist() == [0, 39]


def test_capsule_track_follows_the_segment():
    n = 40
    t = np.linspace(0.0, 1.0, n)
    a = np.column_stack([t, 0.0 * t, 0.5 + 0.0 * t])
    a[20:30] = a[20]  # still for a while
    b = a + np.column_stack([0.0 * t, 0.3 + 0.1 * (t > 0.8), 0.1 + 0.0 * t])
    radius = np.full(n, 0.07)
    shown = np.ones(n, dtype=bool)
    shown[:5] = shown[33:36] = False  # absent at first and for a moment
    frames = 3 * np.arange(n)  # the animation's frames of the replay's
    animation = _Animation()
    replay._capsule_track(animation, frames, "op/seg", a, b, radius, shown, ends=(True, True),
                          axis=True)
    held = replay._held
    for name, centre in (("a", held(a, shown)), ("b", held(b, shown))):
        pose = _replayed(animation.keys[(f"op/seg/{name}", "pose")], frames)
        np.testing.assert_allclose(pose[:, :3, 3], centre, atol=1e-12)
        scale = _replayed(animation.keys[(f"op/seg/{name}", "scale")], frames)
        np.testing.assert_allclose(scale, 0.07)
        visible = animation.keys[(f"op/seg/{name}", "visible")]
        assert {f: bool(v) for f, v in visible.items()} == {0: False, 15: True, 99: False,
                                                            108: True}
    pose = _replayed(animation.keys[("op/seg/axis", "pose")], frames)
    scale = _replayed(animation.keys[("op/seg/axis", "scale")], frames)
    a, b = held(a, shown), held(b, shown)
    np.testing.assert_allclose(pose[:, :3, 3], (a + b) / 2, atol=1e-12)
    # The unit cylinder's z axis along the segment, scaled to its length and radius
    axis = b - a
    length = np.linalg.norm(axis, axis=1)
    np.testing.assert_allclose(pose[:, :3, 2], axis / length[:, None], atol=1e-12)
    np.testing.assert_allclose(scale, np.column_stack([radius, radius, length]), atol=1e-12)
    # Still while a and b are: no key frames there
    assert not set(animation.keys[("op/seg/axis", "pose")]) & set(frames[21:29])


def test_drawn_parts_are_the_union_of_the_capsules(inspection):
    # Inspection measures contact on the segments' axes (the tool point): the replay draws
    # the body's radii all the same.
    truth = truth_recipe(inspection.scenario)
    assert np.all(truth.radius == 0.0)
    recipe, ends, radius, present = replay.true_capsules(
        inspection, np.arange(0, len(inspection.time), 500))
    np.testing.assert_array_equal(run_true_segments(inspection)[0][::500], ends)
    assert sorted(set(radius[0])) == sorted({human_body.DEFAULT_DIMENSIONS[r]
                                             for *_, r in human_body.SEGMENTS})
    balls, axes = replay._drawn_parts(ends, radius, present, recipe.operator)
    # A scripted operator: a ball at each of its ten points, an axis on each of the eight
    # segments between two points (not the head's or the hands': balls).
    assert balls.sum() == human_body.NUM_POINTS
    assert axes.tolist() == [a != b for _, a, b, _ in human_body.SEGMENTS]
    rows = present[:, 0]
    for i in range(len(recipe.names)):  # every end inside a drawn ball as large as its own
        for e in range(2):
            held = [(j, g) for j in range(len(recipe.names)) for g in range(2) if balls[j, g]
                    and np.allclose(ends[rows, j, g], ends[rows, i, e])
                    and np.all(radius[rows, j] >= radius[rows, i])]
            assert held, (recipe.names[i], e)


def test_replay_draws_each_operators_segments_and_the_robot():
    run = simulate(load_scenario(SCENARIOS / "co_kitting.yaml"), duration=17.0)
    html = replay.replay_html(run)
    commands = b"".join(base64.b64decode(blob) for blob in
                        re.findall(r"base64,([A-Za-z0-9+/=]+)", html))
    for operator in ("operator_A", "operator_B"):
        for part in ("upper_trunk/axis", "head/a", "forearm_left/axis", "hand_right/a"):
            assert f"operators/{operator}/{part}".encode() in commands
        assert f"protective/{operator}/axis".encode() in commands
    assert b"technician" not in commands and b"RB1" not in commands  # no body spheres
    assert b"set_animation" in commands and b"shoulder_link" in commands
