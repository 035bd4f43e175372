import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from safety_systems.speed_alteration.ellipsoids import (
    SHOULDER_WIDTH,
    Ellipsoids,
    danger_index,
    human_ellipsoids,
    robot_ellipsoids,
    segment_ellipsoids,
    spheres,
    support,
)
from safety_systems.config.scenario import EllipsoidConfig
from safety_systems.cell.ur5e import dh_frames

SETTINGS = settings(derandomize=True, max_examples=60, deadline=None)
coord = st.floats(-1.0, 1.0)
point = st.tuples(coord, coord, coord)
radius = st.floats(0.01, 0.3)
SIZES = EllipsoidConfig()


def _one(e: Ellipsoids, i: int) -> Ellipsoids:
    return Ellipsoids(e.centres[i:i + 1], e.rotations[i:i + 1], e.semi_axes[i:i + 1])


def _level(e: Ellipsoids, x: np.ndarray) -> np.ndarray:
    """|diag(1/r) R^T (x - c)|^2 of points x (M, 3) in a single ellipsoid (<= 1: inside)."""
    local = (x - e.centres[0]) @ e.rotations[0] / e.semi_axes[0]
    return np.sum(local * local, axis=-1)


def _random_ellipsoids(rng: np.random.Generator, n: int) -> Ellipsoids:
    return Ellipsoids(rng.uniform(-0.3, 0.3, (n, 3)),
                      Rotation.random(n, random_state=rng).as_matrix(),
                      rng.uniform(0.02, 0.3, (n, 3)))


@pytest.mark.parametrize("d, expected", [(0.1, 1.0), (0.05, 4.0), (0.2, 0.25)])
def test_danger_index_of_5cm_spheres(d, expected):
    # Touching (d = r1 + r2): 1; overlapping: > 1; apart: < 1.
    di = danger_index(spheres([[0.0, 0.0, 0.0]], 0.05), spheres([[d, 0.0, 0.0]], 0.05))
    assert di.shape == (1, 1)
    assert di[0, 0] == pytest.approx(expected, rel=1e-12)


def test_coincident_centres_collide():
    assert danger_index(spheres([[1.0, 2.0, 3.0]], 0.01),
                        spheres([[1.0, 2.0, 3.0]], 0.01))[0, 0] == np.inf


@SETTINGS
@given(point, point, radius, radius)
def test_sphere_danger_index_formula(c1, c2, r1, r2):
    d = float(np.linalg.norm(np.subtract(c2, c1)))
    di = danger_index(spheres([c1], r1), spheres([c2], r2))[0, 0]
    if d < 1e-6:
        return
    assert di == pytest.approx(((r1 + r2) / d) ** 2, rel=1e-9)


def test_overlapping_pairs_are_never_reported_apart():
    # Points sampled inside a; if any lies inside b the two overlap, so DI must be >= 1.
    rng = np.random.default_rng(4)
    overlapping = apart = 0
    for _ in range(400):
        pair = _random_ellipsoids(rng, 2)
        a, b = _one(pair, 0), _one(pair, 1)
        w = rng.normal(size=(3000, 3))
        w *= rng.uniform(0, 1, (3000, 1)) ** (1 / 3) / np.linalg.norm(w, axis=1, keepdims=True)
        inside_a = a.centres[0] + (w * a.semi_axes[0]) @ a.rotations[0].T
        assert np.all(_level(a, inside_a) <= 1 + 1e-9)
        di = danger_index(a, b)[0, 0]
        if np.any(_level(b, inside_a) <= 1.0):
            overlapping += 1
            assert di >= 1.0, (pair, di)
        elif di < 1.0:
            apart += 1
    assert overlapping > 50 and apart > 50  # both cases were exercised


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.integers(1, 4), st.integers(1, 4))
def test_danger_index_is_symmetric(seed, n, m):
    rng = np.random.default_rng(seed)
    a, b = _random_ellipsoids(rng, n), _random_ellipsoids(rng, m)
    ab, ba = danger_index(a, b), danger_index(b, a)
    assert ab.shape == (n, m)
    np.testing.assert_allclose(ab, ba.T, rtol=1e-12)


