"""A space file's types: the box of a scenario space (each parameter a [min, max]
range, ``Range``), the cell it is in and the stated assumptions (``ScenarioSpace``), the
ranges each parameter may take and their check.

A space either gives ``parameters``, the ranges of a scripted approach
(``verification.spaces.space`` turns a point of them into a scenario), or a
``recording:`` block, a box around a recording of real operators
(``verification.spaces.recorded``). The recorded kind needs only these types; the
scripted kind's module, which also dispatches to the recorded one, imports it.

This module must not use ``from __future__ import annotations`` (the YAML loader).
"""

import dataclasses as dc
import math
import typing

from safety_systems.config.scenario import (MAX_DURATION, MAX_SCRIPTED_SPEED, RobotConfig,
                                             ScenarioError)
from safety_systems.files.ranges import number

MIN_GAP = 1e-9  # s; shorter dropouts and occlusions are none
NUM_POSTURES = 6  # ``spaces.space.POSTURES``: reach, reach past, elbow, shoulder, lean, both


@dc.dataclass
class Range:
    """A closed interval [min, max]; each parameter's bounds are ``LIMITS``."""

    limits_checked_by = "validate_space"  # not a field: its ranges depend on the parameter
    min: float = 0.0
    max: float = 0.0


def span(r: Range, unit: str = "") -> str:
    """A range in words: its one value where min = max, else "min to max" (then the unit,
    e.g. " m")."""
    return f"{r.min:g}{unit}" if r.min == r.max else f"{r.min:g} to {r.max:g}{unit}"


def stop_times_words(r: Range) -> str:
    """The premise on the real robot's stopping times, for a space whose
    ``braking_time_scale`` is ``r``: their times the data's own (a scale of 1 alone), or
    within the range of the data's times the space scales them by."""
    if r.min == r.max == 1.0:
        return "their times the data's own (the space does not scale them)"
    return f"their times {span(r)} times the data's (the space's braking_time_scale)"


def how_many(r: Range, noun: str) -> str:
    """A whole-number range of ``noun``: "1 operator", "1 to 2 operators"."""
    lo, hi = int(r.min), int(r.max)
    return f"{lo} {noun}" if lo == hi == 1 else f"{lo if lo == hi else f'{lo} to {hi}'} {noun}s"


def _r(lo: float, hi: float):
    return dc.field(default_factory=lambda: Range(lo, hi))


@dc.dataclass
class SpaceParameters:
    """The ranges of a space (angles in degrees, lengths in m, times in s)."""

    azimuth_deg: Range = _r(-180.0, 180.0)
    elevation_deg: Range = _r(-20.0, 20.0)
    start_distance: Range = _r(1.0, 3.0)
    peak_speed: Range = _r(0.5, 2.0)
    acceleration: Range = _r(1.0, 10.0)
    onset_phase: Range = _r(0.0, 1.0)
    target_phase: Range = _r(0.0, 1.0)
    target_link: Range = _r(6.0, 6.0)
    target_along: Range = _r(0.0, 0.0)
    retreat_distance: Range = _r(0.0, 0.0)
    overshoot: Range = _r(0.0, 0.0)
    operators: Range = _r(1.0, 1.0)
    posture: Range = _r(0.0, 0.0)
    heads: Range = _r(0.0, 0.0)
    noise_std: Range = _r(0.0002, 0.0002)
    latency: Range = _r(0.0, 0.0)
    dropout: Range = _r(0.0, 0.0)
    occlusion: Range = _r(0.0, 0.0)
    occluded_bodies: Range = _r(1.0, 1.0)
    outlier_frames: Range = _r(0.0, 0.0)
    outlier_offset: Range = _r(1.0, 1.0)
    outlier_delay: Range = _r(0.1, 0.1)
    braking_time_scale: Range = _r(1.0, 1.0)
    pivot_offset: Range = _r(0.0, 0.0)


@dc.dataclass
class RecordingParameters:
    """The ranges of a recording space (``verification.spaces.recorded``; angles in
    degrees, lengths in m, times in s)."""

    time_shift: Range = _r(0.0, 0.0)
    time_scale: Range = _r(1.0, 1.0)
    offset_x: Range = _r(0.0, 0.0)
    offset_y: Range = _r(0.0, 0.0)
    offset_z: Range = _r(0.0, 0.0)
    yaw_deg: Range = _r(0.0, 0.0)
    occlusion_start: Range = _r(0.0, 0.0)
    occlusion: Range = _r(0.0, 0.0)
    occluded_bodies: Range = _r(1.0, 1.0)
    noise_std: Range = _r(0.0, 0.0)
    latency: Range = _r(0.0, 0.0)
    braking_time_scale: Range = _r(1.0, 1.0)


