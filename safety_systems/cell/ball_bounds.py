"""A ball certain to hold what two facts about a point allow together: the closed-form
bounding ball of the intersection of two balls (the lens), for the regions of the
operator's points (``cell.human_body``).

It rests on one lemma. **Cap lemma**: the part of a ball B(c, r) on the far side of a
plane at signed distance s >= 0 from c (a cap no larger than a hemisphere) lies in the ball
about the plane's foot c + s n of radius sqrt(r^2 - s^2). Proof: a point of the cap at t >=
s along n and rho across has rho^2 <= r^2 - t^2, so its squared distance from the foot is
(t - s)^2 + rho^2 <= r^2 - 2 t s + s^2 <= r^2 - s^2 (t s >= s^2).

A ball given as NaN (a NaN centre or radius) gives NaN: a bad estimate never makes a
small region. The function follows ``compiled_cache``'s conventions (inlined, one exit).
"""

import math

import numba

_EPS = 2.220446049250313e-16  # float64's machine epsilon


@numba.njit(cache=True, inline="always")
def lens_ball(a0, a1, a2, ra, b0, b1, b2, rb):
    """(centre x, y, z, radius) of a ball holding B(a, ra) ∩ B(b, rb), the smallest of
    the sound candidates in closed form (d = |b - a|):

    - one ball inside the other (d + r_small <= r_large): the smaller ball;
    - the balls meet in a circle, in the plane at x = (d^2 + ra^2 - rb^2) / (2 d) from a
      along a -> b. The lens is a cap of each ball cut by that plane. For 0 <= x <= d
      both caps are at most hemispheres, and by the cap lemma both lie in the ball about
      the circle's centre of the circle's radius sqrt(ra^2 - x^2) (= sqrt(rb^2 - (d -
      x)^2)), at most min(ra, rb), widened by a bound on float64's rounding (where the
      balls barely meet the radius is a difference of near-equal squares: without it a
      point of the lens lay 2e-9 m outside). For x < 0 the lens holds a's equator (its points are
      sqrt(d^2 + ra^2) < rb from b), so no ball smaller than B(a, ra) holds it: that
      ball (and B(b, rb) for x > d);
    - the balls disjoint or touching (d >= ra + rb, the facts contradict each other: a
      premise is broken, by a larger person or an estimate off by more than its
      allowance): the smallest ball holding both, never a small one."""
    d0, d1, d2 = b0 - a0, b1 - a1, b2 - a2
    d = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    c0, c1, c2, r = a0, a1, a2, ra  # B(a, ra) unless a smaller sound ball is found
    if math.isnan(d) or math.isnan(ra) or math.isnan(rb):
        c0, c1, c2, r = math.nan, math.nan, math.nan, math.nan
    elif d + rb <= ra:
        c0, c1, c2, r = b0, b1, b2, rb
    elif d + ra <= rb:
        pass
    elif d >= ra + rb:
        r = 0.5 * (d + ra + rb)
        w = (r - ra) / d
        c0, c1, c2 = a0 + w * d0, a1 + w * d1, a2 + w * d2
    else:  # d > |ra - rb| >= 0 here, so d > 0
        x = (d * d + (ra - rb) * (ra + rb)) / (2.0 * d)
        if x > d:
            c0, c1, c2, r = b0, b1, b2, rb
        elif x >= 0.0:
            w = x / d
            c0, c1, c2 = a0 + w * d0, a1 + w * d1, a2 + w * d2
            # rounding, outward: r^2 by both of its forms (each cancels where the other
            # does not) plus a bound on their error, the circle's centre off by at most
            # the error of x (never more than d, since 0 <= x <= d) and that of the sum
            big = ra * ra + rb * rb + d * d
            y = d - x
            r2 = max((ra - x) * (ra + x), (rb - y) * (rb + y), 0.0)
            r = (math.sqrt(r2 + 16.0 * _EPS * big) + min(d, 8.0 * _EPS * big / d)
                 + 4.0 * _EPS * (abs(a0) + abs(a1) + abs(a2) + abs(b0) + abs(b1) + abs(b2)))
            if r >= min(ra, rb):  # (widened past a ball: that ball, sound as it is)
                c0, c1, c2, r = (a0, a1, a2, ra) if ra <= rb else (b0, b1, b2, rb)
    return c0, c1, c2, r
