"""Files made to the specification of C3D files this project must read right or refuse,
from the real c3d.org files in tests/data/c3d_org: each patch changes one parameter in
place (the sizes of the parameter records unchanged), as the named vendors' files have
it. The parameter section is walked as the C3D format lays it out (c3d.org, "The C3D
File Format User Guide", ch. 3): per record a name length and a group id (negative: a
group), the name, a 16-bit offset to the next record, then a parameter's type, its
dimensions and its data. Offsets and numbers are little-endian (Intel and DEC files)."""

import struct
from pathlib import Path

import numpy as np

DATA = Path(__file__).parents[1] / "data" / "c3d_org"
DEC_INT = DATA / "sample02_dec_int.c3d"  # DEC processor, 16-bit integers, 16 analog channels
SGI_INT = DATA / "sample02_sgi_int.c3d"  # the same data from an SGI/MIPS machine
PC_REAL = DATA / "sample02_pc_real.c3d"  # the same data, Intel floats
KYOWA = DATA / "sample27_kyowadengyo.c3d"  # header 11 points, POINT:USED 12
BIOGESTA = DATA / "sample30_biogesta_admarche2.c3d"  # MANUFACTURER: Biogesta Saga-3RT


def parameters(raw: bytes) -> dict[tuple[str, str], int]:
    """(GROUP, NAME) -> the offset of the parameter's type byte (offsets big-endian in
    SGI/MIPS files; the walk ends at a record whose name is not ASCII: c3d.org's SGI float
    sample 02 has a little-endian offset after POINT's records)."""
    i = (raw[0] - 1) * 512 + 4
    order = ">" if raw[i - 1] == 86 else "<"
    groups, found = {}, {}
    while 0 <= i < len(raw) - 2:
        n, gid = struct.unpack_from("bb", raw, i)
        if n == 0 or gid == 0:
            break
        try:
            name = raw[i + 2:i + 2 + abs(n)].decode("ascii")
        except UnicodeDecodeError:
            break
        at = i + 2 + abs(n)
        step = struct.unpack_from(order + "h", raw, at)[0]
        if gid < 0:
            groups[-gid] = name
        else:
            found[(gid, name)] = at + 2
        if step == 0:
            break
        i = at + step
    return {(groups.get(g, ""), name): at for (g, name), at in found.items()}


def data_of(raw: bytes, at: int) -> int:
    """The offset of a parameter's data (after its type, dimension count and dims)."""
    return at + 2 + raw[at + 1]


def dec_float(x: float) -> bytes:
    """``x`` as a DEC F-float: IEEE's bits of 4x, its 16-bit halves swapped."""
    b = struct.pack("<f", 4.0 * x)
    return b[2:4] + b[0:2]


def patched(source: Path, out: Path, *, analog_rate: float | None = None,
            rename: tuple[str, str, str] | None = None, float_offsets: bool = False,
            units: bytes | None = None, metres: bool = False) -> Path:
    """A copy of ``source`` at ``out`` with one parameter changed: ``analog_rate`` (Hz,
    ANALOG:RATE in the file's float storage), ``rename`` (group, name, new name of the same
    length: the parameter is then missing), ``float_offsets`` (ANALOG:OFFSET's 16-bit integers
    stored as half as many floats, 0.0, in the same bytes), ``units`` (POINT:UNITS's 4
    characters) and ``metres`` (a float file's coordinates divided by 1000)."""
    raw = bytearray(source.read_bytes())
    where = parameters(bytes(raw))
    dec = raw[(raw[0] - 1) * 512 + 3] == 85
    if analog_rate is not None:
        at = data_of(raw, where[("ANALOG", "RATE")])
        raw[at:at + 4] = dec_float(analog_rate) if dec else struct.pack("<f", analog_rate)
    if rename is not None:
        group, name, new = rename
        at = where[(group, name)]
        start = at - 2 - len(name)
        assert raw[start:start + len(name)].decode() == name and len(new) == len(name)
        raw[start:start + len(name)] = new.encode("ascii")
    if float_offsets:
        at = where[("ANALOG", "OFFSET")]
        n = raw[at + 2]
        assert raw[at] == 2 and raw[at + 1] == 1 and n % 2 == 0
        raw[at], raw[at + 2] = 4, n // 2
        raw[at + 3:at + 3 + 2 * n] = struct.pack(f"<{n // 2}f", *[0.0] * (n // 2))
    if units is not None:
        at = data_of(raw, where[("POINT", "UNITS")])
        raw[at:at + len(units)] = units
    if metres:
        start = (struct.unpack_from("<H", raw, 16)[0] - 1) * 512
        points, analog, first, last = struct.unpack_from("<4H", raw, 2)
        width = 4 * points + analog
        frames = np.frombuffer(bytes(raw[start:start + (last - first + 1) * width * 4]),
                               dtype="<f4").reshape(-1, width).copy()
        xyz = frames[:, :4 * points].reshape(-1, points, 4)
        xyz[:, :, :3] /= 1000.0
        frames[:, :4 * points] = xyz.reshape(-1, 4 * points)
        raw[start:start + frames.nbytes] = frames.tobytes()
    out.write_bytes(bytes(raw))
    return out


def trimmed(source: Path, out: Path, frames: int, skip: int = 0) -> Path:
    """``frames`` frames of ``source`` from its frame ``skip`` (counted from 0), written to
    ``out``: the header and the parameter section as they are but the header's last frame,
    ``POINT:FRAMES`` and ``TRIAL:ACTUAL_END_FIELD`` (where present) counting the frames
    kept, the data section those frames' bytes, padded to a whole block. A frame's size is
    that of the layout a reader reads that fills the file's data section (The
    MotionMonitor's header understates its analog values per frame). How the vendors'
    files in tests/data/c3d_org were cut to a few tens of KB."""
    from safety_systems.sensing.c3d_header import BLOCK, read_header
    from safety_systems.sensing.c3d_readers import Reading, read_ezc3d, read_py_c3d

    header = read_header(source)
    (layout, *_) = [r.layout for r in (read_ezc3d(str(source)), read_py_c3d(str(source)))
                    if isinstance(r, Reading) and r.layout.fits(header.data_bytes)]
    assert 0 <= skip and skip + frames <= layout.frames
    raw = bytearray(source.read_bytes())
    order = ">" if header.processor == 86 else "<"
    start = (header.data_block - 1) * BLOCK
    width = (4 * layout.points + layout.analog) * layout.word
    raw = raw[:start] + raw[start + skip * width:start + (skip + frames) * width]
    raw += bytes(-len(raw) % BLOCK)
    first = struct.unpack_from(order + "H", raw, 6)[0]
    last = first + frames - 1
    struct.pack_into(order + "H", raw, 8, last)
    where = parameters(bytes(raw))
    if ("POINT", "FRAMES") in where:
        at = where[("POINT", "FRAMES")]
        assert raw[at] == 2  # 16-bit integer in every file cut here
        struct.pack_into(order + "H", raw, data_of(raw, at), frames)
    if ("TRIAL", "ACTUAL_END_FIELD") in where:  # a 32-bit frame number in two 16-bit words
        at = where[("TRIAL", "ACTUAL_END_FIELD")]
        assert raw[at] == 2
        struct.pack_into(order + "2H", raw, data_of(raw, at), last & 0xFFFF, last >> 16)
    out.write_bytes(bytes(raw))
    return out
