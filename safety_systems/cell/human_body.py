"""The operator as capsules: body points, the segments between them, their dimensions, and
the envelopes the monitor puts around the segments it does not see.

**Body points** (:data:`POINTS`, joint centres unless said): the head's centre, the neck's
base (between the shoulders, at the top of the sternum), the chest (mid-sternum, on the
trunk's axis), the pelvis (midway between the hip joints), each shoulder joint, each
elbow joint and the centre of each hand (where a glove's rigid body sits). They form a
tree (:data:`EDGES`): head - neck - chest - pelvis, and neck - shoulder - elbow - hand on
each side.

**Segments** (:data:`SEGMENTS`): every edge is a capsule (its axis the edge, grown by the
segment's radius): the neck, the upper and lower trunk, each shoulder girdle, upper arm
and forearm; the head and each hand are balls about their points. Twelve per operator.

**Dimensions** (:data:`DEFAULT_DIMENSIONS`, metres): each length is the largest distance
between its two points an adult takes, each radius the largest distance of the segment's
surface from its axis, from the 95th percentiles of British adult men aged 19-65
(Pheasant and Haslegrave, *Bodyspace*, 3rd ed., 2006; as reproduced by A. Chan's online
anthropometry pages, City University of Hong Kong, Ch. 2), rounded up:

- ``upper_arm`` 0.40: shoulder-elbow length 395 mm (acromion to the underside of the
  elbow; both joint centres lie inside those landmarks);
- ``forearm`` 0.41, elbow to hand centre: elbow-fingertip length 510 mm less the hand
  centre's distance from the fingertip (at least 0.10 m);
- ``hand_radius`` 0.12: the hand centre to the fingertip and the hand's half breadth
  (hand breadth 95 mm) in any direction;
- ``shoulder`` 0.22, neck base to shoulder joint: half the biacromial breadth, 430 mm;
  ``shoulder_radius`` 0.07: the deltoid, bideltoid breadth 510 mm;
- ``neck`` 0.20, head centre to neck base: sitting height 965 mm less sitting shoulder
  height 645 mm (vertex to acromion) less the head's half length (head length 205 mm);
  ``head_radius`` 0.12: half the head length with the nose;
- ``upper_trunk`` 0.22 and ``lower_trunk`` 0.38, neck base to chest to hip centre:
  sitting shoulder height 645 mm less the hip joints' height above the seat;
  ``trunk_radius`` 0.20: half the hip breadth (405 mm), more than half the chest depth
  (285 mm);
- ``head_shoulder`` 0.32: the head centre's largest distance from a shoulder joint
  (0.20 m below and 0.22 m beside it, the head tilted), a bound tighter than the path
  through the neck (0.42 m);
- ``upper_arm_radius`` 0.06, ``forearm_radius`` 0.05, ``neck_radius`` 0.07 (the limbs'
  half depths, our estimates).

Interpretation: the table's landmarks are surface points (acromion, the back of the
elbow, the vertex); the distances between joint centres are shorter, so the table's
figures bound them. Summing segment lengths gives a longer arm than a real one reaches:
the envelope is larger than the body, never smaller. A person larger than the table
(the 5% of men beyond the 95th percentile) breaks the premise; a configuration can give
its own figures (``SafetyConfig.body``).

**Posture limits** (our assumptions, premises a proof lists as trusted): the trunk
(neck base to chest to pelvis) leans at most ``trunk_lean_deg`` (45) from the vertical,
the neck base lies at most ``neck_lean_deg`` (60) from straight below the head centre
(head tilt and trunk lean together), and the cell's z axis points up.

**Envelopes.** The monitor sees some points (those tracked: a glove, a head, an elbow
marker, a suit's bones) and must bound every segment from all of them together. Each
point gets a *region*, a ball certain to hold it, computed afresh at every evaluation:

1. *First ball.* A tracked point's is its estimate grown by the tracking allowance
   (``tracking_allowance``, which the proof checks covers the tracker's error) and, while
   hidden, by ``occlusion_speed`` times the time unseen. An untracked point's is derived
   from one tracked point along the tree, the tightest such derivation
   (:func:`envelope_recipe`, Dijkstra on the radius): one edge of length l moves a
   region's centre by nothing and grows its radius by l, or, under a lean limit of angle
   a about the vertical, moves the centre l cos(a) along it and grows the radius by
   l sin(a) (the smallest ball about the axis holding every point within l of the edge's
   start and a of the vertical, for a >= 45 deg; below 45 deg the centre moves
   l / (2 cos(a)) and the radius grows as much: :func:`lean_ball`); the shoulders can
   also be derived from the head through ``head_shoulder``. Sound: each step's ball holds
   every point the step's length (and lean limit) allows from any point of the ball
   before it (the triangle inequality; for the lean, :func:`lean_ball`).
2. *Refinement.* Then each region is cut, one tracked point at a time, by the ball
   derived from that point alone (its tightest derivation from it, as above): each time
   it becomes the smaller of the balls holding the intersection of the derived ball with
   its ball and with its first ball, in closed form (``ball_bounds.lens_ball``: the
   smaller ball, or the ball on their circle of intersection, by the cap lemma there;
   the lens ball of a lens ball may stick out of the balls before it, so the first ball
   is tried again). Sound: the true point lies in every derived ball (each holds it, by
   step 1), so in each intersection, which the lens ball holds, and by induction over
   the rows in the region. So a shoulder is bounded by the head, its own hand and the
   other hand at once, an elbow by its hand and the head, a hidden glove's growing ball
   by the helmet and the other glove. A tracked point's ball is kept while its body is
   tracked (the allowance is the smallest of its balls; the truth's known points stay
   exact); a hidden body's is refined. Balls that do not meet (the facts contradict each
   other: a larger person, an estimate off by more than its allowance) give the ball
   holding both: a broken premise never shrinks a region. (Cutting the regions by their
   neighbours' too, one step of the tree at a time, as commit 5460aa3 did, moved the
   real recordings' mean gaps by 0.3% at most, gloves alone, where leaving it out cuts
   the cost per row to 0.70-0.76 of it (``benchmarks/bench_envelopes.py --reference
   5460aa3``, sets short of a full suit). Not done.)

A segment's envelope is its smallest candidate capsule at each frame (every candidate
holds it; "smallest": least r^2 (2 L + 4 r / 3), the capsule's volume with its cylinder
weighed twice), grown by the segment's radius. The candidates, each sound:

- *the hull* of its two points' regions: the segment between the true points lies in the
  convex hull of the two balls (each end in its ball), which lies in the capsule of the
  larger radius U between the centres, the smaller ball's end (radius u) moved up to
  U - u towards the other centre (a ball of radius u lies in one of radius U about any
  centre within U - u of its own: :func:`hull_capsule`); with both points tracked, the
  capsule between their estimates, the only candidate;
- *the ellipsoid* of two points A and B whose tree path holds the segment, each the
  segment's own point or a tracked point with no tracked point inside the path (regions
  of centre c and radius u, path length L): {x : |x - c_A| + |x - c_B| <= L + u_A + u_B}:
  every point x of the path is reached from the true A and the true B along the path, so
  |x - A| + |x - B| <= L, and the true points are within u of the centres. That is why an
  elbow away from the line between hand and shoulder is covered: the ellipsoid's width is
  what the segment lengths allow, not the line. Its semi-axes are a = (L + u_A + u_B) / 2
  along the foci and b = sqrt(a^2 - c^2) across (c half the foci's distance); it lies in
  the capsule of radius b about the foci's axis, of half length a - b about their
  midpoint (a point at t along the axis and rho from it with t^2 / a^2 + rho^2 / b^2 <= 1
  has (|t| - a + b)^2 + rho^2 <= b^2 when |t| > a - b, as |t| <= a). Foci farther apart
  than L + u_A + u_B (a posture the dimensions do not allow) give the capsule between
  the foci. (Pairs with an untracked far focus changed no figure of the real recordings
  and are not tried.)
- *the cone* of a lean-limited edge from one end's region: the capsule from its centre
  l cos(a) along the vertical, of radius u + l sin(a) (every point within l of the apex
  and a of the vertical, for any a < 90 deg).

A floor was weighed and left out: a standing operator's feet on a floor the cell states
would bound the pelvis from above (no higher than the legs' length above the floor,
soundly only while both feet are on that floor: not on a step or a ladder) and every
point from below (nothing under the floor). A half-space cuts a ball's bounding radius
only where it passes beyond the ball's centre (the cap lemma of ``ball_bounds``). On
CMU's subject 131 (``tests/test_cmu_envelope.py``: the floor the lowest toe joint, the
legs' premise as tight as that person allows, the highest their hips rose above it) the
floor and the legs would have shrunk the pelvis's first ball (1.475 m from a glove,
0.619 m from the helmet) by 4.1 mm at most, so the cell is asked for no such premise.

Every envelope carries its regions' bodies' velocities at its ends (each region's first
ball's body), so that the monitor's speeds of a segment are those of its tracked points
(``robot_geometry.segments_pair``), and the largest std of the bodies that shaped its
regions.
"""

