"""Scenario spaces built around a recording: real operators' motion, moved in time and
space, so that ``verify`` and ``tune`` search near how people really move.

A space file with a ``recording:`` block (``box.RecordingBlock``) plays every operator
of its mapping file from its recording (``safety_systems.sensing.recording_mapping``,
the files relative to the space file), as a scenario's recorded operators do
(``OperatorConfig``: ``start``, ``time_scale``, ``yaw_deg``, ``shift``). A point of the
box (``recording.parameters``, a [min, max] range each) becomes one scenario:

- ``time_shift`` (s of recording): recording time ``start + time_shift`` plays at t = 0,
  so the operators' motion meets the robot at another phase of its cycle (a larger
  shift: the same motion earlier);
- ``time_scale``: recording seconds played per second. Above 1 the operators move
  faster than recorded (1.3: every speed 30 % higher, the motion 1.3 times shorter),
  below 1 slower; positions are the recording's, only the time they are reached changes;
- ``yaw_deg``, ``offset_x``, ``offset_y``, ``offset_z``: every body turned by the yaw
  about the cell's z axis (through the robot base), then moved by the offsets (m, cell
  frame): the same motion from another side of the robot, nearer or farther;
- ``occlusion_start``, ``occlusion``, ``occluded_bodies``: an extra occlusion, besides
  the recording's own untracked intervals: the first ``occluded_bodies`` bodies of every
  operator (in the mapping's order; the shipped mapping's: right glove, left glove,
  head) are hidden from the sensor from recording time ``occlusion_start`` (so it
  follows the motion whatever the shift and scale) for ``occlusion`` s of the scenario;
  none when ``occlusion`` is 0. Every body is seen for at least the space's
  ``settle_time`` before an extra occlusion (checked when the file is loaded: a body
  hidden from the start would be one the cell never saw come in);
- ``noise_std``, ``latency`` and ``braking_time_scale``: as in a scripted space (the
  real sensor's noise, m per axis, and latency, s; the real brakes' stopping times as a
  multiple of the stopping data's).

The scenario runs from t = 0 until the recording ends (``(end - start - time_shift) /
time_scale``), or for the block's ``duration`` if that is shorter; the robot runs its
path from t = 0; the configuration's sensor with the point's noise and latency.

These scenarios run in the Drake diagram (``evaluate_batch.evaluate_many``: the batched
evaluator's compiled loops carry scripted operators only). The proofs decline them
(``verification.proof``: a recording space gets ``passed`` or ``falsified``, never
``proved``), and the falsifier's rankings, which model scripted approaches, are not
used on them (``strategies.falsify``).

This module must not use ``from __future__ import annotations`` (the YAML loader).
"""

import dataclasses as dc
import math
import os
from pathlib import Path

import numpy as np

from safety_systems.config.configuration import joint_path
from safety_systems.config.scenario import (
    MAX_DURATION,
    Body,
    ControllerConfig,
    Occlusion,
    OperatorConfig,
    Scenario,
    ScenarioError,
    validate_scenario,
)
from safety_systems.files.input_error import InputError
from safety_systems.sensing.recording_mapping import (
    RecordedBodies,
    load_mapping,
    load_recorded_operator,
    unknown_pivot_bodies,
)
from verification.spaces.box import (
    MIN_GAP,
    Range,
    RecordingBlock,
    RecordingParameters,
    ScenarioSpace,
    check_ranges,
    span,
)

RECORDING_NAMES = tuple(f.name for f in dc.fields(RecordingParameters))
_LIMITS = {  # allowed ranges of each parameter; the times are checked against the file too
    "time_shift": (-100_000.0, 100_000.0), "time_scale": (0.1, 10.0),
    "offset_x": (-5.0, 5.0), "offset_y": (-5.0, 5.0), "offset_z": (-2.0, 2.0),
    "yaw_deg": (-360.0, 360.0), "occlusion_start": (0.0, 100_000.0),
    "occlusion": (0.0, 60.0), "occluded_bodies": (1.0, 8.0), "noise_std": (0.0, 0.05),
    "latency": (0.0, 1.0), "braking_time_scale": (0.1, 10.0),
}
# Fields of a space that a recording space does not use: they must keep their defaults.
_UNUSED = {"tail_time": "the scenario ends with the recording or the block's duration",
           "noise_bound_sigmas": "the proofs decline a recording space",
           "tracked": "the mapping names every tracked body's point"}


