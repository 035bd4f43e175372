"""What a controller configuration means on one robot in one cell, derived once: the
:class:`ResolvedCell` that :func:`resolve` builds by calling the derivations of
``config.configuration`` (the braking table, the stops by speed level, the monitor's
terms, the body and its envelopes, the frame timeout, the capsules, power and force
limiting's terms), never a copy of their maths.

``safety-systems explain`` reads it; the Drake builders, the batched evaluator, the proofs,
tune and the runtime take it. No module outside ``safety_systems/config/`` calls the
derivations :data:`MEANING` names (tests/config/test_resolved_cell.py holds that).
"""

import dataclasses

import numpy as np

from safety_systems.cell import human_body
from safety_systems.cell.braking import BrakingTable
from safety_systems.cell.robot_geometry import Capsules
from safety_systems.cell.robot_model import RobotModel
from safety_systems.config.configuration import (
    PflTerms,
    assumed_stopping,
    body_dimensions,
    braking_table,
    braking_warning,
    frame_timeout,
    level_stops,
    level_terms,
    monitor_capsules,
    monitor_recipe,
    monitor_speed_bound,
    monitor_terms,
    pfl_terms,
    placeholder_braking,
    tracked_points,
    tracker_regions,
    tracker_rules,
)
from safety_systems.config.scenario import (
    ControllerConfig,
    RobotConfig,
    Scenario,
    robot_model_of,
)

# The derivations of what a configuration means, called by :func:`resolve` alone.
MEANING = ("tracker_rules", "tracker_regions", "monitor_capsules", "body_dimensions",
           "monitor_recipe", "scenario_monitor_recipe", "placeholder_braking",
           "braking_table", "braking_warning", "assumed_stopping", "level_stops",
           "level_terms", "monitor_terms", "frame_timeout", "monitor_speed_bound",
           "pfl_terms")
BRAKING_SOURCES = ("placeholder", "configuration")
# The tracked points of an operator when the cell names none: a glove on each hand (the
# shipped default space's operator, models/spaces/default.yaml).
DEFAULT_POINTS = ("hand_right", "hand_left")


def _frozen(x: np.ndarray) -> np.ndarray:
    x = np.array(x, dtype=float)
    x.setflags(write=False)
    return x


@dataclasses.dataclass(frozen=True, eq=False)
class ResolvedCell:
    """A controller configuration ``config`` on the robot station ``robot`` (its model
    ``model``) with operators whose tracked bodies mark ``points``: every term the loop's
    rules take from them (``config.configuration`` says what each is). Arrays are
    read-only."""

    config: ControllerConfig
    robot: RobotConfig
    model: RobotModel
    points: tuple[tuple[str, ...], ...]  # each operator's tracked body points
    braking: BrakingTable  # the stopping data
    braking_source: str  # BRAKING_SOURCES: the robot's placeholder or the configuration's
    braking_warning: str  # the placeholder's warning ("" for the configuration's data)
    stopping: tuple[float, float]  # (T_s, B) at full speed (``assumed_stopping``)
    level_stops: tuple[np.ndarray, np.ndarray]  # (T_s, B) at each level g / SPEED_LEVELS
    level_terms: tuple[np.ndarray, np.ndarray]  # (T_s + T_r, B + C + Z_r) at each level
    monitor_terms: tuple  # as ``separation.pair_separation`` takes them
    z_d_terms: tuple[float, float]  # (Z_d base, sigmas): Z_d = base + sigmas std
    body: dict  # the body's dimensions, m and deg (``human_body.dimensions``)
    recipe: human_body.Recipe  # the envelopes of every segment from the tracked points
    frame_timeout: float  # s
    tracker_rules: np.ndarray  # the tracker's rules (``sensing.tracks.make_rules``)
    tracker_regions: np.ndarray  # the cell's walls and exits (``sensing.tracks.make_regions``)
    capsules: Capsules  # the robot as the monitor measures it
    speed_bound: float  # V_R, m/s: no monitor capsule axis point is faster at rate 1
    pfl: PflTerms  # power and force limiting's caps and clamping surfaces (0 under ssm)

    # recipes of other operator sets, derived by :meth:`recipe_for` on first use and kept
    _recipes: dict = dataclasses.field(default_factory=dict, repr=False)

    @property
    def segment_names(self) -> tuple[str, ...]:
        """Every operator's segments, "operator/segment"."""
        return self.recipe.names

    def recipe_for(self, points, names=None) -> human_body.Recipe:
        """The monitor's envelope recipe for operators whose tracked bodies mark ``points``
        (per operator, in slot order) named ``names`` (None: ``operator_1``, ...): the
        cell's own ``recipe`` for its ``points``, another set's derived on its first use
        and kept (a space's scenarios track one or two operators, with or without a
        helmet: each set is derived once)."""
        key = (tuple(map(tuple, points)), None if names is None else tuple(names))
        if key not in self._recipes:
            self._recipes[key] = monitor_recipe(self.config, [list(p) for p in points],
                                                None if names is None else list(names))
        return self._recipes[key]

    def scenario_recipe(self, scenario: Scenario) -> human_body.Recipe:
        """:meth:`recipe_for` the scenario's operators: their tracked points and names."""
        return self.recipe_for(tracked_points(scenario), [o.name for o in scenario.operators])

    def check_config(self, config: ControllerConfig, what: str) -> None:
        """Raises ValueError unless ``config`` is the configuration this cell was resolved
        from (``what`` names the caller's input): a cell never stands for another
        configuration."""
        if config != self.config:
            raise ValueError(f"{what}: the resolved cell is of another configuration; "
                             "resolve the configuration the scenarios carry")

    def check_scenario(self, scenario: Scenario, what: str) -> None:
        """Raises ValueError unless ``scenario`` runs this cell's configuration on its robot
        station: the same but for the truth's braking time scale and the cycles it runs
        (which a space's scenarios vary, and no term of the cell reads)."""
        self.check_config(scenario.controller, what)
        robot = dataclasses.replace(scenario.robot,
                                    braking_time_scale=self.robot.braking_time_scale,
                                    cycles=self.robot.cycles)
        if robot != self.robot:
            raise ValueError(f"{what}: the resolved cell is of another robot station; "
                             "resolve the scenario's own")


