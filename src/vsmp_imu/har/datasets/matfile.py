"""MATLAB 5 files read safely: their element tags are checked before scipy's reader sees them.

scipy's `loadmat` is not hardened for untrusted files (its docstring says so): a damaged tag
whose data-type code is unknown (0, 8, 10, 11, 15, 19 or >= 20), or a nested matrix where
numbers are expected, makes its C reader look up a missing type and crash the process
(a segmentation fault, found by tests/reliability/test_fuzz.py). `check_mat5` walks every
element of the file first, as the format nests them, and refuses what the reader would
misread; `load_mat` reads a file only after that walk.
"""

from __future__ import annotations

import io
import struct
import zlib
from pathlib import Path

import numpy as np

MAX_FILE_BYTES = 256 * 2**20  # a recording's .mat file (UTD-MHAD's are a few kB)
MAX_INFLATED_BYTES = 256 * 2**20  # what one compressed element may expand to
MAX_DEPTH = 32  # cells and structs nested deeper than this are not a recording
HEADER_BYTES = 128
MI_MATRIX, MI_COMPRESSED = 14, 15
# data-type codes of numbers and text (miINT8 .. miUINT64, miUTF8 .. miUTF32)
DATA_CODES = frozenset({1, 2, 3, 4, 5, 6, 7, 9, 12, 13, 16, 17, 18})
CONTAINER_CLASSES = frozenset({1, 2, 3})  # cell, struct, object: their elements are matrices
MAX_ELEMENTS = 2**40  # a product of dimensions beyond this is a damaged header


class MatFileError(ValueError):
    """The bytes are not a MATLAB 5 file the reader can take."""


def load_mat(path: Path) -> dict:
    """scipy's `loadmat` of `path`, after `check_mat5`; MatFileError when the file is damaged."""
    from scipy.io import loadmat

    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise MatFileError(f"{size} bytes, more than the {MAX_FILE_BYTES // 2**20} MiB a recording's file may hold")
    data = path.read_bytes()
    check_mat5(data)
    return loadmat(io.BytesIO(data))


def check_mat5(data: bytes) -> None:
    """Refuse (MatFileError) bytes that are not a MATLAB 5 file whose every element has a known
    type, a length within its parent and the kind its place asks for."""
    order = _header(data)
    pos = HEADER_BYTES
    while pos < len(data):
        code, size, start = _tag(data, pos, len(data), order)
        if code == MI_COMPRESSED:
            _inflated(data[start:start + size], order)
        elif code == MI_MATRIX:
            _matrix(data, start, start + size, order, 0)
        else:
            raise MatFileError(f"a top-level element of type {code} at byte {pos}: expected a matrix")
        pos = start + size  # the reader steps over top-level elements unpadded


def _header(data: bytes) -> str:
    """The byte order ('<' or '>') of a MATLAB 5 header."""
    if len(data) < HEADER_BYTES:
        raise MatFileError(f"{len(data)} bytes: shorter than a MATLAB 5 header ({HEADER_BYTES} bytes)")
    if 0 in data[:4]:
        raise MatFileError("not a MATLAB 5 file (a version 4 file, or a damaged header)")
    marker = data[126:128]
    if marker not in (b"IM", b"MI"):
        raise MatFileError("not a MATLAB 5 file (no byte-order mark in the header)")
    order = "<" if marker == b"IM" else ">"
    (version,) = struct.unpack(order + "H", data[124:126])
    if version != 0x0100:
        raise MatFileError(f"MATLAB file version {version:#06x}: only version 5 (0x0100) is read")
    return order


def _tag(data: bytes, pos: int, end: int, order: str) -> tuple[int, int, int]:
    """(type code, byte count, start of the data) of the element whose tag is at `pos`."""
    if pos + 8 > end:
        raise MatFileError(f"an element tag at byte {pos} runs past its end ({end})")
    first, second = struct.unpack(order + "II", data[pos:pos + 8])
    if first >> 16:  # small element: count and type in one word, up to 4 bytes of data
        code, size = first & 0xFFFF, first >> 16
        if size > 4:
            raise MatFileError(f"a small element at byte {pos} claims {size} bytes (at most 4)")
        return code, size, pos + 4
    if pos + 8 + second > end:
        raise MatFileError(f"an element at byte {pos} claims {second} bytes, past its end ({end})")
    return first, second, pos + 8


def _inflated(packed: bytes, order: str) -> None:
    """A compressed element holds one matrix: inflated (within MAX_INFLATED_BYTES) and checked."""
    inflate = zlib.decompressobj()
    try:
        body = inflate.decompress(packed, MAX_INFLATED_BYTES)
    except zlib.error as exc:
        raise MatFileError(f"a compressed element does not inflate ({exc})") from None
    if inflate.unconsumed_tail:
        raise MatFileError(f"a compressed element inflates to more than {MAX_INFLATED_BYTES // 2**20} MiB")
    code, size, start = _tag(body, 0, len(body), order)
    if code != MI_MATRIX:
        raise MatFileError(f"a compressed element holds type {code}: expected a matrix")
    _matrix(body, start, start + size, order, 0)


def _matrix(data: bytes, pos: int, end: int, order: str, depth: int) -> None:
    """The elements of one matrix between `pos` and `end`: array flags first; nested matrices only
    in a cell, struct or object; every other element of a known data type."""
    if depth > MAX_DEPTH:
        raise MatFileError(f"matrices nested more than {MAX_DEPTH} deep")
    if pos == end:
        return  # an empty matrix (an empty cell's element)
    code, size, start = _tag(data, pos, end, order)
    if code != 6 or size != 8:  # array flags: two miUINT32
        raise MatFileError(f"a matrix at byte {pos} does not start with its array flags")
    (flags,) = struct.unpack(order + "I", data[start:start + 4])
    container = (flags & 0xFF) in CONTAINER_CLASSES
    index = 0
    pos = start + 8
    while pos < end:
        code, size, start = _tag(data, pos, end, order)
        if code == MI_MATRIX and container:
            _matrix(data, start, start + size, order, depth + 1)
        elif code not in DATA_CODES:
            raise MatFileError(f"an element of unknown type {code} at byte {pos}")
        elif index == 0:
            _dimensions(data[start:start + size], code, order, pos)
        index += 1
        pos = start + (4 if start == pos + 4 else size + (-size % 8))  # small or padded to 8 bytes


def _dimensions(raw: bytes, code: int, order: str, pos: int) -> None:
    """The dimensions element: 32-bit integers, none negative, their product bounded."""
    if code not in (5, 6) or len(raw) % 4:
        raise MatFileError(f"the dimensions at byte {pos} are not 32-bit integers")
    dims = np.frombuffer(raw, dtype=order + ("i4" if code == 5 else "u4")).astype(np.int64)
    if (dims < 0).any() or float(np.prod(dims.astype(float))) > MAX_ELEMENTS:
        raise MatFileError(f"the dimensions at byte {pos} ({', '.join(map(str, dims))}) are not an array's")