def read_recording_block(block: RecordingBlock, folder: Path) -> None:
    """Resolves the block's files relative to ``folder`` (full paths replace them) and
    reads them: every operator of the mapping must be found in the recording; raises
    ScenarioError at the field naming the file, with the file's own error."""
    for field in ("file", "mapping"):
        if not getattr(block, field):
            raise ScenarioError(f"recording.{field}", "", "a file name (relative to the "
                                "space file)")
    block.file, block.mapping = (os.path.abspath(folder / x) for x in (block.file,
                                                                       block.mapping))
    try:
        mapping = load_mapping(block.mapping)
    except InputError as e:
        raise ScenarioError("recording.mapping", block.mapping, f"a mapping file ({e})"
                            ) from None
    for o in mapping.operators:
        try:
            load_recorded_operator(block.file, block.mapping, o.name)
        except InputError as e:
            raise ScenarioError("recording.file", block.file,
                                f"a recording its mapping fits ({e})") from None


def operators(block: RecordingBlock) -> list[tuple[str, RecordedBodies]]:
    """Every operator of the block's mapping, by name, with its recorded bodies."""
    return [(o.name, load_recorded_operator(block.file, block.mapping, o.name))
            for o in load_mapping(block.mapping).operators]


def recording_end(block: RecordingBlock) -> float:
    """The recording's last sample time, s."""
    return max(float(b.times[-1]) for _, b in operators(block))


def validate_recording(space: ScenarioSpace) -> None:
    """A recording space's rules (see the module docstring); raises ScenarioError."""
    block = space.recording
    defaults = ScenarioSpace()
    if space.parameters != defaults.parameters:
        raise ScenarioError("parameters", "given", "none with a recording block (a recording "
                            "space's ranges are recording.parameters)")
    for name, why in _UNUSED.items():
        if getattr(space, name) != getattr(defaults, name):
            default = getattr(defaults, name)
            shown = f"{default:g}" if isinstance(default, float) else repr(default)
            raise ScenarioError(name, getattr(space, name),
                                f"{shown} (unused with a recording block: {why})")
    p = block.parameters
    check_ranges(p, _LIMITS, ("occluded_bodies",), "recording.parameters")
    end = recording_end(block)
    if block.start + p.time_shift.min < 0.0:
        raise ScenarioError("recording.parameters.time_shift", [p.time_shift.min,
                            p.time_shift.max], f"min >= -start ({-block.start:g} s): no "
                            "recording time before the recording's first sample")
    latest = end - space.settle_time * p.time_scale.max
    if block.start + p.time_shift.max > latest:
        raise ScenarioError("recording.parameters.time_shift", [p.time_shift.min,
                            p.time_shift.max], f"max <= {latest - block.start:g} s: the "
                            f"recording ends at {end:g} s, and at least settle_time "
                            f"({space.settle_time:g} s) of it must be left to play at the "
                            "largest time scale")
    fewest = min(len(b.names) for _, b in operators(block))
    if p.occluded_bodies.max > fewest:
        raise ScenarioError("recording.parameters.occluded_bodies",
                            [p.occluded_bodies.min, p.occluded_bodies.max],
                            f"1 to {fewest} (the bodies of the mapping's operators)")
    if p.occlusion.max > MIN_GAP:
        earliest = block.start + p.time_shift.max + space.settle_time * p.time_scale.max
        if p.occlusion_start.min < earliest - 1e-9:
            raise ScenarioError(
                "recording.parameters.occlusion_start",
                [p.occlusion_start.min, p.occlusion_start.max],
                f"min >= {earliest:g} s of recording time (start + the largest time_shift "
                "+ settle_time x the largest time_scale): every body is seen for "
                f"settle_time ({space.settle_time:g} s) before an extra occlusion")
    path = joint_path(space.robot)
    for corner in ("min", "max"):  # the scenarios of the box's corners are valid
        values = {n: float(getattr(getattr(p, n), corner)) for n in RECORDING_NAMES}
        try:
            recorded_scenario(space, ControllerConfig(), values, path=path)
        except InputError as e:
            raise ScenarioError("recording", Path(block.file).name, "a recording whose "
                                f"scenarios are valid (at the box's {corner}: {e})") from None


