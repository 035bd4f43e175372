"""ErgaSpeedController: the seed-004 speed alteration by an elite real-coded GA."""

import numpy as np

from safety_systems.speed_alteration.erga import ErgaParameters
from safety_systems.speed_alteration.methods import erga_speed
from safety_systems.systems.speed_alteration_controller import SpeedAlterationController


class ErgaSpeedController(SpeedAlterationController):
    """Selects the speed minimising Eqs. 11-12 with the ERGA (Fig. 1), at the paper's
    10 Hz by default; the ports are ``SpeedAlterationController``'s.

    Each decision k draws from ``numpy.random.default_rng([seed, k])``, so a run is
    repeatable and a decision does not depend on how many came before it.
    """

    def __init__(self, *, path, config, operator_of, is_hand, offset_sec: float = 0.0) -> None:
        super().__init__(path=path, config=config, operator_of=operator_of, is_hand=is_hand,
                         offset_sec=offset_sec)
        self._params = ErgaParameters(config.population, config.generations,
                                      config.crossover, config.mutation, config.elites)

    def choose(self, *, s, v_prev, danger, danger_now, gap, k) -> float:
        cfg = self._cfg
        v, _ = erga_speed(grid_speeds=self._speeds, danger=danger, v_pre=self._v_pre,
                          v_prev=v_prev, limit=cfg.speed_limit,
                          rng=np.random.default_rng([cfg.seed, k]), params=self._params,
                          P=cfg.P, D=cfg.D, R=cfg.R)
        return v
