"""Any robot model in a Drake MultibodyPlant: ``AddRobot`` and its inverse dynamics."""

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex, MultibodyForces

from safety_systems.cell.robot_model import RobotModel


def AddRobot(plant: MultibodyPlant, model: RobotModel, *,
             model_name: str | None = None) -> ModelInstanceIndex:
    """Parses ``model``'s URDF into ``plant`` (an instance named ``model_name``, by default
    the model's name) and welds its base link to the world origin. Only the model's
    joints move: a moving joint off its chain (a gripper's fingers) is welded where its
    position is 0 (its coupler constraints, such as a ``<mimic>``, removed); every joint of
    the chain gets an actuator if the URDF gives it none (limited to its effort limit)."""
    parser = Parser(plant, model.name if model_name is None else model_name)
    (instance,) = parser.AddModels(str(model.urdf))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(model.base_link, instance),
                     RigidTransform())
    chain = set(model.joint_names)
    off_chain = [plant.get_joint(j) for j in plant.GetJointIndices(instance)
                 if plant.get_joint(j).num_velocities() > 0
                 and plant.get_joint(j).name() not in chain]
    if off_chain:
        for constraint in plant.GetConstraintIds():
            plant.RemoveConstraint(constraint)
        for joint in off_chain:
            for a in plant.GetJointActuatorIndices():  # (by instance: empty until Finalize)
                if plant.get_joint_actuator(a).joint().index() == joint.index():
                    plant.RemoveJointActuator(plant.get_joint_actuator(a))
            parent, child = joint.frame_on_parent(), joint.frame_on_child()
            plant.RemoveJoint(joint)
            plant.WeldFrames(parent, child, RigidTransform())
    actuated = {plant.get_joint_actuator(a).joint().name()
                for a in plant.GetJointActuatorIndices()
                if plant.get_joint_actuator(a).model_instance() == instance}
    for k, name in enumerate(model.joint_names):
        if name not in actuated:
            plant.AddJointActuator(f"{name}_actuator", plant.GetJointByName(name, instance),
                                   float(model.effort_limit[k]))
    return instance


def robot_plant(model: RobotModel, time_step: float = 0.0) -> MultibodyPlant:
    """A finalized plant of ``model`` alone (:func:`AddRobot`)."""
    plant = MultibodyPlant(time_step)
    AddRobot(plant, model)
    plant.Finalize()
    return plant


def inverse_dynamics_torques(model: RobotModel, q: np.ndarray, v: np.ndarray,
                             a: np.ndarray) -> np.ndarray:
    """(T, n) joint torques of ``model``'s plant for the motion q, v, a (T, n), in the
    model's joint order: ``MultibodyPlant.CalcInverseDynamics`` with no applied forces,
    so M(q) a + C(q, v) v without gravity (the plant's force elements, gravity among
    them, are not evaluated into the forces)."""
    plant = robot_plant(model)
    context = plant.CreateDefaultContext()
    forces = MultibodyForces(plant)
    out = np.empty_like(q)
    for i in range(len(q)):
        plant.SetPositions(context, q[i])
        plant.SetVelocities(context, v[i])
        out[i] = plant.CalcInverseDynamics(context, a[i], forces)
    return out
