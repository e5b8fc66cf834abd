"""Never destroy data: outputs never overwrite inputs, one writer per run file, kills and full disks
leave readable files, lost rows are reported and never read as zeros, transcripts cover every row."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

from ecds_lab.cli import main
from ecds_lab.data.columns import INDEX
from ecds_lab.errors import RunFileError
from ecds_lab.storage.lock import lock_path
from ecds_lab.storage.reader import read_run
from ecds_lab.storage.recovery import _chunks, lookup3, read_superblock
from ecds_lab.storage.run_file import RunWriter, metadata_for
from ecds_lab.transports.transcript import SENT

SWEEP = "displacement_sweep.yaml"


@pytest.fixture
def sweep_file(shipped_run, tmp_path):
    """A private copy of a completed sweep's run file."""
    path = tmp_path / "sweep.h5"
    shutil.copyfile(shipped_run(SWEEP).path, path)
    return path


def python(code: str, *, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run Python code in a child process (for kills, limits and crashes the test process must not suffer)."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=timeout, check=False)


def killed_run(experiment, output, *, after_rows: int) -> None:
    """A run whose process dies (os._exit: no cleanup, as SIGKILL) right after writing ``after_rows`` rows."""
    done = python(f"""
        import os
        from ecds_lab.cli import main
        from ecds_lab.storage.run_file import RunWriter
        real = RunWriter.append_row
        def append_row(self, row):
            real(self, row)
            if self.rows == {after_rows}:
                os._exit(9)
        RunWriter.append_row = append_row
        main(["run", {str(experiment)!r}, "-o", {str(output)!r}, "-q"])
    """)
    assert done.returncode == 9, done.stderr


def writer(path, **kwargs) -> RunWriter:
    return RunWriter(path, metadata=metadata_for("kind: x\n", "name: s\n", "t", "displacement_sweep"),
                     transcripts={}, **kwargs)


# -- outputs of export and report ------------------------------------------------------------------
def test_export_onto_its_own_run_file_is_refused_even_with_overwrite(sweep_file, capsys):
    before = sweep_file.read_bytes()
    for extra in ([], ["--overwrite"]):
        assert main(["export", str(sweep_file), "-o", str(sweep_file), *extra]) == 2
        assert "is an input of this command" in capsys.readouterr().err
    assert sweep_file.read_bytes() == before
    assert read_run(sweep_file).status == "completed"


def test_export_onto_an_existing_file_needs_overwrite(sweep_file, tmp_path, capsys):
    existing = tmp_path / "old.csv"
    existing.write_text("keep me\n")
    assert main(["export", str(sweep_file), "-o", str(existing)]) == 2
    assert "exists; choose another -o or pass --overwrite" in capsys.readouterr().err
    assert existing.read_text() == "keep me\n"
    assert main(["export", str(sweep_file), "-o", str(existing), "--overwrite"]) == 0
    assert existing.read_text().startswith("time_s")


def test_export_into_a_missing_or_read_only_folder_is_one_line(sweep_file, tmp_path, capsys):
    assert main(["export", str(sweep_file), "-o", str(tmp_path / "nowhere" / "x.csv")]) == 2
    assert "does not exist" in capsys.readouterr().err
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        if os.access(locked, os.W_OK):
            pytest.skip("running as a user who may write anywhere")
        assert main(["export", str(sweep_file), "-o", str(locked / "x.csv")]) == 2
        assert "not writable" in capsys.readouterr().err
    finally:
        locked.chmod(0o700)


def test_export_onto_a_full_disk_names_the_file_in_one_line_and_leaves_no_part(sweep_file, tmp_path):
    """A file-size limit stands for the full disk (no root needed): the write fails part way."""
    output = tmp_path / "out" / "sweep.csv"
    output.parent.mkdir()
    done = python(f"""
        import resource, signal, sys
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails (EFBIG), as ENOSPC would
        from ecds_lab.cli import main
        from ecds_lab.storage.reader import read_run
        read_run({str(sweep_file)!r})  # anything the reader caches is in place before the limit
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
        sys.exit(main(["export", {str(sweep_file)!r}, "-o", {str(output)!r}]))
    """)
    assert done.returncode == 2, (done.returncode, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr
    assert lines[0].startswith(f"ecds-lab export: {output}: could not be written: ")
    assert list(output.parent.iterdir()) == []  # neither a half-written CSV nor a temporary left


def test_export_whose_sidecar_meets_a_full_disk_names_the_sidecar(sweep_file, tmp_path, monkeypatch, capsys):
    import errno
    from pathlib import Path

    real = Path.write_text

    def full(self, *args, **kwargs):
        if self.name.startswith(".sweep.units.json."):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", full)
    output = tmp_path / "sweep.csv"
    assert main(["export", str(sweep_file), "-o", str(output)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"ecds-lab export: {tmp_path / 'sweep.units.json'}: could not be written: No space left on device"
    assert not (tmp_path / "sweep.units.json").exists()


def test_report_onto_an_input_is_refused(sweep_file, tmp_path, capsys):
    csv = tmp_path / "data.csv"
    assert main(["export", str(sweep_file), "-o", str(csv)]) == 0
    before = csv.read_bytes()
    assert main(["report", str(sweep_file), str(csv), "-o", str(csv), "--overwrite"]) == 2
    assert "is an input of this command" in capsys.readouterr().err
    assert csv.read_bytes() == before


# -- one writer per path ---------------------------------------------------------------------------
def test_a_second_writer_on_a_path_being_written_is_refused(tmp_path):
    path = tmp_path / "run.h5"
    first = writer(path)
    first.append({"time_s": 0.0, "ls_h": 1e-4})
    with pytest.raises(RunFileError, match="another run is writing this file right now"):
        writer(path, overwrite=True)
    first.close("completed")
    assert read_run(path).status == "completed" and len(read_run(path).points) == 1
    assert not lock_path(path).exists()
    writer(path, overwrite=True).close("completed")  # once the first is done, --overwrite may replace it


def test_run_overwrite_onto_a_file_another_process_writes_is_refused(tmp_path, experiments_dir, capsys):
    path = tmp_path / "busy.h5"
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time
        from ecds_lab.storage.run_file import RunWriter
        w = RunWriter({str(path)!r}, metadata={{}}, transcripts={{}})
        print("open", flush=True)
        sys.stdin.readline()
        w.close("completed")
    """)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "open"
        assert main(["run", str(experiments_dir / SWEEP), "-o", str(path), "--overwrite", "-q"]) == 2
        assert "another run is writing this file right now" in capsys.readouterr().err
    finally:
        holder.communicate("\n", timeout=60)
    assert read_run(path).status == "completed"  # the other process's file is intact


def test_two_runs_at_once_on_one_path_exactly_one_wins(tmp_path, experiments_dir):
    path = tmp_path / "race.h5"
    command = [sys.executable, "-m", "ecds_lab.cli", "run", str(experiments_dir / SWEEP), "-o", str(path), "-q"]
    runs = [subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    results = [(run.wait(timeout=300), run.communicate()[1]) for run in runs]
    codes = sorted(code for code, _ in results)
    assert codes == [0, 2], results
    loser = next(err for code, err in results if code == 2)
    assert ("another run is writing this file right now" in loser or "exists; choose another -o" in loser)
    assert "Traceback" not in loser
    assert read_run(path).status == "completed"


# -- kills, readers and lost bytes -----------------------------------------------------------------
@pytest.mark.parametrize("moment", ["completing", "finishing"])
def test_a_kill_during_close_leaves_a_readable_file_with_every_row(moment, tmp_path, experiments_dir, shipped_run):
    """Killed while /entry is completed in place (status not yet written), or later, while the file is
    reopened for the NeXus end_time field (status already written)."""
    path = tmp_path / "closing.h5"
    kill = {"completing": """
        def complete(self, *args):
            self._file["entry"].attrs["end_time"] = "half-way"
            self._file.flush()
            os._exit(9)
        run_file.RunWriter._complete = complete
    """, "finishing": """
        import h5py
        def finish(self):
            h5py.File(self.path, "a", libver="latest")
            os._exit(9)
        run_file.RunWriter._finish_nexus = finish
    """}[moment]
    done = python(f"""
        import os
        from ecds_lab.cli import main
        from ecds_lab.storage import run_file
        {textwrap.indent(textwrap.dedent(kill), "        ").strip()}
        main(["run", {str(experiments_dir / SWEEP)!r}, "-o", {str(path)!r}, "-q"])
    """)
    assert done.returncode == 9, done.stderr
    run = read_run(path)
    assert run.status == ("interrupted" if moment == "completing" else "completed")
    assert len(run.points) == len(read_run(shipped_run(SWEEP).path).points)  # every row of the whole sweep
    if read_superblock(path).left_open:
        assert any("h5clear -s" in note for note in run.notes)
        assert read_superblock(path).left_open  # reading never modified the file
    assert main(["export", str(path), "-o", str(tmp_path / "closing.csv")]) == 0


def test_a_live_swmr_reader_at_the_end_of_a_run_does_not_stop_the_writer(tmp_path):
    path = tmp_path / "watched.h5"
    w = writer(path)
    w.append({"time_s": 0.0, "ls_h": 1e-4})
    with h5py.File(path, "r", swmr=True) as reader:
        w.append({"time_s": 1.0, "ls_h": 2e-4})
        w.close("completed")
        reader["entry/points"].refresh()
        assert reader["entry/points"].shape[0] == 2
    recorded = read_run(path)
    assert recorded.status == "completed" and recorded.notes == []
    np.testing.assert_array_equal(recorded.column("ls_h"), [1e-4, 2e-4])


def test_a_cut_short_killed_file_reports_lost_rows_and_never_exports_zeros(tmp_path, experiments_dir, capsys):
    path = tmp_path / "killed.h5"
    killed_run(experiments_dir / SWEEP, path, after_rows=150)
    whole = read_run(path)
    assert len(whole.points) == 150
    os.truncate(path, int(os.path.getsize(path) * 0.6))
    cut = read_run(path)
    assert 0 < len(cut.points) < 150
    assert any("lost from the end of the file" in note for note in cut.notes)
    np.testing.assert_array_equal(cut.points, whole.points[:len(cut.points)])  # what is kept is what was written
    csv = tmp_path / "killed.csv"
    assert main(["export", str(path), "-o", str(csv)]) == 0
    assert "lost from the end of the file" in capsys.readouterr().err
    exported = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert len(exported) == int(np.isfinite(cut.column("ls_h")).sum())
    assert (exported[:, 0] != 0).sum() >= len(exported) - 1 and (exported[:, 5] != 0).all()  # no rows of zeros


def test_a_killed_runs_transcript_covers_every_kept_reading(tmp_path, experiments_dir):
    for rows in (7, 33, 120):
        path = tmp_path / f"killed{rows}.h5"
        killed_run(experiments_dir / SWEEP, path, after_rows=rows)
        run = read_run(path)
        assert len(run.points) == rows
        bridge = run.transcripts["bridge"]
        measured = sum(1 for e in bridge if e.kind == SENT and e.text == "XALL?")
        assert measured == np.isfinite(run.column("ls_h")).sum()
        last_row_wall = run.column("wall_time_s").max()
        assert bridge[-1].wall_s <= last_row_wall


def test_the_chunk_index_is_read_in_one_pass_or_chunk_by_chunk_alike(sweep_file):
    """HDF5 >= 1.12.3 iterates the chunk index in one pass; older libraries are asked chunk by chunk."""

    class ChunkByChunk:  # a dataset id of an HDF5 without H5Dchunk_iter
        def __init__(self, real):
            self.get_num_chunks, self.get_chunk_info = real.get_num_chunks, real.get_chunk_info

    with h5py.File(sweep_file, "r") as f:
        for name in ("entry/points", "entry/transcripts/log"):
            ident = f[name].id
            assert hasattr(ident, "chunk_iter")
            assert _chunks(ident) == _chunks(ChunkByChunk(ident))
            assert len(_chunks(ident)) == ident.get_num_chunks() > 0


def test_the_superblock_checksum_is_hdf5s(sweep_file):
    head = sweep_file.read_bytes()[:48]
    assert lookup3(head[:44]) == int.from_bytes(head[44:48], "little")


# -- a full disk -----------------------------------------------------------------------------------
def test_a_full_disk_fails_the_run_with_a_clear_message_and_keeps_the_rows(tmp_path, experiments_dir):
    """The file's room runs out part way (a file-size limit stands for the disk: no root, no tmpfs needed); the
    run stops while the file can still be completed, so it says 'failed', names itself, and keeps every row."""
    path = tmp_path / "full.h5"
    done = python(f"""
        import resource, signal, sys
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG, as ENOSPC would
        resource.setrlimit(resource.RLIMIT_FSIZE, (700_000, 700_000))  # full part way through (the run: 240 kB)
        from ecds_lab.cli import main
        sys.exit(main(["run", {str(experiments_dir / SWEEP)!r}, "-o", {str(path)!r}, "-q"]))
    """, timeout=300)
    assert done.returncode == 1, (done.returncode, done.stderr)  # failed, not killed by a signal
    assert "Traceback" not in done.stderr
    assert f"{path}: the disk is nearly full" in done.stderr
    assert done.stdout.startswith("failed: ")
    kept = int(done.stdout.split()[1])
    run = read_run(path)
    assert run.status == "failed"  # the status was written, with the reason naming the file
    assert f"{path}: the disk is nearly full" in run.metadata["error"]
    assert len(run.points) == kept > 10
    assert np.isfinite(run.column("ls_h")).sum() > 0
    assert run.points[:, INDEX["wall_time_s"]].min() > 0


def test_a_write_that_fails_unforeseen_names_the_file_and_the_reader_reports_it(tmp_path, experiments_dir):
    """A disk that fills faster than the room checks see: the failing write (ENOSPC) ends the run with the file
    named; the file is not touched again, keeps its flushed rows and reads as interrupted, saying why it may be."""
    path = tmp_path / "sudden.h5"
    done = python(f"""
        import errno, sys
        from ecds_lab.cli import main
        from ecds_lab.storage import run_file
        real = run_file._Appender.append
        def append(self, values):
            if self.width and self.length >= 40:  # the points table (2-D; the transcript log is 1-D)
                raise OSError(errno.ENOSPC, "No space left on device")
            return real(self, values)
        run_file._Appender.append = append
        sys.exit(main(["run", {str(experiments_dir / SWEEP)!r}, "-o", {str(path)!r}, "-q"]))
    """, timeout=300)
    assert done.returncode == 1, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr
    assert f"{path}: writing the run file failed (disk full?)" in done.stderr
    run = read_run(path)
    assert run.status == "interrupted" and len(run.points) == 40
    assert any("a write failed on a full disk" in note for note in run.notes)


def test_a_nearly_full_disk_stops_the_writer_while_it_can_complete_the_file(tmp_path, monkeypatch):
    """The free space the system reports (shutil.disk_usage, on every platform) is watched every ROOM_CHECK_ROWS
    rows; below what completing needs plus the headroom, the append refuses naming the file, and the file then
    completes as failed with every row."""
    import collections

    from ecds_lab.data.columns import COLUMNS
    from ecds_lab.storage import run_file

    path = tmp_path / "nearly_full.h5"
    free = {"bytes": 10**9}
    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(run_file.shutil, "disk_usage", lambda _: usage(10**10, 0, free["bytes"]))
    monkeypatch.setattr(run_file, "_FILE_SIZE_LIMIT", None)
    w = writer(path)
    row = [1.0] * len(COLUMNS)
    for _ in range(run_file.ROOM_CHECK_ROWS + 5):
        w.append_row(row)
    free["bytes"] = run_file.COMPLETE_MARGIN_BYTES + run_file.HEADROOM_BYTES  # less than the table also needs
    for _ in range(run_file.ROOM_CHECK_ROWS - 5):
        w.append_row(row)  # no check until the next multiple of ROOM_CHECK_ROWS
    with pytest.raises(RunFileError, match=f"{path}: the disk is nearly full") as refused:
        w.append_row(row)
    free["bytes"] = run_file.COMPLETE_MARGIN_BYTES + 4 * run_file.ROOM_CHECK_ROWS * len(COLUMNS) * 8
    w.close("failed", f"RunFileError: {refused.value}")
    run = read_run(path)
    assert run.status == "failed" and str(path) in run.metadata["error"]
    assert len(run.points) == 2 * run_file.ROOM_CHECK_ROWS


def test_the_writer_lock_is_seen_by_readers_and_gone_after_close(tmp_path):
    """storage/lock.py through filelock: a reader's probe sees the writer and does not disturb it."""
    from ecds_lab.storage.lock import is_being_written

    path = tmp_path / "locked.h5"
    w = writer(path)
    assert lock_path(path).read_text() == str(os.getpid())  # the holder named in a second writer's refusal
    assert is_being_written(path) and is_being_written(path)
    w.append_row([1.0] * w._points.width[0])
    w.close("completed")
    assert not lock_path(path).exists() and not is_being_written(path)
    assert read_run(path).status == "completed"
