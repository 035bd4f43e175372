"""HwangSpeedController: the collision-trend baseline of seed 004 (Eq. 13, Hwang et al. 2003)."""

from safety_systems.speed_alteration.methods import hwang_speed
from safety_systems.systems.speed_alteration_controller import SpeedAlterationController


class HwangSpeedController(SpeedAlterationController):
    """Selects, among ``hwang_candidates`` speeds evenly spread over [-limit, limit], the
    one of least penalty index and then least Eq. 13 (collision-trend index of the
    ellipsoids read as Gaussians, ``speed_alteration.hwang_speed``, which says how each
    term was read); the ports are ``SpeedAlterationController``'s."""

    def __init__(self, *, path, config, operator_of, is_hand, offset_sec: float = 0.0) -> None:
        self.grid_size = config.hwang_candidates
        super().__init__(path=path, config=config, operator_of=operator_of, is_hand=is_hand,
                         offset_sec=offset_sec)

    def choose(self, *, s, v_prev, danger, danger_now, gap, k) -> float:
        return hwang_speed(grid_speeds=self._speeds, danger=danger, danger_now=danger_now,
                           v_pre=self._v_pre)
