"""C3D files read right or refused, never misread: one test per class of real file that
was misread or wrongly refused (issue 48), on real c3d.org files (tests/data/c3d_org) or
on files made from them to the class's specification (tests/sensing/c3d_patches.py),
each held to the figures of a second reader."""

import struct
import warnings

import numpy as np
import pytest

from safety_systems.files.input_error import InputError
from safety_systems.sensing.c3d_file import read_c3d, unit_scale
from safety_systems.sensing.c3d_header import read_header
from safety_systems.sensing.c3d_readers import read_ezc3d, read_py_c3d
from tests.sensing.c3d_patches import (
    BIOGESTA,
    DEC_INT,
    KYOWA,
    PC_REAL,
    SGI_INT,
    parameters,
    patched,
)

FEET = ["LFT1", "RFT3"]  # two of the 36 markers of the c3d.org sample 02 gait trial


def _line(e: pytest.ExceptionInfo) -> str:
    line = str(e.value)
    assert "\n" not in line
    return line


def test_the_same_gait_trial_reads_alike_from_intel_dec_and_sgi_files():
    """c3d.org's sample 02 stores one trial in each processor's format: the DEC and the
    Intel files are read by both readers (which agree), the SGI/MIPS file by py-c3d alone
    (ezc3d refuses the processor) and must give the others' figures."""
    assert read_ezc3d(str(SGI_INT)).startswith("MIPS processor type not supported")
    dec, sgi, pc = (read_c3d(f, FEET) for f in (DEC_INT, SGI_INT, PC_REAL))
    assert sgi.format == "C3D (SGI/MIPS processor, 16-bit integers)"
    assert dec.format == "C3D (DEC processor, 16-bit integers)"
    assert dec.rate_hz == pytest.approx(50.0) and dec.times.size == 89
    np.testing.assert_array_equal(np.isnan(sgi.positions), np.isnan(dec.positions))
    # the same integers, but for 3 of 534 coordinates one step (0.28 mm) apart, as
    # c3d.org's conversions wrote them
    step = abs(read_header(DEC_INT).scale) / 1000.0
    np.testing.assert_allclose(sgi.positions, dec.positions, atol=1.001 * step, equal_nan=True)
    same = np.isclose(sgi.positions, dec.positions, rtol=1e-6, atol=0.0)
    assert np.sum(~same & np.isfinite(dec.positions)) == 3
    # the float file holds the integer one's figures to a part in 10^4 of a step
    np.testing.assert_allclose(pc.positions, dec.positions, atol=2e-5, equal_nan=True)
    b = dec.body("LFT1")
    k = np.flatnonzero(np.isfinite(dec.positions[:, b, 0]))[0]
    ezc3d = read_ezc3d(str(DEC_INT))  # the second reader's figure, mm
    np.testing.assert_allclose(dec.positions[k, b] * 1000.0,
                               ezc3d.positions[k, ezc3d.labels.index("LFT1")])


def test_a_label_list_longer_than_the_point_count_names_only_the_points():
    raw = read_py_c3d(str(DEC_INT))
    assert raw.layout.points == 36 and len(raw.labels) == 75  # as c3d.org wrote it
    rec = read_c3d(DEC_INT, raw.labels[:36])
    assert rec.names == raw.labels[:36]
    with pytest.raises(InputError) as e:  # an entry past POINT:USED names no point
        read_c3d(DEC_INT, [raw.labels[40]])
    assert "no point named" in _line(e) and "C3D (DEC processor" in _line(e)


def test_header_and_parameter_counts_that_disagree_are_refused_with_both_figures():
    """Kyowa Dengyo's real file: the header says 11 points, POINT:USED 12; both readers
    take 12 and run out of data at frame 145 of 152. The header's layout fills the data
    section; the parameters' does not. Refused, naming both."""
    for reader in (read_ezc3d, read_py_c3d):
        r = reader(str(KYOWA))
        assert r.layout.points == 12 and r.frames_read == 145
    header = read_header(KYOWA)
    assert (header.layout.points, header.layout.frames) == (11, 152)
    with pytest.raises(InputError) as e:
        read_c3d(KYOWA)
    line = _line(e)
    assert "C3D (DEC processor, 16-bit integers): data section: got '20,992 bytes'" in line
    assert "152 frames of 12 points" in line and "145 frames before the file ends" in line
    assert "the header states 152 frames of 11 points" in line and "which fits" in line