def resolve(config: ControllerConfig, robot: RobotConfig | None = None,
            model: RobotModel | None = None, points: list[list[str]] | None = None,
            names: list[str] | None = None) -> ResolvedCell:
    """The :class:`ResolvedCell` of ``config`` on the robot station ``robot`` (None: the
    default UR5e station, its pick-and-place cycle) whose model is ``model`` (None:
    ``robot_model_of(robot)``), with operators whose tracked bodies mark ``points`` (per
    operator, the point of each body in slot order; None: one operator tracked at
    :data:`DEFAULT_POINTS`) named ``names``. Raises ``InputError`` where a derivation
    refuses (a URDF robot without stopping data, ssm_pfl on a robot without masses)."""
    robot = RobotConfig() if robot is None else robot
    model = robot_model_of(robot) if model is None else model
    points = [list(DEFAULT_POINTS)] if points is None else [list(p) for p in points]
    t_s, b = level_stops(config, model)
    t_sr, const = level_terms(config, model)
    f = config.safety
    placeholder = placeholder_braking(config)
    cell = ResolvedCell(
        config=config, robot=robot, model=model, points=tuple(map(tuple, points)),
        braking=braking_table(config, model),
        braking_source=BRAKING_SOURCES[0 if placeholder else 1],
        braking_warning=braking_warning(model) if placeholder else "",
        stopping=tuple(float(x) for x in assumed_stopping(config, model)),
        level_stops=(_frozen(t_s), _frozen(b)), level_terms=(_frozen(t_sr), _frozen(const)),
        monitor_terms=monitor_terms(config, model),
        z_d_terms=(float(f.human_uncertainty), float(f.human_uncertainty_sigmas)),
        body=body_dimensions(config.body), recipe=monitor_recipe(config, points, names),
        frame_timeout=float(frame_timeout(config)),
        tracker_rules=_frozen(tracker_rules(config)),
        tracker_regions=_frozen(tracker_regions(config)),
        capsules=monitor_capsules(config, model),
        speed_bound=monitor_speed_bound(robot, config), pfl=pfl_terms(robot, config))
    cell._recipes[(cell.points, None if names is None else tuple(names))] = cell.recipe
    return cell


def resolve_scenario(scenario: Scenario) -> ResolvedCell:
    """:func:`resolve` of a scenario's controller, robot and operators."""
    return resolve(scenario.controller, scenario.robot, points=tracked_points(scenario),
                   names=[o.name for o in scenario.operators])


def scenario_cell(scenario: Scenario, cell: ResolvedCell | None, what: str) -> ResolvedCell:
    """The cell a caller of ``scenario`` was given, checked to stand for it
    (:meth:`ResolvedCell.check_scenario`; ``what`` names the caller), or the scenario's own
    when None (:func:`resolve_scenario`)."""
    if cell is None:
        return resolve_scenario(scenario)
    cell.check_scenario(scenario, what)
    return cell