import dataclasses
import math

import numba
import numpy as np

from safety_systems.cell.ball_bounds import lens_ball
from safety_systems.sensing.tracks import TRACK_HIDDEN, TRACK_LOST, TRACK_NONE, TRACK_TRACKING
from safety_systems.ssm.formulas import hidden_ball_radius

POINTS = ("head", "neck", "chest", "pelvis", "shoulder_left", "shoulder_right",
          "elbow_left", "elbow_right", "hand_left", "hand_right")
NUM_POINTS = len(POINTS)
_P = {name: i for i, name in enumerate(POINTS)}
# The tree: (point, point, its length's name, lean limit's name or "" (none)); the lean
# limit bounds the direction from the first point to the second about straight down.
EDGES = (("head", "neck", "neck", "neck_lean_deg"),
         ("neck", "chest", "upper_trunk", "trunk_lean_deg"),
         ("chest", "pelvis", "lower_trunk", "trunk_lean_deg"),
         ("neck", "shoulder_left", "shoulder", ""),
         ("neck", "shoulder_right", "shoulder", ""),
         ("shoulder_left", "elbow_left", "upper_arm", ""),
         ("shoulder_right", "elbow_right", "upper_arm", ""),
         ("elbow_left", "hand_left", "forearm", ""),
         ("elbow_right", "hand_right", "forearm", ""))
# Shortcuts that bound a distance better than the tree path: (point, point, length name).
SHORTCUTS = (("head", "shoulder_left", "head_shoulder"),
             ("head", "shoulder_right", "head_shoulder"))
