import numpy as np
import pytest

from safety_systems.cell.operator_paths import (
    ScriptedOperator,
    make_operator_path,
    operators_bodies_state,
)
from safety_systems.systems.operator_motion import OperatorMotion


def _operators(count: int = 2):
    walk = make_operator_path([0, 0.5, 4.0], [[2, 0, 0], [0.5, 0, 0], [0.5, 1.5, 0]], 1.6, 2.0)
    still = make_operator_path([0], [[-1, 1, 0]], 1.6, 2.0)
    ops = [
        ScriptedOperator(path=walk, body_offsets=[[0, 0.2, 1.0], [0, -0.2, 1.0], [0, 0, 1.7]],
                         enter_time=0.25, leave_time=3.0),
        ScriptedOperator(path=still, body_offsets=[[0, 0, 1.1]], enter_time=1.0),
    ]
    return (ops * 3)[:count]


def test_outputs_match_operators_bodies_state():
    ops = _operators()
    motion = OperatorMotion(operators=ops)
    assert motion.num_bodies == 4
    for name, size in (("positions_true", 12), ("velocities_true", 12), ("present", 4)):
        assert motion.GetOutputPort(name).size() == size
    assert motion.num_input_ports() == 0
    context = motion.CreateDefaultContext()
    seen = []
    for t in (0.0, 0.3, 0.9, 1.0, 2.5, 3.0, 4.7, 9.0):
        context.SetTime(t)
        got = [motion.GetOutputPort(n).Eval(context)
               for n in ("positions_true", "velocities_true", "present")]
        want = operators_bodies_state(ops, t)
        for g, w in zip(got, want):
            np.testing.assert_allclose(g, w, rtol=1e-14, atol=1e-14, err_msg=f"t={t}")
        seen.append(np.concatenate(got))
    # Changing the time changed the outputs (the cache follows time).
    assert all(not np.array_equal(a, b) for a, b in zip(seen[:-1], seen[1:]))


def test_hand_checked_values():
    motion = OperatorMotion(operators=_operators())
    context = motion.CreateDefaultContext()
    context.SetTime(0.2)  # walker not yet entered, still holding its start; still one absent
    np.testing.assert_array_equal(motion.GetOutputPort("present").Eval(context), [0, 0, 0, 0])
    np.testing.assert_allclose(motion.GetOutputPort("positions_true").Eval(context)[:3],
                               [2, 0.2, 1.0])
    # Walker leaves x = 2 along -x at 0.5 s accelerating at 2 m/s^2 (0.8 s up to 1.6 m/s):
    # at 1.2 s it has moved 0.5 * 2 * 0.7^2 = 0.49 m and walks at 1.4 m/s.
    context.SetTime(1.2)
    np.testing.assert_array_equal(motion.GetOutputPort("present").Eval(context), [1, 1, 1, 1])
    p = motion.GetOutputPort("positions_true").Eval(context).reshape(4, 3)
    np.testing.assert_allclose(p, [[1.51, 0.2, 1.0], [1.51, -0.2, 1.0], [1.51, 0, 1.7],
                                   [-1, 1, 1.1]], atol=1e-12)
    v = motion.GetOutputPort("velocities_true").Eval(context).reshape(4, 3)
    np.testing.assert_allclose(v, [[-1.4, 0, 0]] * 3 + [[0, 0, 0]], atol=1e-12)
    context.SetTime(3.5)  # walker left (leave_time 3.0); its bodies keep following the script
    np.testing.assert_array_equal(motion.GetOutputPort("present").Eval(context), [0, 0, 0, 1])
    np.testing.assert_allclose(motion.GetOutputPort("positions_true").Eval(context)[6:9],
                               [0.5, 0, 1.7])


def test_five_operators_accepted():
    motion = OperatorMotion(operators=_operators(5))
    assert motion.num_bodies == 3 + 1 + 3 + 1 + 3
    context = motion.CreateDefaultContext()
    context.SetTime(2.0)
    np.testing.assert_allclose(motion.GetOutputPort("positions_true").Eval(context),
                               operators_bodies_state(_operators(5), 2.0)[0])


@pytest.mark.parametrize("count", [0, 6])
def test_rejects_zero_or_six_operators(count):
    with pytest.raises(ValueError, match=f"operators has {count} entries: allowed 1 to 5"):
        OperatorMotion(operators=_operators(count))


def test_rejects_non_operator():
    with pytest.raises(ValueError, match=r"operators\[1\]"):
        OperatorMotion(operators=[_operators(1)[0], "walker"])
