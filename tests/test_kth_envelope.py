"""The operator model (``cell.human_body``) against a real recorded body: the KTH
human-to-human handover (``tests/data/kth_handover/``, see its README.md: OptiTrack
Motive 3, 120 Hz, 801 rows, a giver and a taker; MIT, KTH-RPL/handovers_dataset).

Each person's hands and head are fed to the model as its only tracked points, with
``tracking_allowance`` 0 (the recorded positions are the truth here), and in every row
each real recorded segment must lie in the envelope the model infers for it. Frames are
the CSV's data rows counted from 0.

**Mapping.** A bone's position is its origin, a joint:

- ``hand_left`` / ``hand_right`` <- the ``LHand`` / ``RHand`` bone: its origin is the
  wrist, not the model's hand centre (about 0.08 m farther on). The wrist lies on the
  forearm's line between the elbow and the hand centre, so the real forearm checked is
  elbow to wrist, a part of the model's forearm (elbow to hand centre).
- ``head`` <- the ``head`` bone: its origin is at the top of the neck, below the head's
  centre (about 0.1 m). The model takes it for the head centre: every length the model
  derives from the head (``neck``, ``head_shoulder``) is then measured from a point nearer
  the shoulders than the centre, which the lengths hold with room (below). The head ball
  itself is not checked: the data has no head centre or surface.

**Real segments** (bone origins): shoulder girdle, ``neck`` to ``L/RUArm`` (the shoulder
joint; the ``L/RShoulder`` clavicle bones start 0.05 m from the neck origin); upper arm,
``UArm`` to ``FArm`` (the elbow); forearm, ``FArm`` to ``Hand`` (the wrist); upper
trunk, ``neck`` to ``chest``; the chest point (against both trunk envelopes); the model's
neck segment, ``head`` to ``neck``; and the lower trunk, ``chest`` to ``ab`` to ``hip``
(the pelvis root), against ``lower_trunk``. Each with the model's segment radius: the
margin of a sample x of the real axis is (envelope radius - segment radius - distance of
x to the envelope's axis), 21 samples per real segment; >= 0 is contained.

**Speeds.** The frame-to-frame hand speeds peak at 2.48 m/s (giver) and 2.68 m/s
(taker), but each peak is the step after a repeated row: the recording repeats a whole
row (every bone, the same 76 rows in both persons' files) and the next step then covers
two periods. Over those two rows the hands move at 1.24 and 1.34 m/s (the giver's right
hand reaches at 1.2-1.3 m/s, its steps above 2.0 m/s all follow a repeated row); the
taker's other steps above 2.0 m/s (2.03, 2.05 m/s) are sideways (y) jumps of 15-21 mm in
one row, 4-6 mm of which reverse in the next row (the skeleton solve, not the hand). A hidden hand's region, grown at
``occlusion_speed`` from the last row seen, holds the real hand at the measured
frame-to-frame peak (by the triangle inequality, whatever the hiding); at ISO 13855's
2.0 m/s it fails by a few millimetres in the row after a repeated row (a stale sample
taken for a new one), and holds through the fastest 0.25 s of real motion.

**Sensor sets** (issue 47): the same check for every sensor set of
``tests/real_bodies.py`` (the seed's gloves; with a helmet; with a chest or a belt body;
with elbow bands; a full suit), fed only the points the set tracks, in every frame of
both persons, with the per-segment gap between the real body and its envelope printed
(mean and 95th percentile over the frames; ``benchmarks/bench_envelopes.py`` prints them
beside main's rule before issue 47).

Run with ``pytest -s`` to see the figures; the assertion messages carry them too.
"""

from pathlib import Path

import numpy as np
import pytest
from real_bodies import SENSOR_SETS, kth_bodies, sensor_set_report

from safety_systems.cell import human_body as hb
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_TRACKING

DATA = Path(__file__).parent / "data" / "kth_handover"
RATE = 120.0  # Hz
ROWS = 801
PERSONS = ("giver", "taker")
BONES = ("head", "neck", "chest", "ab", "hip", "LShoulder", "RShoulder", "LUArm", "RUArm",
         "LFArm", "RFArm", "LHand", "RHand")