# Segments: (name, point, point, radius name); a ball where the two points are one.
SEGMENTS = (("head", "head", "head", "head_radius"),
            ("neck", "head", "neck", "neck_radius"),
            ("upper_trunk", "neck", "chest", "trunk_radius"),
            ("lower_trunk", "chest", "pelvis", "trunk_radius"),
            ("shoulder_left", "neck", "shoulder_left", "shoulder_radius"),
            ("shoulder_right", "neck", "shoulder_right", "shoulder_radius"),
            ("upper_arm_left", "shoulder_left", "elbow_left", "upper_arm_radius"),
            ("upper_arm_right", "shoulder_right", "elbow_right", "upper_arm_radius"),
            ("forearm_left", "elbow_left", "hand_left", "forearm_radius"),
            ("forearm_right", "elbow_right", "hand_right", "forearm_radius"),
            ("hand_left", "hand_left", "hand_left", "hand_radius"),
            ("hand_right", "hand_right", "hand_right", "hand_radius"))
SEGMENT_NAMES = tuple(s[0] for s in SEGMENTS)
NUM_SEGMENTS = len(SEGMENTS)
# The body's default dimensions, metres and degrees (the module docstring says where each
# comes from; the Annex A regions each segment may touch: pfl/segment_regions.py).
DEFAULT_DIMENSIONS = {
    "neck": 0.20, "upper_trunk": 0.25, "lower_trunk": 0.38, "shoulder": 0.22,
    "upper_arm": 0.40, "forearm": 0.41, "head_shoulder": 0.32,
    "head_radius": 0.12, "neck_radius": 0.07, "trunk_radius": 0.20, "shoulder_radius": 0.07,
    "upper_arm_radius": 0.06, "forearm_radius": 0.05, "hand_radius": 0.12,
    "trunk_lean_deg": 45.0, "neck_lean_deg": 60.0,
}
DIMENSION_NAMES = tuple(DEFAULT_DIMENSIONS)
LENGTHS = ("neck", "upper_trunk", "lower_trunk", "shoulder", "upper_arm", "forearm",
           "head_shoulder")
# Legacy body names (the three-ball operator: two gloves and a head) and the points they
# mark, for files that name no point.
LEGACY_POINTS = {"head": "head", "hand": "hand_right", "other_hand": "hand_left",
                 "right_glove": "hand_right", "left_glove": "hand_left"}

# Region rows, one per body point and operator, in point order: (tracked body slot, centre
# offset x, y, z from its estimate, extra radius): the tightest single derivation, each
# region's first ball (a tracked point: its own slot, no offset, no extra).
REGION_COLUMNS = 5
# The recipe's program rows: (segment or -1, region A, region B, static term, kind, dz),
# run in order. Kind 3 (first, before any segment's): refine region A by the ball derived
# from region B, a tracked point's: B's ball moved dz along z and grown by the term
# (``ball_bounds.lens_ball``). Then each segment's candidates: kind 0, the ellipsoid
# |x - c_A| + |x - c_B| <= term + u_A + u_B (term: the tree path's length); kind 1, the
# capsule holding the two regions (their convex hull); kind 2, the cone of a lean-limited
# edge from A's region, the capsule from c_A to c_A + dz z of radius term + u_A.
CANDIDATE_COLUMNS = 6
KIND_ELLIPSOID, KIND_DIRECT, KIND_CONE, KIND_REFINE = 0, 1, 2, 3


def point_index(name: str) -> int:
    """The index of a body point by name; raises ValueError naming the allowed ones."""
    if name not in _P:
        raise ValueError(f"point: got {name!r}; allowed: {' | '.join(POINTS)}")
    return _P[name]


def dimensions(overrides: dict | None = None) -> dict:
    """The table with ``overrides`` (name -> value) replacing its figures; raises
    ValueError on an unknown name or a value outside its range (lengths and radii
    0 < x <= 2 m, angles 0 <= x <= 90 deg)."""
    out = dict(DEFAULT_DIMENSIONS)
    for name, value in (overrides or {}).items():
        if name not in out:
            raise ValueError(f"{name}: not a body dimension; allowed: "
                             f"{' | '.join(DIMENSION_NAMES)}")
        value = float(value)
        ok = (0.0 <= value <= 90.0) if name.endswith("_deg") else (0.0 < value <= 2.0)
        if not (math.isfinite(value) and ok):
            raise ValueError(f"{name}: got {value!r}; allowed: "
                             + ("0 <= x <= 90 deg" if name.endswith("_deg")
                                else "0 < x <= 2 m"))
        out[name] = value
    return out


@dataclasses.dataclass(frozen=True, eq=False)
class Recipe:
    """How to bound every segment of a cell's operators from their tracked bodies (see the
    module docstring): R = 10 x operators regions, C program rows and M = 12 x operators
    segments, all static for a run. ``regions`` (R, 5) and ``candidates`` (C, 6, the
    regions' refinements first, then the segments' candidates) as the module's column
    constants say; ``radius`` (M,) each segment's radius, ``operator`` (M,) its operator,
    ``slots`` (operators, most bodies) each operator's body slots (-1 pads)."""

    regions: np.ndarray
    candidates: np.ndarray
    radius: np.ndarray
    operator: np.ndarray
    slots: np.ndarray
    names: tuple[str, ...]  # "operator/segment"


def _tree():
    """(adjacency: point -> [(point, length name, lean name, sign)], shortcuts)."""
    adj = {i: [] for i in range(NUM_POINTS)}
    for a, b, length, lean in EDGES:
        adj[_P[a]].append((_P[b], length, lean, -1.0))  # b lies below a
        adj[_P[b]].append((_P[a], length, lean, 1.0))  # a lies above b
    return adj


