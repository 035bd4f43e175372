"""A live run's log read back: every tick and frame of every chunk written before a cut
at any byte, the messages as a ROS 2 decoder reads them, and a segment as a recording."""

import io
import struct
import warnings

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from safety_systems.files.input_error import InputError
from safety_systems.runtime.run_log_pipe import FRAME, TICK
from safety_systems.runtime.run_log_writer import Segment
from safety_systems.sensing.recording_files import read_recording
from safety_systems.sensing.run_log import (
    parse_run_log,
    read_run_log,
    read_run_recording,
    whole_records,
)
from safety_systems.sensing.run_log_format import (
    FORMAT_VERSION,
    FRAME_SCALARS,
    decode_frame,
    encode_frame,
    encode_tick,
    field_names,
    tick_columns,
)

TRACE = ["time", "k", "stop_reason", "technician:d_measured", "technician/left_glove:hidden"]
COLUMNS = tick_columns(TRACE, 2)
BODIES = {"1": "RightGlove", "2": "LeftGlove"}


def _row(i: int) -> np.ndarray:
    return np.array([0.002 * i, 0.5, 1.0, 1.2 - 1e-3 * i if i % 7 else np.nan, i % 2, 0.0,
                     0.002 * i - 1e-4, 0.1 * i, -0.2], dtype=float)


STEP = 1.0 / 128.0  # m a body moves per frame (exact in float32, as NatNet sends positions)


def _frame(f: int, capture: float | None = None):
    """Frame f: body 1 tracked, body 2 tracked on even frames, an unmapped id 9; the
    bodies move 7.8 mm a frame (0.98 m/s at 125 Hz: a person's speed, which the
    recording readers' plausibility check allows)."""
    t = 0.008 * f
    return ((t + 0.001, t if capture is None else capture, 100.0 + t, f + 1, 2e-4, 3),
            [1, 2, 9], [[1.0 + STEP * f, 2.0, 3.0], [4.0, 5.0 + STEP * f, 6.0], [0.0, 0.0, 0.0]],
            [[0.0, 0.0, 0.0, 1.0]] * 3, [True, f % 2 == 0, True])


def _write(path, ticks=40, flush_every=10, finish=True, frames=None):
    """A segment as the writer process writes it: a chunk every ``flush_every`` ticks,
    a frame every fourth tick; the ticks of each chunk, in order."""
    info = {"format": FORMAT_VERSION, "columns": COLUMNS, "bodies": BODIES}
    segment = Segment(path, info, COLUMNS)
    chunks, count, f = [], 0, 0
    for i in range(ticks):
        segment.add(TICK, encode_tick(_row(i)), 10**9 + i, i)
        count += 1
        if i % 4 == 0:
            args = (frames or _frame)(f)
            segment.add(FRAME, encode_frame(*args), 10**9 + i, f)
            f += 1
        if (i + 1) % flush_every == 0:
            segment.flush()
            chunks.append(count)
            count = 0
    if finish:
        segment.finish()
    else:
        segment.flush()
        segment.file.close()
    return chunks + ([count] if count else [])


def _chunk_ends(data: bytes) -> list[int]:
    """The byte just after each chunk record of a whole file (walked independently of
    the reader: opcode, then length, from the 8-byte magic on)."""
    at, ends = 8, []
    while at + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, at)
        at += 9 + length
        if opcode == 0x06:
            ends.append(at)
        if opcode == 0x02:
            break
    return ends


def test_a_finished_segment_reads_back_every_row_and_frame(tmp_path):
    path = tmp_path / "log-0000.mcap"
    _write(path)
    log = read_run_log(path)
    assert log.finished and log.columns == tuple(COLUMNS)
    np.testing.assert_array_equal(log.ticks, np.array([_row(i) for i in range(40)]))
    np.testing.assert_array_equal(log.tick_sequence, np.arange(40))
    assert log.frames.shape == (10, len(FRAME_SCALARS)) and log.body_start[-1] == 30
    np.testing.assert_array_equal(log.ids, [1, 2, 9] * 10)
    assert log.tracked.tolist() == [x for f in range(10) for x in (True, f % 2 == 0, True)]
    times, q = log.joints()
    np.testing.assert_array_equal(q[:, 0], 0.1 * np.arange(40))
    np.testing.assert_array_equal(times, 0.002 * np.arange(40) - 1e-4)


