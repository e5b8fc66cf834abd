"""The transcript log (/entry/transcripts/log): every role's traffic of a point in one append, texts of any
length read back exactly, a killed writer leaves complete events only, and files of the per-role layout
written before the log still read."""

from __future__ import annotations

import shutil
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest

from ecds_lab.data.columns import COLUMN_NAMES
from ecds_lab.errors import RunFileError
from ecds_lab.storage.reader import read_run
from ecds_lab.storage.run_file import RunWriter, metadata_for
from ecds_lab.storage.transcript_log import CHUNK_RECORDS, RECORD, TEXT_BYTES, UNWRITTEN
from ecds_lab.transports.transcript import ERROR, KINDS, RECEIVED, SENT, Transcript, TranscriptEvent, pack_event

ROLES = ("bridge", "slide", "scanner", "heater")
#: Texts at and around the record size, empty, multi-byte UTF-8 across a record boundary, control bytes
#: (GRBL's real-time commands) and NUL bytes at the end of a record, which a NUL-padded field alone would lose.
TEXTS = ("", "*IDN?", "x" * (TEXT_BYTES - 1), "y" * TEXT_BYTES, "z" * (TEXT_BYTES + 1), "w" * (3 * TEXT_BYTES),
         "é" * TEXT_BYTES, "\x18", "ok\x00", "a" * (TEXT_BYTES - 1) + "\x00" + "b", "\x00" * (TEXT_BYTES + 2),
         "Keysight Technologies,DAQ970A,MY58000001,A.02.04-00.16-11.29-00.02-02-01")


def _writer(path, transcripts):
    return RunWriter(path, metadata=metadata_for("kind: x\n", "name: s\n", "t", "displacement_sweep"),
                     transcripts=transcripts)


def _row(point: int) -> dict[str, float]:
    return {name: float(point) for name in COLUMN_NAMES}


@pytest.fixture
def transcripts() -> dict[str, Transcript]:
    return {role: Transcript(role) for role in ROLES}


def test_texts_of_every_length_and_byte_read_back_exactly(tmp_path, transcripts):
    path = tmp_path / "texts.h5"
    writer = _writer(path, transcripts)
    for point, text in enumerate(TEXTS):
        transcripts[ROLES[point % 4]].record(float(point), KINDS[point % 3], text)
        transcripts["bridge"].record(point + 0.5, RECEIVED, text[::-1])
        writer.append(_row(point))
    live = read_run(path).transcripts  # while the run writes
    writer.close("completed")
    done = read_run(path).transcripts
    assert live == done == {role: transcripts[role].events for role in ROLES}
    assert [e.text for e in done["bridge"] if e.clock_s % 1 == 0.5] == [text[::-1] for text in TEXTS]


def test_a_log_without_traffic_reads_as_empty_transcripts(tmp_path, transcripts):
    path = tmp_path / "quiet.h5"
    writer = _writer(path, transcripts)
    writer.append(_row(0))
    assert read_run(path).transcripts == {role: [] for role in ROLES}
    writer.close("completed")
    assert read_run(path).transcripts == {role: [] for role in ROLES}


def test_one_points_traffic_of_every_role_is_one_append(tmp_path, transcripts, monkeypatch):
    writer = _writer(tmp_path / "one.h5", transcripts)
    appends = []
    real = writer._log.append
    monkeypatch.setattr(writer._log, "append", lambda values: (appends.append(len(values)), real(values)))
    for role in ROLES:
        transcripts[role].record(1.0, SENT, f"{role} command")
        transcripts[role].record(1.0, RECEIVED, "r" * (2 * TEXT_BYTES + 1))  # three records each
    writer.append(_row(0))
    writer.append(_row(1))  # no new traffic: no append
    assert appends == [4 * 4 * RECORD.itemsize]
    writer.close("completed")
    assert sum(len(events) for events in read_run(tmp_path / "one.h5").transcripts.values()) == 8


def test_the_log_describes_itself_and_is_exact_once_closed(tmp_path, transcripts):
    path = tmp_path / "layout.h5"
    writer = _writer(path, transcripts)
    transcripts["scanner"].record(2.0, ERROR, "timeout")
    writer.append(_row(0))
    with h5py.File(path, "r", swmr=True) as f:
        log = f["entry/transcripts/log"]
        assert list(log.attrs["roles"]) == list(ROLES) and list(log.attrs["kinds"]) == list(KINDS)
        assert log.dtype.names == ("clock_s", "wall_s", "role", "continues", "size", "text", "kind")
        assert log.shape == (CHUNK_RECORDS,)  # grown a chunk ahead while the run writes ...
        assert log[1]["kind"] == UNWRITTEN  # ... past the records written: the fill value says so
        assert f["entry/transcripts"].attrs["NX_class"] == "NXcollection"
    writer.close("completed")
    with h5py.File(path, "r") as f:
        log = f["entry/transcripts/log"][()]
    assert len(log) == 1  # exact once closed
    record = log[0]
    assert (ROLES[record["role"]], KINDS[record["kind"]], record["text"], record["continues"]) == \
        ("scanner", ERROR, b"timeout", 0)