def _path(a: int, b: int, adj) -> list[int]:
    """The tree path from point a to point b (both included)."""
    prev, todo = {a: None}, [a]
    while todo:
        x = todo.pop()
        for y, *_ in adj[x]:
            if y not in prev:
                prev[y] = x
                todo.append(y)
    out = [b]
    while out[-1] != a:
        out.append(prev[out[-1]])
    return out[::-1]


def lean_ball(length: float, lean_deg: float) -> tuple[float, float]:
    """(centre's distance along the vertical, radius) of the smallest ball about the
    vertical through a point A that holds every point B with |B - A| <= ``length`` and
    B - A within ``lean_deg`` (< 90) of the vertical: the solid cone sector, not only its
    cap on the sphere of radius ``length``, since an edge may be shorter than its length
    (a bent, foreshortened or smaller body).

    The sector is convex (a cone of half-angle below 90 degrees cut by a ball), so a
    ball holds it when it holds its extreme points: the apex A and the cap. For a lean
    of 45 degrees or more the ball about l cos(a) of radius l sin(a) holds the cap
    (every cap point is at most l sin(a) from it) and the apex (l cos(a) <= l sin(a)).
    Below 45 degrees the apex lies outside that ball (a lean limit of 10 degrees left the
    lower trunk 0.30 m outside its envelope); the ball about c = l / (2 cos(a)) of radius
    c holds both: the apex at c, a cap point at angle theta <= a at
    sqrt(l^2 - 2 c l cos(theta) + c^2) <= sqrt(l^2 - 2 c l cos(a) + c^2) = c. Both are
    the smallest such balls about the vertical (the first is fixed by the cap's rim, the
    second by the rim and the apex together)."""
    angle = math.radians(lean_deg)
    if lean_deg >= 45.0:
        return length * math.cos(angle), length * math.sin(angle)
    c = length / (2.0 * math.cos(angle))
    return c, c


def _regions(tracked: dict[int, int], dims: dict, adj) -> dict[int, tuple]:
    """Each point's best region (slot, offset (3,), extra radius) from the tracked points
    (point -> body slot), by Dijkstra on the extra radius (every step adds to it)."""
    best = {p: (slot, np.zeros(3), 0.0) for p, slot in tracked.items()}
    todo = sorted(best, key=lambda p: best[p][2])
    done = set()
    while todo:
        todo.sort(key=lambda p: best[p][2])
        x = todo.pop(0)
        if x in done:
            continue
        done.add(x)
        slot, offset, extra = best[x]
        steps = [(y, dims[length], dims[lean] if lean else 90.0, sign)
                 for y, length, lean, sign in adj[x]]
        steps += [(_P[b] if _P[a] == x else _P[a], dims[length], 90.0, 0.0)
                  for a, b, length in SHORTCUTS if x in (_P[a], _P[b])]
        for y, length, lean, sign in steps:
            if lean < 90.0:
                along, grow = lean_ball(length, lean)
                cand = (slot, offset + np.array([0.0, 0.0, sign * along]), extra + grow)
            else:
                cand = (slot, offset.copy(), extra + length)
            if y not in best or cand[2] < best[y][2] - 1e-12:
                best[y] = cand
                todo.append(y)
    return best


def _path_length(path: list[int], dims: dict, adj) -> float:
    total = 0.0
    for x, y in zip(path, path[1:]):
        total += next(dims[length] for z, length, _, _ in adj[x] if z == y)
    return total


def _refinement_rows(tracked: dict[int, int], dims: dict, adj, base: int) -> list[tuple]:
    """The program rows (kind 3) that refine an operator's regions by every tracked point
    (see the module docstring): each point's region (a tracked one's too, for while it is
    hidden) by the ball derived from each other tracked point alone, its tightest
    derivation from that point; none when every point is tracked."""
    if len(tracked) == NUM_POINTS:
        return []
    out = []
    for t, slot in tracked.items():
        for y, (_, offset, extra) in _regions({t: slot}, dims, adj).items():
            if y != t:
                out.append((-1, base + y, base + t, extra, KIND_REFINE, offset[2]))
    return out