def test_danger_index_broadcasts_leading_axes_pair_by_pair():
    # a with leading axes (4, 2), b with (2,) only: every pair equals the definition
    # ((h_a(u) + h_b(u)) / d)^2 with the support functions along the centre offset.
    rng = np.random.default_rng(11)
    a = Ellipsoids(rng.uniform(-0.3, 0.3, (4, 2, 3, 3)),
                   Rotation.random(24, random_state=rng).as_matrix().reshape(4, 2, 3, 3, 3),
                   rng.uniform(0.02, 0.3, (4, 2, 3, 3)))
    b = _random_ellipsoids(rng, 5)
    b = Ellipsoids(np.stack([b.centres, b.centres + 0.1]), np.stack([b.rotations] * 2),
                   np.stack([b.semi_axes] * 2))
    di = danger_index(a, b)
    assert di.shape == (4, 2, 3, 5)
    for i, j, k, m in np.ndindex(di.shape):
        x = b.centres[j, m] - a.centres[i, j, k]
        d = np.linalg.norm(x)
        h = (support(a.rotations[i, j, k], a.semi_axes[i, j, k], x / d)
             + support(b.rotations[j, m], b.semi_axes[j, m], x / d))
        assert di[i, j, k, m] == pytest.approx((h / d) ** 2, rel=1e-12)


def test_danger_index_of_undefined_centres_is_a_collision():
    a = spheres([[np.nan, 0.0, 0.0], [0.0, 0.0, 0.0]], 0.05)
    di = danger_index(a, spheres([[1.0, 0.0, 0.0]], 0.05))[:, 0]
    assert di[0] == np.inf
    assert di[1] == pytest.approx(0.01, rel=1e-12)


def test_support_of_axis_aligned_ellipsoid_is_the_semi_axis():
    semi = np.array([0.3, 0.2, 0.1])
    for i, u in enumerate(np.eye(3)):
        assert support(np.eye(3), semi, u) == pytest.approx(semi[i])
        assert support(np.eye(3), semi, -u) == pytest.approx(semi[i])
    # Rotated a quarter turn about z: the long axis now points along y.
    R = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    assert support(R, semi, np.array([0.0, 1.0, 0.0])) == pytest.approx(0.3)
    assert support(R, semi, np.array([1.0, 0.0, 0.0])) == pytest.approx(0.2)
    diag = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    assert support(np.eye(3), semi, diag) == pytest.approx(np.sqrt((0.09 + 0.04) / 2))


@pytest.mark.parametrize("axis", [(0, 0, 1), (0, 0, -1), (1, 0, -1e-17), (1, 0, 0),
                                  (0, -1, 0), (0, 0, 0)])
def test_segment_frame_on_the_axes(axis):
    # Straight up, straight down, a z component of either sign about 0, and a point.
    e = segment_ellipsoids(np.zeros((1, 3)), np.array([axis], dtype=float), 0.05)
    R = e.rotations[0]
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
    if any(axis):
        np.testing.assert_allclose(R[:, 0], np.array(axis) / np.linalg.norm(axis))


@SETTINGS
@given(point, point, st.floats(0.01, 0.2))
def test_segment_ellipsoid(start, end, r):
    start, end = np.array(start), np.array(end)
    length = float(np.linalg.norm(end - start))
    e = segment_ellipsoids(start[None], end[None], r)
    np.testing.assert_allclose(e.centres[0], (start + end) / 2, atol=1e-12)
    np.testing.assert_allclose(e.semi_axes[0], [length / 2 + r, r, r], atol=1e-12)
    np.testing.assert_allclose(e.rotations[0].T @ e.rotations[0], np.eye(3), atol=1e-9)
    assert np.linalg.det(e.rotations[0]) == pytest.approx(1.0)  # right-handed
    assert np.all(_level(e, np.array([start, end])) <= 1.0 + 1e-9)
    if length > 1e-6:  # the long axis lies along the segment, reaching r past each end
        axis = (end - start) / length
        np.testing.assert_allclose(abs(e.rotations[0][:, 0] @ axis), 1.0, atol=1e-9)
        tips = np.array([start - r * axis, end + r * axis])
        np.testing.assert_allclose(_level(e, tips), 1.0, atol=1e-6)


