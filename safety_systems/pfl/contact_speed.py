"""The permissible relative speed of a contact between the robot and a body region, from
ISO/TS 15066:2016 Annex A's energy model (clause A.3), as plain vectorised functions.

The model: a contact transfers the energy E = F^2 / (2 k) = (p A)^2 / (2 k) into the body
region (spring constant k, force F, or pressure p over the contact area A), and the two
bodies bring E = mu v^2 / 2 with them (v their relative speed, mu the two-body reduced
mass). Holding F and p A at their limits gives the permissible relative speed

    v_max = F_max / sqrt(mu k)    and    v_max = p_max A / sqrt(mu k),

the lesser of the two where a contact area is known. With

    mu = (1 / m_H + 1 / m_R)^-1    (Eq. A.3; m_H the region's effective mass, Table A.3)
    m_R = M / 2 + m_L              (Eq. A.4; M the mass of the robot's moving parts, m_L
                                    the effective payload: tooling and workpiece)

Equation numbers: A.3 and A.4 as two independent transcriptions of Annex A give them; the
speed relations are numbered A.5 (force) and A.6 (pressure) by a public PFL calculator and
the energy relations come before them; those numbers were not checked against the
standard's own text.

Interpretation (ours): k is the table's figure in N/mm taken as N/m times 1000; the
pressure relation needs the contact area (square metres here), which Annex A takes as the
smaller of the robot's and the body's surfaces at the contact. The table's pressures were
measured over about 2 cm^2; over a larger area the pressure relation allows more than the
measurements support, so ``contact_area`` None (force only) is the default. Which
relative speed (the robot's along the contact normal, or the closing speed of both) the
verifier measures is the next stage's choice.

Units: SI throughout (newtons, pascals, square metres, newtons per metre, kilograms,
metres per second).
"""

import numpy as np

from safety_systems.pfl.body_regions import BodyRegion


def robot_effective_mass(moving_mass, payload):
    """m_R = M / 2 + m_L (Eq. A.4): the robot's effective mass, kilograms, from the mass of
    its moving parts ``moving_mass`` and its effective payload ``payload`` (tooling and
    workpiece), both kilograms. Raises ``ValueError`` for a mass that is negative or not
    finite."""
    M, m_L = np.asarray(moving_mass, dtype=float), np.asarray(payload, dtype=float)
    for name, value in (("moving_mass", M), ("payload", m_L)):
        if not np.all(np.isfinite(value) & (value >= 0.0)):
            raise ValueError(f"{name} = {value!r}; need finite kilograms >= 0")
    return M / 2.0 + m_L


def reduced_mass(human_mass, robot_mass):
    """mu = (1 / m_H + 1 / m_R)^-1 (Eq. A.3), kilograms, written m_H m_R / (m_H + m_R) so
    that a massless robot gives 0."""
    m_H, m_R = np.asarray(human_mass, dtype=float), np.asarray(robot_mass, dtype=float)
    return m_H * m_R / (m_H + m_R)


def speed_from_force(force, mu, spring_constant):
    """v = F / sqrt(mu k): the relative speed at which a contact reaches the force
    ``force`` (newtons), metres per second; ``mu`` kilograms, ``spring_constant`` newtons
    per metre. A zero force gives 0; a zero reduced mass an infinite speed."""
    F = np.asarray(force, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(F > 0.0, F / np.sqrt(np.asarray(mu) * np.asarray(spring_constant)),
                        0.0)


def speed_from_pressure(pressure, area, mu, spring_constant):
    """v = p A / sqrt(mu k): the relative speed at which a contact over ``area`` (square
    metres) reaches the pressure ``pressure`` (pascals), metres per second."""
    return speed_from_force(np.asarray(pressure, dtype=float) * np.asarray(area, dtype=float),
                            mu, spring_constant)


def permissible_speed(force, mu, spring_constant, *, pressure=None, area=None):
    """The permissible relative speed, metres per second: :func:`speed_from_force`, and
    the lesser of it and :func:`speed_from_pressure` when both ``pressure`` (pascals) and
    ``area`` (square metres) are given."""
    v = speed_from_force(force, mu, spring_constant)
    if pressure is not None and area is not None:
        v = np.minimum(v, speed_from_pressure(pressure, area, mu, spring_constant))
    return v


def transient_speed(region: BodyRegion, robot_mass, *, contact_area=None):
    """The permissible relative speed of a transient contact with ``region``, metres per
    second, for a robot of effective mass ``robot_mass`` (kilograms, m_R: see
    :func:`robot_effective_mass`; an array gives one speed each): the transient force
    (and pressure over ``contact_area``, square metres, if given) of Table A.2, the
    region's effective mass and spring constant of Table A.3. 0 where the region permits
    no transient contact."""
    mu = reduced_mass(region.effective_mass, robot_mass)
    return permissible_speed(region.transient_force, mu, region.spring_constant,
                             pressure=region.transient_pressure, area=contact_area)