def envelope_recipe(operators: list[list[str]], dims: dict | None = None,
                    names: list[str] | None = None,
                    slots: list[list[int]] | None = None) -> Recipe:
    """The :class:`Recipe` of operators whose tracked bodies mark the points ``operators``
    (per operator, the point of each body slot in slot order), under the dimensions
    ``dims`` (:func:`dimensions`; None: the table). ``slots``: each body's slot in the
    arrays ``envelope_rows`` reads (None: numbered across the operators in order).
    ``names``: the operators' names (for the segments' names). Raises ValueError when an
    operator has no body or two bodies mark one point."""
    dims = dimensions() if dims is None else dims
    adj = _tree()
    regions, refine, candidates, radius, operator, segment_names = [], [], [], [], [], []
    slot_table = np.full((len(operators), max((len(o) for o in operators), default=0)), -1)
    first_slot = 0
    for k, points in enumerate(operators):
        if not points:
            raise ValueError(f"operators[{k}]: no body; allowed: one or more tracked bodies")
        tracked = {}
        for j, name in enumerate(points):
            p = point_index(name)
            if p in tracked:
                raise ValueError(f"operators[{k}]: two bodies mark the point {name!r}")
            tracked[p] = first_slot + j if slots is None else int(slots[k][j])
            slot_table[k, j] = tracked[p]
        best = _regions(tracked, dims, adj)
        base = len(regions)
        for p in range(NUM_POINTS):
            slot, offset, extra = best[p]
            regions.append((slot, *offset, extra))
        refine += _refinement_rows(tracked, dims, adj, base)
        for name, a, b, r in SEGMENTS:
            m = len(radius)
            radius.append(dims[r])
            operator.append(k)
            segment_names.append(f"{names[k] if names else k}/{name}")
            pa, pb = _P[a], _P[b]
            # The capsule holding both regions (a ball about a point too): with both points
            # tracked, the capsule between their estimates, the only candidate.
            candidates.append((m, base + pa, base + pb, 0.0, KIND_DIRECT, 0.0))
            if (pa in tracked and pb in tracked) or pa == pb:
                continue
            for x, y, length, lean, sign in _cones(pa, pb, dims, adj):
                # the edge from x's region within the lean limit: a cone, in a capsule
                angle = math.radians(lean)
                candidates.append((m, base + x, base + x, length * math.sin(angle),
                                   KIND_CONE, sign * length * math.cos(angle)))
            # Every pair of points whose tree path holds the segment's axis; skipped where
            # a tracked point lies strictly inside the path (the shorter chain is inside).
            cut = {x: [e for e in adj[x] if {x, e[0]} != {pa, pb}] for x in adj}
            for A in _component(pa, cut):
                for B in _component(pb, cut):
                    if not ((A == pa or A in tracked) and (B == pb or B in tracked)):
                        continue
                    path = _path(A, B, adj)
                    if any(x in tracked for x in path[1:-1]):
                        continue
                    candidates.append((m, base + A, base + B, _path_length(path, dims, adj),
                                       KIND_ELLIPSOID, 0.0))
        first_slot += len(points)
    return Recipe(np.array(regions, dtype=float).reshape(-1, REGION_COLUMNS),
                  np.array(refine + candidates, dtype=float).reshape(-1, CANDIDATE_COLUMNS),
                  np.array(radius, dtype=float), np.array(operator, dtype=np.int64),
                  slot_table, tuple(segment_names))


def _cones(pa: int, pb: int, dims: dict, adj) -> list[tuple]:
    """The edge pa-pb seen from either end if it has a lean limit below 90 degrees:
    (from, to, length, lean, sign of the direction's z)."""
    out = []
    for x, y in ((pa, pb), (pb, pa)):
        for z, length, lean, sign in adj[x]:
            if z == y and lean and dims[lean] < 90.0:
                out.append((x, y, dims[length], dims[lean], sign))
    return out


def _component(start: int, adj) -> list[int]:
    out, todo = [start], [start]
    while todo:
        x = todo.pop()
        for y, *_ in adj[x]:
            if y not in out:
                out.append(y)
                todo.append(y)
    return out


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def ellipsoid_capsule(c_A, c_B, total):
    """(end A, end B, radius) of the capsule holding the ellipsoid {x : |x - c_A| +
    |x - c_B| <= total} (see the module docstring): its axis on the foci's line about
    their midpoint, half length a - b, radius b; the end nearer c_A first. Foci farther
    apart than ``total``: the segment between them, radius 0."""
    d0, d1, d2 = c_B[0] - c_A[0], c_B[1] - c_A[1], c_B[2] - c_A[2]
    dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    a = 0.5 * total
    c = 0.5 * dist
    if c >= a:
        return (c_A[0], c_A[1], c_A[2]), (c_B[0], c_B[1], c_B[2]), 0.0
    b = math.sqrt((a - c) * (a + c))
    m0, m1, m2 = 0.5 * (c_A[0] + c_B[0]), 0.5 * (c_A[1] + c_B[1]), 0.5 * (c_A[2] + c_B[2])
    if dist == 0.0:
        return (m0, m1, m2), (m0, m1, m2), b
    h = (a - b) / dist  # the half length a - b along the unit axis d / dist
    return ((m0 - h * d0, m1 - h * d1, m2 - h * d2), (m0 + h * d0, m1 + h * d1, m2 + h * d2),
            b)


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per element
def hull_capsule(c_A, u_A, c_B, u_B):
    """(end A, end B, radius) of a capsule holding the balls B(c_A, u_A) and B(c_B, u_B),
    so their convex hull and every segment from a point of one to a point of the other
    (see the module docstring): radius the larger u, the smaller ball's end moved towards
    the other centre by the difference of the radii (a ball of radius u inside one of
    radius U about a centre at most U - u away), at most onto it."""
    d0, d1, d2 = c_B[0] - c_A[0], c_B[1] - c_A[1], c_B[2] - c_A[2]
    dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    end_a, end_b, r = c_A, c_B, u_B
    if u_A <= u_B:
        w = min(u_B - u_A, dist) / dist if dist > 0.0 else 0.0
        end_a = (c_A[0] + w * d0, c_A[1] + w * d1, c_A[2] + w * d2)
    else:  # (also a NaN radius: then r is NaN)
        w = min(u_A - u_B, dist) / dist if dist > 0.0 else 0.0
        end_b, r = (c_B[0] - w * d0, c_B[1] - w * d1, c_B[2] - w * d2), u_A
    return end_a, end_b, r


