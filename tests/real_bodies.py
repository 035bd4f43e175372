"""Real recorded bodies as the operator model's points, for holding the envelopes
(``cell.human_body``) against real people: the KTH handover (``tests/data/kth_handover``,
two persons, OptiTrack Motive 3, 120 Hz) and CMU's subject 131 walking, starting and
stopping (``tests/data/cmu_bvh``, Vicon, 120 Hz, a BVH skeleton). Shared by
``tests/test_kth_envelope.py``, ``tests/test_cmu_envelope.py`` and
``benchmarks/bench_envelopes.py``.

Each body gives the model's ten points per frame (``human_body.POINTS``), a sensor set
feeds the envelopes only the points it tracks (the recorded positions taken as the truth:
allowance 0), and every real segment is checked against its envelope in every frame:
``containment`` (the least margin: envelope radius - segment radius - distance of a
sample of the real axis to the envelope's axis, >= 0 contained) and ``gaps`` (how far the
envelope reaches past the real segment, per frame: in the direction where it reaches
farthest, and averaged over all directions).

**Mapping** (a joint or bone origin for each point; the head's centre and the hands'
centres are not in the data):

- KTH: ``head`` <- the head bone's origin (the top of the neck, about 0.1 m below the
  head's centre), ``neck``, ``chest`` <- those bones, ``pelvis`` <- ``hip`` (the root),
  shoulders <- ``L/RUArm`` (the shoulder joints), elbows <- ``L/RFArm``, hands <-
  ``L/RHand`` (the wrists); the lower trunk is also checked through the ``ab`` bone.
- CMU (Hahne's BVH conversion; the CMU skeleton's joints): ``head`` <- ``Head`` (the top
  of the upper neck, the skull's base), ``neck`` <- ``Neck`` (the upper neck's base, at
  the shoulders' height on the spine), ``chest`` <- ``Chest2`` (the thorax), ``pelvis``
  <- the midpoint of ``LeftHip`` and ``RightHip`` (the hip joints), shoulders <-
  ``Left/RightShoulder`` (the humerus joints), elbows <- ``Left/RightElbow``, hands <-
  ``Left/RightWrist``; the lower trunk is also checked through ``Chest`` (the upper back)
  and the root ``Hips``. Lengths in the file are CMU's units: times 0.056444 is metres
  (CMU's FAQ: (1 / 0.45) x 2.54 / 100); Y up, turned to Z up (x, -z, y).

A head point below the head's centre and a wrist short of the hand's centre lie on the
segments' own lines, nearer the trunk: every length the model derives from them is the
shorter, which the table's lengths hold with room (``test_*_postures_are_ones_the_model
_allows``). The head ball is not checked (no head centre or surface in the data); a hand
ball is checked at the wrist.
"""

import dataclasses
import math
from pathlib import Path

import numpy as np

from safety_systems.cell import human_body as hb
from safety_systems.cell.sensor_sets import SENSOR_SETS
from safety_systems.sensing.bvh_file import read_bvh
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_TRACKING

DATA = Path(__file__).parent / "data"
KTH = DATA / "kth_handover"
CMU = DATA / "cmu_bvh" / "cmu_131_01_start_walk_stop.bvh"
CMU_METRES = 2.54 / 100.0 / 0.45  # m per CMU length unit (CMU's FAQ)
SAMPLES = 21  # axis samples per real segment
# The segments checked and measured: every segment but the head ball.
MEASURED = tuple(name for name in hb.SEGMENT_NAMES if name != "head")


@dataclasses.dataclass(frozen=True)
class RealBody:
    """One recorded person: ``points`` (frames, 10, 3) the model's points, ``extra``
    other real points (name -> (frames, 3)), ``checks`` the real axes held against an
    envelope beyond the model's own segments ((segment, point, point), points by model
    or extra name; the spine's joints, checked with no radius: they lie inside the trunk,
    not on its axis), ``rate`` Hz."""

    name: str
    rate: float
    points: np.ndarray
    extra: dict
    checks: tuple

    def at(self, name: str) -> np.ndarray:
        return self.points[:, hb.point_index(name)] if name in hb.POINTS else self.extra[name]


