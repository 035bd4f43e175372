"""The batched evaluator's throughput of several commits, A/B, in one run.

    python benchmarks/ab_throughput.py 177f5a8 9273221 . [--rounds 5] [--batch 512]
        [--kinds busy,iso,tool] [--trees DIR] [--cpu N]

Each commit's code (``.`` is this working tree, uncommitted changes included; a folder
holding a copy of the project's packages and benchmarks is measured as it is) is checked
out in a git worktree (under ``--trees``, kept there for the next run, since numba
compiles a fresh tree's code for minutes; by default a temporary folder, removed after)
and measured in a child process by its own ``benchmarks/bench_verify.py``'s scenarios
(``_ten_second_scenarios``, the same as ``bench_verify --parts throughput`` times): the
whole cell on iso.yaml's contact terms (``iso``), the same with estimated human speeds
(``busy``: the figure ``bench_verify`` reports is the lower of the two), and the tool
point (``tool``: the seed's configuration over the flange space), each the best of
``bench_verify.REPEATS`` runs of the same batch, in the child's CPU time.

The commits are measured in turns, ``--rounds`` times, the order reversed every other
round (A B C, C B A, ...), so that a drift of the machine's load falls on all of them
alike; a first untimed round per tree compiles and loads its code. Printed: each
commit's best and median over the rounds, its ratio to the first commit (> 1: faster),
the whole cell's ratio to the tool point, the load average during the run, and a hash of
each commit's results (every field of every scenario's result in the busy batch: equal
hashes mean the same figures).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).parents[1]

_CHILD = """
import dataclasses, hashlib, json, math, os, sys, time
sys.path.insert(0, "benchmarks")
import numpy as np
import bench_verify as b
import safety_systems
REPEATS = getattr(b, "REPEATS", 3)
def best(scenarios):
    t = math.inf
    for _ in range(REPEATS):
        start = time.process_time()
        result = b.evaluate_many(scenarios, batch_size=len(scenarios))
        t = min(t, time.process_time() - start)
    return len(scenarios) / t, result
def digest(result):
    h = hashlib.sha256()
    for f in dataclasses.fields(result):
        h.update(np.ascontiguousarray(getattr(result, f.name), dtype=float).tobytes())
    return h.hexdigest()[:16]
cell = {"space": b.SPACE, "config": b.ISO_MOVING, "operators": 2.0, "heads": 1.0}
busy = dataclasses.replace(b.ISO_MOVING, safety=dataclasses.replace(
    b.ISO_MOVING.safety, human_speed="estimated"))
kinds = {"iso": cell, "busy": dict(cell, config=busy),
         "tool": {"space": b.FLANGE, "config": b.SEED, "operators": 1.0}}
out = {"module": b.__file__, "package": safety_systems.__file__,
       "evaluator": sys.modules[b.evaluate_many.__module__].__file__, "load": os.getloadavg()[0]}
for kind in KINDS:
    b.evaluate_many(b._ten_second_scenarios(4, 2, **kinds[kind]))  # loads the code (not timed)
    if not TIMED:
        continue
    rate, result = best(b._ten_second_scenarios(BATCH, 0, **kinds[kind]))
    out[kind] = rate
    out[kind + "_hash"] = digest(result)
out["load_after"] = os.getloadavg()[0]
print(json.dumps(out))
"""


def child(tree: Path, kinds: list[str], batch: int, timed: bool, cpu: int | None) -> dict:
    code = _CHILD.replace("KINDS", repr(kinds)).replace("BATCH", str(batch)).replace(
        "TIMED", repr(timed))
    command = [sys.executable, "-c", code]
    if cpu is not None:
        command = ["taskset", "-c", str(cpu)] + command
    run = subprocess.run(command, cwd=tree, env={**os.environ, "PYTHONPATH": str(tree)},
                         capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise RuntimeError(f"{tree}: {run.stderr.strip()[-2000:]}")
    out = json.loads(run.stdout.strip().splitlines()[-1])
    for key in ("module", "package", "evaluator"):
        if not out[key].startswith(str(tree)):
            raise RuntimeError(f"{tree}: the child ran {out[key]}, not this tree's code")
    return out


def trees_for(commits: list[str], where: Path) -> dict[str, Path]:
    trees = {}
    for c in commits:
        if c == ".":
            trees[c] = ROOT
            continue
        if Path(c).is_dir():  # a tree as it is (a copy with an experiment, say)
            trees[c] = Path(c).resolve()
            continue
        full = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short=7", c],
                              capture_output=True, text=True, check=True).stdout.strip()
        tree = where / f"ab-{full}"
        if not tree.exists():
            subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree),
                            full], capture_output=True, text=True, check=True)
        trees[c] = tree
    return trees


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commits", nargs="+", help="commits ('.': this working tree; or folders); "
                        "the first is the reference of the ratios")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--batch", type=int, default=512)
    parser.add_argument("--kinds", default="busy,iso,tool")
    parser.add_argument("--trees", help="keep the worktrees in this folder (default: a "
                        "temporary one, removed after)")
    parser.add_argument("--cpu", type=int, help="run the children on this core (taskset)")
    args = parser.parse_args()
    kinds = args.kinds.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(args.trees) if args.trees else Path(tmp)
        where.mkdir(parents=True, exist_ok=True)
        trees = trees_for(args.commits, where)
        try:
            for c, tree in trees.items():  # compiles and loads (not timed)
                child(tree, kinds, args.batch, False, args.cpu)
            runs: dict[str, list[dict]] = {c: [] for c in args.commits}
            loads = []
            for r in range(args.rounds):
                order = args.commits if r % 2 == 0 else args.commits[::-1]
                for c in order:
                    out = child(trees[c], kinds, args.batch, True, args.cpu)
                    runs[c].append(out)
                    loads += [out["load"], out["load_after"]]
                    print(f"round {r + 1} {c:>8s}: " + "  ".join(
                        f"{k} {out[k]:7.1f}" for k in kinds) + f"  load {out['load']:.2f}",
                        flush=True)
        finally:
            if not args.trees:
                for c, tree in trees.items():
                    if tree != ROOT:
                        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove",
                                        "--force", str(tree)], capture_output=True, check=False)
    ref = args.commits[0]
    print(f"\n{args.rounds} rounds, batch {args.batch}, each figure the best of the child's "
          f"repeated runs; load average {min(loads):.2f}-{max(loads):.2f}")
    print(f"{'commit':>8s} {'kind':>5s} {'best':>8s} {'median':>8s} {'/ref best':>10s} "
          f"{'/ref med':>9s} {'hash':>17s}")
    for c in args.commits:
        for k in kinds:
            xs = [o[k] for o in runs[c]]
            rs = [o[k] for o in runs[ref]]
            print(f"{c:>8s} {k:>5s} {max(xs):8.1f} {statistics.median(xs):8.1f} "
                  f"{max(xs) / max(rs):10.3f} {statistics.median(xs) / statistics.median(rs):9.3f}"
                  f" {runs[c][-1][k + '_hash']:>17s}")
        if "tool" in kinds:
            for k in ("busy", "iso"):
                if k in kinds:
                    ratio = max(o[k] for o in runs[c]) / max(o["tool"] for o in runs[c])
                    print(f"{c:>8s} {k}/tool (best) {ratio:.3f}")


if __name__ == "__main__":
    main()
