"""The mapping of a recording (or a live stream) onto the cell: which recorded rigid body
marks which body point of which operator, and where the capture frame lies in the cell.

A mapping YAML file::

    capture_to_cell:          # p_cell = R p_capture + translation
      up_axis: y              # Motive's default: Y up (z: the capture frame is Z up)
      rpy_deg: [0, 0, 0]      # then a rotation about the cell's x, y, z axes, deg
      translation: [1.2, -0.4, -0.8]   # m: the capture origin in the cell (robot base) frame
    operators:
    - name: technician
      bodies:
      - {recorded: RightGlove, name: right_glove, point: hand_right, streaming_id: 1}
      - {recorded: LeftGlove, name: left_glove, point: hand_left, streaming_id: 2}
      - {recorded: Helmet, name: head, point: head, streaming_id: 3}
      - {recorded: ElbowBandR, name: right_elbow, point: elbow_right, streaming_id: 4}

``units`` (m, cm, mm or in) is the length unit of a BVH file, which states none (other
formats state theirs, and refuse this field). ``truncated: use`` (default ``refuse``)
reads a recording cut short of the length its header states (a Motive export's ``Total
Exported Frames``) as far as it goes, with a warning line. Only the mapped bodies are
read: the limits on a recording's bodies and the rule that each is named once apply to
those. ``flip_speed`` (m/s, default 10) is the glitch rule's speed
(``sensing.recording.flips``): a mapped body's sample reached and left faster than it,
from and back to a track the body could have followed, is a capture glitch, read as
untracked with a warning line naming the body, how many and the first one's time.
``max_speed`` (m/s, default 10) and ``max_acceleration`` (m/s^2 over 50 ms, default
150) bound how a mapped body may move (``sensing.plausibility``): a recording whose
mapped body moves faster is refused, naming the body, the frame and the figure, before
anything replays; ``implausible: untracked`` (default ``refuse``) reads the samples a
body was held still on before such a jump as untracked, with a warning line, and
refuses what is still implausible (the live replay of ``run`` streams those samples
as untracked too: ``RecordedBodies.held``). ``recording`` (optional) names the recording the
mapping maps, relative to the mapping file: ``check mapping`` then opens it and applies
every rule a simulation applies, and a scenario that names another recording with this
mapping is refused.
``recorded`` names the body in the recording (Motive's rigid body name, a C3D point
label); ``streaming_id`` is its NatNet rigid-body id (Motive's "Streaming ID"), which
the live runtime needs (frames carry ids, not names; 0: not given) and which, where a
recording gives ids too, must agree with it. ``up_axis: y`` turns the capture frame's
Y-up axes into the cell's Z-up ones (a rotation of +90 deg about x: (x, y, z) ->
(x, -z, y)); ``rpy_deg`` is applied after it (R = Rz(yaw) Ry(pitch) Rx(roll)).
``pivot`` [x, y, z] (m, in the rigid body's own frame) is where the body point lies from
the position the recording or the stream reports (Motive's pivot, by default its markers'
centroid), turned with the body's orientation; ``at_point: true`` says the reported
position is the body point itself (the pivot moved onto it in Motive, or a skeleton's
joint). Without either the point may lie as far from the reported position as the body's
kind allows (``sensing.pivots``: a helmet 0.15 m), which a proof's tracking allowance must
cover: the live runtime refuses such a body under a certificate that assumed less.
``point`` is the body point the recorded body marks (``safety_systems.cell.human_body
.POINTS``: head, neck, chest, pelvis, shoulders, elbows, hands; empty: by its name, as
in scenarios: ``head``, ``hand``, ``other_hand``, ``right_glove``, ``left_glove``); the
monitor bounds the operator's other segments from them, the more points the tighter.
Read under the rules of ``safety_systems.files.documents``.

This module must not use ``from __future__ import annotations`` (the YAML loader).
"""

import dataclasses as dc
import functools
import hashlib
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from safety_systems.cell.human_body import LEGACY_POINTS, POINTS
from safety_systems.files.documents import load_document, read_input
from safety_systems.cell.operators import MAX_BODIES_PER_OPERATOR, MAX_OPERATORS, NAME
from safety_systems.files.input_error import InputError
from safety_systems.files.ranges import number
from safety_systems.sensing.plausibility import (
    IMPLAUSIBLE,
    MAX_ACCELERATION,
    MAX_SPEED,
    first_implausible,
    held_before_jumps,
)
from safety_systems.sensing.recording import (
    TRUNCATED,
    Recording,
    fill_gaps,
    flips,
    gaps,
    span,
)
from safety_systems.sensing.pivots import body_points, pivot_bound
from safety_systems.sensing.recording_files import LENGTH_UNITS, read_recording
from safety_systems.sensing.ros_bag import bag_digest

