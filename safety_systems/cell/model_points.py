"""Every robot's rigid points and their velocities J(q) v, compiled, for any
``robot_model.RobotModel``.

Compiled code takes a model as plain arrays, :func:`model_arrays` (made once per model):

- a UR arm (``KIND_UR``): ``(dh,)``, its six DH constants; the points are
  ``ur_kinematics.points_from_trig`` of them (P0 ... P7), the cosines and sines kept in
  ``memo`` (15,) as ``ur_kinematics.trig_reusing`` keeps them (NaN at first);
- a chain (``KIND_CHAIN``): ``(X_parent, axes, kinds, X_tool, point_bodies,
  point_local)``; every point of the layout by ``chain_kinematics`` (the bodies' poses
  and twists in the work arrays ``poses`` (n + 1, 3, 4) and ``twists`` (n + 1, 2, 3)),
  then tool0 (the tool frame's origin) and the tip, tool0 + tool_length z_tool, moving
  at tool0's velocity + tool_length w x z_tool.

:func:`model_points_one` picks the kind when compiling, by the arrays' types (as
``joint_path.path_state_one`` picks a path's kind): a run-time branch would keep the
arrays' reference counting in the callers' loops. :func:`model_work` allocates the
work arrays (``memo``, ``poses``, ``twists``) a caller passes.
"""

import numba
import numpy as np
from numba.core import types
from numba.extending import overload

from safety_systems.cell.chain_kinematics import _point, body_poses_one
from safety_systems.cell.robot_model import KIND_UR, RobotModel
from safety_systems.cell.ur_kinematics import points_from_trig, tool0_from_trig, trig_reusing


def model_arrays(model: RobotModel, *, chain: bool = False) -> tuple:
    """What compiled code reads ``model`` from (see the module docstring); ``chain``: a
    UR arm's chain arrays instead of its closed form (the same points, by the chain's
    arithmetic: a check of one against the other). Made once per model."""
    key = "_chain_arrays" if chain else "_compiled_arrays"
    arrays = model.__dict__.get(key)
    if arrays is None:
        if model.kind == KIND_UR and not chain:
            arrays = (model.dh,)
        else:
            arrays = (model.X_parent, model.axes, model.kinds, model.X_tool,
                      model.point_bodies, model.point_local)
        model.__dict__[key] = arrays  # a cache beside the frozen fields
    return arrays


def model_work(model: RobotModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(memo (15,) NaN, poses (n + 1, 3, 4), twists (n + 1, 2, 3)): the work arrays of
    :func:`model_points_one` for ``model``."""
    return (np.full(15, np.nan), np.zeros((model.n + 1, 3, 4)), np.zeros((model.n + 1, 2, 3)))


def model_points_one(arrays, tool_length, q, v, memo, poses, twists, p, pv):
    """The model's points into p (P, 3) and their velocities J(q) v into pv (P, 3),
    metres and m/s, at joint positions q and velocities v (n,), ``arrays`` from
    :func:`model_arrays`, the work arrays from :func:`model_work`; compiled and callable
    from other compiled code (inlined). A UR's are ``robot_geometry.robot_points_one``'s
    for its constants, bit for bit. Called from Python, it runs the same compiled code."""
    _model_points_from_python(arrays, tool_length, q, v, memo, poses, twists, p, pv)


@numba.njit(cache=True)
def _model_points_from_python(arrays, tool_length, q, v, memo, poses, twists, p, pv):
    model_points_one(arrays, tool_length, q, v, memo, poses, twists, p, pv)


@overload(model_points_one, inline="always")  # no call (and array refcounts) per element
def _model_points_one(arrays, tool_length, q, v, memo, poses, twists, p, pv):
    if isinstance(arrays, types.BaseTuple) and len(arrays.types) == 1:  # a UR arm
        def ur(arrays, tool_length, q, v, memo, poses, twists, p, pv):
            points_from_trig(trig_reusing(q, memo), v, tool_length, arrays[0], p, pv)
        return ur

    def chain(arrays, tool_length, q, v, memo, poses, twists, p, pv):
        X_parent, axes, kinds, X_tool, bodies, local = arrays
        body_poses_one(X_parent, axes, kinds, q, v, poses, twists)
        for i in range(bodies.size):
            _point(poses, twists, bodies[i], local[i], p[i], pv[i])
        n, t = kinds.size, bodies.size
        _point(poses, twists, n, X_tool[:3, 3], p[t], pv[t])
        w0, w1, w2 = twists[n, 0, 0], twists[n, 0, 1], twists[n, 0, 2]
        z0 = poses[n, 0, 0] * X_tool[0, 2] + poses[n, 0, 1] * X_tool[1, 2] + poses[
            n, 0, 2] * X_tool[2, 2]
        z1 = poses[n, 1, 0] * X_tool[0, 2] + poses[n, 1, 1] * X_tool[1, 2] + poses[
            n, 1, 2] * X_tool[2, 2]
        z2 = poses[n, 2, 0] * X_tool[0, 2] + poses[n, 2, 1] * X_tool[1, 2] + poses[
            n, 2, 2] * X_tool[2, 2]
        p[t + 1, 0] = p[t, 0] + tool_length * z0
        p[t + 1, 1] = p[t, 1] + tool_length * z1
        p[t + 1, 2] = p[t, 2] + tool_length * z2
        pv[t + 1, 0] = pv[t, 0] + tool_length * (w1 * z2 - w2 * z1)
        pv[t + 1, 1] = pv[t, 1] + tool_length * (w2 * z0 - w0 * z2)
        pv[t + 1, 2] = pv[t, 2] + tool_length * (w0 * z1 - w1 * z0)
    return chain


def model_tool0_one(arrays, q, v, memo, poses, twists):
    """tool0's position and velocity (6 floats: p, then J(q) v) alone, of a model as
    :func:`model_points_one` takes it: a UR's ``ur_kinematics.tool0_from_trig`` (P6 of
    :func:`model_points_one`, bit for bit; ``ur5e.tool0_reusing_trig`` for the UR5e), a
    chain's tool frame origin. Compiled code only (inlined); from Python, the same."""
    return _model_tool0_from_python(arrays, q, v, memo, poses, twists)