def test_robot_ellipsoids_shape_and_tool_sphere():
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (5, 6))
    frames = dh_frames(q)
    full = robot_ellipsoids(q, SIZES.link_radii, 0.05, tool_offset=0.1)
    assert full.centres.shape == (5, 7, 3) and full.rotations.shape == (5, 7, 3, 3)
    origins = frames[..., :3, 3]
    np.testing.assert_allclose(full.centres[:, :6], (origins[:, :6] + origins[:, 1:]) / 2,
                               atol=1e-12)
    np.testing.assert_allclose(full.semi_axes[:, :6, 1], np.broadcast_to(SIZES.link_radii, (5, 6)))
    tool = robot_ellipsoids(q[0], [], 0.07, tool_offset=-0.05)
    assert tool.centres.shape == (1, 3)
    np.testing.assert_allclose(tool.centres[0],
                               frames[0, 6, :3, 3] - 0.05 * frames[0, 6, :3, 2], atol=1e-12)
    np.testing.assert_allclose(tool.semi_axes[0], [0.07] * 3)
    np.testing.assert_allclose(full.centres[:, 6],
                               origins[:, 6] + 0.1 * frames[:, 6, :3, 2], atol=1e-12)


def _arms(e: Ellipsoids):
    """(shoulders, elbows, hands) (..., 2, 3) read back from the arm segments."""
    def ends(i):
        axis = e.rotations[..., i, :, 0]
        half = (e.semi_axes[..., i, 0] - e.semi_axes[..., i, 1])[..., None]
        return e.centres[..., i, :] - half * axis, e.centres[..., i, :] + half * axis
    fore = [ends(2), ends(3)]
    upper = [ends(4), ends(5)]
    return (np.stack([u[0] for u in upper], -2), np.stack([f[0] for f in fore], -2),
            np.stack([f[1] for f in fore], -2), np.stack([u[1] for u in upper], -2))


hands_strategy = st.tuples(point, point).map(
    lambda h: np.array(h) * [1.5, 1.5, 0.5] + [0.0, 0.0, 1.0])


@SETTINGS
@given(hands_strategy)
def test_human_ellipsoids_structure(hands):
    e = human_ellipsoids(hands, SIZES)
    assert e.centres.shape == (8, 3) and e.semi_axes.shape == (8, 3)
    for field in (e.centres, e.rotations, e.semi_axes):
        assert np.all(np.isfinite(field))
    np.testing.assert_allclose(e.centres[:2], hands)
    np.testing.assert_allclose(e.semi_axes[:2], SIZES.hand_radius)
    np.testing.assert_allclose(e.semi_axes[6], SIZES.head_radius)
    np.testing.assert_allclose(e.semi_axes[7], SIZES.torso_semi_axes)
    shoulders, elbows, fore_end, upper_end = _arms(e)
    np.testing.assert_allclose(fore_end, hands, atol=1e-9)  # forearms end at the hands
    np.testing.assert_allclose(upper_end, elbows, atol=1e-9)  # and start at the elbows
    assert np.linalg.norm(shoulders[0] - shoulders[1]) == pytest.approx(SHOULDER_WIDTH)
    # Arms do not cross: along the operator's left, each hand's shoulder is on its side.
    forward = -np.r_[hands.mean(axis=0)[:2], 0.0]
    if np.linalg.norm(forward) > 1e-6:
        left = np.cross([0.0, 0.0, 1.0], forward / np.linalg.norm(forward))
        hand_gap = (hands[0] - hands[1]) @ left
        shoulder_gap = (shoulders[0] - shoulders[1]) @ left
        if abs(hand_gap) > 1e-9:
            assert np.sign(shoulder_gap) == np.sign(hand_gap)


def test_arms_follow_the_hands_when_swapped():
    hands = np.array([[1.0, 0.2, 1.0], [1.0, -0.2, 1.0]])
    for order in ([0, 1], [1, 0]):
        shoulders = _arms(human_ellipsoids(hands[order], SIZES))[0]
        # Each shoulder is on the same side (sign of y) as its own hand.
        np.testing.assert_array_equal(np.sign(shoulders[:, 1]), np.sign(hands[order, 1]))


@pytest.mark.parametrize("hands", [
    [[0.8, 0.0, 1.0], [0.8, 0.0, 1.0]],  # together
    [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]],  # above the base
    [[-0.1, 0.0, 1.0], [0.1, 0.0, 1.0]],  # either side of the base
    [[3.0, -2.0, 1.0], [-3.0, 2.0, 0.2]],  # far apart
])
def test_human_ellipsoids_finite_in_corner_cases(hands):
    e = human_ellipsoids(np.array(hands), SIZES)
    for field in (e.centres, e.rotations, e.semi_axes):
        assert np.all(np.isfinite(field))
    assert np.all(e.semi_axes > 0)
    batched = human_ellipsoids(np.array([hands, hands]), SIZES)
    assert batched.centres.shape == (2, 8, 3)
    np.testing.assert_allclose(batched.centres[1], e.centres)