UP_AXES = ("y", "z")
MAX_STREAMING_ID = 2**31 - 1
MAX_RECORDING_BYTES = 512 * 1024 * 1024


@dc.dataclass
class CaptureToCell:
    """X_CellCapture: p_cell = R p_capture + translation (see the module docstring)."""

    up_axis: str = "y"
    rpy_deg: list[float] = number([0.0, 0.0, 0.0], ge=-360.0, le=360.0, unit="deg")
    translation: list[float] = number([0.0, 0.0, 0.0], ge=-20.0, le=20.0, unit="m")


@dc.dataclass
class MappedBody:
    """One recorded rigid body as an operator's tracked body, marking the body point
    ``point`` (see the module docstring)."""

    recorded: str = ""
    name: str = ""
    point: str = ""
    streaming_id: int = number(0, ge=0, le=MAX_STREAMING_ID)
    pivot: list[float] = number([], ge=-0.5, le=0.5, unit="m")
    at_point: bool = False


def mapped_point(b: MappedBody) -> str:
    """The body point a mapped body marks: its ``point``, or its legacy name's."""
    return b.point or LEGACY_POINTS.get(b.name, "")


@dc.dataclass
class MappedOperator:
    name: str = ""
    bodies: list[MappedBody] = dc.field(default_factory=list)


@dc.dataclass
class RecordingMapping:
    """See the module docstring. ``ignore_ids``: streaming ids of other rigid bodies in
    the live stream (a tool, the robot base's calibration body) that the runtime leaves
    out; any other id it does not know stops the robot (the tracker's ``unknown_id``)."""

    capture_to_cell: CaptureToCell = dc.field(default_factory=CaptureToCell)
    operators: list[MappedOperator] = dc.field(default_factory=list)
    ignore_ids: list[int] = number([], ge=1, le=MAX_STREAMING_ID)
    truncated: str = "refuse"  # a recording cut short: refuse | use (its frames, warned)
    units: str = ""  # the length unit of a recording that states none (BVH): m | cm | mm | in
    flip_speed: float = number(10.0, ge=2.0, le=1000.0, unit="m/s")  # capture glitches
    max_speed: float = number(MAX_SPEED, ge=1.0, le=1000.0, unit="m/s")  # plausibility
    max_acceleration: float = number(MAX_ACCELERATION, ge=10.0, le=10_000.0, unit="m/s^2")
    implausible: str = "refuse"  # refuse | untracked (held samples before a jump)
    recording: str = ""  # the recording mapped, relative to this file (check mapping)


def validate_mapping(m: RecordingMapping) -> None:
    """Rules between the mapping's fields; raises InputError."""
    c = m.capture_to_cell
    if c.up_axis not in UP_AXES:
        raise InputError("capture_to_cell.up_axis", c.up_axis, " | ".join(UP_AXES))
    for name in ("rpy_deg", "translation"):
        if len(getattr(c, name)) != 3:
            raise InputError(f"capture_to_cell.{name}", getattr(c, name), "3 numbers")
    if not 1 <= len(m.operators) <= MAX_OPERATORS:
        raise InputError("operators", len(m.operators), f"1 to {MAX_OPERATORS} operators")
    if m.truncated not in TRUNCATED:
        raise InputError("truncated", m.truncated, " | ".join(TRUNCATED))
    if m.implausible not in IMPLAUSIBLE:
        raise InputError("implausible", m.implausible, " | ".join(IMPLAUSIBLE))
    if m.units not in ("",) + LENGTH_UNITS:
        raise InputError("units", m.units, "empty, or for a BVH file " + " | ".join(LENGTH_UNITS))
    names, recorded, ids = set(), set(), set()
    for i, o in enumerate(m.operators):
        if NAME.fullmatch(o.name) is None or o.name in names:
            raise InputError(f"operators[{i}].name", o.name, "a unique name of 1 to 64 "
                             "letters, digits, '_', '-' or '.'")
        names.add(o.name)
        if not 1 <= len(o.bodies) <= MAX_BODIES_PER_OPERATOR:
            raise InputError(f"operators[{i}].bodies", len(o.bodies),
                             f"1 to {MAX_BODIES_PER_OPERATOR} bodies (one per body point)")
        slots, marked = set(), set()
        for j, b in enumerate(o.bodies):
            where = f"operators[{i}].bodies[{j}]"
            if NAME.fullmatch(b.name) is None or b.name in slots:
                raise InputError(f"{where}.name", b.name, "a name unique in its operator, 1 "
                                 "to 64 letters, digits, '_', '-' or '.'")
            slots.add(b.name)
            point = mapped_point(b)
            if point not in POINTS or point in marked:
                raise InputError(f"{where}.point", b.point, "a body point no other body of "
                                 "the operator marks: " + " | ".join(POINTS) + " (empty only "
                                 "for the names " + ", ".join(LEGACY_POINTS) + ")")
            marked.add(point)
            if not b.recorded or b.recorded in recorded:
                raise InputError(f"{where}.recorded", b.recorded,
                                 "the name of a recorded body, each mapped once")
            recorded.add(b.recorded)
            if b.streaming_id and b.streaming_id in ids:
                raise InputError(f"{where}.streaming_id", b.streaming_id,
                                 "a streaming id given to one body only")
            ids.add(b.streaming_id)
            if len(b.pivot) not in (0, 3) or (len(b.pivot) and b.at_point):
                raise InputError(f"{where}.pivot", b.pivot, "empty, or [x, y, z] in m (the "
                                 "body point from the reported position, in the body's own "
                                 "frame), and then no at_point")
    for i, x in enumerate(m.ignore_ids):
        if x in ids:
            raise InputError(f"ignore_ids[{i}]", x, "ids of bodies the mapping does not map")