def test_a_record_whose_continuation_is_cut_off_is_dropped(tmp_path, transcripts):
    """As a writer killed between the records of one event leaves it (an append that spans two chunks)."""
    path = tmp_path / "cut.h5"
    writer = _writer(path, transcripts)
    transcripts["bridge"].record(1.0, SENT, "XALL?")
    writer.append(_row(0))
    records = pack_event(1, 2.0, 3.0, RECEIVED, "<" + "s" * 3 * TEXT_BYTES + ">")
    assert len(records) == 4 * RECORD.itemsize
    writer._log.append(records[:-RECORD.itemsize])  # the event's last record never reached the file
    run = read_run(path)
    assert [e.text for e in run.transcripts["bridge"]] == ["XALL?"] and run.transcripts["slide"] == []


def test_a_run_killed_inside_a_transcript_append_reads_back_complete_events(tmp_path):
    """The process dies (os._exit) after the first of the two chunk writes of one append: the event that
    straddles the chunks is dropped, every event before it is kept, nothing is read from unwritten records."""
    path = tmp_path / "killed.h5"
    code = f"""
        import os
        from ecds_lab.storage.run_file import RunWriter, metadata_for
        from ecds_lab.transports.transcript import Transcript
        bridge = Transcript("bridge")
        w = RunWriter({str(path)!r}, metadata=metadata_for("kind: x\\n", "", "t", "displacement_sweep"),
                      transcripts={{"bridge": bridge}})
        for point in range({CHUNK_RECORDS - 2}):
            bridge.record(float(point), "sent", f"command {{point}}")
            w.write_transcripts()

        class DiesAfterOneChunk:
            def __init__(self, real):
                self.real = real
            def __getattr__(self, name):
                return getattr(self.real, name)
            def write_direct_chunk(self, *args):
                self.real.write_direct_chunk(*args)
                os._exit(9)

        w._log.id = DiesAfterOneChunk(w._log.id)
        bridge.record(99.0, "received", "r" * {4 * TEXT_BYTES})
        w.write_transcripts()
    """
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 9, done.stderr
    events = read_run(path).transcripts["bridge"]
    assert [e.text for e in events] == [f"command {point}" for point in range(CHUNK_RECORDS - 2)]


def test_a_run_killed_after_an_append_that_needed_no_flush_keeps_its_traffic(tmp_path):
    """Appends into a chunk already written change no metadata and skip the flush (one flush per new chunk):
    their records are on disk all the same when the append returns, so a kill right after loses nothing."""
    path = tmp_path / "unflushed.h5"
    code = f"""
        import os
        from ecds_lab.storage.run_file import RunWriter, metadata_for
        from ecds_lab.transports.transcript import Transcript
        bridge = Transcript("bridge")
        w = RunWriter({str(path)!r}, metadata=metadata_for("kind: x\\n", "", "t", "displacement_sweep"),
                      transcripts={{"bridge": bridge}})

        class CountsFlushes:
            flushes = 0
            def __init__(self, real):
                self.real = real
            def __getattr__(self, name):
                return getattr(self.real, name)
            def flush(self):
                CountsFlushes.flushes += 1
                self.real.flush()

        w._log.id = CountsFlushes(w._log.id)
        for point in range(3):
            bridge.record(float(point), "sent", f"command {{point}}")
            w.write_transcripts()
        print(CountsFlushes.flushes, flush=True)
        os._exit(9)
    """
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 9, done.stderr
    assert done.stdout.split() == ["1"]  # the first append (a new chunk) flushed, the other two did not
    assert [e.text for e in read_run(path).transcripts["bridge"]] == [f"command {point}" for point in range(3)]