def kth_bodies() -> list[RealBody]:
    """The KTH handover's giver and taker (801 frames)."""
    bones = {"head": "head", "neck": "neck", "chest": "chest", "pelvis": "hip",
             "shoulder_left": "LUArm", "shoulder_right": "RUArm", "elbow_left": "LFArm",
             "elbow_right": "RFArm", "hand_left": "LHand", "hand_right": "RHand"}
    out = []
    for person in ("giver", "taker"):
        def bone(name, person=person):
            return np.loadtxt(KTH / f"{person}_{name}_pose_saved.csv", delimiter=",",
                              skiprows=1)[:, :3]
        points = np.stack([bone(bones[p]) for p in hb.POINTS], axis=1)
        out.append(RealBody(f"KTH {person}", 120.0, points, {"ab": bone("ab")},
                            (("lower_trunk", "chest", "ab"), ("lower_trunk", "ab", "pelvis"))))
    return out


def cmu_body() -> RealBody:
    """CMU subject 131, trial 01 (994 frames, the converter's first frame included)."""
    joints = {"head": "Head", "neck": "Neck", "chest": "Chest2",
              "shoulder_left": "LeftShoulder", "shoulder_right": "RightShoulder",
              "elbow_left": "LeftElbow", "elbow_right": "RightElbow",
              "hand_left": "LeftWrist", "hand_right": "RightWrist"}
    rec = read_bvh(CMU, units="m")
    index = {n: i for i, n in enumerate(rec.names)}

    def joint(name):
        x = rec.positions[:, index[name]] * CMU_METRES
        return np.stack([x[:, 0], -x[:, 2], x[:, 1]], axis=1)  # Y up -> Z up

    given = {p: joint(j) for p, j in joints.items()}
    given["pelvis"] = 0.5 * (joint("LeftHip") + joint("RightHip"))
    points = np.stack([given[p] for p in hb.POINTS], axis=1)
    return RealBody("CMU 131_01", 1.0 / float(np.diff(rec.times).mean()), points,
                    {"upper_back": joint("Chest"), "root": joint("Hips")},
                    (("lower_trunk", "chest", "upper_back"),
                     ("lower_trunk", "upper_back", "root"), ("lower_trunk", "root", "pelvis")))


def envelopes(module, body: RealBody, tracked, dims=None, allowance: float = 0.0,
              hidden: dict | None = None, occlusion_speed: float = 2.0):
    """Every segment's envelope in every frame, by ``module.envelope_batch`` (the rule of
    ``module``, a ``human_body`` of this code or of another commit) from the points
    ``tracked`` alone: ends (frames, 12, 2, 3) and radius (frames, 12). ``hidden``:
    point -> (frames,) time unseen (its estimate then the frame where it was last
    seen)."""
    recipe = module.envelope_recipe([list(tracked)], dims)
    idx = [hb.point_index(t) for t in tracked]
    p = np.ascontiguousarray(body.points[:, idx])
    F, N, M = p.shape[0], len(idx), recipe.radius.size
    status, unseen = np.full((F, N), float(TRACK_TRACKING)), np.zeros((F, N))
    for name, t in (hidden or {}).items():
        j = list(tracked).index(name)
        unseen[:, j] = t
        status[t > 0.0, j] = TRACK_HIDDEN
        seen = np.arange(F) - np.rint(t * body.rate).astype(int)
        p[:, j] = body.points[seen, hb.point_index(name)]
    out = (np.empty((F, M, 2, 3)), np.empty((F, M, 2, 3)), np.empty((F, M)), np.empty((F, M)),
           np.empty((F, M)))
    module.envelope_batch(recipe.regions, recipe.candidates, recipe.radius, recipe.operator,
                          recipe.slots, p, np.zeros((F, N, 3)), status, np.zeros((F, N)),
                          unseen, allowance, occlusion_speed, *out)
    assert np.all((out[3] == TRACK_TRACKING) | (out[3] == TRACK_HIDDEN))
    return out[0], out[2]


