"""The operator's envelopes against real people, before and after issue 47, and their cost.

    python benchmarks/bench_envelopes.py [--reference COMMIT] [--rows 4096] [--json]

For each real recording (``tests/real_bodies.py``: the KTH handover's giver and taker, CMU
subject 131 starting, walking and stopping) and each sensor set (the seed's gloves; with
a helmet; with a chest or a belt body; with elbow bands; a full suit), fed only the points
the set tracks (allowance 0: the recorded positions are the truth), it prints per segment
how far the envelope reaches past the real segment (``real_bodies.gaps``: in the direction
where it reaches farthest, and averaged over all directions: how much nearer a robot far
off in a direction finds the envelope than the real segment), mean / 95th percentile over
the frames, for the reference commit's rule (``human_body`` as it was there: by default
main's before issue 47, each untracked point bounded from one tracked point) beside this
code's (every tracked point together), the mean over the segments, and the least
containment margin of each (>= 0: every real segment inside its envelope in every
frame).

Then the cost of the rule: ``envelope_batch`` over ``--rows`` rows of two operators with
each sensor set, CPU microseconds per row, best of five, both rules in this process (the
reference's module is loaded from git into a temporary folder and compiled there, afresh
on every run: seconds). ``--json`` writes benchmarks/results/bench_envelopes.json.
Run it on an idle core (``taskset -c 0``) for the timing; the gaps do not depend on it.
"""

import argparse
import importlib.util
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from real_bodies import (
    MEASURED,
    SENSOR_SETS,
    cmu_body,
    containment,
    envelopes,
    gaps,
    kth_bodies,
)

from safety_systems.cell import human_body
from safety_systems.sensing.tracks import TRACK_TRACKING

REFERENCE = "3c891a2"  # main before issue 47
RESULTS = ROOT / "benchmarks" / "results" / "bench_envelopes.json"


def reference_module(commit: str, folder: Path):
    """``safety_systems/cell/human_body.py`` as it was at ``commit``, imported from a copy
    in ``folder`` (its compiled functions cached there)."""
    source = subprocess.run(["git", "show", f"{commit}:safety_systems/cell/human_body.py"],
                            cwd=ROOT, check=True, capture_output=True, text=True).stdout
    path = folder / "human_body_reference.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("human_body_reference", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def gap_figures(modules: dict) -> dict:
    """{recording: {set: {rule: {"gaps": {segment: {"worst" | "average": [mean, p95]}},
    "least_margin": m}}}}."""
    out = {}
    for body in kth_bodies() + [cmu_body()]:
        out[body.name] = {}
        for set_name, tracked in SENSOR_SETS.items():
            out[body.name][set_name] = {}
            for rule, module in modules.items():
                ends, radius = envelopes(module, body, tracked)
                least = min(c[3] for c in containment(body, ends, radius))
                out[body.name][set_name][rule] = {
                    "gaps": {k: {kind: list(v) for kind, v in g.items()}
                             for k, g in gaps(body, ends, radius).items()},
                    "least_margin": least}
    return out


def timing(modules: dict, rows: int, repeats: int = 5) -> dict:
    """{set: {rule: microseconds per row}} of ``envelope_batch`` with two operators."""
    rng = np.random.default_rng(0)
    out = {}
    for set_name, tracked in SENSOR_SETS.items():
        out[set_name] = {}
        n = 2 * len(tracked)
        p = rng.normal(size=(rows, n, 3)) * 0.3 + [0.0, 0.0, 1.2]
        for rule, module in modules.items():
            recipe = module.envelope_recipe([list(tracked)] * 2)
            m = recipe.radius.size
            args = (recipe.regions, recipe.candidates, recipe.radius, recipe.operator,
                    recipe.slots, p, np.zeros((rows, n, 3)),
                    np.full((rows, n), float(TRACK_TRACKING)), np.zeros((rows, n)),
                    np.zeros((rows, n)), 0.01, 2.0, np.empty((rows, m, 2, 3)),
                    np.empty((rows, m, 2, 3)), np.empty((rows, m)), np.empty((rows, m)),
                    np.empty((rows, m)))
            module.envelope_batch(*args)  # compiled and warm
            best = np.inf
            for _ in range(repeats):
                start = time.process_time()
                module.envelope_batch(*args)
                best = min(best, time.process_time() - start)
            out[set_name][rule] = best / rows * 1e6
    return out


def print_gaps(figures: dict, rules: list[str]) -> None:
    short = {rule: rule.split(" ")[0] for rule in rules}
    for recording, by_set in figures.items():
        for set_name, by_rule in by_set.items():
            print(f"\n{recording}, {set_name}: how far each envelope reaches past the real "
                  "segment (m, mean / 95th percentile over the frames)")
            print(f"  {'segment':16s}" + "".join(
                f"{kind + ', ' + short[r]:>19s}" for kind in ("worst", "average")
                for r in rules))
            for segment in MEASURED:
                print(f"  {segment:16s}" + "".join(
                    "{:>11.3f} /{:6.3f}".format(*by_rule[r]["gaps"][segment][kind])
                    for kind in ("worst", "average") for r in rules))
            print(f"  {'mean of segments':16s}" + "".join(
                f"{np.mean([by_rule[r]['gaps'][g][kind][0] for g in MEASURED]):>11.3f}"
                + " " * 8 for kind in ("worst", "average") for r in rules))
            print(f"  {'least margin':16s}" + "".join(
                f"{by_rule[r]['least_margin']:>+11.4f}" + " " * 8 for r in rules))


def print_summary(figures: dict, rules: list[str]) -> None:
    print("\nthe mean over the segments of how far the envelopes reach past the real body "
          "(m; before -> after, change)")
    print(f"  {'recording':12s} {'sensor set':22s} {'worst direction':>26s} "
          f"{'average direction':>26s}")
    for recording, by_set in figures.items():
        for set_name, by_rule in by_set.items():
            cells = []
            for kind in ("worst", "average"):
                before, after = (np.mean([by_rule[r]["gaps"][g][kind][0] for g in MEASURED])
                                 for r in rules)
                change = f"{100 * (after / before - 1):+5.1f}%" if before > 0 else "   -  "
                cells.append(f"{before:6.3f} -> {after:6.3f} {change:>8s}")
            print(f"  {recording:12s} {set_name:22s} {cells[0]:>26s} {cells[1]:>26s}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", default=REFERENCE,
                        help=f"the commit whose rule is 'before' (default {REFERENCE})")
    parser.add_argument("--rows", type=int, default=4096,
                        help="rows per envelope_batch call timed (default 4096)")
    parser.add_argument("--json", action="store_true", help=f"write {RESULTS}")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        print(f"loading the reference rule ({args.reference}) and compiling both rules",
              flush=True)
        modules = {f"before ({args.reference})": reference_module(args.reference,
                                                                   Path(folder)),
                   "after (this code)": human_body}
        rules = list(modules)
        figures = gap_figures(modules)
        print_gaps(figures, rules)
        print_summary(figures, rules)
        cost = timing(modules, args.rows)
    print(f"\nenvelope_batch, two operators, {args.rows} rows: CPU microseconds per row")
    for set_name, by_rule in cost.items():
        before, after = (by_rule[r] for r in rules)
        print(f"  {set_name:24s} before {before:6.2f}   after {after:6.2f}   "
              f"ratio {after / before:5.2f}")
    if args.json:
        RESULTS.write_text(json.dumps({"reference": args.reference, "rows": args.rows,
                                       "gaps": figures, "microseconds_per_row": cost},
                                      indent=1) + "\n")
        print(f"wrote {RESULTS.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
