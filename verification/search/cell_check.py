"""Whether a resolved cell (``config.resolved_cell``) is the one of the scenarios it is
given with: the batched evaluator, the reduced model and the Drake replays refuse another."""

import dataclasses

from safety_systems.config.resolved_cell import ResolvedCell
from safety_systems.config.scenario import Scenario


def check_cell(cell: ResolvedCell, scenarios: list[Scenario], what: str) -> None:
    """Raises ValueError unless ``cell`` was resolved from the configuration of the
    scenarios (``scenarios[0]``'s: a batch shares it) on their robot station, but its
    cycles and braking time scale (a space's scenarios vary them; no term of the cell
    depends on them). Their operators may differ from the cell's: their recipe is
    ``ResolvedCell.recipe_for``'s."""
    cell.check_config(scenarios[0].controller, what)
    plain = dataclasses.replace(cell.robot, cycles=1, braking_time_scale=1.0)
    if dataclasses.replace(scenarios[0].robot, cycles=1, braking_time_scale=1.0) != plain:
        raise ValueError(f"{what}: the resolved cell is of another robot station; resolve "
                         "the robot the scenarios carry")
