"""The figures the README and the documentation's pages state from runs agree with the runs
that gave them, and those runs with this code (benchmarks/readme_figures.py: the list of
figures, the walkthrough's record)."""

import dataclasses
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import readme_figure_list as listed  # noqa: E402
import readme_figures as figures  # noqa: E402


def test_every_figure_the_pages_state_from_a_run_agrees_with_its_recorded_run():
    assert figures.problems() == []


def test_the_pages_are_the_readme_then_the_sites_pages_in_the_navs_order():
    names = list(figures.pages())
    assert names[:3] == ["README.md", "docs/index.md", "docs/tutorial.md"]
    assert {"docs/how-to/recordings.md", "docs/how-to/live-run.md",
            "docs/how-to/robot-logs.md", "docs/speed.md"} <= set(names)
    assert sorted(names[1:]) == sorted(str(p.relative_to(ROOT))
                                       for p in (ROOT / "docs").rglob("*.md"))


def test_the_check_fails_on_an_edited_figure_an_edited_command_and_a_lost_figure():
    text = figures.pages()
    data = figures.records()
    f = next(f for f in listed.FIGURES if f.name == "deployed_task_time")
    ((page, match),) = figures.find(f, text)
    assert page == "docs/tutorial.md"
    a, b = match.span("v")
    before = set(figures.problems(text, data))

    def new(page_text: str, page: str = page) -> list[str]:
        return sorted(set(figures.problems(dict(text, **{page: page_text}), data)) - before)

    edited = text[page][:a] + f"{float(match.group('v')) + 0.2:.1f}" + text[page][b:]
    assert [line.split(":")[0] for line in new(edited)] == [f.name]
    assert f"{page} says" in new(edited)[0]
    command = ".venv/bin/safety-systems check out/deploy/params.yaml"
    edited = text[page].replace(command, command + " --require proved")
    assert [line.split(":")[:2] for line in new(edited)] == [["walkthrough", " check-deploy"]]
    edited = text[page][:a] + "about eighty" + text[page][b:]
    assert [line.split(":")[0] for line in new(edited)] == [f.name]
    assert "the pages hold its pattern 0 times" in new(edited)[0]
    # a figure moved to another page is found there; stated twice, it is refused
    moved = text[page][:a - 200] + text[page][b + 50:]
    speed = text["docs/speed.md"] + text[page][a - 200:b + 50]
    assert sorted(set(figures.problems(dict(text, **{page: moved, "docs/speed.md": speed}),
                                       data)) - before) == []
    twice = sorted(set(figures.problems(dict(text, **{"docs/speed.md": speed}), data))
                   - before)  # (the snippet holds the figures beside it too)
    assert f.name in [line.split(":")[0] for line in twice]
    assert all("the pages hold its pattern 2 times" in line and "docs/tutorial.md, "
               "docs/speed.md" in line for line in twice)


def test_noise_is_the_printed_precision_or_the_stated_band():
    assert figures.agrees("78.7", 78.74, "exact") and not figures.agrees("78.7", 78.76, "exact")
    assert figures.agrees("-0.137", -0.1374, "exact")
    assert figures.agrees("1,074", 1074, "exact") and not figures.agrees("1,074", 1075, "exact")
    assert figures.agrees("15", 20.0, 0.5) and not figures.agrees("15", 40.0, 0.5)
    assert figures.agrees("by_speed", "by_speed", "text")
    assert not figures.agrees("iso", "estimated", "text")
    assert not figures.agrees("1.0", float("nan"), "exact")


@pytest.mark.parametrize("name", ["ewaste", "inspection-seed"])
def test_the_recorded_runs_exact_figures_still_come_out_of_this_code(name, tmp_path):
    """The cheap deterministic runs again, on this code: every exact figure the README
    takes from them is what the record holds (a change that moves one fails here until
    the walkthrough is run again and the README written from it)."""
    import shlex

    from safety_systems.cli import main

    recorded = figures.records()
    command = dict(figures.walkthrough(figures.pages()))[name]
    argv = shlex.split(command)[1:]
    out = argv.index("--out") + 1
    argv[out] = str(tmp_path / "out")
    assert main(argv + ["--quiet"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    fresh = {**recorded, "runs": dict(recorded["runs"], **{name: dict(
        recorded["runs"][name], files={"summary": summary})})}
    text = figures.pages()
    checked = []
    for f in listed.FIGURES:
        if ("runs", name) not in f.get.sources or f.noise != "exact":
            continue
        ((_, match),) = figures.find(f, text)
        assert figures.agrees(match.group("v"), f.value(fresh), "exact"), (
            f"{f.name}: the README says {match.group('v')}, this code {f.value(fresh)}")
        checked.append(f.name)
    assert checked


def test_the_shipped_tuned_configuration_is_what_bench_tune_chose():
    from safety_systems.config.scenario import load_controller_config

    chosen = figures.records()["bench_tune"]["chosen"]
    config = load_controller_config(ROOT / "models" / "configs" / "tuned.yaml")
    for name, value in chosen["values"].items():
        block, field = name.split(".")
        shipped = getattr(getattr(config, block), field)
        assert shipped == pytest.approx(value, abs=1e-12) if isinstance(value, float) \
            else str(shipped).lower() == str(value).lower(), name
    assert dataclasses.is_dataclass(config)


def test_the_figures_computed_in_process_come_out_of_this_code():
    """The proofs' and distances' figures (PROBES) computed again here: the README states
    what this code computes."""
    recorded = figures.records()
    fresh = dict(recorded, probes=figures.compute_probes())
    text = figures.pages()
    checked = []
    for f in listed.FIGURES:
        if not any(kind == "probes" for kind, _ in f.get.sources):
            continue
        ((_, match),) = figures.find(f, text)
        assert figures.agrees(match.group("v"), f.value(fresh), f.noise), (
            f"{f.name}: the README says {match.group('v')}, this code {f.value(fresh)}")
        checked.append(f.name)
    assert len(checked) == len(listed.PROBES)


def test_the_tutorial_tune_command_chose_what_bench_tune_chose():
    """The tutorial says its tune command makes the same choice as bench_tune."""
    recorded = figures.records()
    walked = recorded["runs"]["tune"]["files"]["tune"]["chosen"]["values"]
    assert walked == recorded["bench_tune"]["chosen"]["values"]
    assert "same choice as `bench_tune.py`" in " ".join(
        figures.pages()["docs/tutorial.md"].split())
