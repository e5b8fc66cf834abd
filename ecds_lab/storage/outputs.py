"""Output files written by commands (export, report): never onto an input, never over a file unasked,
and never half-written (written beside the target, then moved over it in one step)."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from ecds_lab.errors import EcdsLabError


class OutputError(EcdsLabError):
    """An output path that must not or cannot be written; the message names it and why."""


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except OSError:
        return False


def check_output(output: Path, inputs: Sequence[Path], *, overwrite: bool) -> None:
    """Refuse an output that is one of the inputs (even with ``overwrite``), that exists (unless
    ``overwrite``), or whose folder is missing or not writable."""
    output = Path(output)
    for source in inputs:
        if _same_file(output, Path(source)):
            raise OutputError(f"{output}: is an input of this command; it is never overwritten -- choose another -o")
    if output.is_dir():
        raise OutputError(f"{output}: is a folder; give a file name with -o")
    if output.exists() and not overwrite:
        raise OutputError(f"{output} exists; choose another -o or pass --overwrite to replace it")
    folder = output.parent if str(output.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"{output}: folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputError(f"{output}: folder {folder} is not writable")


@contextmanager
def replacing(output: Path) -> Iterator[Path]:
    """A temporary path beside ``output``; on success it replaces ``output`` at once, on failure it is removed
    (a full disk or a kill never leaves a half-written or destroyed ``output``)."""
    output = Path(output)
    handle, temporary = tempfile.mkstemp(prefix=f".{output.name}.", suffix=".part", dir=output.parent or ".")
    os.close(handle)
    try:
        yield Path(temporary)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)  # as a plain open() would have created it
        os.replace(temporary, output)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def write_output(output: Path, inputs: Sequence[Path], overwrite: bool, write: Callable[[Path], object]) -> None:
    """Check ``output`` against the inputs and write it through ``write(path)`` in one step."""
    check_output(output, inputs, overwrite=overwrite)
    try:
        with replacing(output) as temporary:
            write(temporary)
    except OSError as exc:
        raise OutputError(f"{output}: could not be written: {exc.strerror or exc}") from exc