TRACKED = ("hand_left", "hand_right", "head")  # the model's points, in body slot order
BONE_OF = {"hand_left": "LHand", "hand_right": "RHand", "head": "head"}
DIMS = hb.DEFAULT_DIMENSIONS
ALLOWANCE = 0.0  # m: the recorded positions are the truth
ISO_HAND_SPEED = 2.0  # m/s, ISO 13855
HIDE_ROWS = 30  # 0.25 s at 120 Hz
SAMPLES = 21
# (model segment, bone at one end, bone at the other, the model's radius name)
REAL_SEGMENTS = (
    ("neck", "head", "neck", "neck_radius"),
    ("shoulder_left", "neck", "LUArm", "shoulder_radius"),
    ("shoulder_right", "neck", "RUArm", "shoulder_radius"),
    ("upper_arm_left", "LUArm", "LFArm", "upper_arm_radius"),
    ("upper_arm_right", "RUArm", "RFArm", "upper_arm_radius"),
    ("forearm_left", "LFArm", "LHand", "forearm_radius"),
    ("forearm_right", "RFArm", "RHand", "forearm_radius"),
    ("upper_trunk", "neck", "chest", "trunk_radius"),
    ("upper_trunk", "chest", "chest", "trunk_radius"),  # the chest point
    ("lower_trunk", "chest", "chest", "trunk_radius"),
)
LOWER_TRUNK = (
    ("lower_trunk", "chest", "ab", "trunk_radius"),
    ("lower_trunk", "ab", "hip", "trunk_radius"),
    ("lower_trunk", "ab", "ab", "trunk_radius"),
    ("lower_trunk", "hip", "hip", "trunk_radius"),
)


def load(person: str) -> dict[str, np.ndarray]:
    """Each bone's origin per row, (801, 3) m, Z up."""
    out = {}
    for bone in BONES:
        rows = np.loadtxt(DATA / f"{person}_{bone}_pose_saved.csv", delimiter=",",
                          skiprows=1)
        assert rows.shape == (ROWS, 7), (person, bone, rows.shape)
        out[bone] = rows[:, :3]
    return out


BODY = {person: load(person) for person in PERSONS}
RECIPE = hb.envelope_recipe([list(TRACKED)] * len(PERSONS), names=list(PERSONS))


def seg_index(person: str, segment: str) -> int:
    return RECIPE.names.index(f"{person}/{segment}")


def tracked_positions() -> np.ndarray:
    """(rows, bodies, 3): the tracked bodies in the recipe's slot order."""
    return np.stack([BODY[person][BONE_OF[point]] for person in PERSONS for point in TRACKED],
                    axis=1)


def run_envelopes(p, status=None, unseen=None, occlusion_speed=ISO_HAND_SPEED):
    """Every segment's envelope per row: ends (rows, M, 2, 3) and radius (rows, M), from
    the tracked positions p (rows, bodies, 3), with status and time unseen per row and
    body (default: all tracking); one ``envelope_rows`` call per row."""
    rows, n = p.shape[:2]
    status = np.full((rows, n), float(TRACK_TRACKING)) if status is None else status
    unseen = np.zeros((rows, n)) if unseen is None else unseen
    m = RECIPE.radius.size
    ends, radius = np.empty((rows, m, 2, 3)), np.empty((rows, m))
    e, ev, r, st, sd = np.empty((m, 2, 3)), np.empty((m, 2, 3)), np.empty(m), np.empty(m), \
        np.empty(m)
    v, std = np.zeros((n, 3)), np.zeros(n)
    for f in range(rows):
        hb.envelope_rows(RECIPE.regions, RECIPE.candidates, RECIPE.radius, RECIPE.operator,
                         RECIPE.slots, np.ascontiguousarray(p[f], dtype=float), v,
                         np.ascontiguousarray(status[f]), std,
                         np.ascontiguousarray(unseen[f]), ALLOWANCE, occlusion_speed,
                         e, ev, r, st, sd)
        assert np.all((st == TRACK_TRACKING) | (st == TRACK_HIDDEN)), (f, st)
        ends[f], radius[f] = e, r
    return ends, radius


