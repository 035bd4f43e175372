"""OptiTrack Motive's CSV export: rigid bodies and markers over time.

The export's layout (Motive 2.x and 3.x, "Format Version" 1.2x), as read here (1.21 and
1.22 leave the Type, Name and ID labels empty: there the rows are taken in that order;
skeleton exports add a ``Parent`` row after ID)::

    Format Version,1.23,Take Name,...,Capture Frame Rate,120.0,...,Rotation Type,Quaternion,
        Length Units,Meters,Coordinate Space,Global
    (an empty line)
    ,Type,Rigid Body,Rigid Body,...,Marker,...
    ,Name,RightGlove,RightGlove,...,RightGlove:Marker1,...
    ,ID,1,1,...
    ,,Rotation,Rotation,Rotation,Rotation,Position,Position,Position,Mean Marker Error,...
    Frame,Time (Seconds),X,Y,Z,W,X,Y,Z,,...
    0,0.000000,0.0012,...

The first line holds key, value pairs: ``Rotation Type`` is ``Quaternion`` (columns X, Y,
Z, W) or an Euler order (``XYZ``, ``XZY``, ``YXZ``, ``YZX``, ``ZXY``, ``ZYX``: columns X,
Y, Z in degrees, read as rotations about the body's own axes in that order; Motive's
documentation says "elemental rotations" without saying about which axes, so this is
our reading), ``Length Units`` is ``Meters``, ``Centimeters`` or ``Millimeters``. The
bodies are the ``Rigid Body`` and ``Bone`` columns (position and rotation) and the
``Marker`` columns (position only); ``Rigid Body Marker`` and ``Bone Marker`` columns
(where the solved model expects its markers) and the quality columns are skipped. An
empty cell is a frame where the body was not tracked. Times are kept as seconds from the
first frame (see :func:`read_motive_csv` for the frame rate).
"""

import csv
import io
import math
import warnings
from collections.abc import Collection
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from safety_systems.files.documents import read_text
from safety_systems.files.input_error import InputError
from safety_systems.sensing.recording import MAX_SAMPLES, TRUNCATED, Recording, check_recording

EULER_ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
ROTATION_TYPES = ("Quaternion",) + EULER_ORDERS
UNITS = {"Meters": 1.0, "Centimeters": 0.01, "Millimeters": 0.001}
# Column types read as bodies: rigid bodies and skeleton bones (position and rotation),
# markers (position). "Rigid Body Marker" and "Bone Marker" columns (where the solved
# model puts its markers) and the quality columns are skipped.
BODY_TYPES = ("Rigid Body", "Bone", "Marker")
ROTATED = ("Rigid Body", "Bone")
HEADER_ROWS = ("Type", "Name", "ID", "Parent")
# The export layouts read (the first line's "Format Version"): 1.2 and 1.21 (Motive 1.x
# and 2.0, unlabelled header rows and quality columns), 1.22 (Motive 2.x), 1.23 to 1.25
# (Motive 2.2 to 3.x, labelled rows, skeleton exports with a Parent row).
VERSIONS = ("1.2", "1.21", "1.22", "1.23", "1.24", "1.25")
MAX_BYTES = 512 * 1024 * 1024


def _settings(rows: list[list[str]], file: str) -> dict[str, str]:
    """The first line's key, value pairs; raises InputError naming the export's format
    version where it is not one read here (:data:`VERSIONS`), or where the file does not
    begin as a Motive export."""
    row = rows[0]
    if len(row) < 2 or row[0].strip() != "Format Version":
        said = _version_said(rows[:8])
        raise InputError("line 1", ",".join(row[:4]), f"a Motive CSV export of Format "
                         f"Version {', '.join(VERSIONS)} (it begins with 'Format Version')"
                         + (f"; this file says {said}" if said else ""), file=file)
    settings = {row[i].strip(): row[i + 1].strip() for i in range(0, len(row) - 1, 2)}
    version = settings["Format Version"]
    if version not in VERSIONS:
        raise InputError("Motive CSV: Format Version", version, f"{', '.join(VERSIONS)}, the "
                         "versions read (another version's layout differs: export the take "
                         "again from a Motive that writes one of these)", file=file)
    return settings


def _version_said(rows: list[list[str]]) -> str:
    """'version 1.1' where an older export names its format in its first lines (a cell
    'version' or 'format version' followed by the figure), else ''."""
    for row in rows:
        cells = [c.strip() for c in row]
        for i, c in enumerate(cells[:-1]):
            if c.lower() in ("version", "format version", "format") and cells[i + 1]:
                return f"{c} {cells[i + 1]}"
    return ""