def load_mapping(path: str | Path) -> RecordingMapping:
    """Loads and checks a mapping file; raises InputError (one line)."""
    return load_document(path, RecordingMapping, validate_mapping)


def rotation_matrix(c: CaptureToCell) -> np.ndarray:
    """R of :class:`CaptureToCell` (3, 3)."""
    up = np.eye(3) if c.up_axis == "z" else Rotation.from_euler("x", 90.0, degrees=True
                                                                 ).as_matrix()
    return Rotation.from_euler("xyz", c.rpy_deg, degrees=True).as_matrix() @ up


def to_cell(c: CaptureToCell, positions: np.ndarray) -> np.ndarray:
    """Capture-frame positions (..., 3) in the cell frame (NaN stays NaN). The one
    transform of recordings and of the live stream."""
    return np.asarray(positions, dtype=float) @ rotation_matrix(c).T + np.asarray(
        c.translation, dtype=float)


def unknown_pivots(mapping: RecordingMapping) -> list[tuple[str, float]]:
    """(its field, "operators[i].bodies[j]", how far its point may be from its reported
    position, m) of every mapped body whose mapping gives neither its pivot nor
    ``at_point`` (``sensing.pivots.pivot_bound``)."""
    out = []
    for i, o in enumerate(mapping.operators):
        for j, b in enumerate(o.bodies):
            bound = pivot_bound(mapped_point(b), b.pivot, b.at_point)
            if bound > 0.0:
                out.append((f"operators[{i}].bodies[{j}]", bound))
    return out


def unknown_pivot_bodies(mapping: RecordingMapping, operator: str | None = None
                         ) -> list[tuple[str, str, str, str, float]]:
    """(field, operator, recorded name, point marked, how far the point may be from the
    reported position, m) of every body of ``mapping`` (of its operator ``operator``; None:
    every operator) whose pivot is unknown (:func:`unknown_pivots`)."""
    return [(f"operators[{i}].bodies[{j}]", o.name, b.recorded, mapped_point(b), bound)
            for i, o in enumerate(mapping.operators) if operator in (None, o.name)
            for j, b in enumerate(o.bodies)
            if (bound := pivot_bound(mapped_point(b), b.pivot, b.at_point)) > 0.0]


def pivot_warnings(path: str | Path, operator: str | None = None) -> list[str]:
    """One line per body of the mapping file ``path`` whose pivot is unknown
    (:func:`unknown_pivot_bodies`): the body, the point it marks and the pivot offset a
    proof's tracking allowance must then cover. Replays of recordings and verifications
    over them take such a body's reported position for its point and say so with these
    lines."""
    return [f"{Path(path).name}: {field}.pivot: {name}'s {recorded} (marking the {point}) "
            "gives neither pivot nor at_point: its reported position (a rigid body's pivot, "
            f"by default its markers' centroid) is taken for the point, and may be {bound:g} "
            "m off it, the pivot offset a proof's tracking allowance must then cover "
            "(sensing.pivots)"
            for field, name, recorded, point, bound in
            unknown_pivot_bodies(load_mapping(path), operator)]


def bodies(mapping: RecordingMapping) -> list[tuple[str, MappedBody]]:
    """Every mapped body with its operator's name, operator by operator."""
    return [(o.name, b) for o in mapping.operators for b in o.bodies]


