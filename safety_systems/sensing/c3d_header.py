"""A C3D file's own structure, read from its bytes: the 512-byte header, the processor
type, and the check that a reader's layout of the data fits the data's size.

A C3D file is 512-byte blocks: the header (block 1), the parameter section (from the
header's ``parameter_block``; its 4th byte names the processor: 84 Intel, 85 DEC, 86
SGI/MIPS) and the data (from ``data_block`` to the end). The data is ``frames`` frames
of ``points`` points (4 words each: x, y, z and a residual/camera word) and ``analog``
analog values (every channel's samples of the frame), each word 2 bytes (16-bit
integers, a positive scale factor) or 4 (floats, a negative one), the last block padded
to 512 bytes. A layout (points, analog values, frames, word size) thus fits the file
when its frames fill the data section short of at most one block: a reader that takes
the wrong count of points or analog values per frame reads every frame after the first
at the wrong offset, and its layout does not fit. These are the C3D format's figures
(c3d.org, "The C3D File Format User Guide", Motion Lab Systems, 2008, ch. 2-3); the
header's integer words are 16-bit, little-endian but on SGI/MIPS machines.
"""

import dataclasses
import struct
from pathlib import Path

BLOCK = 512
PROCESSORS = {84: "Intel", 85: "DEC", 86: "SGI/MIPS"}


@dataclasses.dataclass(frozen=True)
class Layout:
    """How a reader (or the header) lays out the data: per frame ``points`` points and
    ``analog`` analog values (channels times samples per frame), ``frames`` frames, words
    of ``word`` bytes (2: integers, 4: floats)."""

    points: int
    analog: int
    frames: int
    word: int

    def bytes(self) -> int:
        """The data's size in bytes under this layout (before the last block's padding)."""
        return self.frames * (4 * self.points + self.analog) * self.word

    def fits(self, data_bytes: int) -> bool:
        """True when the data section's ``data_bytes`` hold exactly this layout's frames,
        padded to a whole block."""
        return 0 <= data_bytes - self.bytes() <= BLOCK

    def words(self) -> str:
        """The layout in words, e.g. '243 frames of 22 points and 476 analog values
        (16-bit integers)'."""
        kind = "16-bit integers" if self.word == 2 else "floats"
        return (f"{self.frames:,} frames of {self.points} points and {self.analog} analog "
                f"values ({kind}), {self.bytes():,} bytes")


@dataclasses.dataclass(frozen=True)
class Header:
    """The header's figures and the file's size (see the module docstring)."""

    processor: int  # 84, 85, 86, or another byte (not a C3D processor)
    parameter_block: int
    data_block: int
    layout: Layout
    samples_per_frame: int  # analog samples per frame, per channel
    file_bytes: int
    scale: float  # the header's scale factor (POINT:SCALE's twin: mm or m per integer)

    @property
    def data_bytes(self) -> int:
        """The data section's size: from the header's data block to the file's end."""
        return self.file_bytes - (self.data_block - 1) * BLOCK

    def describe(self) -> str:
        """'DEC processor, 16-bit integers' and the like (the file's own words)."""
        name = PROCESSORS.get(self.processor, f"processor byte {self.processor}")
        kind = "16-bit integers" if self.layout.word == 2 else "floats"
        return f"{name}{' processor' if self.processor in PROCESSORS else ''}, {kind}"


def read_header(path: str | Path) -> Header | str:
    """The header of the C3D file ``path``, or a sentence saying why it is not one."""
    with open(path, "rb") as f:
        head = f.read(BLOCK)
        size = f.seek(0, 2)
        if len(head) < BLOCK or head[1] != 0x50:
            return "not a C3D file (its 2nd byte is not 0x50, the C3D key)"
        parameter_block = head[0]
        if parameter_block < 2 or parameter_block * BLOCK > size:
            return f"not a C3D file (its parameter section at block {parameter_block})"
        f.seek((parameter_block - 1) * BLOCK + 3)
        processor = f.read(1)[0]
    order = ">" if processor == 86 else "<"
    words = struct.unpack(order + "10H", head[2:22])
    points, analog, first, last, _gap, _s1, _s2, data_block, per_frame, _r1 = words
    scale = _float(head[12:16], processor)
    word = 4 if scale < 0.0 else 2  # floats where the scale factor is negative
    return Header(processor, parameter_block, data_block,
                  Layout(points, analog, last - first + 1, word), per_frame, size, scale)


def _float(raw: bytes, processor: int) -> float:
    """A 32-bit float of the header in the processor's storage: IEEE little-endian
    (Intel), IEEE big-endian (SGI/MIPS), or DEC's F-float: its 16-bit halves swapped
    against IEEE little-endian and its value four times the IEEE reading of the same bits
    (an exponent bias of 128, not 127, and a fraction 0.1f, not 1.f), 0 where its
    exponent is 0."""
    if processor == 86:
        return struct.unpack(">f", raw)[0]
    if processor != 85:
        return struct.unpack("<f", raw)[0]
    swapped = raw[2:4] + raw[0:2]
    if (swapped[3] & 0x7F) == 0 and (swapped[2] & 0x80) == 0:
        return 0.0
    return struct.unpack("<f", swapped)[0] / 4.0