def _header_rows(rows: list[list[str]], file: str) -> tuple[dict, int]:
    """The Type, Name, ID and Parent rows by name, the group row and the axis row, and the
    index of the first data row. The rows between the settings and the group row are
    named by their label (column 2: Format Version 1.23 on); where the label is empty
    (1.21, 1.22) they are, in order, Type, Name, ID and Parent."""
    for i, row in enumerate(rows[1:16], start=1):
        if row and row[0].strip() == "Frame":
            break
    else:
        raise InputError("header row 'Frame'", "missing", "Motive's header rows: Type, Name, "
                         "ID, the column groups and 'Frame,Time (Seconds),...'", file=file)
    found: dict[str, list[str]] = {}
    unlabelled = []
    for row in rows[1:i - 1]:
        if not any(c.strip() for c in row):
            continue
        label = row[1].strip() if len(row) > 1 and not row[0].strip() else ""
        if label in HEADER_ROWS and label not in found:
            found[label] = row
        else:
            unlabelled.append(row)
    for label, row in zip([k for k in HEADER_ROWS if k not in found], unlabelled):
        found[label] = row
    for label in ("Type", "Name"):
        if label not in found:
            raise InputError(f"header row '{label}'", "missing", "Motive's header rows: Type, "
                             "Name, ID, the column groups and 'Frame,Time (Seconds),...'",
                             file=file)
    found["group"], found["axis"] = rows[i - 1], rows[i]
    return found, i + 1


def _number(cell: str, line: int, column: str, file: str) -> float:
    if not cell.strip():
        return math.nan
    try:
        x = float(cell)
    except ValueError:
        raise InputError(f"line {line}, column {column}", cell, "a number or an empty cell",
                         file=file) from None
    if not math.isfinite(x):
        raise InputError(f"line {line}, column {column}", cell, "a finite number", file=file)
    return x


def _rate(settings: dict[str, str], file: str) -> float:
    """The export's frame rate (Hz) from its header (``Export Frame Rate``, else ``Capture
    Frame Rate``); NaN where neither is given."""
    for key in ("Export Frame Rate", "Capture Frame Rate"):
        if settings.get(key, ""):
            try:
                rate = float(settings[key])
            except ValueError:
                rate = math.nan
            if not (math.isfinite(rate) and 0.0 < rate <= 100_000.0):
                raise InputError(key, settings[key], "a frame rate in Hz, above 0 and at most "
                                 "100,000", file=file)
            return rate
    return math.nan


def read_motive_csv(path: str | Path, bodies: Collection[str] | None = None, *,
                    truncated: str = "refuse") -> Recording:
    """Reads a Motive CSV export (see the module docstring); raises InputError.

    ``bodies``: the names to read (a mapping's recorded bodies; None: every body), so
    that the limit on bodies and the rule that each is named once apply to those only.
    Times come from the frame numbers and the header's frame rate (the time column is
    rounded: at 360 Hz to a few ms), checked against the time column to half a frame;
    frames missing from the numbering are frames in which no body was tracked. An export
    with fewer frames than its header's ``Total Exported Frames`` (cut short) is refused,
    or, with ``truncated="use"``, read as far as it goes, with a warning line."""
    file = str(path)
    if truncated not in TRUNCATED:
        raise ValueError(f"truncated={truncated!r}: allowed {' | '.join(TRUNCATED)}")
    rows = list(csv.reader(io.StringIO(read_text(path, max_bytes=MAX_BYTES))))
    if not rows:
        raise InputError("<file>", "empty", "a Motive CSV export", file=file)
    settings = _settings(rows, file)
    what = f"Motive CSV (Format Version {settings['Format Version']})"
    try:
        return _read_rows(rows, settings, bodies, truncated, what, file)
    except InputError as e:  # the format and its version named in every refusal
        raise InputError(f"{what}: {e.field}", e.value, e.allowed, file=e.file) from None