def find_operator(mapping: RecordingMapping, name: str, where: str) -> MappedOperator:
    """The mapping's operator ``name`` (empty: the only one); raises InputError."""
    if not name and len(mapping.operators) == 1:
        return mapping.operators[0]
    for o in mapping.operators:
        if o.name == name:
            return o
    raise InputError(where, name, "one of the mapping's operators "
                     f"{[o.name for o in mapping.operators]}")


@dc.dataclass(frozen=True, eq=False)
class RecordedBodies:
    """One mapped operator's bodies from a recording, in the cell frame: the samples
    (``times`` (T,), ``points`` (T, n, 3) with untracked samples filled,
    ``recording.fill_gaps``), when each body is tracked (``tracked_times`` (n, 2), first
    and last) and the gaps in between (recording time), names, body points and ids."""

    times: np.ndarray
    points: np.ndarray
    tracked_times: np.ndarray
    gaps: tuple
    names: tuple
    points_marked: tuple  # the body point each body marks (``human_body.POINTS``)
    ids: tuple
    raw: np.ndarray  # (T, n, 3) the cell-frame samples, NaN where untracked
    flips: tuple = ()  # per body: samples taken as capture glitches (``recording.flips``)
    held: np.ndarray | None = None  # (T, n) samples read as untracked by the mapping's
    #                                 implausible: untracked (held still before a jump)


def recorded_bodies(rec: Recording, mapping: RecordingMapping, operator: MappedOperator
                    ) -> RecordedBodies:
    """The bodies of ``operator`` in ``rec`` (see :class:`RecordedBodies`); raises
    InputError naming a body the recording lacks or whose id differs."""
    index = []
    for j, b in enumerate(operator.bodies):
        if b.recorded not in rec.names:
            raise InputError(f"operators[{operator.name}].bodies[{j}].recorded", b.recorded,
                             f"a body of {rec.file}: {list(rec.names)}")
        k = rec.body(b.recorded)
        if b.streaming_id and rec.ids[k] and b.streaming_id != rec.ids[k]:
            raise InputError(f"operators[{operator.name}].bodies[{j}].streaming_id",
                             b.streaming_id, f"the recording's id of {b.recorded} "
                             f"({rec.ids[k]})")
        index.append(k)
    reported = rec.positions[:, index].copy()
    for i, b in enumerate(operator.bodies):  # each at the body point it marks
        if len(b.pivot):
            if not np.isfinite(rec.rotations[:, index[i]]).any():
                raise InputError(f"operators[{operator.name}].bodies[{i}].pivot", b.pivot,
                                 f"empty for a body {rec.format or 'the recording'} gives "
                                 "no orientation of (a marker, not a rigid body)",
                                 file=rec.file)
            reported[:, i] = body_points(reported[:, i], rec.rotations[:, index[i]],
                                         b.pivot)
    raw = to_cell(mapping.capture_to_cell, reported)
    glitch, held = _repaired(rec, mapping, [b.recorded for b in operator.bodies], raw)
    tracked = np.all(np.isfinite(raw), axis=2)
    return RecordedBodies(
        times=rec.times, points=fill_gaps(rec.times, raw),
        tracked_times=np.array([span(rec.times, tracked[:, i]) for i in range(len(index))]),
        gaps=tuple(tuple(gaps(rec.times, tracked[:, i])) for i in range(len(index))),
        names=tuple(b.name for b in operator.bodies),
        points_marked=tuple(mapped_point(b) for b in operator.bodies),
        ids=tuple(rec.ids[k] for k in index), raw=raw,
        flips=tuple(int(n) for n in glitch.sum(axis=0)), held=held)


