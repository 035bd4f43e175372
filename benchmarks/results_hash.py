"""A hash of the batched evaluator's results on fixed batches: an optimisation of the
evaluator is exact when it leaves these unchanged.

    python benchmarks/results_hash.py [--batch 512]

Batches (``bench_verify._ten_second_scenarios``, seed 0, and a second seed-3 batch of
each whole-cell kind): the whole cell with estimated human speeds (``busy``, the
throughput's figure), on iso.yaml's contact terms (``iso``), iso.yaml itself with its Z_r
(``iso_zr``), the tool point (``tool``), and the whole cell with the human speed's
floor and sigmas (``floor``), with the robot's fastest point (``fastest``) and with S by
speed (``by_speed``); and under power and force limiting (``safety.mode: ssm_pfl``, as
test_evaluate_batch's Drake comparisons configure it): the seed's configuration with the
robot's capsules over the whole cell with one operator (``pfl``), the same stopping by
speed with a bench below the robot (``pfl_table``, its clamping rule), and iso.yaml by
speed with a payload (``iso_pfl``). For each, every field of every scenario's
``BatchResult`` (their float64 bytes) is hashed; printed one line per batch and one for
all, with the count of scenarios violating each property (a change that moved no figure
keeps every line).

    python benchmarks/results_hash.py --batch 64 --write   # records the baseline
    python benchmarks/results_hash.py --batch 64 --check   # exit 1 if a hash moved

The baseline (``benchmarks/results/results_hash.json``) was taken from the code before the
configuration's derivations moved into one resolved cell (issue 52); tests/benchmarks/
test_results_hash.py holds every batch's hash equal to it.
"""

import argparse
import dataclasses
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import bench_verify as b  # noqa: E402
from safety_systems.config.scenario import Box  # noqa: E402

BASELINE = Path(__file__).parent / "results" / "results_hash.json"
TABLE = Box([-1.5, -1.5, -0.8], [1.5, 1.5, -0.3])  # test_evaluate_batch's bench


def digest(result) -> str:
    h = hashlib.sha256()
    for f in dataclasses.fields(result):
        h.update(np.ascontiguousarray(getattr(result, f.name), dtype=np.float64).tobytes())
    return h.hexdigest()[:16]


def batches(n: int) -> dict:
    cell = {"space": b.SPACE, "config": b.ISO_MOVING, "operators": 2.0, "heads": 1.0}

    def safety(config=b.ISO_MOVING, **kw):
        return dataclasses.replace(config, safety=dataclasses.replace(config.safety, **kw))

    busy = safety(human_speed="estimated")
    one = {"space": b.SPACE, "operators": 1.0}
    return {
        "busy": b._ten_second_scenarios(n, 0, **dict(cell, config=busy)),
        "busy_seed3": b._ten_second_scenarios(n, 3, **dict(cell, config=busy)),
        "iso": b._ten_second_scenarios(n, 0, **cell),
        "iso_seed3": b._ten_second_scenarios(n, 3, **cell),
        "iso_zr": b._ten_second_scenarios(n, 0, **dict(cell, config=b.ISO)),
        "tool": b._ten_second_scenarios(n, 0, space=b.FLANGE, config=b.SEED, operators=1.0),
        "floor": b._ten_second_scenarios(n, 0, **dict(cell, config=safety(
            human_speed="estimated_with_floor", human_uncertainty_sigmas=2.0))),
        "fastest": b._ten_second_scenarios(n, 0, **dict(cell, config=safety(
            human_speed="estimated", robot_speed="fastest_point"))),
        "by_speed": b._ten_second_scenarios(n, 0, **dict(cell, config=safety(
            stopping="by_speed", robot_speed="fastest_point", reaction_time=0.1,
            intrusion_distance=0.0, robot_uncertainty=0.1))),
        "pfl": b._ten_second_scenarios(n, 0, **dict(one, config=safety(
            b.SEED, mode="ssm_pfl", robot_geometry="capsules"))),
        "pfl_table": b._ten_second_scenarios(n, 0, **dict(one, config=safety(
            b.SEED, mode="ssm_pfl", robot_geometry="capsules", stopping="by_speed",
            pfl_speed=0.3, fixed_surfaces=[TABLE], clamp_margin=0.1))),
        "iso_pfl": b._ten_second_scenarios(n, 0, **dict(cell, config=safety(
            b.ISO, mode="ssm_pfl", stopping="by_speed", robot_speed="fastest_point",
            payload_mass=5.0))),
    }


def hashes(batch: int, echo=None) -> dict:
    """Each batch's hash of ``batch`` scenarios, and "all" over them in order; ``echo``
    (None: silent) is called with each batch's line."""
    whole, out = hashlib.sha256(), {}
    for name, scenarios in batches(batch).items():
        r = b.evaluate_many(scenarios, batch_size=batch)
        out[name] = h = digest(r)
        whole.update(h.encode())
        if echo is not None:
            echo(f"{name:12s} {h}  contact violated {int(np.sum(r.robustness < 0))}, "
                 f"separation violated {int(np.sum(r.separation < 0))}, "
                 f"min separation {np.min(r.min_separation_while_moving):+.6f}, "
                 f"permitted contact exceeded {int(np.sum(r.permitted_contact < 0))}")
    out["all"] = whole.hexdigest()[:16]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=512)
    what = parser.add_mutually_exclusive_group()
    what.add_argument("--write", action="store_true", help="record the baseline")
    what.add_argument("--check", action="store_true", help="compare with the baseline")
    args = parser.parse_args()
    got = hashes(args.batch, echo=lambda line: print(line, flush=True))
    print(f"{'all':12s} {got['all']}")
    if args.write:
        BASELINE.write_text(json.dumps({"batch": args.batch, "hashes": got}, indent=1) + "\n")
    elif args.check:
        base = json.loads(BASELINE.read_text())
        if base["batch"] != args.batch:
            sys.exit(f"{BASELINE}: batch: {base['batch']}; --check needs --batch {base['batch']}")
        moved = [k for k in base["hashes"] if base["hashes"][k] != got.get(k)]
        print("unchanged" if not moved else f"moved: {', '.join(moved)}")
        sys.exit(1 if moved else 0)


if __name__ == "__main__":
    main()
