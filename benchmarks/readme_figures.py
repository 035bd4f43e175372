"""The README's and the documentation's figures from runs, measured by the runs and
checked against them.

    python benchmarks/readme_figures.py run [--fresh] [--only ID,...] [--skip ID,...]
    python benchmarks/readme_figures.py check
    python benchmarks/readme_figures.py write

The pages are the README and the documentation site's pages (``docs/``, in the order of
``mkdocs.yml``'s nav). Every figure they state from a run of a command or a benchmark is
listed in ``FIGURES`` (``benchmarks/readme_figure_list.py``): where it stands (a pattern
whose group ``v`` is the figure, found in exactly one place of all the pages), which run
gives it and where in that run's output, and the noise within which two runs agree:
``exact`` for what the code determines (a margin, a task time, a count: equal to the
digits the page prints) or a relative band for what the machine and its load move
(times, rates).

``run`` is the walkthrough a new user makes: every command of the pages' code blocks, in
their order (the README's set-up first, then the tutorial's path and the other pages';
``--fresh`` does it all in a fresh clone of this repository's HEAD, in a new virtual
environment, so the first compile and every missing install step show), then the runs
the pages' prose quotes (``EXTRA_RUNS``: the same commands with another option, or
another shipped file), then, if asked (``--only bench_tune`` and the like), the
benchmarks, each with ``--json``. It writes what each printed and wrote to
``benchmarks/results/walkthrough.json`` (and the benchmarks' own files beside it), with
the date, the commit and the machine's load.

``check`` compares each figure with the recorded runs and prints one line per figure
that disagrees beyond its noise (exit 1), or that the pages no longer hold in exactly one
place; and whether the pages' commands are still the ones walked through.
``tests/test_readme_figures.py`` runs it, and re-runs the cheap deterministic commands to
check the recorded figures against this code. ``write`` rewrites the figures from the
record, each in its page (at the precision the page gives it).
"""

import argparse
import datetime
import json
import math
import os
import re
import resource
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
MKDOCS = ROOT / "mkdocs.yml"
RESULTS = ROOT / "benchmarks" / "results"
RECORD = RESULTS / "walkthrough.json"
CLI = ".venv/bin/safety-systems"
STDOUT_LINES = 60  # of each run's stdout, kept in the record
CHECK_KINDS = ("scenario", "config", "space", "scene", "task-path", "mapping", "robot-log",
               "recording", "params")  # ``check KIND FILE``'s kinds (safety_systems.cli)


# ------------------------------------------------------------------ the pages' commands

def _nav_files(nav) -> list[str]:
    """The pages of an mkdocs nav, in order."""
    if isinstance(nav, str):
        return [nav]
    if isinstance(nav, dict):
        return [f for v in nav.values() for f in _nav_files(v)]
    if isinstance(nav, list):
        return [f for v in nav for f in _nav_files(v)]
    return []


def pages() -> dict[str, str]:
    """Every page's text by its path from the root: the README, then the documentation's
    pages in the order of mkdocs.yml's nav, then any page the nav leaves out."""
    import yaml

    docs = MKDOCS.parent / yaml.safe_load(MKDOCS.read_text()).get("docs_dir", "docs")
    ordered = [docs / f for f in _nav_files(yaml.safe_load(MKDOCS.read_text())["nav"])]
    ordered += sorted(set(docs.rglob("*.md")) - set(ordered))
    out = {"README.md": README.read_text()}
    for path in ordered:
        out[str(path.relative_to(ROOT))] = path.read_text()
    return out


def readme_commands(text: str) -> list[str]:
    """The commands of a page's code blocks, in order: the set-up's two lines and every
    ``.venv/bin/safety-systems`` line (a command written otherwise, as on a page whose
    commands need a cluster, is not walked through)."""
    commands, inside = [], False
    for line in text.splitlines():
        if line.startswith("```"):
            inside = not inside
            continue
        line = line.strip()
        if inside and (line.startswith(CLI) or line.startswith("python3 -m venv")):
            commands.append(line)
    return commands


