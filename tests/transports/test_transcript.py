"""Transcript: events packed as they are recorded (the run file's log records) and read back exactly."""

from __future__ import annotations

import struct

import pytest

from ecds_lab.transports.transcript import (
    ERROR,
    RECEIVED,
    RECORD_BYTES,
    SENT,
    TEXT_BYTES,
    UNWRITTEN,
    Transcript,
    TranscriptEvent,
    pack_event,
    unpack_events,
)

#: Texts at and around the record size, multi-byte UTF-8 across a record boundary, NUL and control bytes.
TEXTS = ("", "*IDN?", "x" * TEXT_BYTES, "z" * (TEXT_BYTES + 1), "é" * TEXT_BYTES, "\x18", "ok\x00",
         "\x00" * (TEXT_BYTES + 2))


def test_a_record_is_68_bytes_laid_out_as_the_log_with_kind_last():
    assert RECORD_BYTES == 68
    packed = pack_event(3, 1.5, 2.5, RECEIVED, "ok")
    assert packed == (struct.pack("<dd", 1.5, 2.5) + bytes([3, 0, 2]) + b"ok" + bytes(TEXT_BYTES - 2) + bytes([1]))


def test_a_long_text_goes_on_in_records_marked_continues_but_the_last():
    packed = pack_event(1, 0.0, 0.0, SENT, "a" * TEXT_BYTES + "b" * TEXT_BYTES + "c")
    records = [packed[at:at + RECORD_BYTES] for at in range(0, len(packed), RECORD_BYTES)]
    assert [(r[17], r[18], r[19:20]) for r in records] == [(1, TEXT_BYTES, b"a"), (1, TEXT_BYTES, b"b"), (0, 1, b"c")]


def test_unpacking_stops_at_an_unwritten_record_and_drops_an_event_cut_off():
    whole = pack_event(0, 1.0, 2.0, SENT, "XALL?")
    long = pack_event(2, 3.0, 4.0, RECEIVED, "r" * (2 * TEXT_BYTES))
    unwritten = bytes(RECORD_BYTES - 1) + bytes([UNWRITTEN])
    after = pack_event(0, 5.0, 6.0, ERROR, "timeout")
    assert unpack_events(whole + long[:RECORD_BYTES]) == [(0, TranscriptEvent(1.0, 2.0, SENT, "XALL?"))]
    assert unpack_events(whole + unwritten + after) == [(0, TranscriptEvent(1.0, 2.0, SENT, "XALL?"))]
    assert unpack_events(long + after, kinds=("s", "r", "e")) == [(2, TranscriptEvent(3.0, 4.0, "r", "r" * 96)),
                                                                  (0, TranscriptEvent(5.0, 6.0, "e", "timeout"))]


def test_events_read_back_exactly_as_recorded_and_follow_later_recording():
    transcript = Transcript("bridge")
    for at, text in enumerate(TEXTS):
        transcript.record(float(at), (SENT, RECEIVED, ERROR)[at % 3], text)
    assert [(e.clock_s, e.kind, e.text) for e in transcript.events] == \
        [(float(at), (SENT, RECEIVED, ERROR)[at % 3], text) for at, text in enumerate(TEXTS)]
    assert len(transcript) == len(TEXTS) and len(transcript.records) == (len(TEXTS) + 3) * RECORD_BYTES
    transcript.record(99.0, SENT, "*TRG")
    assert transcript.events[-1].text == "*TRG" and len(transcript) == len(TEXTS) + 1
    assert transcript.sent() == [text for at, text in enumerate(TEXTS) if at % 3 == 0] + ["*TRG"]
    transcript.clear()
    assert transcript.events == [] and not transcript.records


def test_a_text_that_cannot_be_encoded_is_recorded_with_the_bad_character_replaced():
    transcript = Transcript("bridge")
    transcript.record(0.0, ERROR, "port \udcff gone")
    assert transcript.events[0].text == "port ? gone"


def test_a_role_code_given_later_applies_to_the_events_recorded_before():
    transcript = Transcript("scanner")
    transcript.record(0.0, SENT, "*IDN?")
    transcript.record(0.0, RECEIVED, "d" * (TEXT_BYTES + 5))
    transcript.role = 2
    transcript.record(1.0, SENT, "READ?")
    assert [role for role, _ in unpack_events(transcript.records)] == [2, 2, 2]
    assert set(transcript.records[16::RECORD_BYTES]) == {2}
    with pytest.raises(ValueError, match="role code is 0 to 254, not 255"):
        transcript.role = 255
