"""pyserial URL handler ``ecdssim://LAB/INSTRUMENT``: a serial port wired to an emulator.

pyserial finds this module through ``serial.protocol_handler_packages`` (registered
by ``ecds_lab.simulators.registry.register_lab``). Reads hand out the emulator's replies; when
none is ready, the host's wait passes on the lab's simulated clock, up to the port
timeout, so instrument-internal delays cost no wall time.
"""

from __future__ import annotations

from urllib.parse import urlparse

from serial.serialutil import PortNotOpenError, SerialBase, SerialException, SerialTimeoutException

from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.registry import emulator


class _Received:
    """Reply bytes collected from the emulator and how far the host has read them.

    Its own small object because pyvisa-py reads a reply one byte per call: attributes of a plain slotted
    object are quicker to reach than those of a pyserial port (an ``io.RawIOBase``), about a third of a read.
    """

    __slots__ = ("at", "data", "end")

    def __init__(self) -> None:
        self.data = b""
        self.at = 0
        self.end = 0  # len(data) while the port is open, 0 once closed: one comparison says whether to serve


class Serial(SerialBase):
    """A serial port whose far end is a protocol emulator in this process."""

    is_open: bool

    def open(self) -> None:
        if self._port is None:
            raise SerialException("Port must be configured before it can be used.")
        if self.is_open:
            raise SerialException("Port is already open.")
        parts = urlparse(self._port)
        if parts.scheme != "ecdssim" or not parts.netloc or not parts.path.strip("/"):
            raise SerialException(f"expected ecdssim://LAB/INSTRUMENT, got {self._port!r}")
        try:
            self._emulator = emulator(parts.netloc, parts.path.strip("/"))
        except KeyError as exc:
            raise SerialException(str(exc.args[0])) from exc
        self._received = _Received()
        self.is_open = True
        self._emulator.on_open()

    def from_url(self, url: str) -> str:
        return url

    def _reconfigure_port(self) -> None:
        """Baud rate and framing mean nothing in process."""

    def close(self) -> None:
        self.is_open = False
        self._received.end = 0

    @property
    def emulator(self) -> LineEmulator:
        return self._emulator

    @property
    def in_waiting(self) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        received = self._received
        if received.at >= received.end:
            self._collect()
        return received.end - received.at

    def read(self, size: int = 1) -> bytes:
        """Ready bytes; if none, wait on the simulated clock up to the timeout, then raise.

        Raising SerialTimeoutException (instead of returning b"") tells pyvisa-py at once
        that the read timed out; otherwise it would keep polling for its wall-clock timeout
        while every empty read let more simulated time pass.
        """
        received = self._received
        at = received.at
        if at >= received.end:  # one comparison on the path pyvisa-py takes for every byte (closed: end 0)
            if not self.is_open:
                raise PortNotOpenError()
            self._collect()
            if not received.data:
                self._wait_for_reply()
                if not received.data:
                    raise SerialTimeoutException(f"{self._port}: no reply within {self._timeout} s (simulated)")
            at = 0
        received.at = at + size
        return received.data[at:at + size]  # read position moved instead of copying the rest for every byte

    def write(self, data: bytes) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        self._emulator.receive(bytes(data))
        return len(data)

    def reset_input_buffer(self) -> None:
        self._emulator.take_ready()
        self._received = _Received()

    def reset_output_buffer(self) -> None:
        """Nothing is buffered on the way out."""

    def _collect(self) -> None:
        """Unread bytes plus the replies whose time has come (the read position back at 0)."""
        received = self._received
        received.data = received.data[received.at:] + self._emulator.take_ready()
        received.at = 0
        received.end = len(received.data)

    def _wait_for_reply(self) -> None:
        """Let simulated time pass until a reply is ready, at most the port timeout."""
        clock = self._emulator.lab.clock
        ready = self._emulator.next_reply_time()
        limit = clock.now() + (self._timeout if self._timeout is not None else 1.0)
        clock.advance(max(0.0, min(ready, limit) - clock.now()) if ready is not None else limit - clock.now())
        self._collect()
