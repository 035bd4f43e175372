"""What a configuration and a scenario mean for the loop's rules: plain functions shared by
the Drake diagram, the batched verifier and the proof (never a copy in each)."""

import numpy as np

from safety_systems.scenario import ControllerConfig, Scenario, actual_sensor, body_names
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
