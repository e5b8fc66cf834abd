"""Which file ``ecds-lab watch`` may follow, decided before serving, and the bounded wait for one to appear.

A path that exists must be a run file (HDF5): a CSV or any other file is refused at once, since it
will never grow into a run. A path that does not exist yet is a run about to start only if its
folder exists and its name is a run file's; watch then waits for it a bounded time (``--wait``,
docs/live_view.md) and says so, instead of showing a page that waits forever for a mistyped name.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from ecds_lab.data.files import RUN_FILE_SUFFIXES, file_kind
from ecds_lab.errors import RunFileError

#: How long ``watch`` waits for a run file that does not exist yet, unless ``--wait`` says otherwise.
DEFAULT_WAIT_S = 60.0
POLL_S = 0.2


def check_watch_target(path: Path) -> bool:
    """True when ``path`` is a run file now, False when it may still be created by a run about to start.

    Anything else raises RunFileError (or DataError) with one line naming the path and what is wrong.
    """
    if path.exists():
        if path.is_dir():
            raise RunFileError(f"{path}: a folder, not a run file; watch follows one run file (.h5)")
        if path.stat().st_size == 0 and path.suffix.lower() in RUN_FILE_SUFFIXES:
            return True  # created by its run an instant ago, HDF5 header not yet written
        if file_kind(path) != "run":
            raise RunFileError(f"{path}: a CSV, not a run file; watch follows a run file (.h5) while its run "
                               "writes it (for a CSV: ecds-lab fit, diagnose or report)")
        return True
    if not path.parent.is_dir():
        raise RunFileError(f"{path}: no such file, and its folder {path.parent} does not exist (check the path)")
    if path.suffix.lower() not in RUN_FILE_SUFFIXES:
        raise RunFileError(f"{path}: no such file, and not a run file's name (a run file ends in "
                           f"{', '.join(RUN_FILE_SUFFIXES)}); check the path")
    return False


def wait_for_run_file(path: Path, timeout_s: float, *, sleep: Callable[[float], None] = time.sleep,
                      now: Callable[[], float] = time.monotonic) -> None:
    """Return once ``path`` exists; after ``timeout_s`` raise RunFileError saying nothing created it."""
    deadline = now() + timeout_s
    while not path.exists():
        if now() >= deadline:
            raise RunFileError(f"{path}: not created within {timeout_s:g} s, so no run is writing it; check the "
                               f"path, or start the run with -o {path} (--wait SECONDS waits longer)")
        sleep(POLL_S)