@numba.njit(cache=True, inline="always")  # no call (and array refcounts) per row
def _envelope_row(b, regions, candidates, radius, operator, slots, p, v, status, std, unseen,
                  allowance, occlusion_speed, ends, end_velocities, out_radius, out_status,
                  out_std, op_status, centre, grow, region_std, best, chosen):
    """:func:`envelope_rows` of row b of every tracker output and envelope array (one
    more leading axis each), with its working arrays given (``op_status`` (K,),
    ``centre`` (regions, 3), ``grow`` (regions,), ``region_std`` (regions,), ``best``
    (M,), ``chosen`` (M,) int): a batch allocates them once, not per row."""
    none, tracking, hidden, lost = TRACK_NONE, TRACK_TRACKING, TRACK_HIDDEN, TRACK_LOST
    K = slots.shape[0]
    for k in range(K):
        n_none, n_lost, n_hidden, n = 0, 0, 0, 0
        for j in range(slots.shape[1]):
            i = slots[k, j]
            if i < 0:
                continue
            n += 1
            if status[b, i] == none:
                n_none += 1
            elif status[b, i] == hidden:
                n_hidden += 1
            elif status[b, i] != tracking:
                n_lost += 1
        if n_none == n:
            op_status[k] = none
        elif n_lost > 0 or n_none > 0:
            op_status[k] = lost
        elif n_hidden > 0:
            op_status[k] = hidden
        else:
            op_status[k] = tracking
    for m in range(radius.size):
        out_status[b, m] = op_status[operator[m]]
        out_std[b, m] = np.nan
        out_radius[b, m] = np.nan
        for e in range(2):
            for x in range(3):
                ends[b, m, e, x] = np.nan
                end_velocities[b, m, e, x] = np.nan
    # Each region's first ball: its tracked body's estimate moved by the offset, its radius
    # the extra plus the body's own (the allowance, and while hidden its ball's radius).
    for ra in range(regions.shape[0]):
        i = int(regions[ra, 0])
        grow[ra] = regions[ra, 4] + allowance
        if status[b, i] == hidden:
            grow[ra] += hidden_ball_radius(unseen[b, i], occlusion_speed)
        for x in range(3):
            centre[ra, x] = p[b, i, x] + regions[ra, 1 + x]
        region_std[ra] = std[b, i]
    # The refinements, in order: each region becomes the smaller of the lens balls of the
    # ball derived from a tracked point with the region's ball and with its first ball
    # (the lens ball of a lens ball may stick out of the first: the smaller holds the
    # point too). A tracked point's own ball is kept while its body is tracked (its
    # allowance is the smallest; the truth stays exact).
    for c in range(candidates.shape[0]):
        if candidates[c, 4] != KIND_REFINE:
            continue
        t, s = int(candidates[c, 1]), int(candidates[c, 2])
        i = int(regions[t, 0])
        k = t // NUM_POINTS
        if not (op_status[k] == tracking or op_status[k] == hidden):
            continue
        if regions[t, 4] == 0.0 and status[b, i] == tracking:
            continue
        s0, s1, s2 = centre[s, 0], centre[s, 1], centre[s, 2] + candidates[c, 5]
        u = grow[s] + candidates[c, 3]
        c0, c1, c2, r = lens_ball(centre[t, 0], centre[t, 1], centre[t, 2], grow[t], s0, s1,
                                  s2, u)
        first = regions[t, 4] + allowance
        if status[b, i] == hidden:
            first += hidden_ball_radius(unseen[b, i], occlusion_speed)
        f0, f1, f2 = (p[b, i, 0] + regions[t, 1], p[b, i, 1] + regions[t, 2],
                      p[b, i, 2] + regions[t, 3])
        if not (grow[t] == first and centre[t, 0] == f0 and centre[t, 1] == f1
                and centre[t, 2] == f2):  # (refined before: try the first ball too)
            f0, f1, f2, q = lens_ball(f0, f1, f2, first, s0, s1, s2, u)
            if q < r:
                c0, c1, c2, r = f0, f1, f2, q
        if not (r == grow[t] and c0 == centre[t, 0] and c1 == centre[t, 1]
                and c2 == centre[t, 2]):
            region_std[t] = max(region_std[t], region_std[s])
        centre[t, 0], centre[t, 1], centre[t, 2], grow[t] = c0, c1, c2, r
    # The smallest candidate of each segment, by its size alone (its axis' length and
    # radius, without its ends); then its ends, once.
    for m in range(radius.size):
        best[m], chosen[m] = np.inf, -1
    for c in range(candidates.shape[0]):
        kind = candidates[c, 4]
        if kind == KIND_REFINE:
            continue
        m = int(candidates[c, 0])
        if not (out_status[b, m] == tracking or out_status[b, m] == hidden):
            continue
        ra, rb = int(candidates[c, 1]), int(candidates[c, 2])
        if kind == KIND_CONE:
            length, r = abs(candidates[c, 5]), candidates[c, 3] + grow[ra]
        else:
            d0, d1 = centre[rb, 0] - centre[ra, 0], centre[rb, 1] - centre[ra, 1]
            d2 = centre[rb, 2] - centre[ra, 2]
            dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if kind == KIND_DIRECT:  # hull_capsule's axis length and radius
                r = max(grow[ra], grow[rb])
                length = dist - min(abs(grow[ra] - grow[rb]), dist)
                if math.isnan(grow[ra]) or math.isnan(grow[rb]):
                    r = np.nan
            else:  # ellipsoid_capsule's axis length and radius
                a, half = 0.5 * (candidates[c, 3] + grow[ra] + grow[rb]), 0.5 * dist
                if half >= a:
                    length, r = dist, 0.0
                else:
                    r = math.sqrt((a - half) * (a + half))
                    length = 2.0 * (a - r)
        r += radius[m]
        size = r * r * (2.0 * length + 4.0 * r / 3.0)  # (its cylinder weighed twice)
        if size < best[m] or (math.isnan(size) and not math.isnan(best[m])):
            best[m], chosen[m] = size, c  # (a NaN, once met, is kept: the segment is NaN)
    for m in range(radius.size):
        c = chosen[m]
        if c < 0:
            continue
        ra, rb = int(candidates[c, 1]), int(candidates[c, 2])
        ia, ib = int(regions[ra, 0]), int(regions[rb, 0])
        c_a = (centre[ra, 0], centre[ra, 1], centre[ra, 2])
        c_b = (centre[rb, 0], centre[rb, 1], centre[rb, 2])
        if candidates[c, 4] == KIND_DIRECT:
            end_a, end_b, r = hull_capsule(c_a, grow[ra], c_b, grow[rb])
        elif candidates[c, 4] == KIND_CONE:
            end_a, end_b, r = c_a, (c_a[0], c_a[1], c_a[2] + candidates[c, 5]), \
                candidates[c, 3] + grow[ra]
        else:
            end_a, end_b, r = ellipsoid_capsule(c_a, c_b, candidates[c, 3] + grow[ra]
                                                + grow[rb])
        out_radius[b, m] = r + radius[m]
        out_std[b, m] = max(region_std[ra], region_std[rb])
        for x in range(3):
            ends[b, m, 0, x], ends[b, m, 1, x] = end_a[x], end_b[x]
            end_velocities[b, m, 0, x], end_velocities[b, m, 1, x] = v[b, ia, x], v[b, ib, x]