def run_id(command: str, seen: dict) -> str:
    """A command's name in the record: its output folder's (``--out``, ``--log``; the
    set-up's main job is ``inspection``), ``tests`` for the set-up's test line, or the
    subcommand and the folder it reads (``check-deploy``); a repeated command gets
    ``#2``."""
    words = shlex.split(command.split("&&")[-1])
    name = "tests" if "pytest" in command else None
    for flag in ("--out", "--log"):
        if name is None and flag in words:
            name = Path(words[words.index(flag) + 1]).name
    if name is None:  # check PARAMS: the folder it checks (check KIND FILE: the file's)
        first = next(w for w in words[2:] if not w.startswith("-") and w not in CHECK_KINDS)
        name = words[1] + "-" + Path(first).parent.name
    seen[name] = seen.get(name, 0) + 1
    return name if seen[name] == 1 else f"{name}#{seen[name]}"


def walkthrough(texts: dict[str, str]) -> list[tuple[str, str]]:
    """(id, command) of the pages' commands, page by page (``pages``), and then of
    ``EXTRA_RUNS``."""
    from readme_figure_list import EXTRA_RUNS

    seen: dict = {}
    runs = [(run_id(c, seen), c) for text in texts.values() for c in readme_commands(text)]
    return runs + [(name, command) for name, command in EXTRA_RUNS]


# ------------------------------------------------------------------------------ running

def _json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _trim(data, depth: int = 0):
    """What the record keeps of an output file: lists of more than 12 entries (every
    simulation, every premise's text) and long strings dropped to their length."""
    if isinstance(data, dict):
        return {k: _trim(v, depth + 1) for k, v in data.items()}
    if isinstance(data, list):
        return [_trim(v, depth + 1) for v in data] if len(data) <= 12 else {"length":
                                                                             len(data)}
    if isinstance(data, str) and len(data) > 400:
        return {"characters": len(data)}
    return data


OUTPUT_FILES = ("summary.json", "report.json", "tune.json", "certificate.json")


def run_one(command: str, cwd: Path) -> dict:
    """Runs one page's command in ``cwd`` (its shell line as written): exit code, wall
    and CPU seconds (its children's), the tail of its stdout, the last lines of stderr,
    and the JSON files it wrote to its output folder."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, shell=True, cwd=cwd, capture_output=True, text=True,
                          env={**os.environ, "PYTHONUNBUFFERED": "1"}, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    out: dict = {"command": command, "exit": done.returncode, "wall": round(wall, 2),
                 "cpu": round(after.ru_utime - before.ru_utime
                              + after.ru_stime - before.ru_stime, 2),
                 "stdout": [line for line in done.stdout.replace("\r", "\n").splitlines()
                            if line.strip() and "it/s" not in line and "sim/s" not in line
                            ][-STDOUT_LINES:],
                 "stderr": done.stderr.replace("\r", "\n").splitlines()[-5:], "files": {}}
    words = shlex.split(command.split("&&")[-1])
    for flag in ("--out", "--log"):
        if flag in words:
            folder = cwd / words[words.index(flag) + 1]
            for name in OUTPUT_FILES:
                data = _json(folder / name)
                if data is not None:
                    out["files"][name.removesuffix(".json")] = _trim(data)
    return out


def _fresh_clone(where: Path) -> Path:
    """A fresh clone of this repository's HEAD in ``where``."""
    tree = where / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(tree)], check=True)
    return tree


def _machine() -> dict:
    return {"cores": os.cpu_count(), "load_1min": round(os.getloadavg()[0], 2),
            "python": sys.version.split()[0]}


# The exit codes the pages' commands should end with (0 where not listed): the previous
# behaviour falsified, the seed's configuration falsified over the recording's space.
EXPECTED_EXIT = {"verify-occluded": 1, "verify-elbow": 1, "verify-recording": 1,
                 "verify-recording-previous": 1}
