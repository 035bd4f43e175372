"""C3D files of markers (or rigid-body centres exported as points), read twice and
checked against the file's own structure (``c3d_header``).

Two independent readers (``c3d_readers``: ezc3d and py-c3d) read the file. A reading is
used only when its layout of the data (points and analog values per frame, frames, word
size) fills the file's data section to within its last 512-byte block and it read every
frame it states: a reader that takes a wrong count per frame reads every later frame at
the wrong offset, and that shows in the sizes. Where both readings are used they must
agree (layout, labels, units, rate and every position), else the file is refused naming
both figures. Where the header's counts differ from the readings' the file is refused,
unless the file's size rules the header's layout out. Where one reader cannot read the
file at all (ezc3d: SGI/MIPS processors, float analog offsets; py-c3d: some ART and
Xsens parameter sections), the other's checked reading is used. Every refusal is one
line naming the file, its processor and storage (and vendor, where it says), what was
found and what is read.

Every labelled point is a body (``POINT:LABELS`` then ``LABELS2``, ...: the first
``POINT:USED`` entries name the points, later ones are ignored), with its position only
(C3D holds no orientation; the rotations are NaN) and no streaming id. Units from
``POINT:UNITS``: mm, cm or m, any case, or a word of at least three letters that begins
millimetres/centimetres/metres (``'mete'``: a ``meters`` cut to the parameter's four
characters); millimetres, the format's convention, where none is given. Sample times
from ``POINT:RATE``. A point is untracked in a frame where the reader marks it invalid
(a negative residual), gives a non-finite coordinate, or places it at exactly (0, 0, 0)
(how several vendors store a drop-out).
"""

import dataclasses
from collections.abc import Collection
from pathlib import Path

import numpy as np

from safety_systems.files.documents import read_input
from safety_systems.files.input_error import InputError
from safety_systems.sensing.c3d_header import BLOCK, PROCESSORS, Header, read_header
from safety_systems.sensing.c3d_readers import Reading, read_ezc3d, read_py_c3d
from safety_systems.sensing.recording import Recording, check_recording

UNITS = {"mm": 0.001, "cm": 0.01, "m": 1.0}
UNIT_WORDS = {"mm": ("millimeters", "millimetres"), "cm": ("centimeters", "centimetres"),
              "m": ("meters", "metres")}
MAX_BYTES = 512 * 1024 * 1024
MAX_HEADER_FRAMES = 65535  # the header's last frame is a 16-bit word
RTOL = 1e-6  # the two readers' positions agree to float32's rounding (6e-8) and more
READ = ("C3D files of Intel, DEC or SGI/MIPS processors, 16-bit integer or float, whose "
        "header, parameters and size agree")


def unit_scale(text: str) -> float | None:
    """Metres per unit of a ``POINT:UNITS`` string (see the module docstring); None when
    it names no length unit read here."""
    t = text.strip().lower()
    for unit, words in UNIT_WORDS.items():
        if t == unit or t in words or (len(t) >= 3 and any(w.startswith(t) for w in words)):
            return UNITS[unit]
    return None


def read_c3d(path: str | Path, bodies: Collection[str] | None = None, *,
             truncated: str = "refuse") -> Recording:
    """Reads a C3D file's points (see the module docstring); raises InputError.
    ``bodies``: the labels to read (None: every point), so that the limit on bodies and
    the rule that each is named once apply to those only (real files repeat labels of
    points nobody maps). ``truncated`` is not used: a C3D file cut short is refused
    (its data section is shorter than its frames)."""
    file = str(path)
    read_input(path, max_bytes=MAX_BYTES)  # readable, not too large, and remembered
    header = read_header(file)
    if isinstance(header, str):
        raise InputError("C3D", header, READ, file=file)
    what = f"C3D ({header.describe()})"
    if header.processor not in PROCESSORS:
        raise InputError(f"{what}: processor", header.processor, "84 (Intel), 85 (DEC) or "
                         "86 (SGI/MIPS), the byte the format allows", file=file)
    readings = {"ezc3d": read_ezc3d(file), "c3d": read_py_c3d(file)}
    # the vendor as the file states it, from whichever reader read it, so that every
    # refusal from here on names it (a reading need not pass the checks to read it)
    vendor = next((r.vendor for r in readings.values() if isinstance(r, Reading)
                   and r.vendor), "")
    what = f"C3D ({header.describe()}{', ' + vendor if vendor else ''})"
    return _recording(_checked(header, readings, what, file), bodies, what, file)


