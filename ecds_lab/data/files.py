"""What is this file? A run file (HDF5), a CSV in the import format, or neither: decided by its content.

The one place the question is answered; storage.data_file opens what this finds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from ecds_lab.data.measurements import CSV_COLUMNS, DataError

FileKind = Literal["run", "csv"]

#: The HDF5 format signature (at the start of a file without a user block, as run files are written).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
RUN_FILE_SUFFIXES = (".h5", ".hdf5", ".nxs")
_UTF8_BOM = b"\xef\xbb\xbf"


def file_kind(path: str | Path) -> FileKind:
    """``run`` for an HDF5 file, ``csv`` for a text file whose header holds the import columns.

    A file that is neither raises DataError saying what it is not and what was expected.
    """
    path = Path(path)
    try:
        with path.open("rb") as handle:
            head = handle.read(4096)
    except FileNotFoundError:
        raise DataError(f"{path}: no such file") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read: {exc.strerror}") from exc
    if head.startswith(HDF5_SIGNATURE):
        return "run"
    if path.suffix.lower() in RUN_FILE_SUFFIXES:
        raise DataError(f"{path}: not an HDF5 file, so not an ecds-lab run file (truncated, or another format?)")
    header = _first_line(head.removeprefix(_UTF8_BOM))
    if header is None:
        raise DataError(f"{path}: neither an ecds-lab run file (HDF5) nor a CSV in the import format "
                        f"(a text file whose first line names {','.join(CSV_COLUMNS)})")
    missing = [column for column in CSV_COLUMNS if column not in header]
    separator = _other_separator(head.removeprefix(_UTF8_BOM)) if missing else None
    if separator is not None:
        raise DataError(f"{path}: a CSV whose columns are separated by {separator}, not by commas: the import format "
                        f"is comma-separated with a decimal point ({','.join(CSV_COLUMNS)}); save it as CSV with "
                        "commas (a spreadsheet set to a decimal comma writes semicolons)")
    if missing:
        raise DataError(f"{path}: not an ecds-lab run file, nor a CSV in the import format: its header must "
                        f"contain {','.join(CSV_COLUMNS)}; missing {', '.join(missing)}")
    return "csv"


#: Separators a spreadsheet or a lab program may write instead of the comma, as they are named in an error.
_OTHER_SEPARATORS = {";": "semicolons", "\t": "tabs", "|": "vertical bars"}


def _other_separator(head: bytes) -> str | None:
    """How the first line's columns are separated where another separator than the comma gives every import
    column (a European spreadsheet's semicolons and decimal commas), else None."""
    line = (head.decode("utf-8", errors="ignore").splitlines() or [""])[0]
    for separator, name in _OTHER_SEPARATORS.items():
        if all(column in [cell.strip().strip('"') for cell in line.split(separator)] for column in CSV_COLUMNS):
            return name
    return None


def _first_line(head: bytes) -> list[str] | None:
    """The header cells of a text file's first line, or None when it is not UTF-8 text."""
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 3:  # a multi-byte character cut at the end of the buffer is fine
            return None
        text = head[:exc.start].decode("utf-8")
    return [cell.strip().strip('"') for cell in text.splitlines()[0].split(",")] if text.strip() else []
