"""Where a tracked rigid body's reported position lies from the body point it marks: the
pivot, written once for recordings, the live stream and the proofs.

Motive (and most motion-capture software) reports a rigid body at its *pivot*, by default
the centroid of its markers: a helmet's sits 0.10-0.15 m above the head's centre, a
glove's on the back of the hand. The monitor takes a tracked body's position for the body
point it marks (``cell.human_body``), so an unmoved pivot is an error of up to that
distance in every envelope, which only the tracking allowance can cover.

A mapping says, per body (``recording_mapping.MappedBody``), either the pivot's offset
``pivot`` [x, y, z] (m, in the rigid body's own frame: from its reported position to the
body point, turned with its orientation: :func:`body_points`), or ``at_point: true``
(the reported position is the body point: the pivot was moved onto it in Motive, or the
body is a skeleton's joint, as in a BVH file). Without either, the body's point may be as
far from its reported position as its kind allows (:func:`pivot_bound`,
:data:`PIVOT_BOUNDS`), and a proof's tracking allowance must cover that (the live runtime
refuses such a mapping under a certificate whose space assumed less:
``verification.spaces.box`` ``pivot_offset``).

:data:`PIVOT_BOUNDS` are our estimates of how far a worn marker cluster's centroid may lie
from the joint centre it stands for (a person's joint centres lie inside the body, the
markers on a plate or shell outside it): a helmet 0.15 m (the issue's 0.10-0.15 m above
the head centre), a glove's back-of-hand cluster 0.08 m (the hand's half thickness, the
plate and the markers' stems), a band on an elbow or a shoulder 0.10 m (the joint's
depth under the skin plus the band), a chest or back plate 0.20 m and a belt's 0.20 m
(the trunk's half depth plus the plate), the neck 0.10 m.
"""

import numpy as np
from scipy.spatial.transform import Rotation

PIVOT_BOUNDS = {"head": 0.15, "neck": 0.10, "chest": 0.20, "pelvis": 0.20,
                "shoulder_left": 0.10, "shoulder_right": 0.10, "elbow_left": 0.10,
                "elbow_right": 0.10, "hand_left": 0.08, "hand_right": 0.08}


def pivot_bound(point: str, pivot, at_point: bool) -> float:
    """How far (m) a body marking ``point`` may be from its reported position once its
    mapping's ``pivot`` (a 3-vector, or empty) and ``at_point`` are applied: 0 when either
    is given, else the kind's :data:`PIVOT_BOUNDS`."""
    return 0.0 if at_point or len(pivot) else PIVOT_BOUNDS[point]


def body_points(positions: np.ndarray, quaternions: np.ndarray, pivot) -> np.ndarray:
    """(..., 3) the body points of rigid bodies reported at ``positions`` (..., 3) with
    orientations ``quaternions`` (..., 4: x, y, z, w, body to capture frame): position +
    R(q) pivot, in the positions' frame. NaN where a position or its orientation is not
    known (an untracked sample: never a point guessed without its orientation)."""
    p = np.asarray(positions, dtype=float)
    q = np.asarray(quaternions, dtype=float).reshape(-1, 4)
    out = np.full(q.shape[:1] + (3,), np.nan)
    ok = np.all(np.isfinite(q), axis=1) & (np.linalg.norm(q, axis=1) > 0.0)
    if ok.any():
        out[ok] = Rotation.from_quat(q[ok]).apply(np.asarray(pivot, dtype=float))
    return p + out.reshape(p.shape)