def duration(space: ScenarioSpace, values: dict[str, float]) -> float:
    """How long the scenario of ``values`` runs, s (see the module docstring)."""
    block = space.recording
    played = ((recording_end(block) - block.start - values["time_shift"])
              / values["time_scale"])
    return min(played, block.duration or MAX_DURATION, MAX_DURATION)


def recorded_scenario(space: ScenarioSpace, config: ControllerConfig,
                      values: dict[str, float], *, name: str = "sample", path=None,
                      validate: bool = True) -> Scenario:
    """The scenario of one point of a recording space (``values`` by parameter name; see
    the module docstring); ``path``: the space robot's joint path, if the caller has it."""
    v, block = values, space.recording
    path = joint_path(space.robot) if path is None else path
    start = block.start + v["time_shift"]
    scale = v["time_scale"]
    ops = [OperatorConfig(name=o, bodies=[Body(name=n, point=q)
                                          for n, q in zip(bodies.names, bodies.points_marked)],
                          recording=block.file, mapping=block.mapping, start=start,
                          time_scale=scale, yaw_deg=v["yaw_deg"],
                          shift=[v["offset_x"], v["offset_y"], v["offset_z"]])
           for o, bodies in operators(block)]
    sensor = dc.replace(config.sensor, noise_std=v["noise_std"], latency=v["latency"],
                        dropouts=[], occlusions=[], faults=[])
    length = duration(space, v)
    t0 = (v["occlusion_start"] - start) / scale
    if v["occlusion"] > MIN_GAP and t0 < length:  # (one after the end would do nothing)
        hidden = int(round(v["occluded_bodies"]))
        sensor.occlusions = [Occlusion(f"{o.name}/{b.name}", t0,
                                       min(t0 + v["occlusion"], length))
                             for o in ops for b in o.bodies[:hidden]]
    robot = dc.replace(space.robot, braking_time_scale=v["braking_time_scale"],
                       cycles=int(math.ceil(length / path.cycle_time)) + 1)
    scenario = Scenario(name=name, duration=length, contact_geometry=space.contact_geometry,
                        contact_distance=space.contact_distance, robot=robot,
                        controller=config, sensor=sensor, operators=ops)
    if validate:
        validate_scenario(scenario)
    return scenario


def played_window(block: RecordingBlock) -> tuple[float, float]:
    """The recording times any point of the space plays, s: from its start at the
    smallest time shift to the end of the longest play at the largest shift and time
    scale (or the recording's end)."""
    p = block.parameters
    longest = min(block.duration or MAX_DURATION, MAX_DURATION) * p.time_scale.max
    return (block.start + p.time_shift.min,
            min(recording_end(block), block.start + p.time_shift.max + longest))


def recorded_speed(block: RecordingBlock) -> float:
    """The fastest any body moves as recorded over the part the space plays
    (:func:`played_window`), m/s: the largest speed of the played truth's segments
    (linear between samples, ``sensing.recording``) that reach into that part while the
    body is present; the played speed is this times the time scale."""
    fastest = 0.0
    first, last = played_window(block)
    for _, b in operators(block):
        step = np.linalg.norm(np.diff(b.points, axis=0), axis=2) / np.diff(b.times)[:, None]
        played = (b.times[1:] > first) & (b.times[:-1] < last)
        inside = ((b.times[:-1, None] >= b.tracked_times[:, 0])
                  & (b.times[1:, None] <= b.tracked_times[:, 1]) & played[:, None])
        if inside.any():
            fastest = max(fastest, float(step[inside].max()))
    return fastest


def recorded_reach(space: ScenarioSpace) -> float:
    """A bound on how far from the robot base any body of the space's scenarios gets, m:
    the farthest recorded position while present (the yaw turns about the base, which
    keeps distances to it), plus the largest offset."""
    p, far = space.recording.parameters, 0.0
    for _, b in operators(space.recording):
        times = b.times[:, None]
        inside = (times >= b.tracked_times[:, 0]) & (times <= b.tracked_times[:, 1])
        if inside.any():
            far = max(far, float(np.linalg.norm(b.points, axis=2)[inside].max()))
    offset = math.sqrt(sum(max(abs(r.min), abs(r.max)) ** 2
                           for r in (p.offset_x, p.offset_y, p.offset_z)))
    return far + offset