def test_a_chunk_write_cut_short_at_any_byte_reads_back_complete_events(tmp_path, transcripts):
    """A kill during the chunk's write leaves a prefix of it on disk (the kernel stops between pages, which
    fall anywhere in a chunk): at every cut inside the new records, the reader sees the event whole or not
    at all (``kind``, each record's last byte, is written last)."""
    path = tmp_path / "torn.h5"
    writer = _writer(path, transcripts)
    transcripts["bridge"].record(1.0, SENT, "XALL?")
    writer.write_transcripts()
    chunk = writer._log.id.get_chunk_info(0)
    before = path.read_bytes()[chunk.byte_offset:chunk.byte_offset + chunk.size]
    transcripts["scanner"].record(2.0, RECEIVED, "+2.20066087E+01," * 4)  # 64 bytes: two records
    writer.write_transcripts()
    assert writer._log.id.get_chunk_info(0).byte_offset == chunk.byte_offset  # rewritten in place
    whole = path.read_bytes()
    after = whole[chunk.byte_offset:chunk.byte_offset + chunk.size]
    new = range(RECORD.itemsize, 3 * RECORD.itemsize + 1)
    assert after[:new.start] == before[:new.start] and after[new.stop:] == before[new.stop:]
    for cut in new:
        torn = tmp_path / f"torn{cut}.h5"
        end = chunk.byte_offset + chunk.size
        torn.write_bytes(whole[:chunk.byte_offset] + after[:cut] + before[cut:] + whole[end:])
        read = read_run(torn).transcripts
        assert read["bridge"] == transcripts["bridge"].events, cut
        assert read["scanner"] == (transcripts["scanner"].events if cut == new.stop - 1 else []), cut
    writer.close("completed")


def test_traffic_recorded_before_the_run_file_goes_to_its_role(tmp_path, transcripts):
    """The station's identification comes before the run file that gives each role its code in the log."""
    for role in ROLES:
        transcripts[role].record(0.0, SENT, "*IDN?")
        transcripts[role].record(0.0, RECEIVED, f"{role} " + "i" * TEXT_BYTES)
    path = tmp_path / "identified.h5"
    writer = _writer(path, transcripts)
    transcripts["heater"].record(1.0, SENT, "OUTP:GEN OFF")
    writer.append(_row(0))
    writer.close("completed")
    read = read_run(path).transcripts
    assert read == {role: transcripts[role].events for role in ROLES}
    assert [e.text[:7] for e in read["scanner"]] == ["*IDN?", "scanner"]
    assert read["heater"][-1].text == "OUTP:GEN OFF"


def test_one_transcript_for_two_roles_is_refused(tmp_path, transcripts):
    with pytest.raises(RunFileError, match="one transcript is given for two roles"):
        _writer(tmp_path / "shared.h5", {"bridge": transcripts["bridge"], "scanner": transcripts["bridge"]})
    assert not (tmp_path / "shared.h5").exists()  # refused before the file was created, and its lock released:
    _writer(tmp_path / "shared.h5", transcripts).close("completed")


def test_resumed_events_go_to_their_role_and_an_unknown_role_is_refused(tmp_path, transcripts):
    path = tmp_path / "resumed.h5"
    writer = _writer(path, transcripts)
    earlier = [TranscriptEvent(0.5, 10.0, SENT, "$X"), TranscriptEvent(0.6, 10.1, RECEIVED, "ok")]
    writer.add_transcript_events("slide", earlier)
    with pytest.raises(RunFileError, match="no transcript for 'camera'; this run records bridge, slide"):
        writer.add_transcript_events("camera", earlier)
    transcripts["slide"].record(1.0, SENT, "?")
    writer.close("completed")
    assert read_run(path).transcripts["slide"] == [*earlier, *transcripts["slide"].events]


# -- files written before the log -------------------------------------------------------------------
def test_a_file_with_per_role_transcripts_reads_as_before(tmp_path, transcripts, per_role_transcripts):
    path = tmp_path / "new.h5"
    writer = _writer(path, transcripts)
    for point, text in enumerate(TEXTS):
        transcripts[ROLES[point % 4]].record(float(point), KINDS[point % 3], text)
        writer.append(_row(point))
    writer.close("completed")
    old = per_role_transcripts(shutil.copyfile(path, tmp_path / "old.h5"))
    with h5py.File(old, "r") as f:
        assert "log" not in f["entry/transcripts"]
        assert f["entry/transcripts/bridge/events"].shape[1] == 4
    recorded = read_run(old)
    assert recorded.transcripts == read_run(path).transcripts == {role: transcripts[role].events for role in ROLES}
    np.testing.assert_array_equal(recorded.points, read_run(path).points)


def test_the_close_trims_the_log_under_a_live_reader(tmp_path, transcripts):
    """A viewer holding the file (SWMR) while the run closes: the close still shrinks the log to its records."""
    path = tmp_path / "watched.h5"
    writer = _writer(path, transcripts)
    transcripts["bridge"].record(1.0, SENT, "*TRG")
    writer.append(_row(0))
    with h5py.File(path, "r", swmr=True) as reader:
        log = reader["entry/transcripts/log"]
        assert log.shape == (CHUNK_RECORDS,)
        transcripts["bridge"].record(2.0, SENT, "*WAI")
        writer.append(_row(1))
        writer.close("completed")
        log.refresh()
        assert log.shape == (2,) and list(log["kind"]) == [KINDS.index(SENT)] * 2
    recorded = read_run(path)
    assert recorded.status == "completed" and recorded.notes == []
    assert recorded.transcripts["bridge"] == transcripts["bridge"].events
