"""What a configuration and a scenario mean for the loop's rules: plain functions shared by
the Drake diagram, the batched verifier and the proof (never a copy in each)."""

import dataclasses

import numpy as np

from safety_systems.robot_geometry import Capsules, robot_capsules, tool_point
from safety_systems.scenario import (
    ControllerConfig,
    RobotConfig,
    Scenario,
    actual_sensor,
    body_names,
)
from safety_systems.sensor_faults import fault_table
from safety_systems.tracks import make_regions, make_rules


def tracker_rules(config: ControllerConfig) -> np.ndarray:
    """The tracker's rules (``safety_systems.tracks.make_rules``) of a configuration."""
    s, t = config.sensor, config.tracker
    return make_rules(
        measurement_std=s.noise_std if t.measurement_std is None else t.measurement_std,
        velocity_process_noise=t.velocity_process_noise,
        initial_velocity_std=t.initial_velocity_std, period=1.0 / s.rate_hz,
        hidden_bodies=t.hidden_bodies, max_coast_time=t.max_coast_time,
        exit_radius=t.exit_radius, gate=t.gate, gate_speed=t.gate_speed,
        gate_width=t.gate_width, human_uncertainty=config.safety.human_uncertainty)


def tracker_regions(config: ControllerConfig) -> np.ndarray:
    """The cell's walls and exits (``safety_systems.tracks.make_regions``)."""
    t = config.tracker
    cell = None if t.cell is None else (t.cell.min, t.cell.max)
    return make_regions(cell, [(b.min, b.max) for b in t.exits])


def sensor_faults(scenario: Scenario) -> np.ndarray:
    """The fault table (``safety_systems.sensor_faults``) of the scenario's real sensor."""
    names = body_names(scenario)
    return fault_table([
        (f.kind, names.index(f.body) if f.body else -1,
         names.index(f.other) if f.other else -1, f.start, f.end, f.offset)
        for f in actual_sensor(scenario).faults])


def body_radii(scenario: Scenario) -> np.ndarray:
    """(N,) the radius of every body slot's sphere, m."""
    return np.array([b.radius for o in scenario.operators for b in o.bodies], dtype=float)


def monitor_capsules(config: ControllerConfig) -> Capsules:
    """The robot as the SeparationMonitor measures it: the UR5e's capsules with the
    configured link radii (if any) and tool, or the seed's tool point."""
    f = config.safety
    if f.robot_geometry == "tool_point":
        return tool_point()
    return robot_capsules(link_radii=f.link_radii or None, payload_radius=f.payload_radius,
                          tool_length=f.tool_length)


def monitored_body_radii(scenario: Scenario) -> np.ndarray:
    """(N,) body radii the monitor uses: the scenario's, or 0 on the tool point (Eq. 8
    measures points)."""
    return monitored_radii(scenario.controller, body_radii(scenario))


def monitored_radii(config: ControllerConfig, radii: np.ndarray) -> np.ndarray:
    """The radii (N,) the monitor uses for bodies of these ``radii``: as given, or 0 on
    the tool point (Eq. 8 measures points)."""
    radii = np.asarray(radii, dtype=float)
    return np.zeros_like(radii) if config.safety.robot_geometry == "tool_point" else radii


def contact_capsules(robot: RobotConfig, contact_geometry: str) -> Capsules:
    """The real robot for the safety properties: the UR5e model's capsules with the cell's
    real tool (``robot.payload_radius``, ``robot.tool_length``), or the tool point."""
    if contact_geometry == "tool_point":
        return tool_point()
    return robot_capsules(payload_radius=robot.payload_radius, tool_length=robot.tool_length)


def contact_body_radii(scenario: Scenario) -> np.ndarray:
    """(N,) body radii for the safety properties: the scenario's, or 0 on the tool point."""
    if scenario.contact_geometry == "tool_point":
        return np.zeros(sum(len(o.bodies) for o in scenario.operators))
    return body_radii(scenario)


def with_controller(scenario: Scenario, config: ControllerConfig) -> Scenario:
    """``scenario`` run under another controller configuration: ``config``'s settings
    in the scenario's cell. What belongs to the cell stays the scenario's: its real sensor
    (``actual_sensor``: the configuration states what the controller is configured for,
    not what the cell's sensor does) and, when ``config`` declares none, its exits and
    walls (``tracker.exits``, ``tracker.cell``: where operators come and go)."""
    tracker = config.tracker
    if not tracker.exits and tracker.cell is None:
        cell = scenario.controller.tracker
        tracker = dataclasses.replace(tracker, exits=list(cell.exits), cell=cell.cell)
    return dataclasses.replace(scenario, sensor=actual_sensor(scenario),
                               controller=dataclasses.replace(config, tracker=tracker))
