import math

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from pydrake.geometry import (
    Capsule,
    Cylinder,
    GeometryInstance,
    ProximityProperties,
    Role,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder
from scipy.spatial.transform import Rotation

from safety_systems.cell import ur5e
from safety_systems.speed_alteration import ellipsoids
from safety_systems.ssm import formulas as ssm
from safety_systems.cell.robot_geometry import (
    CAPSULE_NAMES,
    LINK_NAMES,
    LINK_SEGMENTS,
    NUM_POINTS,
    RADIUS_STEP,
    Capsules,
    capsule_ends,
    clearances,
    min_clearance,
    model_link_capsules,
    nearest_capsule_one,
    nearest_capsules,
    robot_capsules,
    robot_points,
    robot_points_one,
    robot_points_one_memo,
    segment_pair,
    tool_point,
)

SETTINGS = settings(derandomize=True, max_examples=200, deadline=None)
TOOL = 0.15  # m
CAPSULES = robot_capsules(payload_radius=0.05, tool_length=TOOL)


def _bits(x) -> np.ndarray:
    """The bit patterns of float64 values (NaNs folded to one pattern)."""
    x = np.array(x, dtype=float)
    x[np.isnan(x)] = np.nan
    return x.view(np.uint64)


def _assert_bitwise(x, y):
    np.testing.assert_array_equal(_bits(x), _bits(y))


def _random_q(rng, n):
    return rng.uniform(-2 * np.pi, 2 * np.pi, (n, 6))


@numba.njit
def _points_in_turn(q, v, tool_length, memo):
    """robot_points_one (out[0]) and robot_points_one_memo with one memo (out[1]) of rows."""
    out = np.empty((2, 2, q.shape[0], NUM_POINTS, 3))
    for row in range(q.shape[0]):
        robot_points_one(q[row], v[row], tool_length, out[0, 0, row], out[0, 1, row])
        robot_points_one_memo(q[row], v[row], tool_length, memo, out[1, 0, row],
                              out[1, 1, row])
    return out


@numba.njit
def _segment_pairs(p_B, v_B, A, B, vA, vB):
    out = np.empty((p_B.shape[0], 3))
    for i in range(p_B.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = segment_pair(p_B[i], v_B[i], A[i], B[i], vA[i], vB[i])
    return out


@numba.njit
def _separation_pairs(p_R, v_R, p_B, v_B):
    out = np.empty((p_B.shape[0], 3))
    for i in range(p_B.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = ssm.separation_pair(p_R[i], v_R[i], p_B[i], v_B[i])
    return out


@numba.njit
def _nearest(p_B, v_B, r_B, ends, end_velocities, radius):
    c, v_h, v_r, index = nearest_capsule_one(p_B, v_B, r_B, ends, end_velocities, radius)
    return np.array([c, v_h, v_r]), index


# --- points ---------------------------------------------------------------------------

def test_points_are_the_dh_origins_and_the_tool_tip():
    rng = np.random.default_rng(0)
    q = _random_q(rng, 200)
    p, _ = robot_points(q, tool_length=TOOL)
    frames = ur5e.dh_frames(q)
    assert p.shape == (200, NUM_POINTS, 3)
    np.testing.assert_allclose(p[:, :7], frames[..., :3, 3], rtol=0, atol=1e-12)
    z6 = frames[:, 6, :3, 2]
    np.testing.assert_allclose(p[:, 7], frames[:, 6, :3, 3] + TOOL * z6, rtol=0, atol=1e-12)
    # z6 is (P6 - P5) / d6 and does not turn with q6
    np.testing.assert_allclose((p[:, 6] - p[:, 5]) / ur5e.DH_D[5], z6, rtol=0, atol=1e-12)
    q_turned = q.copy()
    q_turned[:, 5] += rng.uniform(-3, 3, 200)
    _assert_bitwise(robot_points(q_turned, tool_length=TOOL)[0], p)


angles = arrays(np.float64, (4, 6), elements=st.floats(-50, 50))


@SETTINGS
@given(q=angles, v=angles)
def test_tool0_is_ur5e_tool0_bit_for_bit(q, v):
    p, pv = robot_points(q, v, TOOL)
    p6, v6 = ur5e.tool0_position_and_velocity(q, v)
    _assert_bitwise(p[:, 6], p6)
    _assert_bitwise(pv[:, 6], v6)
    one_p, one_v = ur5e.tool0_position_and_velocity(q[0], v[0])  # the one-row path
    _assert_bitwise(p[0, 6], one_p)
    _assert_bitwise(pv[0, 6], one_v)


def test_velocities_are_derivatives_of_positions():
    rng = np.random.default_rng(1)
    q, v = _random_q(rng, 300), rng.uniform(-3, 3, (300, 6))
    tool = rng.uniform(0, 0.3, (300, 1))
    h = 1e-6
    for k in range(300):
        _, pv = robot_points(q[k], v[k], tool[k, 0])
        ahead, _ = robot_points(q[k] + h * v[k], tool_length=tool[k, 0])
        behind, _ = robot_points(q[k] - h * v[k], tool_length=tool[k, 0])
        np.testing.assert_allclose(pv, (ahead - behind) / (2 * h), rtol=0, atol=2e-8)
    assert np.all(robot_points(q[0], v[0])[1][:2] == 0.0)  # P0 and P1 never move


def test_memo_variant_equals_plain_bit_for_bit():
    rng = np.random.default_rng(2)
    q = _random_q(rng, 40)
    q[5:10] = q[4]  # at rest: every angle reused
    q[12:15, 1:4] = q[11, 1:4]  # some joints still
    q[20] = 0.0
    q[21] = -0.0  # a memo of 0 must not keep the sign of sin(-0)
    q[22] = 0.0
    q[23, [0, 2, 4]] = 0.0
    q[24] = q[23]
    v = rng.uniform(-3, 3, (40, 6))
    v[5:10] = 0.0
    memo = np.full(15, np.nan)
    out = _points_in_turn(q, v, TOOL, memo)
    _assert_bitwise(out[1], out[0])
    _assert_bitwise(out[0, 0], robot_points(q, v, TOOL)[0])
    again = _points_in_turn(q[::-1].copy(), v[::-1].copy(), TOOL, memo)  # a used memo
    _assert_bitwise(again[1], again[0])


# --- the capsules against the model's collision geometry ------------------------------

@pytest.fixture(scope="module")
def ur5e_scene():
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    ur5e.AddUr5e(plant)
    plant.Finalize()
    diagram = builder.Build()
    return plant, scene_graph, diagram, diagram.CreateDefaultContext()


def _cylinder_samples(rng, X_WG, radius, length, n):
    """Points of a cylinder (in its frame G, axis z): rims, side, end discs and inside."""
    s = rng.uniform(0, 2 * np.pi, n)
    rim = np.stack([radius * np.cos(s), radius * np.sin(s),
                    np.where(np.arange(n) % 2, 0.5, -0.5) * length], axis=1)
    s = np.arange(4096) * (2 * np.pi / 4096)  # rims, densely, for the tightness check
    dense = np.concatenate([np.stack([radius * np.cos(s), radius * np.sin(s),
                                      np.full(4096, z)], axis=1) for z in (-length / 2,
                                                                            length / 2)])
    rho = radius * np.sqrt(rng.uniform(0, 1, n))
    s = rng.uniform(0, 2 * np.pi, n)
    inner = np.stack([rho * np.cos(s), rho * np.sin(s), rng.uniform(-0.5, 0.5, n) * length],
                     axis=1)
    side = inner.copy()
    side[:, :2] *= radius / np.maximum(rho, 1e-12)[:, None]
    disc = inner.copy()
    disc[:, 2] = np.sign(disc[:, 2]) * length / 2
    G = np.concatenate([rim, dense, inner, side, disc])
    return G @ X_WG.rotation().matrix().T + X_WG.translation()


def _link_geometry(plant, scene_graph, diagram, context, q):
    """[(link index, shape, X_WG)] of the moving links' collision geometries at q."""
    plant.SetPositions(plant.GetMyMutableContextFromRoot(context), q)
    query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
    inspector = query.inspector()
    found = []
    for gid in inspector.GetAllGeometryIds(role=Role.kProximity):
        body = plant.GetBodyFromFrameId(inspector.GetFrameId(gid)).name()
        if body == "base_link":
            continue
        found.append((LINK_NAMES.index(body), inspector.GetShape(gid), query.GetPoseInWorld(gid)))
    return found


def test_link_capsules_contain_their_collision_cylinders_tightly(ur5e_scene):
    rng = np.random.default_rng(3)
    radii = CAPSULES.radius[:6]
    largest = np.zeros(6)
    reach = np.full(6, -np.inf)  # how far out of each capsule its farthest point lies
    low = np.full(6, np.inf)  # the lowest axis fraction of its points
    for q in _random_q(rng, 12):
        geometry = _link_geometry(*ur5e_scene, q)
        assert sorted(k for k, _, _ in geometry) == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5]
        ends, _ = capsule_ends(q, CAPSULES)
        for k, shape, X_WG in geometry:
            assert isinstance(shape, Cylinder)
            largest[k] = max(largest[k], shape.radius())
            points = _cylinder_samples(rng, X_WG, shape.radius(), shape.length(), 2000)
            c = clearances(q, CAPSULES, points, 0.0)[:, k]
            assert c.max() <= 1e-9, (CAPSULE_NAMES[k], c.max())
            reach[k] = max(reach[k], c.max())
            A, B = ends[k]
            low[k] = min(low[k], np.min((points - A) @ (B - A)) / ((B - A) @ (B - A)))
    message = f"capsule radii {radii}, largest cylinder radii {largest}"
    # Not loose: 0.5 mm (the rounding) less radius would leave some point out, the
    # segments start where the cylinders do, and no radius is far above the cylinders'
    # (the worst, the forearm: its 45 mm housing is 120 mm long across the axis, so it
    # needs hypot(45, 60) = 75 mm).
    assert np.all(reach > -RADIUS_STEP - 1e-6), (reach, message)
    np.testing.assert_allclose(low, 0.0, atol=1e-6)
    assert np.all(radii <= 1.7 * largest), message


def test_fitted_capsules():
    fitted = model_link_capsules()
    assert [(a, b) for a, b, *_ in fitted] == list(LINK_SEGMENTS)
    # housings along the axis (60, 40 mm) or across it: hypot(60, 60) -> 85, hypot(45, 60) = 75
    np.testing.assert_array_equal([r for *_, r in fitted], [0.06, 0.085, 0.075, 0.04, 0.04, 0.04])
    lengths = np.hypot(ur5e.DH_A, ur5e.DH_D)
    housing = np.array([0.06, 0.06, 0.045, 0.06, 0.06, 0.06])  # half-length or radius
    np.testing.assert_allclose([t0 for _, _, t0, _, _ in fitted], -housing / lengths, rtol=1e-12)
    assert [t1 for _, _, _, t1, _ in fitted] == [1.0] * 6


def test_too_small_capsules_miss_the_cylinders(ur5e_scene):
    q = np.random.default_rng(4).uniform(-3, 3, 6)
    thin = robot_capsules(link_radii=CAPSULES.radius[:6] - 0.001, payload_radius=0.05)
    checked = []
    for k, shape, X_WG in _link_geometry(*ur5e_scene, q):
        points = _cylinder_samples(np.random.default_rng(k), X_WG, shape.radius(),
                                   shape.length(), 500)
        if shape.radius() == CAPSULES.radius[k]:  # the housings along the axis
            assert clearances(q, thin, points, 0.0)[:, k].max() > 0.0009
            checked.append(k)
    assert sorted(checked) == [0, 3, 4, 5]


def _register(scene_graph, source, ends, radius, name):
    A, B = ends
    axis = B - A
    length = float(np.linalg.norm(axis))
    if length == 0.0:
        shape, X = Sphere(radius), RigidTransform(A)
    else:
        shape = Capsule(radius, length)
        X = RigidTransform(RotationMatrix.MakeFromOneVector(axis, 2), (A + B) / 2)
    gid = scene_graph.RegisterAnchoredGeometry(source, GeometryInstance(X, shape, name))
    scene_graph.AssignRole(source, gid, ProximityProperties())
    return gid


def test_clearances_equal_drake_signed_distances():
    rng = np.random.default_rng(5)
    q = _random_q(rng, 6)
    sets = (CAPSULES, robot_capsules(payload_radius=0.03), tool_point())
    scene_graph = SceneGraph()
    source = scene_graph.RegisterSource("capsules")
    ids = {}
    for s, capsules in enumerate(sets):
        ends, _ = capsule_ends(q, capsules)
        for pose in range(len(q)):
            for j in range(len(capsules.names)):
                gid = _register(scene_graph, source, ends[pose, j], capsules.radius[j],
                                f"{s}_{pose}_{j}")
                ids[gid] = (s, pose, j)
    query = scene_graph.get_query_output_port().Eval(scene_graph.CreateDefaultContext())
    points = rng.uniform(-1.0, 1.0, (300, 3))
    p, _ = robot_points(q, tool_length=TOOL)  # and points near the arm, some inside
    near = p[rng.integers(0, 6, 300), rng.integers(0, 8, 300)] + rng.normal(0, 0.05, (300, 3))
    points = np.concatenate([points, near])
    ours = [clearances(q, capsules, points[None], 0.0) for capsules in sets]  # (6, N, K)
    inside = compared = 0
    for i, point in enumerate(points):
        for result in query.ComputeSignedDistanceToPoint(point):
            s, pose, j = ids[result.id_G]
            assert ours[s][pose, i, j] == pytest.approx(result.distance, abs=1e-9)
            inside += result.distance < 0
            compared += 1
    assert compared == len(points) * len(ids) and inside > 100


# --- segment_pair and nearest_capsule_one ---------------------------------------------

finite = st.floats(-3, 3)
maybe_nan = st.one_of(finite, st.just(np.nan))
vectors = st.tuples(maybe_nan, finite, finite)


@SETTINGS
@given(A=vectors, vA=vectors, p_B=vectors, v_B=vectors, coincident=st.booleans())
def test_point_segment_is_separation_pair_bit_for_bit(A, vA, p_B, v_B, coincident):
    A, vA, v_B = np.array([A]), np.array([vA]), np.array([v_B])
    p_B = A.copy() if coincident else np.array([p_B])
    _assert_bitwise(_segment_pairs(p_B, v_B, A, A.copy(), vA, vA.copy()),
                    _separation_pairs(A, vA, p_B, v_B))


def test_tool_point_reproduces_the_seed_point_bit_for_bit():
    rng = np.random.default_rng(6)
    q, v = _random_q(rng, 50), rng.uniform(-3, 3, (50, 6))
    p_B, v_B = rng.uniform(-1, 1, (50, 4, 3)), rng.uniform(-2, 2, (50, 4, 3))
    p_B[3, 2] = ur5e.tool0_position(q[3])  # a body at tool0
    p_R, v_R = ur5e.tool0_position_and_velocity(q, v)
    d, v_h, v_r, index = nearest_capsules(q, v, tool_point(), p_B, v_B, 0.0)
    expected = ssm.separation_and_directed_speeds(p_R, v_R, p_B, v_B)
    _assert_bitwise(np.stack([d, v_h, v_r]), np.stack(expected))
    assert np.all(index == 0) and d[3, 2] == 0.0


segments = arrays(np.float64, (6, 3), elements=st.floats(-1, 1))


@SETTINGS
@given(x=segments)
def test_segment_distance_is_the_minimum_over_the_axis(x):
    A, B, p_B = x[0], x[1], x[2]
    d, _, _ = _segment_pairs(p_B[None], x[3][None], A[None], B[None], x[4][None], x[5][None])[0]
    axis = A + np.linspace(0, 1, 20001)[:, None] * (B - A)
    brute = np.min(np.linalg.norm(axis - p_B, axis=1))
    assert d <= brute + 1e-12
    assert brute - d <= np.linalg.norm(B - A) / 20000 + 1e-12


def _moved_distance(tau, A, B, vA, omega, p_B, v_B, body=True, segment=True):
    """segment_pair's distance after tau seconds of the body moving at v_B (if ``body``)
    and the segment turning at omega about A moving at vA (if ``segment``)."""
    turn = Rotation.from_rotvec(omega * tau * segment).apply(B - A)
    At = A + vA * tau * segment
    q_B = p_B + v_B * tau * body
    return _segment_pairs(q_B[None], v_B[None], At[None], (At + turn)[None], vA[None],
                          vA[None])[0, 0]


def test_directed_speeds_are_rates_of_the_axis_distance():
    rng = np.random.default_rng(7)
    h, checked = 1e-6, 0
    for _ in range(500):
        A, B, p_B = rng.uniform(-1, 1, (3, 3))
        vA, omega, v_B = rng.uniform(-2, 2, (3, 3))
        vB = vA + np.cross(omega, B - A)  # a rigid motion of the segment
        out = _segment_pairs(p_B[None], v_B[None], A[None], B[None], vA[None], vB[None])[0]
        d, v_h, v_r = out
        t = np.dot(p_B - A, B - A) / np.dot(B - A, B - A)
        if d < 1e-3 or min(abs(t), abs(t - 1)) < 1e-3:  # a kink: no derivative to compare
            continue
        motion = (A, B, vA, omega, p_B, v_B)
        for kind, rate in (({}, -(v_h + v_r)), ({"segment": False}, -v_h),
                           ({"body": False}, -v_r)):
            difference = (_moved_distance(h, *motion, **kind)
                          - _moved_distance(-h, *motion, **kind)) / (2 * h)
            assert difference == pytest.approx(rate, abs=1e-7), kind
        checked += 1
    assert checked > 400


def _reference_clearance(p_B, r_B, ends, radius):
    A, B = ends[:, 0], ends[:, 1]
    e = B - A
    t = np.clip(np.einsum("ki,ki->k", p_B - A, e) / np.einsum("ki,ki->k", e, e), 0, 1)
    return np.linalg.norm(A + t[:, None] * e - p_B, axis=1) - radius - r_B


def test_nearest_capsule_is_the_minimum_over_capsules():
    rng = np.random.default_rng(8)
    for _ in range(300):
        K = rng.integers(1, 9)
        ends, end_v = rng.uniform(-1, 1, (K, 2, 3)), rng.uniform(-1, 1, (K, 2, 3))
        radius, r_B = rng.uniform(0, 0.2, K), rng.uniform(0, 0.1)
        p_B, v_B = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, 3)
        (c, v_h, v_r), index = _nearest(p_B, v_B, r_B, ends, end_v, radius)
        reference = _reference_clearance(p_B, r_B, ends, radius)
        assert index == np.argmin(reference)
        assert c == pytest.approx(reference.min(), abs=1e-12)
        pair = _segment_pairs(p_B[None], v_B[None], ends[index, 0][None], ends[index, 1][None],
                              end_v[index, 0][None], end_v[index, 1][None])[0]
        _assert_bitwise([c, v_h, v_r], [pair[0] - radius[index] - r_B, pair[1], pair[2]])
    # ties: the first
    ends = np.repeat(rng.uniform(-1, 1, (1, 2, 3)), 3, axis=0)
    assert _nearest(np.zeros(3), np.ones(3), 0.0, ends, ends, np.full(3, 0.05))[1] == 0


@pytest.mark.parametrize("where", ["p_B", "v_B", "r_B", "end", "end_velocity", "radius"])
def test_nearest_capsule_of_nan_is_nan(where):
    rng = np.random.default_rng(9)
    args = {"p_B": rng.uniform(-1, 1, 3), "v_B": rng.uniform(-1, 1, 3), "r_B": 0.05,
            "ends": rng.uniform(-1, 1, (4, 2, 3)), "end_velocities": rng.uniform(-1, 1, (4, 2, 3)),
            "radius": np.full(4, 0.05)}
    (c, _, _), index = _nearest(**args)
    assert np.isfinite(c) and index >= 0
    if where in ("p_B", "v_B"):
        args[where][1] = np.nan
    elif where == "r_B":
        args["r_B"] = np.nan
    elif where == "end":
        args["ends"][2, 1, 0] = np.nan
    elif where == "end_velocity":
        args["end_velocities"][3, 0, 2] = np.nan
    else:
        args["radius"][1] = np.nan
    figures, index = _nearest(**args)
    assert np.all(np.isnan(figures)) and index == -1


def test_wrappers_agree_and_broadcast():
    rng = np.random.default_rng(10)
    q, v = _random_q(rng, 6).reshape(2, 3, 6), rng.uniform(-3, 3, (3, 6))
    p_B, v_B = rng.uniform(-1, 1, (3, 5, 3)), rng.uniform(-1, 1, (5, 3))
    r_B = rng.uniform(0, 0.1, 5)
    every = clearances(q, CAPSULES, p_B, r_B)
    assert every.shape == (2, 3, 5, 7)
    c, v_h, v_r, index = nearest_capsules(q, v, CAPSULES, p_B, v_B, r_B)
    assert c.shape == v_h.shape == index.shape == (2, 3, 5)
    np.testing.assert_array_equal(c, every.min(axis=-1))
    np.testing.assert_array_equal(index, every.argmin(axis=-1))
    np.testing.assert_array_equal(min_clearance(q, CAPSULES, p_B, r_B), c)
    ends, end_v = capsule_ends(q, CAPSULES, v)
    p, _ = robot_points(q, v, TOOL)
    assert ends.shape == end_v.shape == (2, 3, 7, 2, 3) and p.shape == (2, 3, 8, 3)
    np.testing.assert_array_equal(ends[..., :6, 1, :], p[..., 1:7, :])  # t1 = 1: P_{k+1}
    np.testing.assert_array_equal(ends[..., 6, :, :], p[..., 6:8, :])
    assert capsule_ends(q, CAPSULES)[1] is None and robot_points(q)[1] is None
    for lead in np.ndindex(2, 3):
        (c1, vh1, vr1), i1 = _nearest(p_B[lead[1], 0], v_B[0], r_B[0], ends[lead],
                                      end_v[lead], CAPSULES.radius)
        _assert_bitwise([c1, vh1, vr1], [c[lead][0], v_h[lead][0], v_r[lead][0]])
        assert i1 == index[lead][0]


# --- builders --------------------------------------------------------------------------

def test_robot_capsules():
    caps = robot_capsules(payload_radius=0.07, tool_length=0.2)
    assert caps.names == CAPSULE_NAMES and caps.tool_length == 0.2
    fitted = np.array(model_link_capsules())
    np.testing.assert_array_equal(caps.a, [0, 1, 2, 3, 4, 5, 6])
    np.testing.assert_array_equal(caps.b, [1, 2, 3, 4, 5, 6, 7])
    np.testing.assert_array_equal(caps.t0, np.append(fitted[:, 2], 0.0))
    np.testing.assert_array_equal(caps.t1, np.append(fitted[:, 3], 1.0))
    np.testing.assert_array_equal(caps.radius, np.append(fitted[:, 4], 0.07))
    assert caps.a.dtype == np.int64 and not caps.radius.flags.writeable
    given_radii = robot_capsules(link_radii=[0.1, 0.2, 0.3, 0.4, 0.5, 0.6], payload_radius=0.01)
    np.testing.assert_array_equal(given_radii.radius, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.01])
    assert ellipsoids.ROBOT_SEGMENTS == LINK_SEGMENTS == ((0, 1), (1, 2), (2, 3), (3, 4),
                                                           (4, 5), (5, 6))


