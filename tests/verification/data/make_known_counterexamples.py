"""Writes known_counterexamples.json: the counterexamples the closed loop
(``verification.search.evaluate_batch``) finds among the points of a Sobol set over
``models/spaces/default.yaml`` with its operators in suits (every body point tracked:
with gloves and a helmet only, the untracked segments' envelopes keep these variants
clear of the truth in every point of the set), for two variants of
``models/configs/iso.yaml``; run it
again when the space or the loop changes what is a counterexample (the test of the
ranking, ``tests/verification/search/test_ranking.py``, checks they still are).

    .venv/bin/python tests/verification/data/make_known_counterexamples.py
"""

import dataclasses
import json
from pathlib import Path

import numpy as np

from safety_systems.cell.human_body import POINTS as BODY_POINTS
from safety_systems.config.scenario import load_controller_config
from verification.search.evaluate_batch import evaluate_many
from verification.search.strategies import sweep_points
from verification.spaces.space import free_parameters, load_space, make_scenario, to_point

ROOT = Path(__file__).resolve().parents[3]
POINTS, SEED, KEEP = 16384, 11, 12  # the Sobol set, and how many of each to keep
VARIANTS = (  # (property, the safety fields changed from iso.yaml's)
    ("separation", {"robot_uncertainty": 0.1}),
    ("contact", {"robot_uncertainty": 0.0, "iso_human_speed": 1.0,
                 "iso_reduced_human_speed": 1.0}),
)


def main() -> None:
    space = dataclasses.replace(load_space(ROOT / "models" / "spaces" / "default.yaml"),
                                tracked=list(BODY_POINTS))
    iso = load_controller_config(ROOT / "models" / "configs" / "iso.yaml")
    d = len(free_parameters(space))
    pool = sweep_points("sobol", POINTS, d, seed=SEED)
    sets = []
    for prop, safety in VARIANTS:
        config = dataclasses.replace(iso, safety=dataclasses.replace(iso.safety, **safety))
        result = evaluate_many([make_scenario(space, config, to_point(space, u)) for u in pool])
        figures = result.robustness if prop == "contact" else result.separation
        found = np.flatnonzero(figures < 0.0)
        print(f"{prop}: {found.size} of {POINTS} break it")
        keep = found[np.linspace(0, found.size - 1, min(KEEP, found.size)).astype(int)] \
            if found.size else found
        sets.append({"property": prop, "safety": safety, "tracked": list(space.tracked),
                     "sobol_index": [int(i) for i in keep],
                     "points": pool[keep].tolist()})
    about = (f"Counterexamples the closed loop (verification.search.evaluate_batch) found among "
             f"the {POINTS} points of sweep_points('sobol', {POINTS}, {d}, seed={SEED}) over "
             "models/spaces/default.yaml with every body point tracked, for two variants of "
             "models/configs/iso.yaml (up to "
             f"{KEEP} each, spread over the set; made by make_known_counterexamples.py); "
             "tests/verification/search/test_ranking.py checks they still are, and that the "
             "falsifier's ranking never pushes them below its exploration budget.")
    out = Path(__file__).with_name("known_counterexamples.json")
    out.write_text(json.dumps({"about": about, "sets": sets}, indent=1) + "\n")


if __name__ == "__main__":
    main()
