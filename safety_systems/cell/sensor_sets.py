"""Sensor sets: which body points of an operator a cell tracks (issue 47).

The seed tracked two gloves (seed 000, Section 4: one rigid body per hand). Each set here
names the body points (``human_body.POINTS``) its rigid bodies mark; the envelopes of the
untracked segments are bounded from these (``human_body``), so more points give narrower
envelopes: what each set buys is measured on real people (``tests/test_kth_envelope.py``,
``tests/test_cmu_envelope.py``, ``benchmarks/bench_envelopes.py``) and in lost time
(``verification.tune.levers``, ``benchmarks/bench_levers.py``).
"""

from safety_systems.cell.human_body import POINTS

GLOVES = ("hand_left", "hand_right")
SENSOR_SETS = {
    "gloves": GLOVES,
    "gloves+helmet": GLOVES + ("head",),
    "gloves+helmet+chest": GLOVES + ("head", "chest"),
    "gloves+helmet+belt": GLOVES + ("head", "pelvis"),
    "gloves+helmet+elbows": GLOVES + ("head", "elbow_left", "elbow_right"),
    "gloves+helmet+belt+elbows": GLOVES + ("head", "pelvis", "elbow_left", "elbow_right"),
    "full suit": POINTS,
}


def points_of(name: str) -> tuple[str, ...]:
    """The body points sensor set ``name`` tracks (KeyError naming the sets if unknown)."""
    if name not in SENSOR_SETS:
        raise KeyError(f"sensor set {name!r}: one of " + " | ".join(SENSOR_SETS))
    return SENSOR_SETS[name]