def _repaired(rec: Recording, mapping: RecordingMapping, names: list[str], raw: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """Applies the mapping's glitch and plausibility rules to the samples ``raw`` (T, n,
    3) of the recorded bodies ``names``, in place (see the module docstring): (capture
    glitches, samples held before a jump) read as untracked, each (T, n) bool, with a
    warning line per body; raises InputError naming the recording, its format, the body,
    the frame and the figure of what is still implausible."""
    glitch = flips(rec.times, raw, mapping.flip_speed)
    raw[glitch] = np.nan
    for i in np.flatnonzero(glitch.any(axis=0)):
        first = float(rec.times[np.flatnonzero(glitch[:, i])[0]])
        warnings.warn(f"{rec.file}: {names[i]}: {int(glitch[:, i].sum())} "
                      f"sample(s) from t = {first:g} s read as untracked: capture glitches "
                      f"(out of its track and back faster than flip_speed, "
                      f"{mapping.flip_speed:g} m/s)", stacklevel=3)
    held = np.zeros(raw.shape[:2], dtype=bool)
    if mapping.implausible == "untracked":
        held = held_before_jumps(rec.times, raw, max_speed=mapping.max_speed)
        raw[held] = np.nan
        for i in np.flatnonzero(held.any(axis=0)):
            frames = np.flatnonzero(held[:, i])
            warnings.warn(f"{rec.file}: {names[i]}: {frames.size} sample(s) "
                          f"from frame {frames[0]} (t = {rec.times[frames[0]]:g} s) read as "
                          "untracked: held still, then left faster than max_speed "
                          f"({mapping.max_speed:g} m/s; implausible: untracked)", stacklevel=3)
    bad = first_implausible(rec.times, raw, max_speed=mapping.max_speed,
                            max_acceleration=mapping.max_acceleration)
    if bad is None:
        return glitch, held
    body = names[bad.body]
    what = rec.format or "the recording"
    if bad.what == "speed":
        figure, allowed = f"{bad.figure:.2f} m/s", (
            f"at most max_speed, {mapping.max_speed:g} m/s, from its previous tracked sample")
    else:
        figure, allowed = f"{bad.figure:.1f} m/s^2", (
            f"at most max_acceleration, {mapping.max_acceleration:g} m/s^2 over 50 ms")
    raise InputError(f"{what}: '{body}' at frame {bad.frame} of the file (counted from 0; "
                     f"t = {rec.times[bad.frame]:.4g} s from its first): {bad.what}", figure,
                     allowed + ", a person's (5 mm of capture "
                     "noise allowed per sample; a misread file or a body held still then "
                     "jumping moves so: the mapping's max_speed and max_acceleration raise "
                     "the bounds, implausible: untracked reads held samples as untracked)",
                     file=rec.file)


def check_recording_file(path: str | Path) -> Recording:
    """``check recording``: the recording ``path`` read (every body, capture frame) under
    the rules a mapping applies to its bodies at the default bounds (capture glitches,
    then plausibility: a rigid transform to the cell keeps every speed); raises
    InputError with the line a mapping of the offending body would give."""
    rec = read_recording(path)
    _repaired(rec, RecordingMapping(), list(rec.names), rec.positions.copy())
    return rec


def mapped_names(mapping: RecordingMapping) -> list[str]:
    """The recorded bodies a mapping maps, every operator's: the ones a reader reads."""
    return [b.recorded for o in mapping.operators for b in o.bodies]


@functools.lru_cache(maxsize=16)
def _cached(recording: str, mapping: str, operator: str, digests: tuple) -> RecordedBodies:
    m = load_mapping(mapping)
    named = mapped_recording(m, mapping)
    if named is not None and named != Path(recording).resolve():
        raise InputError("recording", m.recording, f"empty, or the recording used with it "
                         f"({recording})", file=mapping)
    try:
        chosen = find_operator(m, operator, "name")
        rec = read_recording(recording, mapped_names(m), truncated=m.truncated,
                             units=m.units)
        return recorded_bodies(rec, m, chosen)
    except InputError as e:
        raise e.in_file(mapping) from None


def mapped_recording(m: RecordingMapping, mapping: str | Path) -> Path | None:
    """The full path of the recording mapping ``m`` (read from ``mapping``) names, or
    None where it names none."""
    return (Path(mapping).parent / m.recording).resolve() if m.recording else None


def check_mapping(path: str | Path) -> list[RecordedBodies]:
    """``check mapping``: the mapping file ``path`` and, where it names its recording,
    that recording under every rule a simulation applies to it (each operator's bodies
    read, glitches, plausibility), through the simulation's own function
    (:func:`load_recorded_operator`); raises InputError, the line a simulation gives."""
    m = load_mapping(path)
    recording = mapped_recording(m, path)
    if recording is None:
        return []
    if not (recording.is_file() or recording.is_dir()):
        raise InputError("recording", m.recording, f"an existing recording file or ROS bag "
                         f"folder ({recording})", file=str(path))
    return [load_recorded_operator(recording, path, o.name) for o in m.operators]


def load_recorded_operator(recording: str | Path, mapping: str | Path,
                           operator: str = "") -> RecordedBodies:
    """:func:`recorded_bodies` of files, kept while neither file's bytes change (the
    scenarios of a space share them; each call still reads both files, so that they are
    named among a result's inputs); raises InputError."""
    digests = tuple(bag_digest(p) if Path(p).is_dir() else
                    hashlib.sha256(read_input(p, max_bytes=MAX_RECORDING_BYTES)).hexdigest()
                    for p in (recording, mapping))
    return _cached(str(recording), str(mapping), operator, digests)
