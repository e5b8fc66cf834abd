"""What a crash can leave, made readable: write flags still set, a file cut short, chunks past its end.

A run file's writer that was killed leaves the superblock's file-consistency flags set; the HDF5
library then refuses a plain open (``h5clear -s FILE`` clears them for other tools). A file cut
short (a full disk, a copy interrupted) also records an end-of-file address past its real end.
:func:`readable_copy` makes a private copy with a corrected superblock (what ``h5clear -s`` plus
``h5clear --increment`` do), so such a file opens plainly and fails fast where it is damaged,
instead of SWMR-read retrying for minutes; the original is never modified.

Superblock versions 2 and 3 (what ``libver='latest'`` writes; HDF5 File Format Specification,
"Superblock Format Version 2/3"): signature (8), version, size of offsets, size of lengths,
consistency flags, then base, extension, end-of-file and root addresses, and a Jenkins lookup3
checksum of everything before it.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_M = 0xFFFFFFFF


@dataclass(frozen=True)
class Superblock:
    version: int
    offset_size: int
    flags: int
    eof: int

    @property
    def left_open(self) -> bool:
        """Write-access (bit 0) or SWMR-write (bit 2) flag still set: the writer never closed the file."""
        return bool(self.flags & 0x05)


def read_superblock(path: Path) -> Superblock | None:
    """The superblock of a version 2/3 file at offset 0, or None (another version, or not HDF5)."""
    with open(path, "rb") as raw:
        head = raw.read(12 + 4 * 8 + 4)
    if len(head) < 16 or head[:8] != HDF5_SIGNATURE or head[8] not in (2, 3):
        return None
    size = head[9]
    eof_at = 12 + 2 * size
    if len(head) < 12 + 4 * size + 4:
        return None
    return Superblock(head[8], size, head[11], int.from_bytes(head[eof_at:eof_at + size], "little"))


def truncated(path: Path) -> bool:
    """Whether the file is shorter than its superblock says (bytes were lost at its end)."""
    block = read_superblock(path)
    return block is not None and block.eof > os.path.getsize(path)


def readable_copy(path: Path, folder: Path) -> Path:
    """A copy of ``path`` in ``folder`` with the write flags cleared and the end-of-file address set to
    the real size (``h5clear -s`` and ``--increment``), so the original stays as the crash left it."""
    copy = Path(folder) / Path(path).name
    shutil.copyfile(path, copy)
    with open(copy, "r+b") as raw:
        head = bytearray(raw.read(12 + 4 * 8 + 4))
        size = head[9]
        end = 12 + 4 * size
        head[11] = 0
        eof_at = 12 + 2 * size
        # the real size: a killed SWMR writer's superblock may record less than it wrote, a cut file more
        head[eof_at:eof_at + size] = os.path.getsize(copy).to_bytes(size, "little")
        head[end:end + 4] = lookup3(bytes(head[:end])).to_bytes(4, "little")
        raw.seek(0)
        raw.write(bytes(head[:end + 4]))
    return copy


def private_folder() -> tempfile.TemporaryDirectory[str]:
    """A temporary folder for a readable copy (removed when the caller is done)."""
    return tempfile.TemporaryDirectory(prefix="ecds-lab-recover-")


def unreadable_rows(dataset: h5py.Dataset, file_size: int) -> np.ndarray:
    """A mask of the dataset's rows whose chunk lies (partly) past the end of the file: rows that were
    lost, which HDF5 would otherwise hand back as zeros."""
    rows = dataset.shape[0]
    lost = np.zeros(rows, bool)
    chunk_rows = dataset.chunks[0] if dataset.chunks else rows
    stored: set[int] = set()
    for info in _chunks(dataset.id):
        start = info.chunk_offset[0]
        stored.add(start)
        if info.byte_offset is None or info.byte_offset + info.size > file_size:
            lost[start:start + chunk_rows] = True
    for start in range(0, rows, chunk_rows):
        if start not in stored:  # a chunk the index does not hold (its index entry was lost)
            lost[start:start + chunk_rows] = True
    return lost


def _chunks(dataset_id: h5py.h5d.DatasetID) -> list[Any]:
    """Where each stored chunk of a dataset is: one pass over the chunk index (H5Dchunk_iter, HDF5 >= 1.12.3 /
    1.10.10); without it, chunk by chunk, which costs time growing with the square of the chunk count."""
    found: list[Any] = []
    chunk_iter = getattr(dataset_id, "chunk_iter", None)
    if chunk_iter is not None:
        chunk_iter(found.append)
        return found
    return [dataset_id.get_chunk_info(index) for index in range(dataset_id.get_num_chunks())]


def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & _M


def lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle``, the checksum HDF5 puts on superblocks and object headers."""
    length = len(data)
    a = b = c = (0xDEADBEEF + length + initval) & _M
    i = 0
    while length > 12:
        a = (a + int.from_bytes(data[i:i + 4], "little")) & _M
        b = (b + int.from_bytes(data[i + 4:i + 8], "little")) & _M
        c = (c + int.from_bytes(data[i + 8:i + 12], "little")) & _M
        a = (a - c) & _M; a ^= _rot(c, 4); c = (c + b) & _M  # noqa: E702 - the mix, as published
        b = (b - a) & _M; b ^= _rot(a, 6); a = (a + c) & _M  # noqa: E702
        c = (c - b) & _M; c ^= _rot(b, 8); b = (b + a) & _M  # noqa: E702
        a = (a - c) & _M; a ^= _rot(c, 16); c = (c + b) & _M  # noqa: E702
        b = (b - a) & _M; b ^= _rot(a, 19); a = (a + c) & _M  # noqa: E702
        c = (c - b) & _M; c ^= _rot(b, 4); b = (b + a) & _M  # noqa: E702
        length -= 12
        i += 12
    if length == 0:
        return c
    tail = data[i:] + bytes(12 - length)
    a = (a + int.from_bytes(tail[0:4], "little")) & _M
    b = (b + int.from_bytes(tail[4:8], "little")) & _M
    c = (c + int.from_bytes(tail[8:12], "little")) & _M
    c ^= b; c = (c - _rot(b, 14)) & _M  # noqa: E702 - the final mix, as published
    a ^= c; a = (a - _rot(c, 11)) & _M  # noqa: E702
    b ^= a; b = (b - _rot(a, 25)) & _M  # noqa: E702
    c ^= b; c = (c - _rot(b, 16)) & _M  # noqa: E702
    a ^= c; a = (a - _rot(c, 4)) & _M  # noqa: E702
    b ^= a; b = (b - _rot(a, 14)) & _M  # noqa: E702
    c ^= b; c = (c - _rot(b, 24)) & _M  # noqa: E702
    return c
