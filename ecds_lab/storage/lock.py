"""One writer per run file: an advisory lock file beside it (``.<name>.lock``), held while the run writes.

The lock is the operating system's (``flock`` on POSIX, ``LockFileEx`` on Windows), taken through
filelock's ``lock_descriptor`` on a descriptor this module opens, so the system releases it when the
writer dies (even by SIGKILL): a stale lock file never blocks a later run. The lock is taken *before*
the run file is looked at or created, so of two runs started on one path exactly one proceeds.
Nothing here is POSIX-only: the reader imports :func:`is_being_written` on every platform.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from filelock import lock_descriptor, unlock_descriptor

from ecds_lab.errors import RunFileError

#: A probe that finds the lock held tries again this many times, this far apart (s): another reader's
#: probe holds it for microseconds, a writer for its whole run.
_PROBES = 2
_PROBE_PAUSE_S = 0.005


def lock_path(path: Path) -> Path:
    """Where the lock of a run file lives."""
    return path.with_name(f".{path.name}.lock")


def _holder(fd: int) -> str:
    """The process id the holder wrote into the lock file (Windows may refuse the read of a locked byte)."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return os.read(fd, 64).decode(errors="replace").strip() or "another process"
    except OSError:
        return "another process"


class WriterLock:
    """Exclusive lock on a run file's path; ``release`` removes the lock file."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.lock_file = lock_path(self.path)
        self._fd: int | None = None
        for _ in range(10):  # the holder may remove the lock file between our open and our lock: retry
            fd = os.open(self.lock_file, os.O_RDWR | os.O_CREAT | getattr(os, "O_BINARY", 0), 0o644)
            try:
                locked = lock_descriptor(fd, blocking=False)
            except OSError:
                os.close(fd)
                raise
            if not locked:
                holder = _holder(fd)
                os.close(fd)
                raise RunFileError(f"{self.path}: another run is writing this file right now (process {holder}); "
                                   "wait for it to end or choose another -o")
            if os.path.exists(self.lock_file) and os.stat(self.lock_file).st_ino == os.fstat(fd).st_ino:
                os.ftruncate(fd, 0)
                os.lseek(fd, 0, os.SEEK_SET)
                os.write(fd, str(os.getpid()).encode())
                self._fd = fd
                return
            os.close(fd)
        raise RunFileError(f"{self.path}: could not take the writer lock {self.lock_file}")

    def release(self) -> None:
        """Remove the lock file, then let go of the lock (a waiting writer then retries on a fresh file).
        Where an open file cannot be removed (Windows), the lock goes first and the file after it."""
        if self._fd is None:
            return
        try:
            self.lock_file.unlink(missing_ok=True)
            removed = True
        except OSError:
            removed = False
        os.close(self._fd)
        self._fd = None
        if not removed:
            try:
                self.lock_file.unlink(missing_ok=True)
            except OSError:  # another writer has taken it meanwhile
                pass


def is_being_written(path: Path) -> bool:
    """Whether a live ecds-lab process holds the writer lock of ``path`` (False where that cannot be told:
    no lock file, a folder that cannot be written, a file system without locks)."""
    lock_file = lock_path(Path(path))
    if not lock_file.exists():
        return False
    for probe in range(_PROBES):
        try:
            fd = os.open(lock_file, os.O_RDONLY | getattr(os, "O_BINARY", 0))
        except OSError:
            return False
        try:
            if lock_descriptor(fd, blocking=False):
                unlock_descriptor(fd)
                return False
        except OSError:
            return False
        finally:
            os.close(fd)
        if probe + 1 < _PROBES:
            time.sleep(_PROBE_PAUSE_S)
    return True
