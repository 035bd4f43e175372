"""The IAPF field (seed 001, Eqs. 2-4): every force is minus the gradient of its
potential, checked against finite differences."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from safety_systems.planning.potential_field import (
    attractive_gradient,
    attractive_potential,
    d_factor,
    d_factor_gradient,
    field_from_scene,
    repulsive_forces,
    repulsive_potential,
    total_force,
    total_potential,
)
from safety_systems.planning.task_space import load_scene, signed_distances

PAPER = Path(__file__).parents[1] / "models" / "scenes" / "paper.yaml"
GOAL = np.array([70.0, 30.0, 5.0])  # cm, the seed's units
H = 1e-6


def _numeric_gradient(f, q, h=H):
    return np.stack([(f(q + h * e) - f(q - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)


@pytest.mark.parametrize("radius", [4.0, 30.0], ids=["quadratic", "conic"])
def test_attractive_gradient_in_both_regimes(radius):
    rng = np.random.default_rng(2)
    direction = rng.standard_normal((50, 3))
    q = GOAL + radius * direction / np.linalg.norm(direction, axis=1, keepdims=True)
    d_goal = 10.0

    def u(x):
        return attractive_potential(x, GOAL, 0.03, d_goal)

    np.testing.assert_allclose(attractive_gradient(q, GOAL, 0.03, d_goal),
                               _numeric_gradient(u, q), rtol=1e-6, atol=1e-9)
    # Conic: a constant pull K_att d*_goal (Eq. 2c scaled); quadratic: K_att d.
    magnitude = np.linalg.norm(attractive_gradient(q, GOAL, 0.03, d_goal), axis=1)
    np.testing.assert_allclose(magnitude, 0.03 * min(radius, d_goal))


def test_attractive_pieces_join_continuously():
    d_goal = 10.0
    inside = GOAL + np.array([[d_goal * (1 - 1e-9), 0.0, 0.0]])
    outside = GOAL + np.array([[d_goal * (1 + 1e-9), 0.0, 0.0]])
    for f in (attractive_potential, attractive_gradient):
        np.testing.assert_allclose(f(inside, GOAL, 0.03, d_goal),
                                   f(outside, GOAL, 0.03, d_goal), rtol=1e-7)
    # The seed's printed constant K_att / (2 d*^2) would leave a step of about 1.5 here.
    assert attractive_potential(inside, GOAL, 0.03, d_goal)[0] == pytest.approx(1.5)


def test_d_factor_and_its_gradient():
    q = np.array([[10.0, 70.0, 15.0], [40.0, 50.0, 10.0]])
    np.testing.assert_allclose(d_factor(q, GOAL, 2.0, True),
                               np.sum((q - GOAL) ** 2, axis=1))
    np.testing.assert_allclose(d_factor(q, GOAL, 2.0, False), [1.0, 1.0])
    for n in (0.5, 1.0, 2.0, 3.0):
        np.testing.assert_allclose(d_factor_gradient(q, GOAL, n, True), _numeric_gradient(
            lambda x, n=n: d_factor(x, GOAL, n, True), q), rtol=1e-6)
    assert not d_factor_gradient(q, GOAL, 2.0, False).any()


@pytest.mark.parametrize("flag", [True, False], ids=["d_factor", "plain"])
def test_repulsive_forces_are_minus_the_gradient(flag):
    s = load_scene(PAPER)
    field = dataclasses.replace(field_from_scene(s), flag=flag).in_unit
    # Points around O1 (30, 55) cm, inside its 4 cm zone and outside it, in cm.
    rng = np.random.default_rng(3)
    angle = rng.uniform(0, 2 * np.pi, 60)
    gap = rng.uniform(0.5, 6.0, 60)
    q = np.column_stack([30 + (3 + gap) * np.cos(angle), 55 + (3 + gap) * np.sin(angle),
                         rng.uniform(2, 18, 60)])

    def rho_of(x):
        return signed_distances(x / 100.0, field.obstacles)[0] * 100.0

    def u(x):
        return repulsive_potential(rho_of(x), field.zeta, field.k_rep,
                                   d_factor(x, field.goal, field.n, field.flag)).sum(axis=1)

    rho, grad = signed_distances(q / 100.0, field.obstacles)
    f1, f2 = repulsive_forces(q, rho * 100.0, grad, field)
    np.testing.assert_allclose((f1 + f2).sum(axis=1), -_numeric_gradient(u, q, 1e-5),
                               rtol=1e-5, atol=1e-9)
    active = gap < 4.0
    assert np.abs(f1).sum(axis=(1, 2))[active].min() > 0.0
    assert not f1[~active].any() and not f2[~active].any()
    if flag:  # F(2) pulls towards the goal (Ge and Cui's n_RG)
        towards = (field.goal - q) / np.linalg.norm(field.goal - q, axis=1, keepdims=True)
        pull = f2.sum(axis=1)
        assert (np.einsum("ij,ij->i", pull[active], towards[active]) > 0).all()
    else:
        assert not f2.any()


def test_total_force_is_minus_the_gradient_of_the_total_potential_per_metre():
    s = load_scene(PAPER)
    for field in (field_from_scene(s), field_from_scene(s, baseline=True)):
        rng = np.random.default_rng(4)
        q = rng.uniform([0.1, 0.2, 0.02], [0.7, 0.7, 0.25], size=(300, 3))
        rho, _ = signed_distances(q, field.obstacles)
        q = q[rho.min(axis=1) > 0.005]
        numeric = -_numeric_gradient(lambda x, f=field: total_potential(x, f), q, 1e-8)
        np.testing.assert_allclose(total_force(q, field), numeric, rtol=1e-4, atol=1e-6)


def test_field_is_in_centimetres():
    s = load_scene(PAPER)
    field = field_from_scene(s)
    far = np.array([[0.10, 0.70, 0.15]])  # 72.8 cm from the goal, no obstacle within zeta
    # Conic attraction: |F| = K_att d*_goal per cm = 0.03 * 10 per cm = 30 per metre.
    assert np.linalg.norm(total_force(far, field)) == pytest.approx(30.0)
    assert total_potential(far, field)[0] == pytest.approx(0.03 * 10 * 72.80 - 1.5, rel=1e-4)
