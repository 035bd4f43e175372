"""A Motive export made to the specification of one whose rigid bodies freeze and then
jump (issue 48: a Motive 1.23 export whose bodies hold still for most frames and jump
30-38 times each): the real diabolo export z_hop_1.csv (Format Version 1.22, 120 Hz)
with stick_right's cells held at one frame's values over given frames, as Motive writes
a body it lost and found again."""

import csv
import io
from pathlib import Path

Z_HOP = Path(__file__).parents[1] / "data" / "motive_csv" / "2020-07-11_basic_physics__z_hop_1.csv"
HOLDS = ((100, 160), (260, 320), (340, 400))  # frames held: [a, b), jumps of 50-55 m/s


def held_export(out: Path, body: str = "stick_right", holds=HOLDS) -> Path:
    """z_hop_1.csv with ``body``'s cells in frames a + 1 .. b - 1 equal to frame a's, for
    each (a, b) in ``holds``; written to ``out``."""
    rows = list(csv.reader(io.StringIO(Z_HOP.read_text())))
    names = next(r for r in rows[:8] if body in r)
    cols = [j for j, x in enumerate(names) if x == body]
    first = next(i for i, r in enumerate(rows) if r and r[0] == "Frame") + 1
    for a, b in holds:
        for i in range(first + a + 1, first + b):
            for j in cols:
                rows[i][j] = rows[first + a][j]
    text = io.StringIO()
    csv.writer(text, lineterminator="\n").writerows(rows)
    out.write_text(text.getvalue())
    return out


def positions(path: Path, body: str = "stick_right") -> list[tuple[float, float, float]]:
    """The body's Position X, Y, Z cells per frame, read with nothing but the csv module
    (the second reader of these figures)."""
    rows = list(csv.reader(io.StringIO(path.read_text())))
    names = next(r for r in rows[:8] if body in r)
    groups = rows[next(i for i, r in enumerate(rows) if r and r[0] == "Frame") - 1]
    cols = [j for j, x in enumerate(names) if x == body and groups[j] == "Position"]
    first = next(i for i, r in enumerate(rows) if r and r[0] == "Frame") + 1
    return [tuple(float(r[j]) for j in cols) for r in rows[first:] if r]