@numba.njit(cache=True)
def envelope_rows(regions, candidates, radius, operator, slots, p, v, status, std, unseen,
                  allowance, occlusion_speed, ends, end_velocities, out_radius, out_status,
                  out_std):
    """Every segment's envelope (see the module docstring) from the tracked bodies'
    estimates p, v (N, 3), status (N,), std (N,) and time unseen (N,): capsule ends and
    their velocities (M, 2, 3), radius (M,), the operator's status (M,) and the largest
    std of the bodies the envelope was taken from (M,); compiled.

    A body's region radius is ``allowance``, plus, while hidden, its ball's radius
    (``formulas.hidden_ball_radius``: ``occlusion_speed`` times its time unseen). An
    operator's status (``sensing.tracks``), which all its segments take: tracking when
    every body is tracked, hidden when some are hidden and the rest tracked, none when no
    body was ever seen or all have left, and lost otherwise: a lost body, or some bodies
    seen and others not (an operator is seen whole before the robot may move, and a body
    is never forgotten while its companions are here). Unusable operators' segments are
    NaN. A NaN in the used estimates gives NaN ends."""
    K, R, M = slots.shape[0], regions.shape[0], radius.size
    _envelope_row(0, regions, candidates, radius, operator, slots, p[np.newaxis],
                  v[np.newaxis], status[np.newaxis], std[np.newaxis], unseen[np.newaxis],
                  allowance, occlusion_speed, ends[np.newaxis], end_velocities[np.newaxis],
                  out_radius[np.newaxis], out_status[np.newaxis], out_std[np.newaxis],
                  np.empty(K), np.empty((R, 3)), np.empty(R), np.empty(R), np.empty(M),
                  np.empty(M, dtype=np.int64))


@numba.njit(cache=True)
def envelope_batch(regions, candidates, radius, operator, slots, p, v, status, std, unseen,
                   allowance, occlusion_speed, ends, end_velocities, out_radius, out_status,
                   out_std):
    """:func:`envelope_rows` of every row of the tracker's outputs p, v (B, N, 3), status,
    std, unseen (B, N) into ends, end_velocities (B, M, 2, 3), out_radius, out_status,
    out_std (B, M), the same numbers; compiled, its working arrays made once."""
    K, R, M = slots.shape[0], regions.shape[0], radius.size
    op_status, centre, grow = np.empty(K), np.empty((R, 3)), np.empty(R)
    region_std, best, chosen = np.empty(R), np.empty(M), np.empty(M, dtype=np.int64)
    for b in range(p.shape[0]):
        _envelope_row(b, regions, candidates, radius, operator, slots, p, v, status, std,
                      unseen, allowance, occlusion_speed, ends, end_velocities, out_radius,
                      out_status, out_std, op_status, centre, grow, region_std, best, chosen)


# An upright operator relative to its head, in its facing frame (forward f, left l, up z),
# m: the shape ``complete_posture`` gives the points a scenario leaves out. Every edge is
# shorter than the table's, so the posture is one the dimensions allow.
_UPRIGHT = {"head": (0.0, 0.0, 0.0), "neck": (0.0, 0.0, -0.18), "chest": (0.0, 0.0, -0.38),
            "pelvis": (0.0, 0.0, -0.73), "shoulder_left": (0.0, 0.19, -0.20),
            "shoulder_right": (0.0, -0.19, -0.20), "elbow_left": (0.08, 0.22, -0.48),
            "elbow_right": (0.08, -0.22, -0.48), "hand_left": (0.42, 0.20, -0.50),
            "hand_right": (0.42, -0.20, -0.50)}
_UPRIGHT_ROWS = {k: np.array(v) for k, v in _UPRIGHT.items()}
_UPPER_ARM, _FOREARM = 0.36, 0.37  # m, the arm ``complete_posture`` bends to reach a hand
_HANDS_TO_HEAD = (-0.30, 0.45)  # m back and up from the hands to the head