def _read_rows(rows: list[list[str]], settings: dict[str, str], bodies, truncated: str,
               what: str, file: str) -> Recording:
    """:func:`read_motive_csv`'s reading of the rows after the first line."""
    rotation = settings.get("Rotation Type", "Quaternion")
    if rotation not in ROTATION_TYPES:
        raise InputError("Rotation Type", rotation, " | ".join(ROTATION_TYPES), file=file)
    unit = settings.get("Length Units", "")
    if unit not in UNITS:
        raise InputError("Length Units", unit, " | ".join(UNITS), file=file)
    rate = _rate(settings, file)
    head, first = _header_rows(rows, file)
    width = len(head["axis"])
    pad = {k: (v + [""] * width)[:width] for k, v in head.items()}
    wanted = None if bodies is None else set(bodies)
    found: dict[tuple[str, str], dict] = {}  # (type, name) -> columns
    for j in range(2, width):
        kind, name = pad["Type"][j].strip(), pad["Name"][j].strip()
        group, axis = pad["group"][j].strip(), pad["axis"][j].strip()
        if kind not in BODY_TYPES or group not in ("Position", "Rotation"):
            continue
        if wanted is not None and name not in wanted:
            continue
        entry = found.setdefault((kind, name), {"id": pad.get("ID", pad["Name"])[j].strip()})
        entry[(group, axis)] = j
    if not found:
        raise InputError("Type", "no Rigid Body, Bone or Marker columns" + (
            "" if wanted is None else f" named {sorted(wanted)}"), "a recording of rigid "
            "bodies, bones or markers", file=file)
    data = [r for r in rows[first:] if any(c.strip() for c in r)]
    if len(data) > MAX_SAMPLES:
        raise InputError("<frames>", len(data), f"at most {MAX_SAMPLES:,} frames", file=file)
    used = sorted({0, 1} | {j for b in found.values() for k, j in b.items() if k != "id"})
    table = np.full((len(data), width), np.nan)
    for i, row in enumerate(data):
        if len(row) > width:
            raise InputError(f"line {first + i + 1}", f"{len(row)} cells",
                             f"at most {width} cells, as in the header", file=file)
        for j in used:
            if j < len(row):
                table[i, j] = _number(row[j], first + i + 1, pad["axis"][j] or str(j + 1),
                                      file)
    if np.any(np.isnan(table[:, 1])):
        raise InputError("Time (Seconds)", "an empty cell", "a time on every frame", file=file)
    frame_at = _frame_numbers(table, first, file)
    _check_complete(settings, len(data), truncated, file)
    scale = UNITS[unit]
    names, ids, positions, rotations = [], [], [], []
    for (kind, name), cols in found.items():
        need = [("Position", a) for a in "XYZ"]
        if kind in ROTATED:
            need += [("Rotation", a) for a in need_axes(rotation)]
        missing = [f"{g} {a}" for g, a in need if (g, a) not in cols]
        if missing:
            raise InputError(f"{kind} '{name}'", f"no {missing[0]} column",
                             f"columns {', '.join(f'{g} {a}' for g, a in need)}", file=file)
        p = table[:, [cols[("Position", a)] for a in "XYZ"]] * scale
        q = np.full((len(data), 4), np.nan)
        if kind in ROTATED:
            r = table[:, [cols[("Rotation", a)] for a in need_axes(rotation)]]
            ok = np.all(np.isfinite(r), axis=1)
            if ok.any():
                q[ok] = (Rotation.from_quat(r[ok]) if rotation == "Quaternion" else
                         Rotation.from_euler(rotation, r[ok], degrees=True)).as_quat()
        p[~np.all(np.isfinite(p), axis=1)] = np.nan
        names.append(name)
        ids.append(int(cols["id"]) if cols["id"].isdigit() else 0)
        positions.append(p)
        rotations.append(q)
    times = table[:, 1] - table[0, 1]
    p, q = np.stack(positions, axis=1), np.stack(rotations, axis=1)
    if math.isfinite(rate):
        times, p, q = _on_frames(frame_at, rate, times, p, q, first, file)
    return check_recording(Recording(file, times, tuple(names), tuple(ids), p, q, what))


def _frame_numbers(table: np.ndarray, first: int, file: str) -> np.ndarray:
    """The Frame column: whole numbers, increasing (raises InputError naming the line)."""
    frames = table[:, 0]
    bad = np.flatnonzero(~(np.isfinite(frames) & (frames == np.round(frames))
                           & (np.abs(frames) < 2**52)))
    if bad.size:
        raise InputError(f"line {first + bad[0] + 1}, column Frame", table[bad[0], 0],
                         "a whole frame number", file=file)
    back = np.flatnonzero(np.diff(frames) <= 0)
    if back.size:
        k = back[0] + 1
        raise InputError(f"line {first + k + 1}, column Frame", int(frames[k]),
                         f"a frame after the previous line's ({int(frames[k - 1])})", file=file)
    return frames.astype(np.int64)


