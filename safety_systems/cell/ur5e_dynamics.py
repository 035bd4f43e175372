"""The UR5e model's inverse dynamics (a Drake MultibodyPlant of ``models/ur5e/``)."""

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import MultibodyForces

from safety_systems.cell.ur5e import AddUr5e


def inverse_dynamics_torques(q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """(T, 6) joint torques of the UR5e model for the given motion:
    ``CalcInverseDynamics`` with no applied forces, so M(q) a + C(q, v) v without gravity
    (the plant's force elements, gravity among them, are not evaluated into the forces)."""
    plant = MultibodyPlant(0.0)
    AddUr5e(plant)
    plant.Finalize()
    context = plant.CreateDefaultContext()
    forces = MultibodyForces(plant)
    out = np.empty_like(q)
    for i in range(len(q)):
        plant.SetPositions(context, q[i])
        plant.SetVelocities(context, v[i])
        out[i] = plant.CalcInverseDynamics(context, a[i], forces)
    return out