def test_a_log_cut_at_any_byte_gives_every_chunk_written_before_the_cut(tmp_path):
    """Every cut of an unfinished segment (a kill while it was written) and of a finished
    one: the rows read are those of the chunks whole before the cut, in order, never an
    error past the run's metadata; zeros after the data (blocks a crash left unwritten)
    change nothing."""
    for finish in (False, True):
        path = tmp_path / f"cut_{finish}.mcap"
        per_chunk = _write(path, ticks=23, flush_every=5, finish=finish)
        data = path.read_bytes()
        ends = _chunk_ends(data)
        assert len(ends) == len(per_chunk) == 5
        metadata_end = 8 + 9 + struct.unpack_from("<Q", data, 9)[0]  # the header record
        metadata_end += 9 + struct.unpack_from("<Q", data, metadata_end + 1)[0]
        for cut in range(len(data) + 1):
            if cut < metadata_end:
                with pytest.raises(InputError) as e:
                    parse_run_log(data[:cut], "cut.mcap")
                assert len(str(e.value).splitlines()) == 1
                continue
            log = parse_run_log(data[:cut], "cut.mcap")
            whole = sum(n for n, end in zip(per_chunk, ends) if end <= cut)
            assert log.ticks.shape == (whole, len(COLUMNS)), cut
            np.testing.assert_array_equal(log.ticks[:, 0], 0.002 * np.arange(whole))
            assert log.finished == (finish and cut == len(data))
        cut_path = tmp_path / "zeros.mcap"
        cut_path.write_bytes(data + bytes(4096))
        log = read_run_log(cut_path)
        assert len(log.ticks) == 23 and log.finished == finish


def test_a_chunk_whose_checksum_fails_ends_a_cut_log_and_refuses_a_finished_one(tmp_path):
    for finish in (False, True):
        path = tmp_path / f"crc_{finish}.mcap"
        _write(path, ticks=30, flush_every=10, finish=finish)
        data = bytearray(path.read_bytes())
        last = _chunk_ends(bytes(data))[-1]
        data[last - 20] ^= 0xFF  # inside the last chunk's compressed records
        path.write_bytes(bytes(data))
        if finish:
            with pytest.raises(InputError, match="<chunk>"):
                read_run_log(path)
        else:
            assert len(read_run_log(path).ticks) == 20


def test_the_messages_are_what_a_ros_2_decoder_reads(tmp_path):
    """The mcap-ros2-support decoder (what Foxglove's Python tools use) reads /tick and
    /frame by their .msg schemas as this project's reader does."""
    path = tmp_path / "log-0000.mcap"
    _write(path, ticks=8)
    names = field_names(COLUMNS)
    ticks, frames = [], []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, message in reader.iter_decoded_messages():
            if channel.topic == "/tick":
                ticks.append([getattr(message, n) for n in names])
            else:
                frames.append(message)
    np.testing.assert_array_equal(np.array(ticks), read_run_log(path).ticks)
    assert len(frames) == 2
    scalars, ids, bodies, tracked = decode_frame(encode_frame(*_frame(1)))
    assert frames[1].id == ids.tolist() == [1, 2, 9]
    assert frames[1].x == bodies[:, 0].tolist() and frames[1].qw == bodies[:, 6].tolist()
    assert list(frames[1].tracked) == [1, 0, 1] and frames[1].frame_number == scalars[3]
    assert names[3:5] == ["technician_d_measured", "technician_left_glove_hidden"]


def test_field_names_are_ros_2_field_names_and_unique():
    names = field_names(["A:b", "a/b", "2x", "q_0", "--", "a__b_"])
    assert names == ["a_b", "a_b_2", "c_2x", "q_0", "column", "a_b_3"]


