"""HwangSpeedController: the collision-trend baseline of seed 004 (Eq. 13, Hwang et al. 2003)."""

import numpy as np

from safety_systems.speed_alteration.methods import hwang_candidates, hwang_speed
from safety_systems.systems.speed_alteration_controller import SpeedAlterationController


class HwangSpeedController(SpeedAlterationController):
    """Selects, among the pre-programmed speed and the two speed limits, the one of least
    penalty index and then least Eq. 13, keeping to speeds that reduce the
    collision-trend sum while its speed is altered (``speed_alteration.hwang_speed``,
    which says how each term was read); the ports are ``SpeedAlterationController``'s."""

    def candidate_speeds(self) -> np.ndarray:
        return hwang_candidates(self._v_pre, self._cfg.speed_limit)

    def choose(self, *, s, v_prev, danger, danger_now, gap, k) -> float:
        return hwang_speed(speeds=self._speeds, danger=danger, danger_now=danger_now,
                           v_pre=self._v_pre, v_prev=v_prev)