def test_a_16_bit_dec_file_whose_analog_rate_is_not_a_whole_multiple_is_refused(tmp_path):
    """The EVaRT class: DEC, 16-bit integers, analog channels; the header says 4 analog
    samples per frame (200 Hz at 50 Hz, which the data's size confirms), ANALOG:RATE says
    190 Hz (3.8 per frame). Both readers take 3 and would read every frame after the
    first at the wrong offset: refused."""
    bad = patched(DEC_INT, tmp_path / "evart_like.c3d", analog_rate=190.0)
    for reader in (read_ezc3d, read_py_c3d):
        r = reader(str(bad))
        assert r.layout.analog == 16 * 3 and not r.layout.fits(read_header(bad).data_bytes)
    # what a single reader would have replayed: frame 2 onwards at the wrong offset
    truth, misread = read_ezc3d(str(DEC_INT)), read_ezc3d(str(bad))
    k = truth.labels.index("LFT1")
    assert np.allclose(truth.positions[0, k], misread.positions[0, k], equal_nan=True)
    off = np.nanmax(np.abs(truth.positions[1:, k] - misread.positions[1:, k]))
    assert off > 100.0  # mm
    with pytest.raises(InputError) as e:
        read_c3d(bad, FEET)
    line = _line(e)
    assert "C3D (DEC processor, 16-bit integers): data section: got '37,376 bytes'" in line
    assert "16 analog channels x 3 samples per frame" in line
    assert "the header states 89 frames of 36 points and 64 analog values" in line
    assert "which fits: the header and the parameters disagree" in line


def test_a_missing_analog_rate_is_read_by_the_reader_whose_layout_fits(tmp_path):
    """The BTS class (c3d.org float files with ANALOG:USED but no ANALOG:RATE, 6 analog
    values per frame in the header): ezc3d takes 0 analog values per frame, which leaves
    the data section 89 x 256 bytes over; py-c3d takes the header's 64, which fills it.
    The fitting reading is used, and gives the untouched file's figures."""
    bad = patched(PC_REAL, tmp_path / "no_rate.c3d", rename=("ANALOG", "RATE", "RATX"))
    data = read_header(bad).data_bytes
    ez, py = read_ezc3d(str(bad)), read_py_c3d(str(bad))
    assert ez.layout.analog == 0 and data - ez.layout.bytes() == 89 * 64 * 4 + 192
    assert py.layout.analog == 64 and py.layout.fits(data)
    k = ez.labels.index("LFT1")
    assert np.nanmax(np.abs(ez.positions[:, k] - read_ezc3d(str(PC_REAL)).positions[:, k])) > 100
    rec, truth = read_c3d(bad, FEET), read_c3d(PC_REAL, FEET)
    np.testing.assert_array_equal(rec.positions, truth.positions)


def test_float_analog_offsets_do_not_refuse_a_file(tmp_path):
    """The PhoeniX class: ANALOG:OFFSET stored as floats. ezc3d refuses the file; the
    analog values are not used, so py-c3d's reading (without analog scaling) is, and it
    gives ezc3d's figures for the untouched file."""
    bad = patched(PC_REAL, tmp_path / "float_offsets.c3d", float_offsets=True)
    assert read_ezc3d(str(bad)) == "OFFSET parameter is not an INT"
    rec = read_c3d(bad, FEET)
    truth = read_ezc3d(str(PC_REAL))
    np.testing.assert_allclose(rec.positions * 1000.0, truth.positions[:, [
        truth.labels.index(x) for x in rec.names]], rtol=1e-6)