def _checked(header: Header, readings: dict, what: str, file: str) -> Reading:
    """The reading to use (see the module docstring); raises InputError."""
    read = [r for r in readings.values() if isinstance(r, Reading)]
    if not read:
        raise InputError(f"{what}: <file>", "; ".join(f"{k}: {v}" for k, v in readings.items()),
                         READ + " (neither C3D reader can read this one)", file=file)
    data, said = header.data_bytes, header.layout
    # The frames the file holds: the header's count (a 16-bit word: a longer file states
    # its count in parameters, so there the reader's), which the data's size must confirm.
    saturated = said.frames <= 0 or said.frames >= MAX_HEADER_FRAMES
    expected = {r.library: r.layout.frames if saturated else said.frames for r in read}
    fit = [dataclasses.replace(r, layout=dataclasses.replace(r.layout,
                                                             frames=expected[r.library]))
           for r in read if r.frames_read == expected[r.library]]
    fit = [r for r in fit if r.layout.fits(data)]
    if not fit:
        if not any(r.has_point_group for r in read):
            raise InputError(f"{what}: POINT parameters", "none (no POINT group in the "
                             f"parameter section at block {header.parameter_block})",
                             "a POINT group: its USED, RATE and LABELS name the points a "
                             "mapping reads", file=file)
        readers = "; ".join(f"{r.library} reads {r.how}: " + dataclasses.replace(
            r.layout, frames=expected[r.library]).words() + (
            f", {r.frames_read:,} frames before the file ends"
            if r.frames_read < expected[r.library] else "") for r in read)
        fits = said.fits(data) and not saturated
        raise InputError(f"{what}: data section", f"{data:,} bytes", "the frames of the "
                         f"layout the parameters state, to within one {BLOCK}-byte block "
                         f"({readers}); the header states {said.words()}, " + (
                             "which fits: the header and the parameters disagree" if fits
                             else "which does not fit either"), file=file)
    for r in fit:
        per_frame = (r.layout.points, r.layout.analog, r.layout.word)
        if per_frame != (said.points, said.analog, said.word) and said.fits(data):
            raise InputError(f"{what}: header", said.words(), f"the parameters' layout as "
                             f"{r.library} reads them ({r.how}: {r.layout.words()}); both "
                             "fit the file's size, so it cannot say which is right", file=file)
        if r.layout.word == 2 and not np.isclose(r.scale, header.scale, rtol=1e-5, atol=0):
            raise InputError(f"{what}: POINT:SCALE", r.scale, f"the header's scale factor "
                             f"({header.scale:g}): the two disagree on the length of an "
                             "integer step, so on every position", file=file)
    if len(fit) == 2:
        _agree(*fit, what, file)
    return fit[0]


def _agree(a: Reading, b: Reading, what: str, file: str) -> None:
    """Raises InputError naming both figures where two readings differ."""
    def refuse(field: str, x, y) -> None:
        raise InputError(f"{what}: {field}", f"{a.library} {x}, {b.library} {y}",
                         "the same from both C3D readers", file=file)

    if a.layout != b.layout:
        refuse("layout", a.layout.words(), b.layout.words())
    n = a.layout.points
    if a.labels[:n] != b.labels[:n]:
        k = next(i for i in range(n) if a.labels[i:i + 1] != b.labels[i:i + 1])
        refuse(f"POINT:LABELS[{k}]", a.labels[k:k + 1], b.labels[k:k + 1])
    if a.units.lower() != b.units.lower():
        refuse("POINT:UNITS", repr(a.units), repr(b.units))
    if not np.isclose(a.rate, b.rate, rtol=RTOL, atol=0.0):
        refuse("POINT:RATE", f"{a.rate:g} Hz", f"{b.rate:g} Hz")
    p, q = a.positions, b.positions
    same = (np.isnan(p) == np.isnan(q)) & (np.isnan(p) | np.isclose(p, q, rtol=RTOL,
                                                                    atol=RTOL))
    if not same.all():
        t, k = np.argwhere(~np.all(same, axis=2))[0]
        label = a.labels[k] if k < len(a.labels) else f"point {k + 1}"
        refuse(f"frame {t + 1}, point '{label}'", _position(p[t, k]), _position(q[t, k]))


def _position(p: np.ndarray) -> str:
    return "invalid" if np.isnan(p).any() else "(" + ", ".join(f"{x:.4f}" for x in p) + ")"


def _recording(reading: Reading, bodies, what: str, file: str) -> Recording:
    """The Recording of a checked reading (labels, units, rate, drop-outs)."""
    n = reading.layout.points
    labels = list(reading.labels[:n]) + [""] * max(0, n - len(reading.labels))
    scale = unit_scale(reading.units) if reading.units else UNITS["mm"]
    if scale is None:
        raise InputError(f"{what}: POINT:UNITS", reading.units, "mm | cm | m (any case), or "
                         "a word of 3 or more letters that begins millimeters, centimeters "
                         "or meters (or -metres)", file=file)
    rate = reading.rate
    if not np.isfinite(rate) or not 0.0 < rate <= 100_000.0:
        raise InputError(f"{what}: POINT:RATE", rate, "a frame rate in Hz, 0 < rate <= "
                         "100000", file=file)
    positions = reading.positions * scale
    # A point at exactly the origin is a drop-out (ART, Motion Analysis and others store
    # a lost point as 0, 0, 0, with or without an invalid residual), not a position.
    positions[np.all(positions == 0.0, axis=2)] = np.nan
    wanted = None if bodies is None else set(bodies)
    keep = [i for i, x in enumerate(labels) if x and (wanted is None or x in wanted)]
    if not reading.has_point_group:
        raise InputError(f"{what}: POINT parameters", "none (its parameter section holds no "
                         "POINT group, so its points have no labels)", "labelled points: a "
                         "POINT group whose LABELS name the points a mapping reads",
                         file=file)
    if not keep:
        raise InputError(f"{what}: POINT:LABELS", f"no point named {sorted(bodies or ())}"
                         if bodies is not None else "no labelled point",
                         f"labels of the file: {labels[:20]}", file=file)
    frames = positions.shape[0]
    try:
        return check_recording(Recording(file, np.arange(frames) / rate,
                                         tuple(labels[i] for i in keep), (0,) * len(keep),
                                         positions[:, keep], np.full((frames, len(keep), 4),
                                                                     np.nan), what))
    except InputError as e:
        raise InputError(f"{what}: {e.field}", e.value, e.allowed, file=file) from None