@pytest.mark.parametrize("kwargs, match", [
    ({"link_radii": [0.1] * 5}, "link_radii"),
    ({"link_radii": [0.1] * 5 + [0.0]}, "link_radii"),
    ({"link_radii": [0.1] * 5 + [np.nan]}, "link_radii"),
    ({"link_radii": [0.1] * 5 + [-0.1]}, "link_radii"),
    ({"payload_radius": 0.0}, "payload_radius = 0.0"),
    ({"payload_radius": -0.05}, "payload_radius"),
    ({"payload_radius": math.inf}, "payload_radius"),
    ({"tool_length": -0.01}, "tool_length = -0.01"),
    ({"tool_length": math.nan}, "tool_length"),
])
def test_robot_capsules_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        robot_capsules(**{"payload_radius": 0.05, **kwargs})


def test_capsules_checks_its_arrays():
    with pytest.raises(ValueError, match="radius"):
        Capsules(("a", "b"), [0, 1], [1, 2], [0, 0], [1, 1], [0.1])
    with pytest.raises(ValueError, match="indices"):
        Capsules(("a",), [0], [8], [0], [1], [0.1])


def test_tool_point():
    point = tool_point()
    assert point.names == ("tool0",) and point.tool_length == 0.0
    assert list(point.a) == list(point.b) == [6]
    assert list(point.t0) == list(point.t1) == list(point.radius) == [0.0]
    q = np.random.default_rng(11).uniform(-3, 3, 6)
    ends, _ = capsule_ends(q, point)
    _assert_bitwise(ends[0, 0], ur5e.tool0_position(q))
    _assert_bitwise(ends[0, 1], ur5e.tool0_position(q))