def test_a_unit_string_cut_short_is_read(tmp_path):
    """The Peak Performance class: POINT:UNITS 'mete', meters cut to 4 characters."""
    bad = patched(PC_REAL, tmp_path / "mete.c3d", units=b"mete", metres=True)
    assert read_py_c3d(str(bad)).units == "mete"
    np.testing.assert_allclose(read_c3d(bad, FEET).positions, read_c3d(PC_REAL, FEET)
                               .positions, rtol=1e-6)
    for text, scale in (("mete", 1.0), ("m", 1.0), ("metres", 1.0), ("MM", 0.001),
                        ("millim", 0.001), ("cm", 0.01), ("cent", 0.01)):
        assert unit_scale(text) == scale, text
    for text in ("me", "feet", "in", "mmm", ""):
        assert unit_scale(text) is None, text
    with pytest.raises(InputError) as e:
        read_c3d(patched(PC_REAL, tmp_path / "feet.c3d", units=b"feet"), FEET)
    assert "POINT:UNITS: got 'feet'" in _line(e) and "C3D (Intel processor, floats)" in _line(e)


def test_two_readings_that_differ_refuse_naming_both(tmp_path):
    """A residual word no reader agrees on (a float of 1.7e38, as a real file of c3d.org's
    sample 30 has): ezc3d keeps the point, py-c3d marks it invalid. Refused."""
    raw = bytearray(PC_REAL.read_bytes())
    start = (struct.unpack_from("<H", raw, 16)[0] - 1) * 512
    labels = read_py_c3d(str(PC_REAL)).labels
    k = labels.index("LFT1")
    frame = next(t for t in range(89) if np.isfinite(read_ezc3d(str(PC_REAL)).positions[t, k, 0]))
    at = start + (frame * (4 * 36 + 64) + 4 * k + 3) * 4
    raw[at:at + 4] = struct.pack("<f", 1.7e38)
    (tmp_path / "residual.c3d").write_bytes(bytes(raw))
    with pytest.raises(InputError) as e:
        read_c3d(tmp_path / "residual.c3d", FEET)
    line = _line(e)
    assert f"frame {frame + 1}, point 'LFT1': got 'ezc3d (" in line and "c3d invalid" in line
    assert "the same from both C3D readers" in line


def test_every_refusal_names_the_vendor_the_file_states(tmp_path):
    """Biogesta's real file (c3d.org sample 30, MANUFACTURER 'Biogesta' 'Saga-3RT'): its
    residual words are -1 where ezc3d reads on, so the readers disagree from frame 1; the
    refusal names the vendor, as one made from its structure does (the file cut short)."""
    ez, py = read_ezc3d(str(BIOGESTA)), read_py_c3d(str(BIOGESTA))
    assert ez.vendor == py.vendor == "Biogesta Saga-3RT"
    k = ez.labels.index("GD")
    assert np.isfinite(ez.positions[0, k]).all() and np.isnan(py.positions[0, k]).all()
    with pytest.raises(InputError) as e:
        read_c3d(BIOGESTA)
    assert _line(e).startswith(f"{BIOGESTA}: C3D (Intel processor, floats, Biogesta "
                               "Saga-3RT): frame 1, point 'GD': got 'ezc3d (-2174.0330, ")
    raw = BIOGESTA.read_bytes()
    (tmp_path / "cut.c3d").write_bytes(raw[:len(raw) - 2048])
    with pytest.raises(InputError) as e:
        read_c3d(tmp_path / "cut.c3d")
    assert "C3D (Intel processor, floats, Biogesta Saga-3RT): data section: got" in _line(e)


