"""(Re)create the recorded sessions in this folder from the simulated lab.

    /work/venv/bin/python tests/data/sessions/record_sessions.py            # all sessions
    /work/venv/bin/python tests/data/sessions/record_sessions.py heating    # just one

Each session is one ``ecds-lab run`` of an experiment YAML that lives beside this script:

  sweep.h5             sweep.yaml: 5 positions x 2 frequencies, forward and backward (20 points)
  instrument_error.h5  instrument_error.yaml on station_bridge_error.yaml, whose simulated bridge
                       answers ERROR to "FREQ 15000" (``faults`` in the lab config): 2 points, then
                       the run fails with the bridge's error
  heating.h5           heating.yaml: target held at 26 C and 30 C, a 3-position sweep at each,
                       logging during the ramps, a short cool-down (completes)

The files are then compacted: the same groups, datasets, values and attributes, rewritten
with chunks the size of the data and gzip (a fresh run file reserves chunk space for a long
run, ~0.4 MB even when nearly empty). Finally every session is replayed with ``replay_run``
to check it reproduces before it is committed. The simulated lab is seeded, so re-recording
gives the same commands and readings; only wall-clock times differ.

tests/replay/test_recorded_sessions.py replays every ``*.h5`` in this folder, so a recording
from the real lab dropped here (with its own experiment and station inside it) is tested too.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py

HERE = Path(__file__).resolve().parent

#: session name -> (experiment YAML, station YAML or None for the default simulated lab, expected status)
SESSIONS: dict[str, tuple[str, str | None, str]] = {
    "sweep": ("sweep.yaml", None, "completed"),
    "instrument_error": ("instrument_error.yaml", "station_bridge_error.yaml", "failed"),
    "heating": ("heating.yaml", None, "completed"),
}


def ecds_lab_command() -> list[str]:
    """The ``ecds-lab`` of the running interpreter's environment (the venv), else the one on PATH."""
    beside = Path(sys.executable).with_name("ecds-lab")
    if beside.exists():
        return [str(beside)]
    found = shutil.which("ecds-lab")
    if found:
        return [found]
    return [sys.executable, "-c", "import sys; from ecds_lab.cli import main; sys.exit(main())"]


def record(name: str, folder: Path = HERE) -> Path:
    """Run one session's experiment with ``ecds-lab run`` and write ``<folder>/<name>.h5``, compacted."""
    experiment, station, expected = SESSIONS[name]
    target = folder / f"{name}.h5"
    with tempfile.TemporaryDirectory() as scratch:
        raw = Path(scratch) / f"{name}.h5"
        command = [*ecds_lab_command(), "run", str(HERE / experiment), "-o", str(raw), "--quiet"]
        if station:
            command += ["--station", str(HERE / station)]
        done = subprocess.run(command, capture_output=True, text=True)
        if not raw.exists():
            raise SystemExit(f"{name}: ecds-lab run wrote no file (exit {done.returncode}):\n{done.stderr}")
        with h5py.File(raw, "r") as f:
            status = f["entry"].attrs["status"]
        if status != expected:
            raise SystemExit(f"{name}: run ended {status!r}, expected {expected!r}:\n{done.stdout}{done.stderr}")
        compact(raw, target)
    return target


def compact(source: Path, target: Path) -> None:
    """Copy a run file with every dataset rechunked to its size and gzip-compressed (values unchanged)."""
    with h5py.File(source, "r") as src, h5py.File(target, "w", libver="latest") as dst:
        _copy_attrs(src, dst)
        _copy_group(src, dst)


def _copy_group(src: h5py.Group, dst: h5py.Group) -> None:
    for key, item in src.items():
        if isinstance(item, h5py.Group):
            group = dst.create_group(key)
            _copy_attrs(item, group)
            _copy_group(item, group)
        else:
            data = item[()]
            if not item.shape:  # a scalar field (NXentry start_time, end_time): nothing to chunk
                ds = dst.create_dataset(key, data=data)
                _copy_attrs(item, ds)
                continue
            chunks = tuple(max(1, min(n, c)) for n, c in zip(item.shape, item.chunks or item.shape, strict=True))
            ds = dst.create_dataset(key, data=data, maxshape=item.maxshape, chunks=chunks,
                                    compression="gzip", compression_opts=9, shuffle=True)
            _copy_attrs(item, ds)


def _copy_attrs(src: h5py.HLObject, dst: h5py.HLObject) -> None:
    for key in src.attrs:
        dst.attrs.create(key, src.attrs[key], dtype=src.attrs.get_id(key).dtype)


def check(path: Path) -> str:
    """Replay a session and say whether it reproduces (raises when it does not)."""
    from ecds_lab.replay import format_replay, replay_run

    result = replay_run(path)
    if not result.reproduced:
        raise SystemExit(format_replay(result))
    return f"{path.name}: {path.stat().st_size / 1024:.0f} KiB, {result.original_points} points, " \
           f"{result.original_status}, reproduced"


def main(names: list[str]) -> int:
    unknown = sorted(set(names) - set(SESSIONS))
    if unknown:
        print(f"unknown session(s) {', '.join(unknown)}; choose from {', '.join(SESSIONS)}", file=sys.stderr)
        return 2
    for name in names or list(SESSIONS):
        print(check(record(name)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
