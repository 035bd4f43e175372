"""The figures keep their legends off the data and explain what needs explaining."""

from pathlib import Path

import matplotlib
import pytest

from safety_systems.outputs.compare import comparison_figure, controller_metrics
from safety_systems.outputs.run_files import S_NOTE, run_figure
from safety_systems.config.scenario import load_scenario
from safety_systems.diagrams.simulation import simulate

matplotlib.use("Agg")
SCENARIOS = Path(__file__).parents[1] / "models" / "scenarios"


def _legends_off_the_axes(fig) -> int:
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), legend.get_texts()[0]
    return len(legends)


@pytest.mark.parametrize("name, duration, note", [("inspection", 36.0, True),
                                                   ("ewaste_sorting", 12.0, False)])
def test_run_figure_legends_stand_beside_the_data(name, duration, note):
    run = simulate(load_scenario(SCENARIOS / f"{name}.yaml"), duration=duration)
    fig = run_figure(run)
    assert _legends_off_the_axes(fig) == 2
    # Inspection's S goes negative while the technician walks away (about 34 s).
    assert (fig._supxlabel is not None and fig._supxlabel.get_text() == S_NOTE) == note


def test_comparison_figure_has_time_on_its_axis_and_its_legend_beside():
    scenario = load_scenario(SCENARIOS / "erga_positive.yaml")
    run = simulate(scenario, duration=1.0)
    rows = [{"scenario": scenario.name, "controller": "erga", **controller_metrics(run)}]
    fig = comparison_figure(rows)
    assert _legends_off_the_axes(fig) == 1
    assert fig.axes[1].get_xlabel() == "time [s] (a sample every 0.1 s)"
    line = fig.axes[1].get_lines()[0]
    assert line.get_xdata()[1] == pytest.approx(0.1)