@dc.dataclass
class RecordingBlock:
    """A recording space's motion: every operator of the mapping file ``mapping`` played
    from the recording ``file`` (both relative to the space file), recording time
    ``start`` at t = 0 before the shift, for at most ``duration`` s (0: until the
    recording ends), transformed as ``parameters`` say (``verification.spaces.recorded``)."""

    file: str = ""
    mapping: str = ""
    start: float = number(0.0, ge=0.0, le=100_000.0, unit="s")
    duration: float = number(0.0, ge=0.0, le=MAX_DURATION, unit="s")
    parameters: RecordingParameters = dc.field(default_factory=RecordingParameters)


@dc.dataclass
class ScenarioSpace:
    """A box of approaches, the cell they happen in and the stated assumptions.

    ``settle_time``: s every operator stands still before any onset. ``tail_time``: s
    simulated after the lead point reaches the target. ``contact_geometry`` and
    ``contact_distance``: what contact means (as in a scenario: any segment of an
    operator's body, ``safety_systems.cell.human_body``, its radii the table's).
    ``noise_bound_sigmas``: for proofs, sensor noise is assumed bounded at this many
    standard deviations per axis. ``tracked``: the body points every operator is tracked
    at (``safety_systems.cell.human_body.POINTS``, e.g. all ten for a motion-capture
    suit); empty: two gloves, and a helmet where ``heads`` is 1. ``notes``: assumptions in words, repeated in every
    result. ``recording``: a box around a recording instead of ``parameters``
    (``verification.spaces.recorded``; then ``settle_time`` is the least time from t = 0
    to an extra occlusion, and ``tail_time`` and ``noise_bound_sigmas`` are not used:
    they must keep their defaults).
    """

    name: str = ""
    settle_time: float = number(1.0, gt=0.0, le=60.0, unit="s")
    tail_time: float = number(1.5, gt=0.0, le=60.0, unit="s")
    contact_geometry: str = "capsules"
    contact_distance: float = number(0.0, ge=0.0, le=1.0, unit="m")
    noise_bound_sigmas: float = number(4.0, gt=0.0, le=10.0)
    tracked: list[str] = dc.field(default_factory=list)
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    parameters: SpaceParameters = dc.field(default_factory=SpaceParameters)
    notes: list[str] = dc.field(default_factory=list)
    recording: typing.Optional[RecordingBlock] = None


NAMES = tuple(f.name for f in dc.fields(SpaceParameters))


# target_link indexes the space's robot's capsules (its links', then the tool's): at most
# the robot's count less one (checked on the robot, ``spaces.space.validate_space``; the
# UR family has 7: ``robot_geometry.CAPSULE_NAMES``), and never above this.
MAX_TARGET_LINK = 63.0
LIMITS = {  # allowed ranges of each parameter
    "azimuth_deg": (-360.0, 360.0), "elevation_deg": (-80.0, 80.0),
    "start_distance": (0.2, 10.0), "peak_speed": (0.01, MAX_SCRIPTED_SPEED),
    "acceleration": (0.1, 100.0),
    "onset_phase": (0.0, 1.0), "target_phase": (0.0, 1.0),
    "target_link": (0.0, MAX_TARGET_LINK), "target_along": (0.0, 1.0),
    "retreat_distance": (0.0, 5.0), "overshoot": (0.0, 2.0), "operators": (1.0, 5.0),
    "posture": (0.0, NUM_POSTURES - 1.0), "heads": (0.0, 1.0), "noise_std": (0.0, 0.05),
    "latency": (0.0, 1.0), "dropout": (0.0, 5.0), "occlusion": (0.0, 60.0),
    "occluded_bodies": (1.0, 10.0),
    "outlier_frames": (0.0, 40.0), "outlier_offset": (0.0, 10.0), "outlier_delay": (0.0, 10.0),
    "braking_time_scale": (0.1, 10.0), "pivot_offset": (0.0, 0.5),
}


WHOLE = ("target_link", "operators", "posture", "heads", "occluded_bodies", "outlier_frames")


def check_ranges(block, limits: dict, whole: tuple, prefix: str) -> None:
    """Each Range of ``block`` within its ``limits`` (min <= max; every field has
    them), whole where named in ``whole``; raises ScenarioError naming ``prefix.name``."""
    for field in dc.fields(block):
        name = field.name
        (lo, hi), r = limits[name], getattr(block, name)
        ok = math.isfinite(r.min) and math.isfinite(r.max) and lo <= r.min <= r.max <= hi
        if not ok:
            raise ScenarioError(f"{prefix}.{name}", [r.min, r.max],
                                f"min <= max within [{lo:g}, {hi:g}]")
    for name in whole:
        r = getattr(block, name)
        if r.min != round(r.min) or r.max != round(r.max):
            raise ScenarioError(f"{prefix}.{name}", [r.min, r.max], "whole numbers")