def complete_posture(given: dict[str, np.ndarray], facing: np.ndarray) -> dict[str, np.ndarray]:
    """Every body point's offset, from those ``given`` (point -> offset, m) and the
    horizontal direction the operator faces (``facing``, any length): the points not
    given stand upright (:data:`_UPRIGHT`) about the head, which, if not given, stands
    0.30 m behind and 0.45 m above the hands (their mean) or above the trunk's given
    point; a given hand's elbow bends down between its shoulder and the hand
    (:data:`_UPPER_ARM`, :data:`_FOREARM`). Raises ValueError when a given hand is
    farther from its shoulder than that arm reaches."""
    f = np.array([facing[0], facing[1], 0.0], dtype=float)
    norm = np.linalg.norm(f)
    f = f / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
    f0, f1, f2 = float(f[0]), float(f[1]), float(f[2])
    # up x f, as np.cross computes it (each product, then the difference), without its cost
    left = np.array([0.0 * f2 - 1.0 * f1, 1.0 * f0 - 0.0 * f2, 0.0 * f1 - 0.0 * f0])
    frame = np.array([f, left, [0.0, 0.0, 1.0]])  # rows: forward, left, up

    def template(name):
        return _UPRIGHT_ROWS[name] @ frame

    given = {k: np.asarray(v, dtype=float) for k, v in given.items()}
    for name in given:
        point_index(name)
    if "head" in given:
        head = given["head"]
    else:
        hands = [given[h] for h in ("hand_left", "hand_right") if h in given]
        trunk = [k for k in ("neck", "chest", "pelvis", "shoulder_left", "shoulder_right",
                             "elbow_left", "elbow_right") if k in given]
        if hands:
            head = np.mean(hands, axis=0) + _HANDS_TO_HEAD[0] * f + [0.0, 0.0,
                                                                    _HANDS_TO_HEAD[1]]
        elif trunk:
            head = given[trunk[0]] - template(trunk[0])
        else:
            head = np.zeros(3)
    out = {k: given[k] if k in given else head + template(k) for k in POINTS}
    if "hand_left" in given and "hand_right" in given and \
            (given["hand_left"] - given["hand_right"]) @ left < 0.0:
        # the hands are crossed in the facing frame (the file's sides are its own): the
        # arms' points not given are mirrored, each shoulder on its hand's side
        for k in ("shoulder_left", "shoulder_right", "elbow_left", "elbow_right"):
            if k not in given:
                x = np.array(_UPRIGHT[k]) * [1.0, -1.0, 1.0]
                out[k] = head + x @ frame
    for side in ("left", "right"):
        hand, elbow = f"hand_{side}", f"elbow_{side}"
        if hand in given and elbow not in given:
            shoulder = out[f"shoulder_{side}"]
            outward = shoulder - out["neck"]
            out[elbow] = _elbow(shoulder, out[hand], outward / max(np.linalg.norm(outward),
                                                                   1e-9), side)
    return out


def _elbow(shoulder: np.ndarray, hand: np.ndarray, outward: np.ndarray, side: str) -> np.ndarray:
    """The elbow of an arm of :data:`_UPPER_ARM` and :data:`_FOREARM` reaching from
    ``shoulder`` to ``hand``, bent downwards (or outwards where the arm points down)."""
    d = hand - shoulder
    dist = float(np.linalg.norm(d))
    if dist > _UPPER_ARM + _FOREARM - 1e-9:
        raise ValueError(f"hand_{side}: {dist:.3f} m from its shoulder; allowed: at most "
                         f"{_UPPER_ARM + _FOREARM:.2f} m (the arm the posture bends)")
    if dist < abs(_UPPER_ARM - _FOREARM) + 1e-9:
        return shoulder + _UPPER_ARM * outward
    u = d / dist
    along = (dist * dist + _UPPER_ARM**2 - _FOREARM**2) / (2.0 * dist)
    across = math.sqrt(max(_UPPER_ARM**2 - along * along, 0.0))
    down = np.array([0.0, 0.0, -1.0]) - u * (-u[2])
    if np.linalg.norm(down) < 1e-6:
        down = outward - u * (outward @ u)
    return shoulder + along * u + across * down / np.linalg.norm(down)


def posture_violations(points: np.ndarray, dims: dict, tolerance: float = 1e-9) -> list[str]:
    """What of a posture (10, 3) the dimensions ``dims`` do not allow, in words (empty when
    it is a posture the model allows, the premise under which every envelope holds its
    segment): an edge longer than its length, the head farther from a shoulder than
    ``head_shoulder``, a lean-limited edge farther from straight down than its limit."""
    out = []
    for a, b, length, lean in EDGES:
        d = points[_P[b]] - points[_P[a]]
        dist = float(np.linalg.norm(d))
        if dist > dims[length] + tolerance:
            out.append(f"{a}-{b} {dist:.3f} m > {length} {dims[length]:g} m")
        if lean and dist > 0.0:
            angle = math.degrees(math.acos(max(-1.0, min(1.0, -d[2] / dist))))
            if angle > dims[lean] + tolerance:
                out.append(f"{a}-{b} {angle:.1f} deg from straight down > {lean} "
                           f"{dims[lean]:g} deg")
    for a, b, length in SHORTCUTS:
        dist = float(np.linalg.norm(points[_P[b]] - points[_P[a]]))
        if dist > dims[length] + tolerance:
            out.append(f"{a}-{b} {dist:.3f} m > {length} {dims[length]:g} m")
    return out
