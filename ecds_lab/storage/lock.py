"""One writer per run file: an advisory lock file beside it (``.<name>.lock``), held while the run writes.

The lock is an ``flock`` on that file, so the operating system releases it when the writer dies
(even by SIGKILL): a stale lock file never blocks a later run. The lock is taken *before* the run
file is looked at or created, so of two runs started on one path exactly one proceeds.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

from ecds_lab.errors import RunFileError


def lock_path(path: Path) -> Path:
    """Where the lock of a run file lives."""
    return path.with_name(f".{path.name}.lock")


class WriterLock:
    """Exclusive lock on a run file's path; ``release`` removes the lock file."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.lock_file = lock_path(self.path)
        self._fd: int | None = None
        for _ in range(10):  # the holder may remove the lock file between our open and our lock: retry
            fd = os.open(self.lock_file, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "another process"
                os.close(fd)
                raise RunFileError(f"{self.path}: another run is writing this file right now (process {holder}); "
                                   "wait for it to end or choose another -o") from None
            if os.path.exists(self.lock_file) and os.stat(self.lock_file).st_ino == os.fstat(fd).st_ino:
                os.ftruncate(fd, 0)
                os.pwrite(fd, str(os.getpid()).encode(), 0)
                self._fd = fd
                return
            os.close(fd)
        raise RunFileError(f"{self.path}: could not take the writer lock {self.lock_file}")

    def release(self) -> None:
        """Remove the lock file, then let go of the lock (a waiting writer then retries on a fresh file)."""
        if self._fd is None:
            return
        try:
            self.lock_file.unlink(missing_ok=True)
        except OSError:
            pass
        os.close(self._fd)
        self._fd = None


def is_being_written(path: Path) -> bool:
    """Whether a live ecds-lab process holds the writer lock of ``path``."""
    lock_file = lock_path(Path(path))
    try:
        fd = os.open(lock_file, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)
    return False