NOT_BY_DEFAULT = {"tests"}  # the test suite: CI runs it on every submission


def measure(only: set | None, skip: set, fresh: bool) -> None:
    """``run``: the walkthrough (see the module docstring); merges into the record."""
    record = _json(RECORD) or {"runs": {}}
    text = pages()
    skip = skip | (NOT_BY_DEFAULT - (only or set()))
    with tempfile.TemporaryDirectory() as scratch:
        tree = _fresh_clone(Path(scratch)) if fresh else ROOT
        if not fresh and not only:  # the whole walkthrough's outputs start afresh
            shutil.rmtree(tree / "out", ignore_errors=True)
        commit = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True, check=False).stdout.strip()
        for name, command in walkthrough(text):
            if (only and name not in only) or name in skip:
                continue
            print(f"{name}: {command}", flush=True)
            written = command
            if not fresh and command.startswith("python3 -m venv"):
                command = command.split("&&")[-1].strip()  # this tree's venv is there
            result = run_one(command, tree)
            result["command"] = written
            result.update(date=datetime.date.today().isoformat(), commit=commit,
                          fresh_clone=fresh, machine=_machine())
            print(f"  exit {result['exit']}, {result['wall']:.1f} s wall, "
                  f"{result['cpu']:.1f} s CPU", flush=True)
            record["runs"][name] = result
            RESULTS.mkdir(parents=True, exist_ok=True)
            RECORD.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
        if not only or "probes" in only:
            record["probes"] = compute_probes()
            RECORD.write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
        from readme_figure_list import BENCHES

        for name, argv in BENCHES.items():
            if not only or name not in only or name in skip:
                continue
            target = RESULTS / f"{name}.json"
            print(f"{name}: {' '.join(argv)} --json {target}", flush=True)
            subprocess.run([sys.executable, *argv, "--json", str(target)], cwd=ROOT,
                           check=False)


# ----------------------------------------------------------------------------- checking

def decimals(text: str) -> int:
    """Digits after the point in a figure as printed."""
    return len(text.split(".")[1]) if "." in text else 0


def number(text: str) -> float:
    return float(text.replace(",", "").replace("+", ""))


def agrees(printed: str, value: float, noise) -> bool:
    """Whether a page's ``printed`` figure is ``value`` within ``noise``: "exact"
    (equal at the precision printed, half a unit of its last digit) or a relative band
    (a float: |printed - value| <= band * |value|, or within the rounding to the digits
    printed where that is wider)."""
    if noise == "text":
        return printed == value
    if value is None or not math.isfinite(value):
        return False
    x = number(printed)
    if noise == "exact":
        return abs(x - value) <= 0.5 * 10.0 ** -decimals(printed) * (1 + 1e-9) + 1e-12
    # a band, and never less than the rounding of the digits printed
    return abs(x - value) <= max(noise * abs(value),
                                 0.5 * 10.0 ** -decimals(printed) * (1 + 1e-9))


def compute_probes() -> dict:
    """Every probe's figure, computed now on this code."""
    from readme_figure_list import PROBES

    return {name: f() for name, f in PROBES.items()}


def records() -> dict:
    """The record of runs and each benchmark's figures, as the figures' getters read
    them: {"runs": {...}, "probes": {...}, "bench_tune": {...}, ...}."""
    record = _json(RECORD) or {}
    data = {"runs": record.get("runs", {}), "probes": record.get("probes", {})}
    for path in RESULTS.glob("bench_*.json"):
        data[path.stem] = _json(path) or {}
    return data


def find(figure, texts: dict[str, str]) -> list[tuple[str, re.Match]]:
    """Where ``figure``'s pattern stands in the pages ``texts``: (page, match) (a space in
    it matches any run of white space, so a page may be rewrapped)."""
    pattern = re.compile(figure.pattern.replace(" ", r"\s+"), flags=re.S)
    return [(page, m) for page, text in texts.items() for m in pattern.finditer(text)]