@numba.njit(cache=True)
def _model_tool0_from_python(arrays, q, v, memo, poses, twists):
    return model_tool0_one(arrays, q, v, memo, poses, twists)


@overload(model_tool0_one, inline="always")  # no call (and array refcounts) per element
def _model_tool0_one(arrays, q, v, memo, poses, twists):
    if isinstance(arrays, types.BaseTuple) and len(arrays.types) == 1:  # a UR arm
        def ur(arrays, q, v, memo, poses, twists):
            return tool0_from_trig(trig_reusing(q, memo), v, arrays[0])
        return ur

    def chain(arrays, q, v, memo, poses, twists):
        X_parent, axes, kinds, X_tool, bodies, local = arrays
        body_poses_one(X_parent, axes, kinds, q, v, poses, twists)
        n = kinds.size
        out, out_v = np.empty(3), np.empty(3)
        _point(poses, twists, n, X_tool[:3, 3], out, out_v)
        return out[0], out[1], out[2], out_v[0], out_v[1], out_v[2]
    return chain


@numba.njit(cache=True)
def model_point_rows(arrays, tool_length, q, v, memo, poses, twists, p, pv):
    """:func:`model_points_one` of rows q, v (L, n) into p, pv (L, P, 3)."""
    for row in range(q.shape[0]):
        model_points_one(arrays, tool_length, q[row], v[row], memo, poses, twists, p[row],
                         pv[row])


def model_points(model: RobotModel, q: np.ndarray, v: np.ndarray | None = None,
                 tool_length: float = 0.0, *, chain: bool = False
                 ) -> tuple[np.ndarray, np.ndarray | None]:
    """The model's points (..., P, 3), metres, at joint positions q (..., n), and their
    velocities J(q) v (m/s) at joint velocities v (None when v is None); ``chain``: by a
    UR's chain arrays (:func:`model_arrays`)."""
    q = np.asarray(q, dtype=float)
    lead = q.shape[:-1] if v is None else np.broadcast_shapes(q.shape[:-1], np.shape(v)[:-1])
    n = model.n
    if q.shape[-1:] != (n,) or (v is not None and np.shape(v)[-1:] != (n,)):
        raise ValueError(f"q has shape {q.shape}: need (..., {n}) joint positions of the "
                         f"{model.name}")
    q_rows = np.ascontiguousarray(np.broadcast_to(q, lead + (n,))).reshape(-1, n)
    v_rows = (np.zeros_like(q_rows) if v is None else np.ascontiguousarray(
        np.broadcast_to(np.asarray(v, dtype=float), lead + (n,))).reshape(-1, n))
    P = model.num_points
    p, pv = np.empty((q_rows.shape[0], P, 3)), np.empty((q_rows.shape[0], P, 3))
    model_point_rows(model_arrays(model, chain=chain), float(tool_length), q_rows, v_rows,
                     *model_work(model), p, pv)
    return p.reshape(lead + (P, 3)), None if v is None else pv.reshape(lead + (P, 3))


def tool0_position(model: RobotModel):
    """A function q (..., n) -> tool0's position (..., 3) of ``model`` (for
    ``braking.tool_stopping_distance``)."""
    return lambda q: model_points(model, q)[0][..., model.tool0, :]