def _on_frames(frames: np.ndarray, rate: float, times: np.ndarray, p: np.ndarray,
               q: np.ndarray, first: int, file: str) -> tuple:
    """Times from the frame numbers at ``rate``, checked against the time column to half a
    frame; frames the numbering skips added as frames in which no body was tracked."""
    n = frames - frames[0]
    exact = n / rate
    off = np.flatnonzero(np.abs(times - exact) > 0.5 / rate)
    if off.size:
        k = off[0]
        raise InputError(f"line {first + k + 1}, column Time", float(times[k]),
                         f"frame {int(frames[k])} at {rate:g} Hz, {exact[k]:.6f} s after the "
                         f"first frame, to half a frame (the header's frame rate)", file=file)
    if n[-1] + 1 > MAX_SAMPLES:
        raise InputError("<frames>", int(n[-1] + 1), f"at most {MAX_SAMPLES:,} frames "
                         "from the first frame number to the last", file=file)
    if n[-1] + 1 == frames.size:
        return exact, p, q
    full_p = np.full((int(n[-1]) + 1,) + p.shape[1:], np.nan)
    full_q = np.full((int(n[-1]) + 1,) + q.shape[1:], np.nan)
    full_p[n], full_q[n] = p, q
    return np.arange(int(n[-1]) + 1) / rate, full_p, full_q


def _check_complete(settings: dict[str, str], frames: int, truncated: str, file: str) -> None:
    """An export shorter than its header's ``Total Exported Frames``: refused, or with
    ``truncated="use"`` a warning line."""
    total = settings.get("Total Exported Frames", "")
    if not total.isdigit() or frames >= int(total):
        return
    said = (f"{file}: Total Exported Frames {total}, but {frames} frames in the file: "
            "a truncated export")
    if truncated == "use":
        warnings.warn(said + "; the frames present are used", stacklevel=3)
        return
    raise InputError("Total Exported Frames", int(total), f"{frames} frames, as in the file "
                     "(it was cut short; `truncated: use` in the mapping reads the frames "
                     "present)", file=file)


def need_axes(rotation: str) -> str:
    """The rotation columns of a rotation type: X, Y, Z, W for quaternions, else X, Y, Z."""
    return "XYZW" if rotation == "Quaternion" else "XYZ"


def motive_csv_text(times: np.ndarray, names: list[str], ids: list[int],
                    positions: np.ndarray, rotations: np.ndarray, *, rate_hz: float,
                    units: str = "Meters", rotation_type: str = "Quaternion",
                    take: str = "safety-systems") -> str:
    """A Motive CSV export of rigid bodies (the layout :func:`read_motive_csv` reads):
    ``positions`` (T, B, 3) in metres and ``rotations`` (T, B, 4) quaternions (x, y, z,
    w) in the capture frame; a row where a body's position is NaN leaves its cells
    empty (not tracked)."""
    if units not in UNITS or rotation_type not in ROTATION_TYPES:
        raise ValueError(f"units {units!r} / rotation_type {rotation_type!r}: allowed "
                         f"{list(UNITS)} / {list(ROTATION_TYPES)}")
    axes = need_axes(rotation_type)
    per = len(axes) + 4  # rotation, position, mean marker error
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    T = len(times)
    w.writerow(["Format Version", "1.23", "Take Name", take, "Take Notes", "",
                "Capture Frame Rate", f"{rate_hz:.6f}", "Export Frame Rate", f"{rate_hz:.6f}",
                "Capture Start Time", "2025-01-01 12.00.00.000 PM", "Capture Start Frame", "0",
                "Total Frames in Take", str(T), "Total Exported Frames", str(T),
                "Rotation Type", rotation_type, "Length Units", units,
                "Coordinate Space", "Global"])
    w.writerow([])
    w.writerow(["", "Type"] + ["Rigid Body"] * per * len(names))
    w.writerow(["", "Name"] + [n for n in names for _ in range(per)])
    w.writerow(["", "ID"] + [str(i) for i in ids for _ in range(per)])
    group = ["Rotation"] * len(axes) + ["Position"] * 3 + ["Mean Marker Error"]
    w.writerow(["", ""] + group * len(names))
    w.writerow(["Frame", "Time (Seconds)"] + (list(axes) + ["X", "Y", "Z", ""]) * len(names))
    scale = UNITS[units]
    for t in range(T):
        row = [str(t), f"{times[t]:.6f}"]
        for b in range(len(names)):
            p, q = positions[t, b], rotations[t, b]
            if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
                row += [""] * per
                continue
            r = (q if rotation_type == "Quaternion" else
                 Rotation.from_quat(q).as_euler(rotation_type, degrees=True))
            row += [f"{x:.6f}" for x in r] + [f"{x / scale:.6f}" for x in p] + ["0.000100"]
        w.writerow(row)
    return out.getvalue()