def _axis_distance(x, a, b):
    """Distance of points x (..., 3) to the segments a-b (..., 3)."""
    d = b - a
    dd = (d * d).sum(-1)
    s = np.clip(((x - a) * d).sum(-1) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
    return np.linalg.norm(x - (a + s[..., None] * d), axis=-1)


def real_axes(body: RealBody, dims=hb.DEFAULT_DIMENSIONS) -> list[tuple[str, str, str, float]]:
    """(segment, point, point, radius) of every real axis held against an envelope: the
    model's segments but the head ball, with their radii, and the body's extra checks,
    with none."""
    return [(name, a, b, dims[r]) for name, a, b, r in hb.SEGMENTS if name != "head"] + \
        [(segment, a, b, 0.0) for segment, a, b in body.checks]


def containment(body: RealBody, ends, radius, dims=hb.DEFAULT_DIMENSIONS) -> list[tuple]:
    """[(segment, point, point, least margin, its frame)] for every real axis
    (:func:`real_axes`): the least over the frames and SAMPLES axis samples of the
    envelope radius less the axis' radius less the sample's distance to the envelope's
    axis (>= 0: contained)."""
    out = []
    w = np.linspace(0.0, 1.0, SAMPLES)[None, :, None]
    for segment, a, b, own in real_axes(body, dims):
        m = hb.SEGMENT_NAMES.index(segment)
        x = (1.0 - w) * body.at(a)[:, None] + w * body.at(b)[:, None]
        gap = _axis_distance(x, ends[:, m, 0][:, None], ends[:, m, 1][:, None])
        margin = (radius[:, m][:, None] - own - gap).min(axis=1)
        f = int(np.argmin(margin))
        out.append((segment, a, b, float(margin[f]), f))
    return out


def _directions(n: int = 256) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over the sphere (a Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    rho = np.sqrt(1.0 - z * z)
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1)


DIRECTIONS = _directions()


def gaps(body: RealBody, ends, radius, dims=hb.DEFAULT_DIMENSIONS) -> dict:
    """Per measured segment (:data:`MEASURED`), how far its envelope reaches past the real
    segment, m, each as (mean, 95th percentile) over the frames: ``"worst"``, in the
    direction where it reaches farthest (the farther envelope end's distance from the
    real axis plus the envelope's radius less the segment's: the one-sided Hausdorff
    distance of the two capsules), and ``"average"``, averaged over the directions
    (:data:`DIRECTIONS`) of how much farther out the envelope's surface lies than the
    segment's (their support functions' difference: how much nearer a robot far off in
    that direction finds the envelope than the real segment)."""
    out = {}
    for name, a, b, r in hb.SEGMENTS:
        if name not in MEASURED:
            continue
        m = hb.SEGMENT_NAMES.index(name)
        A, B = body.at(a), body.at(b)
        worst = np.maximum(_axis_distance(ends[:, m, 0], A, B),
                           _axis_distance(ends[:, m, 1], A, B)) + radius[:, m] - dims[r]
        envelope = np.maximum(ends[:, m, 0] @ DIRECTIONS.T, ends[:, m, 1] @ DIRECTIONS.T) \
            + radius[:, m][:, None]
        real = np.maximum(A @ DIRECTIONS.T, B @ DIRECTIONS.T) + dims[r]
        average = (envelope - real).mean(axis=1)
        out[name] = {k: (float(x.mean()), float(np.percentile(x, 95)))
                     for k, x in (("worst", worst), ("average", average))}
    return out


def derived_least(tracked, results) -> tuple:
    """The least margin of :func:`containment`'s results over the axes not between two
    tracked points (those are the estimates' own capsules: margin 0 with no allowance),
    or None when every axis is."""
    derived = [r for r in results if not (r[1] in tracked and r[2] in tracked)]
    return min(derived, key=lambda r: r[3]) if derived else None


def sensor_set_report(set_name: str, body: RealBody) -> tuple[str, float]:
    """Text of the containment and gaps of ``body``'s envelopes under a sensor set, and the
    least margin over every axis (the assertion's figure)."""
    tracked = SENSOR_SETS[set_name]
    ends, radius = envelopes(hb, body, tracked)
    results = containment(body, ends, radius)
    least = min(r[3] for r in results)
    worst = derived_least(tracked, results)
    lines = [f"{body.name}, {set_name}: {body.points.shape[0]} frames, least margin "
             f"{least:+.4f} m" + ("" if worst is None else
                                  f"; of the segments not between two tracked points "
                                  f"{worst[3]:+.4f} m ({worst[0]} {worst[1]}-{worst[2]}, "
                                  f"frame {worst[4]})"),
             ("  how far each envelope reaches past the real segment (m, mean / 95th "
              "percentile over the frames):"),
             f"    {'segment':16s} {'worst direction':>17s} {'average direction':>19s}"]
    for segment, g in gaps(body, ends, radius).items():
        lines.append(f"    {segment:16s} {g['worst'][0]:7.3f} / {g['worst'][1]:5.3f}"
                     f"   {g['average'][0]:7.3f} / {g['average'][1]:5.3f}")
    return "\n".join(lines), least