def problems(text: dict[str, str] | None = None, data: dict | None = None) -> list[str]:
    """One line per figure of the pages ``text`` (default: ``pages()``) that disagrees
    with its run (see ``check``)."""
    from readme_figure_list import FIGURES

    text = pages() if text is None else text
    data = records() if data is None else data
    out = []
    names = [f.name for f in FIGURES]
    if len(set(names)) != len(names):
        out.append("FIGURES: a name is listed twice")
    for f in FIGURES:
        found = find(f, text)
        if len(found) != 1:
            out.append(f"{f.name}: the pages hold its pattern {len(found)} times, not once "
                       f"({f.pattern[:60]!r}...{', in ' if found else ''}"
                       f"{', '.join(page for page, _ in found)})")
            continue
        try:
            value = f.value(data)
        except (KeyError, IndexError, TypeError) as e:
            out.append(f"{f.name}: no recorded run gives it ({type(e).__name__}: {e}); "
                       "run: python benchmarks/readme_figures.py run")
            continue
        page, match = found[0]
        printed = match.group("v")
        if not agrees(printed, value, f.noise):
            shown = value if isinstance(value, str) else f"{value:.6g}"
            out.append(f"{f.name}: {page} says {printed}, the run {shown} (noise: "
                       f"{f.noise})")
    runs = data["runs"]
    for name, command in walkthrough(text):
        if name in NOT_BY_DEFAULT:
            continue
        if name not in runs or runs[name]["command"] != command:
            out.append(f"walkthrough: {name}: `{command}` was not walked through as the "
                       "pages write it (run: python benchmarks/readme_figures.py run)")
        elif runs[name]["exit"] != EXPECTED_EXIT.get(name, 0):
            out.append(f"walkthrough: {name}: exit {runs[name]['exit']}, not "
                       f"{EXPECTED_EXIT.get(name, 0)}: {runs[name]['stderr'][-1:]}")
    return out


def write() -> int:
    """Rewrites each figure from the record, in its page, at the precision it is
    printed."""
    from readme_figure_list import FIGURES

    text, data = pages(), records()
    for f in FIGURES:
        found = find(f, text)
        if len(found) != 1:
            print(f"{f.name}: not once in the pages; left")
            continue
        try:
            value = f.value(data)
        except (KeyError, IndexError, TypeError):
            print(f"{f.name}: no recorded run; left")
            continue
        page, match = found[0]
        printed = match.group("v")
        spec = (("+" if printed.startswith("+") else "") + ("," if "," in printed else "")
                + f".{decimals(printed)}f")
        new = value if isinstance(value, str) else format(value, spec)
        a, b = match.span("v")
        text[page] = text[page][:a] + new + text[page][b:]
    for page, content in text.items():
        if (ROOT / page).read_text() != content:
            (ROOT / page).write_text(content)
    return 0


def main() -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=("run", "check", "write"))
    parser.add_argument("--fresh", action="store_true",
                        help="run: in a fresh clone of HEAD, with a new venv")
    parser.add_argument("--only", default="", help="run: these ids only (comma-separated)")
    parser.add_argument("--skip", default="", help="run: not these ids (comma-separated)")
    args = parser.parse_args()
    if args.what == "run":
        measure(set(filter(None, args.only.split(","))) or None,
                set(filter(None, args.skip.split(","))), args.fresh)
        return 0
    if args.what == "write":
        return write()
    found = problems()
    for line in found:
        print(line)
    from readme_figure_list import FIGURES

    wrong = {line.split(":")[0] for line in found}
    print(f"{sum(f.name not in wrong for f in FIGURES)} of {len(FIGURES)} figures agree with "
          "their runs" + ("; the walkthrough is not the pages'" if "walkthrough" in wrong
                          else ""))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