def test_what_is_not_a_c3d_file_or_has_no_point_parameters_is_one_clear_line(tmp_path):
    (tmp_path / "text.c3d").write_text("not a c3d file " * 100)
    with pytest.raises(InputError) as e:
        read_c3d(tmp_path / "text.c3d")
    assert "C3D: got 'not a C3D file" in _line(e)
    raw = bytearray(DEC_INT.read_bytes())
    raw[(raw[0] - 1) * 512 + 3] = 0x42  # a processor byte the format does not have
    (tmp_path / "processor.c3d").write_bytes(bytes(raw))
    with pytest.raises(InputError) as e:
        read_c3d(tmp_path / "processor.c3d")
    assert "processor: got 66" in _line(e) and "85 (DEC)" in _line(e)
    # no POINT group (PhaseSpace's sample file has no parameters at all): not the former
    # "POINT:RATE: got [0.0]"
    raw = bytearray(PC_REAL.read_bytes())
    group = bytes(raw).index(b"POINT", (raw[0] - 1) * 512)
    assert struct.unpack_from("b", raw, group - 1)[0] < 0  # the group's record
    raw[group:group + 5] = b"POINX"
    (tmp_path / "no_point.c3d").write_bytes(bytes(raw))
    with pytest.raises(InputError) as e:
        read_c3d(tmp_path / "no_point.c3d")
    assert "POINT parameters: got 'none" in _line(e) and "POINT:RATE" not in _line(e)
    # a parameter section neither reader can read: no advice no one can follow
    raw = bytearray(PC_REAL.read_bytes())
    at = parameters(bytes(raw))[("POINT", "LABELS")]
    raw[at - 2:at] = struct.pack("<h", -30000)  # an offset to the next record far behind
    (tmp_path / "broken.c3d").write_bytes(bytes(raw))
    with pytest.raises(InputError) as e:
        read_c3d(tmp_path / "broken.c3d")
    assert "ignoreBadFormatting" not in _line(e) and "C3D (Intel processor, floats)" in _line(e)


# Vendors' real files (tests/data/c3d_org/README.md: each cut to its first frames, or the
# frames named there): (file, the refusals' words for it, metres per unit, the readers
# that read it, the first body that moves as no person can under the default bounds
# after the glitch rule, with its frame and figure, or None).
VENDORS = [
    ("sample00_codamotion_gaitwands.c3d", ("Intel processor, floats, File Import by "
     "Charnwood Dynamics Ltd. Origin: MDF File"), 0.001, ("ezc3d", "c3d"), None),
    ("sample00_nexgen_test1.c3d", "Intel processor, floats", 1.0, ("ezc3d", "c3d"), None),
    ("sample02_dec_real.c3d", "DEC processor, floats", 0.001, ("ezc3d", "c3d"), None),
    ("sample02_sgi_real.c3d", "SGI/MIPS processor, floats", 0.001, ("c3d",), None),
    ("sample02_pc_int.c3d", "Intel processor, 16-bit integers", 0.001, ("ezc3d", "c3d"),
     None),
    ("sample22_bkin.c3d", "Intel processor, floats", 1.0, ("c3d",), None),
    # The MotionMonitor: M7 leaves its track at 30 m/s for 2 frames (glitches, read as
    # untracked) and then moves at 15.8 m/s
    ("sample24_motionmonitor.c3d", "Intel processor, floats", 1.0, ("ezc3d", "c3d"),
     ("M7", 24, "speed: got '15.76 m/s'")),
    ("sample34_xsens_basketball.c3d", ("Intel processor, 16-bit integers, Xsens "
     "Technologies B.V. MVN Studio C3D Exporter"), 0.001, ("ezc3d", "c3d"), None),
    # ART's 16-bit file: a scale of 0.048 mm holds at most 32,767 steps, 1.5728 m; the
    # head's Z-axis point passes it and wraps to -1.5725 m
    ("sample37_art_human_tools.c3d", ("Intel processor, 16-bit integers, Advanced "
     "Realtime Tracking GmbH & Co. KG ART-Human 2.1.2"), 0.001, ("ezc3d",),
     ("Human3:HEADZ", 22, "speed: got '188.06 m/s'")),
]


