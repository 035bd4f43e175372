"""The batched evaluator's results on the benchmark batches (benchmarks/results_hash.py)
are unchanged: each batch's hash equals the baseline recorded before the configuration's
derivations moved into one resolved cell (issue 52), so that move changed no figure."""

import json
import sys
from pathlib import Path

ROOT = Path(__file__).parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import results_hash  # noqa: E402


def test_every_benchmark_batchs_results_hash_is_the_baselines():
    base = json.loads(results_hash.BASELINE.read_text())
    got = results_hash.hashes(base["batch"])
    assert got == base["hashes"]
