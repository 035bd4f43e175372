"""The lens ball (``cell.ball_bounds.lens_ball``): it holds every point of both balls'
intersection (their extreme points: the circle where the spheres meet and each cap's
apex, and random points), it is never larger than the smaller ball where the balls meet,
it holds both balls where they do not, and NaN gives NaN."""

import math

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from safety_systems.cell.ball_bounds import lens_ball

coord = st.floats(-2.0, 2.0, allow_nan=False)
point = st.tuples(coord, coord, coord)
radius = st.floats(0.0, 2.0, allow_nan=False)
TOL = 1e-9


def _bound(a, ra, b, rb):
    c0, c1, c2, r = lens_ball(*a, ra, *b, rb)
    return np.array([c0, c1, c2]), r


def _lens_extremes(a, ra, b, rb, rng):
    """Points of B(a, ra) ∩ B(b, rb) that a bound must hold: the circle where the spheres
    meet (eight points of it), each cap's apex where it lies in the other ball, and random
    points of each sphere and ball that lie in the other ball."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = float(np.linalg.norm(b - a))
    out = []
    u = (b - a) / d if d > 0 else np.array([1.0, 0.0, 0.0])
    side = np.cross(u, [0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    other = np.cross(u, side)
    if abs(ra - rb) < d < ra + rb:
        x = (d * d + ra * ra - rb * rb) / (2 * d)
        h = math.sqrt(max(ra * ra - x * x, 0.0))
        for phi in np.linspace(0.0, 2 * math.pi, 8, endpoint=False):
            out.append(a + x * u + h * (math.cos(phi) * side + math.sin(phi) * other))
    for p in (a + ra * u, b - rb * u, a - ra * u, b + rb * u, a + ra * side, b + rb * side):
        if np.linalg.norm(p - a) <= ra and np.linalg.norm(p - b) <= rb:
            out.append(p)
    for c, r, c2, r2 in ((a, ra, b, rb), (b, rb, a, ra)):  # each cap's surface, and inside
        for k in range(60):
            v = rng.normal(size=3)
            p = c + r * (1.0 if k % 2 else rng.uniform() ** (1 / 3)) * v / np.linalg.norm(v)
            if np.linalg.norm(p - c2) <= r2:
                out.append(p)
    return out


@settings(max_examples=400, deadline=None)
@given(a=point, ra=radius, b=point, rb=radius, seed=st.integers(0, 2**32 - 1))
@example(a=(0.0, 0.0, 0.0), ra=1.0, b=(1.9, 0.0, 0.0), rb=1.0, seed=0)  # a thin lens
@example(a=(0.0, 0.0, 0.0), ra=1.0, b=(0.3, 0.0, 0.0), rb=1.0, seed=0)  # a fat one
@example(a=(0.0, 0.0, 0.0), ra=0.4, b=(0.5, 0.0, 0.0), rb=1.0, seed=0)  # x < 0: ball a
@example(a=(0.0, 0.0, 0.0), ra=1.0, b=(0.0, 0.0, 0.0), rb=1.0, seed=0)  # one ball twice
@example(a=(0.0, 0.0, 0.0), ra=1.5, b=(0.0, 0.0, 1.5), rb=5.960464477539063e-08,
         seed=0)  # barely meeting: r^2 by cancellation (2e-9 m short before rounding's bound)
def test_the_lens_ball_holds_the_intersection(a, ra, b, rb, seed):
    centre, r = _bound(a, ra, b, rb)
    d = math.dist(a, b)
    if d < ra + rb:  # they meet: no larger than either, and holds what both allow
        assert r <= min(ra, rb) + TOL
    for p in _lens_extremes(a, ra, b, rb, np.random.default_rng(seed)):
        assert np.linalg.norm(p - centre) <= r + TOL, (p, centre, r)


@settings(max_examples=200, deadline=None)
@given(a=point, ra=radius, b=point, rb=radius)
def test_balls_that_do_not_meet_give_a_ball_holding_both(a, ra, b, rb):
    if math.dist(a, b) <= (ra + rb) * (1.0 + 1e-12) + 1e-12:
        return  # (touching, to rounding: the intersection is a point, held)
    centre, r = _bound(a, ra, b, rb)
    assert np.linalg.norm(np.subtract(a, centre)) + ra <= r + TOL
    assert np.linalg.norm(np.subtract(b, centre)) + rb <= r + TOL


def test_the_closed_form_of_a_lens():
    # two unit balls 1.6 apart meet in a circle of radius 0.6 about their midpoint
    centre, r = _bound((0.0, 0.0, 0.0), 1.0, (1.6, 0.0, 0.0), 1.0)
    np.testing.assert_allclose(centre, [0.8, 0.0, 0.0], atol=1e-15)
    assert abs(r - 0.6) < 1e-12
    # a ball inside another: the inner one
    centre, r = _bound((0.0, 0.0, 0.0), 2.0, (0.5, 0.0, 0.0), 1.0)
    np.testing.assert_array_equal(centre, [0.5, 0.0, 0.0])
    assert r == 1.0


def test_nan_gives_nan():
    for args in (((math.nan, 0.0, 0.0), 1.0, (0.0, 0.0, 0.0), 1.0),
                 ((0.0, 0.0, 0.0), math.nan, (0.0, 0.0, 0.0), 1.0),
                 ((0.0, 0.0, 0.0), 1.0, (0.0, 0.0, 0.0), math.nan)):
        centre, r = _bound(*args)
        assert math.isnan(r) and np.all(np.isnan(centre))