def _raw_points(path, points: int, analog: int, frames: int) -> np.ndarray:
    """(frames, points, 3) in the file's units, NaN where the residual word is negative,
    read from the bytes with numpy alone (a third reader): Intel little-endian, SGI
    big-endian, DEC F-floats (16-bit halves swapped, 4 times IEEE's value)."""
    h = read_header(path)
    word, raw = h.layout.word, path.read_bytes()
    start = (h.data_block - 1) * 512
    size = frames * (4 * points + analog) * word
    data = raw[start:start + size]
    if word == 2:
        w = np.frombuffer(data, ">i2" if h.processor == 86 else "<i2").astype(float)
    elif h.processor == 85:
        halves = np.frombuffer(data, "<u2").reshape(-1, 2)[:, ::-1].copy()
        w = halves.view("<f4").ravel().astype(float) / 4.0
    else:
        w = np.frombuffer(data, ">f4" if h.processor == 86 else "<f4").astype(float)
    xyzr = w.reshape(frames, -1)[:, :4 * points].reshape(frames, points, 4)
    xyz = xyzr[..., :3] * (h.scale if word == 2 else 1.0)
    xyz[xyzr[..., 3] < 0] = np.nan
    return xyz


@pytest.mark.parametrize("case", VENDORS, ids=[c[0].split(".")[0] for c in VENDORS])
def test_vendors_files_are_read_as_their_bytes_say_and_checked_for_plausibility(case,
                                                                                tmp_path):
    from safety_systems.sensing.plausibility import first_implausible
    from safety_systems.sensing.recording import flips
    from safety_systems.sensing.recording_mapping import check_mapping
    from tests.sensing.c3d_patches import DATA

    name, words, unit, readers, implausible = case
    path = DATA / name
    read = {r.library: r for r in (read_ezc3d(str(path)), read_py_c3d(str(path)))
            if not isinstance(r, str)}
    assert tuple(read) == readers  # (where both read, read_c3d holds them to each other)
    rec = read_c3d(path)
    assert rec.format == f"C3D ({words})"
    r = next(iter(read.values()))
    raw = _raw_points(path, r.layout.points, r.layout.analog, r.layout.frames)
    labels = list(r.labels[:r.layout.points])
    index = [labels.index(n) for n in rec.names]
    expected = raw[:, index] * unit
    expected[np.all(expected == 0.0, axis=2)] = np.nan  # a drop-out, as c3d_file reads it
    assert np.isfinite(rec.positions).mean() > 0.8
    np.testing.assert_array_equal(np.isnan(rec.positions), np.isnan(expected))
    np.testing.assert_allclose(rec.positions, expected, rtol=1e-6, atol=1e-9)
    # every body of the file under the mapping's rules, at the default bounds
    p = rec.positions.copy()
    p[flips(rec.times, p, 10.0)] = np.nan
    bad = first_implausible(rec.times, p)
    if implausible is None:
        assert bad is None, (rec.names[bad.body], bad)
        return
    body, frame, figure = implausible
    assert (rec.names[bad.body], bad.frame) == (body, frame)
    (tmp_path / name).write_bytes(path.read_bytes())
    (tmp_path / "map.yaml").write_text(
        f"recording: {name}\ncapture_to_cell: {{up_axis: z}}\noperators:\n- name: worker\n"
        f"  bodies:\n  - {{recorded: '{body}', name: b, point: head}}\n")
    with warnings.catch_warnings(record=True) as seen, pytest.raises(InputError) as e:
        warnings.simplefilter("always")
        check_mapping(tmp_path / "map.yaml")
    glitches = int(np.any(np.isnan(p) & ~np.isnan(rec.positions)))  # M7's 2 frames
    assert [str(w.message).split(": ")[2] for w in seen] == (
        ["2 sample(s) from t = 0.15 s read as untracked"] if glitches else [])
    assert _line(e).startswith(f"{tmp_path / name}: C3D ({words}): '{body}' at frame "
                               f"{frame} of the file (counted from 0; t = ")
    assert f"{figure}; allowed: at most max_speed, 10 m/s" in _line(e)