def margins(ends, radius, m, A, B, seg_radius):
    """Per row, the least margin of the real axis A-B (rows, 3) grown by ``seg_radius`` in
    envelope m: envelope radius - seg_radius - distance of each axis sample to the
    envelope's axis, least over SAMPLES samples; and the sample where it is least."""
    w = np.linspace(0.0, 1.0, SAMPLES)[None, :, None]
    x = (1.0 - w) * A[:, None, :] + w * B[:, None, :]  # rows, samples, 3
    a, b = ends[:, m, 0][:, None, :], ends[:, m, 1][:, None, :]
    d = b - a
    dd = (d * d).sum(-1)
    s = np.clip(((x - a) * d).sum(-1) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
    gap = np.linalg.norm(x - (a + s[..., None] * d), axis=-1)
    mg = radius[:, m][:, None] - seg_radius - gap
    return mg.min(axis=1), mg.argmin(axis=1)


def containment(person, ends, radius, segments, rows=None):
    """[(label, least margin, its row, its sample's fraction along A-B)] per real segment
    of ``person``; ``rows``: the recorded rows the envelopes are for (default: all)."""
    body = {k: x if rows is None else x[rows] for k, x in BODY[person].items()}
    out = []
    for segment, a, b, r_name in segments:
        mg, where = margins(ends, radius, seg_index(person, segment), body[a], body[b],
                            DIMS[r_name])
        f = int(np.argmin(mg))
        label = f"{segment} <- {a}" + ("" if a == b else f"-{b}")
        out.append((label, float(mg[f]), f if rows is None else int(rows[f]),
                    where[f] / (SAMPLES - 1)))
    return out


def table(title, results):
    lines = [title] + [f"  {label:30s} least margin {mg:+.4f} m at frame {f:3d} "
                       f"({a:.2f} along)" for label, mg, f, a in results]
    text = "\n".join(lines)
    print(text)
    return text


@pytest.fixture(scope="module")
def tracked_envelopes():
    return run_envelopes(tracked_positions())


def test_the_copied_recording_is_whole():
    assert (DATA / "LICENSE").read_text().startswith("MIT License")
    assert "b3fbd4096cf53bf574b39d3ad8e7ee011a70f77f" in (DATA / "README.md").read_text()
    for person in PERSONS:
        for bone, x in BODY[person].items():
            assert np.all(np.isfinite(x)), (person, bone)


def test_the_real_postures_are_ones_the_dimensions_allow():
    """The model's premises on the real skeletons: every edge no longer than its length,
    the trunk and neck within their lean limits (the head row: from the head bone's
    origin, the lower point the model takes for the head centre)."""
    edges = (("shoulder", "neck", ("LUArm", "RUArm")), ("upper_arm", "LUArm", ("LFArm",)),
             ("upper_arm", "RUArm", ("RFArm",)), ("forearm", "LFArm", ("LHand",)),
             ("forearm", "RFArm", ("RHand",)), ("upper_trunk", "neck", ("chest",)),
             ("lower_trunk", "chest", ("hip",)), ("neck", "head", ("neck",)),
             ("head_shoulder", "head", ("LUArm", "RUArm")))
    leans = (("neck_lean_deg", "head", "neck"), ("trunk_lean_deg", "neck", "chest"),
             ("trunk_lean_deg", "chest", "hip"))
    lines, bad = ["real lengths and leans (largest over rows) against the model's"], []
    for person in PERSONS:
        Q = BODY[person]
        for name, a, bs in edges:
            longest = max(float(np.linalg.norm(Q[b] - Q[a], axis=1).max()) for b in bs)
            lines.append(f"  {person} {name:13s} {a}-{'/'.join(bs):11s} {longest:.4f} m "
                         f"(model {DIMS[name]:.2f}, spare {DIMS[name] - longest:+.4f})")
            bad += [(person, name)] if longest > DIMS[name] else []
        for name, a, b in leans:
            u = Q[b] - Q[a]
            lean = float(np.degrees(np.arccos(-u[:, 2] / np.linalg.norm(u, axis=1))).max())
            lines.append(f"  {person} {name:13s} {a}-{b:11s} {lean:5.1f} deg "
                         f"(model {DIMS[name]:.0f})")
            bad += [(person, name, a)] if lean > DIMS[name] else []
    text = "\n".join(lines)
    print(text)
    assert not bad, f"{bad}\n{text}"


@pytest.mark.parametrize("person", PERSONS)
def test_every_real_segment_lies_in_its_envelope(person, tracked_envelopes):
    ends, radius = tracked_envelopes
    results = containment(person, ends, radius, REAL_SEGMENTS)
    text = table(f"{person}: hands and head tracked, allowance 0, {ROWS} frames", results)
    worst = min(results, key=lambda x: x[1])
    print(f"  least: {worst[0]} {worst[1]:+.4f} m at frame {worst[2]}")
    assert worst[1] >= -1e-9, text


@pytest.mark.parametrize("person", PERSONS)
def test_the_lower_trunk_envelope_holds_the_ab_and_hip(person, tracked_envelopes):
    # Found contained with room (>= 0.34 m): no finding against the model here.
    ends, radius = tracked_envelopes
    results = containment(person, ends, radius, LOWER_TRUNK)
    text = table(f"{person}: ab and hip against lower_trunk", results)
    assert min(x[1] for x in results) >= -1e-9, text


@pytest.mark.parametrize("person", PERSONS)
def test_a_hand_to_shoulder_line_misses_the_real_elbows(person, tracked_envelopes):
    """The same check with the arm envelopes replaced by the line from the hand to the
    real shoulder joint (the UArm origin, the line most favourable to it), grown by the
    segment's radius: it fails, at the elbows, in every arm."""
    ends, radius = (x.copy() for x in tracked_envelopes)
    Q = BODY[person]
    for side, shoulder, hand in (("left", "LUArm", "LHand"), ("right", "RUArm", "RHand")):
        for segment in ("upper_arm", "forearm"):
            m = seg_index(person, f"{segment}_{side}")
            ends[:, m, 0], ends[:, m, 1] = Q[hand], Q[shoulder]
            radius[:, m] = DIMS[f"{segment}_radius"]
    results = containment(person, ends, radius, REAL_SEGMENTS)
    text = table(f"{person}: arm envelopes replaced by the hand-to-shoulder line", results)
    for side, s, e, h in (("left", "LUArm", "LFArm", "LHand"),
                          ("right", "RUArm", "RFArm", "RHand")):
        mg, _ = margins(ends, radius, seg_index(person, f"upper_arm_{side}"), Q[s], Q[e],
                        DIMS["upper_arm_radius"])
        line = f"  {side} elbow off the line: fails in {int((mg < 0).sum())} of {ROWS} " \
               f"frames, by up to {-mg.min():.4f} m (frame {int(mg.argmin())})"
        print(line)
        text += "\n" + line
        by_label = {label: mg for label, mg, _, _ in results}
        assert by_label[f"upper_arm_{side} <- {s}-{e}"] < -0.02, text
        assert by_label[f"forearm_{side} <- {e}-{h}"] < -0.02, text
        assert (mg < 0).sum() == ROWS, text  # the real arms are bent in every frame
    # and the containment check catches it: the least over all segments is negative
    assert min(x[1] for x in results) < 0.0


def frame_speeds(x):
    """Frame-to-frame speeds (rows - 1,), m/s."""
    return np.linalg.norm(np.diff(x, axis=0), axis=1) * RATE


def repeated_rows(person):
    """Rows that repeat the row before them in every bone (bool per step, rows - 1)."""
    return np.all([np.all(np.diff(x, axis=0) == 0.0, axis=1) for x in BODY[person].values()],
                  axis=0)


PEAK_SPEED = max(float(frame_speeds(BODY[p][h]).max()) for p in PERSONS
                 for h in ("LHand", "RHand"))


def test_the_real_hand_speeds_and_where_the_peaks_come_from():
    lines = ["hand speeds (m/s)"]
    for person, readme_peak in (("giver", 2.48), ("taker", 2.68)):
        repeat = repeated_rows(person)
        for hand in ("LHand", "RHand"):
            v = frame_speeds(BODY[person][hand])
            k = int(v.argmax())
            two_rows = np.linalg.norm(BODY[person][hand][k + 1] - BODY[person][hand][k - 1]) \
                * RATE / 2.0
            lines.append(f"  {person} {hand}: frame-to-frame peak {v[k]:.3f} (frames "
                         f"{k}->{k + 1}; the row before repeated: {bool(repeat[k - 1])}), "
                         f"over the two rows {two_rows:.3f}; steps above 2.0: "
                         f"{np.flatnonzero(v > ISO_HAND_SPEED).tolist()}")
            if hand == "RHand":
                assert v[k] == pytest.approx(readme_peak, abs=0.005)
                assert repeat[k - 1] and two_rows < 1.4  # the peak is a doubled step
        lines.append(f"  {person}: {int(repeat.sum())} rows repeat the row before in every "
                     "bone")
        assert repeat.sum() == 76
    np.testing.assert_array_equal(repeated_rows("giver"), repeated_rows("taker"))
    lines.append(f"  measured peak over the four hands: {PEAK_SPEED:.3f}")
    text = "\n".join(lines)
    print(text)
    assert 2.5 < PEAK_SPEED < 2.7, text


def region_excess(x, speed, rows=HIDE_ROWS):
    """(starts, rows): |x[s + k] - x[s]| - speed k / RATE, the hand's distance outside its
    hidden region k rows after it was last seen at row s, for k = 1..rows."""
    k = np.arange(1, rows + 1)
    s = np.arange(x.shape[0] - rows)
    return np.linalg.norm(x[s[:, None] + k[None, :]] - x[s][:, None, :], axis=-1) \
        - speed * k[None, :] / RATE


def test_no_hidden_hand_leaves_a_region_grown_at_the_measured_peak():
    """Every 0.25 s hiding of every hand, from every row: the region grown at 2.0 m/s
    misses the real hand for a few starts (the rows after a repeated row); grown at the
    measured frame-to-frame peak it never does."""
    lines = ["hands hidden 0.25 s from every row: distance outside the region"]
    for person in PERSONS:
        for hand in ("LHand", "RHand"):
            x = BODY[person][hand]
            iso, peak = region_excess(x, ISO_HAND_SPEED), region_excess(x, PEAK_SPEED)
            starts = np.flatnonzero(iso.max(axis=1) > 0.0)
            lines.append(f"  {person} {hand}: at 2.0 m/s {iso.max():+.4f} m "
                         f"(seen last at rows {starts.tolist()}); at {PEAK_SPEED:.3f} m/s "
                         f"{peak.max():+.4f} m")
            assert peak.max() <= 1e-12, "\n".join(lines)
    text = "\n".join(lines)
    print(text)


def hide(person, hand, start):
    """Envelopes while ``person``'s ``hand`` (model point) is hidden for HIDE_ROWS rows
    after row ``start`` (its estimate frozen there), at 2.0 m/s and at the peak: the
    containment results of the hand (the wrist with the hand's radius), its forearm and
    every real segment of the person."""
    rows = np.arange(start + 1, start + 1 + HIDE_ROWS)
    p = tracked_positions()[rows]
    slot = PERSONS.index(person) * len(TRACKED) + TRACKED.index(hand)
    p[:, slot] = BODY[person][BONE_OF[hand]][start]
    status = np.full(p.shape[:2], float(TRACK_TRACKING))
    status[:, slot] = TRACK_HIDDEN
    unseen = np.zeros(p.shape[:2])
    unseen[:, slot] = (rows - start) / RATE
    bone = BONE_OF[hand]
    segments = ((hand, bone, bone, "hand_radius"),) + REAL_SEGMENTS + LOWER_TRUNK
    out = {}
    for speed in (ISO_HAND_SPEED, PEAK_SPEED):
        ends, radius = run_envelopes(p, status, unseen, occlusion_speed=speed)
        out[speed] = containment(person, ends, radius, segments, rows=rows)
    return out


@pytest.mark.parametrize("person", PERSONS)
def test_a_hidden_hand_at_the_real_speed(person):
    """The right hand (the one that reaches) hidden for 0.25 s: (a) from the row whose
    hiding outruns 2.0 m/s the most (a repeated row, just before the peak step): at
    2.0 m/s the real hand (the wrist with the hand's radius) leaves its envelope in the
    first hidden row, the forearm stays inside (its envelope reaches the shoulder region);
    at the measured peak everything stays inside (the taker's hand with no room: the peak
    is that very step); (b) through its fastest 0.25 s (the 30 rows with the longest
    path): 2.0 m/s holds."""
    x = BODY[person]["RHand"]
    worst = int(region_excess(x, ISO_HAND_SPEED).max(axis=1).argmax())
    step = np.linalg.norm(np.diff(x, axis=0), axis=1)
    fastest = int(np.convolve(step, np.ones(HIDE_ROWS), "valid").argmax())
    lines = []
    for title, start in (("hidden after its worst row", worst),
                         ("hidden through its fastest 0.25 s", fastest)):
        mean = step[start:start + HIDE_ROWS].sum() * RATE / HIDE_ROWS
        out = hide(person, "hand_right", start)
        lines.append(f"{person} right hand {title}: last seen at frame {start}, hidden "
                     f"frames {start + 1}-{start + HIDE_ROWS} (mean speed {mean:.3f} m/s)")
        for speed, results in out.items():
            least = min(results, key=lambda r: r[1])
            by = {label.split(" ")[0]: (mg, f) for label, mg, f, _ in results}
            lines.append(f"  occlusion_speed {speed:.3f}: hand {by['hand_right'][0]:+.4f} "
                         f"m (frame {by['hand_right'][1]}), forearm "
                         f"{by['forearm_right'][0]:+.4f} m (frame {by['forearm_right'][1]}), "
                         f"least of all {least[1]:+.4f} m ({least[0]}, frame {least[2]})")
        text = "\n".join(lines)
        if start == worst:
            assert min(r[1] for r in out[ISO_HAND_SPEED]) < -0.003, text  # leaves
        else:
            assert min(r[1] for r in out[ISO_HAND_SPEED]) >= -1e-9, text
        assert min(r[1] for r in out[PEAK_SPEED]) >= -1e-9, text  # stays inside
    print("\n".join(lines))


@pytest.mark.parametrize("set_name", list(SENSOR_SETS))
def test_every_sensor_sets_envelopes_hold_both_real_bodies(set_name):
    texts = []
    for body in kth_bodies():
        text, least = sensor_set_report(set_name, body)
        texts.append(text)
        assert least >= -1e-9, text
    print("\n".join(texts))