def tracked_from_start(space: ScenarioSpace) -> bool:
    """Every body is tracked at t = 0 at every point of the box: its first tracked
    sample no later than the earliest recording time played at t = 0."""
    first = space.recording.start + space.recording.parameters.time_shift.min
    return all(float(b.tracked_times[:, 0].max()) <= first
               for _, b in operators(space.recording))


def recording_assumptions(space: ScenarioSpace, config: ControllerConfig) -> list[str]:
    """The assumptions of a verdict over a recording space, in words (without the
    contact line and the notes, which ``space.assumptions`` adds)."""
    block = space.recording
    p = block.parameters
    ops = operators(block)
    speed = recorded_speed(block)
    glitches = sum(sum(b.flips) for _, b in ops)
    flip_speed = load_mapping(block.mapping).flip_speed
    bodies = "; ".join(f"{o}: " + ", ".join(f"{n} ({q})" for n, q in
                                              zip(b.names, b.points_marked)) for o, b in ops)
    first = ", ".join(f"{o}: {', '.join(b.names[:int(p.occluded_bodies.max)])}"
                      for o, b in ops)

    return [
        f"the operators of {Path(block.mapping).name} as recorded in "
        f"{Path(block.file).name} (tracked bodies and the body points they mark: {bodies}; "
        "each operator a whole body, its segments between untracked points bounded from "
        "the recorded ones), each present while the recording tracks it, moving linearly "
        "between its samples; the recording's untracked intervals are occlusions"
        + (f" (among them {glitches} sample(s) taken as capture glitches: out of a body's "
           f"track and back faster than {flip_speed:g} m/s)" if glitches else "")
        + "; no other body enters the cell",
        f"recording time {span(_shifted(block, p.time_shift), ' s')} plays at t = 0, at "
        f"{span(p.time_scale)} recording seconds per second (above 1: faster than "
        f"recorded, every speed scaled by it); every body turned by {span(p.yaw_deg, ' deg')} "
        f"about the robot base's vertical axis, then moved by x {span(p.offset_x, ' m')}, "
        f"y {span(p.offset_y, ' m')}, z {span(p.offset_z, ' m')}",
        f"the recorded bodies move at up to {speed:.3f} m/s as recorded, "
        f"{speed * p.time_scale.max:.3f} m/s at the largest time scale (hand speed in "
        "ISO 13855: 2.0 m/s)",
        f"sensor: {config.sensor.rate_hz:g} Hz, noise std {span(p.noise_std, ' m')}, latency "
        f"{span(p.latency, ' s')}; "
        + (f"an extra occlusion of up to {p.occlusion.max:g} s of the first "
           f"{span(p.occluded_bodies)} bodies of every operator ({first}), from recording "
           f"time {span(p.occlusion_start, ' s')}" if p.occlusion.max > MIN_GAP
           else "no extra occlusion"),
        "the robot stops as its stopping data says"
        + ("" if p.braking_time_scale.min == p.braking_time_scale.max == 1.0 else
           f", times scaled by {span(p.braking_time_scale)}")
        + "; scenarios run until the recording ends"
        + (f" or for {block.duration:g} s" if block.duration else ""),
    ] + _pivot_assumption(block)


def _pivot_assumption(block: RecordingBlock) -> list[str]:
    """The assumption that the bodies whose mapping leaves their pivot unknown are at the
    points they mark (``recording_mapping.unknown_pivot_bodies``), naming each and how
    far off it may be; none when the mapping places every body."""
    unknown = unknown_pivot_bodies(load_mapping(block.mapping))
    if not unknown:
        return []
    largest = max(bound for *_, bound in unknown)
    return [f"each recorded body's reported position is the body point it marks, though "
            f"{Path(block.mapping).name} gives neither pivot nor at_point for "
            + ", ".join(f"{name}'s {recorded} ({point}, up to {bound:g} m off)"
                        for _, name, recorded, point, bound in unknown)
            + f": a rigid body's pivot is by default its markers' centroid, and a proof's "
            f"tracking allowance would have to cover a pivot offset of {largest:g} m "
            "(sensing.pivots)"]


def _shifted(block: RecordingBlock, shift: Range) -> Range:
    """The range of recording times played at t = 0."""
    return Range(block.start + shift.min, block.start + shift.max)
