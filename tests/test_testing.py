"""expected_protocol: a driver against a literal list of (command, reply) byte pairs, no simulator."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.instrument import Instrument
from ecds_lab.errors import TransportTimeout
from ecds_lab.testing import ProtocolMismatch, ProtocolTransport, expected_protocol


class Echo(Instrument):
    """A minimal driver: one query, one raw real-time byte."""

    model = "echo"

    def __init__(self, transport, *, prefix: str = "") -> None:
        super().__init__(transport)
        self.prefix = prefix

    def value(self) -> str:
        return self.prefix + self.ask("VAL?")

    def poke(self) -> None:
        self.transport.write_bytes(b"!")


def test_pairs_in_order_pass_and_constructor_kwargs_reach_the_driver():
    with expected_protocol(Echo, [(b"VAL?\n", b"1.5\n"), (b"!", None), (b"VAL?\n", b"2\n")], prefix="v=") as echo:
        assert echo.value() == "v=1.5"
        echo.poke()
        assert echo.value() == "v=2"


def test_a_different_command_fails_at_once_naming_both():
    with (pytest.raises(ProtocolMismatch,
                        match=r"pair 0: expected the command b'VAL\?\\r\\n', the driver sent b'VAL\?\\n'"),
          expected_protocol(Echo, [(b"VAL?\r\n", b"1\n")]) as echo):
        echo.value()


def test_link_settings_set_the_terminations():
    settings = {"write_termination": "\r\n", "read_termination": "\r", "baudrate": 9600}  # framing ignored
    with expected_protocol(Echo, [(b"VAL?\r\n", b"7\r")], link_settings=settings) as echo:
        assert echo.value() == "7"


def test_unused_pairs_fail_on_exit():
    with (pytest.raises(ProtocolMismatch, match=r"1 expected pair\(s\) never used, first \(b'!', None\)"),
          expected_protocol(Echo, [(b"VAL?\n", b"1\n"), (b"!", None)]) as echo):
        echo.value()


def test_unread_reply_bytes_fail_on_exit():
    with (pytest.raises(ProtocolMismatch, match=r"never read by the driver: b'extra\\n'"),
          expected_protocol(Echo, [(b"VAL?\n", b"1\nextra\n")]) as echo):
        echo.value()


def test_sending_past_the_last_pair_fails():
    with (pytest.raises(ProtocolMismatch, match=r"sent b'!' after all 0 expected pairs"),
          expected_protocol(Echo, []) as echo):
        echo.poke()


def test_an_unprompted_reply_is_read_without_a_command():
    transport = ProtocolTransport([(None, b"hello\n"), (b"VAL?\n", b"3\n")])
    assert transport.read_line() == "hello"
    assert transport.query("VAL?") == "3"
    transport.check_finished()


def test_nothing_to_read_is_a_timeout_on_the_simulated_clock():
    transport = ProtocolTransport([(b"VAL?\n", None)], timeout_s=2.0)
    with pytest.raises(TransportTimeout):
        transport.query("VAL?")
    assert transport.clock.now() == 2.0


def test_a_failure_inside_the_block_is_not_masked():
    with pytest.raises(ZeroDivisionError), expected_protocol(Echo, [(b"VAL?\n", b"1\n")]):
        raise ZeroDivisionError


def test_pairs_must_be_bytes():
    with pytest.raises(TypeError, match=r"pair 0 is \('VAL\?', None\)"):
        ProtocolTransport([("VAL?", None)])  # type: ignore[list-item]
