"""bench_verify's closed loop alone: the batched evaluator's one test that opens the true
properties at a tick is there once (else the benchmark measures nothing), and nothing
before it in the tick, nor the follower's update after it, reads what the properties
write (so the copy without them runs the same loop). Under ``safety.mode: ssm_pfl`` that
block also runs the robot's own contact detection (``pfl.contact_limits``: its episodes,
read by the next tick's command), a model of the real robot on the truth: the loop alone
is measured under ``ssm`` only, where none of it runs."""

import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[3] / "benchmarks"))
import bench_verify  # noqa: E402

# What the properties' block writes: the figures and the bounds it keeps across ticks.
WRITTEN = ("min_sep", "sep_min", "sep_time", "pc", "kept", "seg_kept", "op_kept", "last_x",
           "last_ends", "travel")


def _advance_source() -> list[str]:
    lines = (bench_verify.ROOT / bench_verify.EVALUATOR).read_text().splitlines(keepends=True)
    start = next(i for i, line in enumerate(lines) if line.startswith("def _advance("))
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith("def "))
    return lines[start:end]


def test_the_properties_test_is_there_once():
    text = (bench_verify.ROOT / bench_verify.EVALUATOR).read_text()
    assert text.count(bench_verify.PROPERTIES_AT_A_TICK) == 1


def test_the_loop_reads_nothing_the_properties_write():
    lines = _advance_source()
    body_start = [i for i, line in enumerate(lines) if '"""' in line][1] + 1  # docstring's end
    at = lines.index(bench_verify.PROPERTIES_AT_A_TICK)
    indent = len(bench_verify.PROPERTIES_AT_A_TICK) - len(
        bench_verify.PROPERTIES_AT_A_TICK.lstrip())
    after = next(i for i in range(at + 1, len(lines))
                 if lines[i].strip() and len(lines[i]) - len(lines[i].lstrip()) <= indent)
    unpacking = re.compile(r"^\s*kept, seg_kept, op_kept, last_x, last_ends, travel = ")
    loop = [line.split("#")[0] for line in lines[body_start:at] + lines[after:]
            if not unpacking.match(line)]
    for name in WRITTEN:
        used = [line for line in loop if re.search(rf"\b{name}\b", line)]
        assert not used, (name, used)