def test_a_segment_is_a_recording_of_the_frames_as_received(tmp_path):
    """Names from the run's mapping (an unmapped id by its number), capture-frame
    positions as streamed, NaN where untracked, times from the first frame's capture; a
    frame whose capture time does not move on is left out; the registry reads .mcap."""
    captures = [0.0, 0.008, 0.016, 0.012, 0.024, 0.032, 0.040, 0.048, 0.056, 0.064]
    path = tmp_path / "log-0000.mcap"
    _write(path, frames=lambda f: _frame(f, capture=1.5 + captures[f]))
    rec = read_recording(path, ["LeftGlove", "RightGlove"])
    assert rec.names == ("RightGlove", "LeftGlove") and rec.ids == (1, 2)
    kept = [f for f in range(10) if f != 3]
    np.testing.assert_allclose(rec.times, np.array(captures)[kept], atol=1e-12)
    np.testing.assert_array_equal(rec.positions[:, 0, 0], 1.0 + STEP * np.array(kept))
    np.testing.assert_array_equal(np.isnan(rec.positions[:, 1, 0]),
                                  [f % 2 == 1 for f in kept])
    assert read_run_recording(path).names == ("RightGlove", "LeftGlove", "id9")
    with pytest.raises(InputError, match="bodies of the run"):
        read_run_recording(path, ["Helmet"])


def test_an_unfinished_segment_is_refused_as_a_recording_unless_used(tmp_path):
    path = tmp_path / "log-0000.mcap"
    _write(path, finish=False)
    with pytest.raises(InputError, match="truncated: use") as e:
        read_recording(path)
    assert len(str(e.value).splitlines()) == 1
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = read_recording(path, truncated="use")
    assert len(rec.times) == 10 and "not finished" in str(caught[0].message)


def test_a_file_that_is_not_a_run_log_is_one_line(tmp_path):
    other = tmp_path / "other.mcap"
    other.write_bytes(b"not an mcap file at all")
    with pytest.raises(InputError, match="an MCAP file"):
        read_run_log(other)
    from mcap.writer import Writer

    buffer = io.BytesIO()
    writer = Writer(buffer)
    writer.start(profile="ros2")
    writer.finish()
    other.write_bytes(buffer.getvalue())
    with pytest.raises(InputError, match="<metadata>"):
        read_run_log(other)
    assert whole_records(buffer.getvalue())[1]


def test_a_segment_reads_as_a_recorded_operator_through_the_runs_mapping(tmp_path):
    """What simulate's recorded operators and verify's recording spaces call
    (``load_recorded_operator``) reads a segment with the run's mapping: the gloves in
    the cell frame at the frames' times, the left glove's untracked frames its gaps."""
    from safety_systems.sensing.recording_mapping import load_recorded_operator

    path = tmp_path / "log-0000.mcap"
    _write(path)
    (tmp_path / "mapping.yaml").write_text(
        "capture_to_cell: {up_axis: z, translation: [1.0, 0.0, 0.0]}\noperators:\n"
        "- name: technician\n  bodies:\n"
        "  - {recorded: RightGlove, name: right_glove, point: hand_right, streaming_id: 1}\n"
        "  - {recorded: LeftGlove, name: left_glove, point: hand_left, streaming_id: 2}\n"
        "ignore_ids: [9]\n")
    bodies = load_recorded_operator(path, tmp_path / "mapping.yaml")
    assert bodies.names == ("right_glove", "left_glove") and bodies.ids == (1, 2)
    np.testing.assert_allclose(bodies.raw[:, 0, 0], 2.0 + STEP * np.arange(10))  # + 1 m in x
    np.testing.assert_allclose(bodies.times, 0.008 * np.arange(10), atol=1e-12)
    assert len(bodies.gaps[1]) == 4 and not bodies.gaps[0]  # frames 1, 3, 5, 7 unseen
