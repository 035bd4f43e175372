"""BimodalSpeedController: Morato et al.'s stop/go baseline (seed 004, Section IV-B)."""

from safety_systems.speed_alteration.methods import bimodal_speed
from safety_systems.systems.speed_alteration_controller import SpeedAlterationController


class BimodalSpeedController(SpeedAlterationController):
    """The pre-programmed speed while every robot-operator ellipsoid pair is more than
    ``bimodal_clearance`` apart, else a stop; the ports are
    ``SpeedAlterationController``'s."""

    def choose(self, *, s, v_prev, danger, danger_now, gap, k) -> float:
        return bimodal_speed(gap, v_pre=self._v_pre, threshold=self._cfg.bimodal_clearance)
