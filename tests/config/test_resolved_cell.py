"""``resolve``: one value holding what ``config.configuration``'s derivations give for a
configuration on a robot, the same figures, read-only."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from safety_systems.cell.robot_model import SHIPPED
from safety_systems.config import configuration as derive
from safety_systems.config.resolved_cell import resolve, resolve_scenario
from safety_systems.config.scenario import (
    RobotConfig,
    load_controller_config,
    load_scenario,
    robot_model_of,
)
from safety_systems.files.input_error import InputError

MODELS = Path(__file__).parents[2] / "models"


def _config(name: str, **safety):
    config = load_controller_config(MODELS / "configs" / f"{name}.yaml")
    return dataclasses.replace(config, safety=dataclasses.replace(config.safety, **safety))


@pytest.mark.parametrize("name,robot", [("iso", ""), ("tuned", ""), ("seed_estimated", ""),
                                        ("tuned", "ur10e")])
def test_every_term_is_the_derivations(name, robot):
    config, station = _config(name), RobotConfig(model=robot)
    model = robot_model_of(station)
    cell = resolve(config, station)
    table = derive.braking_table(config, model)
    for field in ("speed_fraction", "stopping_time", "stopping_distance"):
        np.testing.assert_array_equal(getattr(cell.braking, field), getattr(table, field))
    assert cell.stopping == derive.assumed_stopping(config, model)
    for mine, theirs in zip(cell.level_stops + cell.level_terms,
                            derive.level_stops(config, model) + derive.level_terms(config, model)):
        np.testing.assert_array_equal(mine, theirs)
    assert cell.monitor_terms == derive.monitor_terms(config, model)
    assert cell.frame_timeout == derive.frame_timeout(config)
    assert cell.body == derive.body_dimensions(config.body)
    np.testing.assert_array_equal(cell.capsules.radius,
                                  derive.monitor_capsules(config, model).radius)
    recipe = derive.monitor_recipe(config, [["hand_right", "hand_left"]])
    np.testing.assert_array_equal(cell.recipe.candidates, recipe.candidates)
    assert cell.segment_names == recipe.names
    assert cell.speed_bound == derive.monitor_speed_bound(station, config) > 0.0
    np.testing.assert_array_equal(cell.pfl.caps, derive.pfl_terms(station, config).caps)
    assert cell.model.name == (robot or "ur5e")
    assert cell.braking_source == "placeholder" and cell.braking_warning
    with pytest.raises(ValueError):  # read-only
        cell.level_terms[0][0] = 0.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        cell.frame_timeout = 1.0


def test_a_configurations_own_stopping_data_is_its_source():
    config = _config("iso")
    config = dataclasses.replace(config, braking=dataclasses.replace(
        config.braking, speed_fraction=[0.5, 1.0], stopping_time=[0.3, 0.5],
        stopping_distance=[0.1, 0.25]))
    cell = resolve(config)
    assert cell.braking_source == "configuration" and cell.braking_warning == ""
    np.testing.assert_array_equal(cell.braking.stopping_time, [0.3, 0.5])


def test_ssm_pfl_has_caps_and_ssm_has_none():
    assert not resolve(_config("iso")).pfl.capped
    # (test_permitted_contact's: a contact force limit low enough for caps above 0)
    cell = resolve(_config("seed_estimated", mode="ssm_pfl", robot_geometry="capsules",
                           clamp_margin=0.0, tool_length=0.3, contact_stop_force=50.0))
    assert cell.pfl.capped and cell.pfl.boxes.shape[1:] == (2, 3)
    assert cell.pfl.speed_bound == cell.speed_bound


def test_a_urdf_robot_without_stopping_data_is_refused(tmp_path):
    shipped = SHIPPED["panda"].resolve()  # a copy is a robot from a URDF: no placeholder
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(shipped.read_text().replace("meshes/", f"{shipped.parent}/meshes/"))
    with pytest.raises(InputError, match="controller.braking: .* the stopping data measured"):
        resolve(_config("iso"), RobotConfig(urdf=str(urdf)))


def test_a_scenarios_operators_give_the_points():
    scenario = load_scenario(MODELS / "scenarios" / "inspection_seed.yaml")
    cell = resolve_scenario(scenario)
    assert cell.points == tuple(tuple(p) for p in derive.tracked_points(scenario))
    assert cell.segment_names == derive.scenario_monitor_recipe(scenario).names


def test_a_cells_recipe_for_another_operator_set_is_the_configurations_and_kept():
    from safety_systems.config.configuration import monitor_recipe
    from safety_systems.config.scenario import load_controller_config
    config = load_controller_config(MODELS / "configs" / "iso.yaml")
    cell = resolve(config)
    assert cell.recipe_for(cell.points) is cell.recipe
    two = [["hand_right", "hand_left", "head"], ["hand_right", "hand_left"]]
    got = cell.recipe_for(two, ["a", "b"])
    want = monitor_recipe(config, two, ["a", "b"])
    assert got.names == want.names and np.array_equal(got.radius, want.radius)
    assert cell.recipe_for(two, ["a", "b"]) is got
    cell.check_config(config, "x")
    other = dataclasses.replace(config, safety=dataclasses.replace(config.safety,
                                                                   reaction_time=0.5))
    with pytest.raises(ValueError, match="x: the resolved cell is of another"):
        cell.check_config(other, "x")


def _derivations_named(path: Path) -> list[str]:
    """The MEANING derivations ``path`` imports from config.configuration or reaches as
    its attributes (``configuration.frame_timeout``)."""
    import ast

    from safety_systems.config.resolved_cell import MEANING

    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module == "safety_systems.config.configuration":
            found += [a.name for a in node.names if a.name in MEANING]
        elif isinstance(node, ast.Attribute) and node.attr in MEANING and isinstance(
                node.value, ast.Name) and node.value.id in ("configuration", "derive"):
            found.append(node.attr)
    return found


def test_no_module_outside_the_configuration_room_derives_what_a_configuration_means():
    """The Drake systems and builders, the batched evaluator, the proofs, tune, deploy,
    the runtime, the outputs and the benchmarks take a ResolvedCell; only
    safety_systems/config/ calls the derivations (issue 52)."""
    root = Path(__file__).parents[2]
    files = [p for d in ("safety_systems", "verification", "benchmarks")
             for p in (root / d).rglob("*.py")
             if not p.is_relative_to(root / "safety_systems" / "config")]
    assert len(files) > 100
    offenders = {str(p.relative_to(root)): names for p in files
                 if (names := _derivations_named(p))}
    assert offenders == {}


def test_the_scan_sees_a_derivation_imported_or_reached(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from safety_systems.config.configuration import frame_timeout, joint_path\n"
                   "from safety_systems.config import configuration\n"
                   "x = configuration.braking_table\n")
    assert _derivations_named(bad) == ["frame_timeout", "braking_table"]


def test_a_cell_refuses_a_scenario_of_another_robot_but_not_its_truths_brakes_or_cycles():
    scenario = load_scenario(MODELS / "scenarios" / "inspection_seed.yaml")
    cell = resolve_scenario(scenario)
    cell.check_scenario(dataclasses.replace(scenario, robot=dataclasses.replace(
        scenario.robot, braking_time_scale=1.5, cycles=9)), "x")
    with pytest.raises(ValueError, match="x: the resolved cell is of another robot station"):
        cell.check_scenario(dataclasses.replace(scenario, robot=dataclasses.replace(
            scenario.robot, payload_radius=scenario.robot.payload_radius + 0.05)), "x")
