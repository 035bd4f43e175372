"""PreprogrammedSpeedController: no speed alteration (the seed-004 reference run)."""

from safety_systems.systems.speed_alteration_controller import SpeedAlterationController


class PreprogrammedSpeedController(SpeedAlterationController):
    """Always the pre-programmed speed (Eq. 8), whatever the operators do; it still
    reports the danger index. The ports are ``SpeedAlterationController``'s."""

    def choose(self, *, s, v_prev, danger, danger_now, gap, k) -> float:
        return self._v_pre
