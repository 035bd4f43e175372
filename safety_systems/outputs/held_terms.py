"""What held the robot, in words and terms an integrator can act on, without a run's
signals: the body points whose tracking would bound a segment by its own points, what
the monitor asks of each segment before the robot may move at all, and the console's
words. ``outputs.held`` (a simulated run) and the live runtime (``runtime.run_tally``'s
summary) share them; nothing here imports Drake.
"""

from safety_systems.cell.human_body import SEGMENTS


def untracked_points(segment: str, tracked: list[list[str]]) -> list[str]:
    """The body points of ``segment`` (its two ends, ``human_body.SEGMENTS``) that no
    operator's bodies mark: tracking them is what would bound it by its own points
    instead of an envelope of the others (empty: its points are tracked, or no segment)."""
    ends = next((s[1:3] for s in SEGMENTS if s[0] == segment), ())
    marked = {q for points in tracked for q in points}
    return [q for q in dict.fromkeys(ends) if q not in marked]


def lowest_speed_table(cell) -> dict:
    """For each segment (by its name without the operator's), what the monitor asks of it
    before the robot may move at all: S at the lowest speed level (the human's speed
    bound, ``explanation.segment_figures``; the largest over the operators) with its terms
    and the largest of them, d_min, and which of S and d_min binds. Empty when the human
    speed in S is ``estimated`` (S then follows the tracker's speeds, not a bound the
    monitor keeps)."""
    from safety_systems.outputs.explanation import TERMS, segment_figures
    from safety_systems.ssm.formulas import SPEED_LEVELS

    safety = cell.config.safety
    if safety.human_speed == "estimated":
        return {}
    out: dict = {}
    for f in segment_figures(cell, rates=(1.0 / SPEED_LEVELS,)):
        name = f.segment.rsplit("/", 1)[-1]
        if name in out and out[name]["S"] >= f.s:
            continue
        terms = {t: float(f.terms[t]) for t in TERMS if t != "C + envelope"}
        out[name] = {"S": float(f.s), "terms": terms, "dominant": max(terms, key=terms.get),
                     "d_min": float(safety.d_min),
                     "binding": "d_min" if safety.d_min >= f.s else "S"}
    return out


def lowest_speed_of(table: dict, segment: str, separation: dict) -> dict | None:
    """``segment``'s row of :func:`lowest_speed_table` with ``envelope_beyond_body``: how
    far its envelope reached beyond the real body while it held the robot (the true minus
    the measured clearance, medians, from ``separation``; None where the truth is not
    known, as in a live run). None for no such row."""
    row = table.get(segment)
    if row is None:
        return None
    true = separation.get("true_clearance_median")
    measured = separation.get("measured_clearance_median")
    return {**row, "envelope_beyond_body": None if true is None or measured is None
            else max(0.0, float(true) - float(measured))}


def held_words(held: dict) -> str:
    """The console's words for ``outputs.held.held_by``'s figures (or a live run's): the
    separation stops' segments, most first, with the real body's median clearance, the
    monitor's measure, what binds at the lowest speed and the points whose tracking would
    release it; empty when nothing held the robot."""
    separation = held.get("separation") or {}
    if not separation.get("time"):
        return ""
    parts = ", ".join(f"{name} {t:.1f} s" for name, t in separation["by_segment"].items())
    clearance = separation.get("true_clearance_median")
    measured = separation.get("measured_clearance_median")
    then = []
    if clearance is not None:
        then.append(f"the real body then {clearance:.2f} m away, median")
    if measured is not None:
        then.append(f"the monitor's measure {measured:.2f} m")
    low = separation.get("lowest_speed")
    if low:
        binding = (f"d_min {low['d_min']:.3f} m binds" if low["binding"] == "d_min"
                   else f"S binds, {low['dominant']} {low['terms'][low['dominant']]:.3f} m "
                        "its largest term")
        then.append(f"at the lowest speed S {low['S']:.3f} m and {binding}")
        if low.get("envelope_beyond_body"):
            then.append(f"the envelope {low['envelope_beyond_body']:.2f} m beyond the body")
    points = separation.get("untracked_points")
    first = next(iter(separation["by_segment"]), None)
    if points:
        then.append(f"tracking {' and '.join(points)} would bound {first} by its own points")
    return (f"held on separation stops {separation['time']:.1f} s by {parts}"
            + (f" ({'; '.join(then)})" if then else ""))
