"""pyserial link, opened with ``serial_for_url``.

Real ports (``/dev/ttyUSB0``, ``COM3``), ``socket://host:port``, ``loop://`` and any
scheme registered with pyserial (the simulated lab registers ``ecdssim://``) all go
through this one code path; the transport knows nothing of who is at the far end.
"""

from __future__ import annotations

import serial

from ecds_lab.errors import TransportError
from ecds_lab.transports.base import Transport

_PARITY = {"N": serial.PARITY_NONE, "E": serial.PARITY_EVEN, "O": serial.PARITY_ODD}


class SerialTransport(Transport):
    """A line link over a pyserial port; buffers whole chunks instead of reading byte by byte."""

    def __init__(
        self,
        name: str,
        url: str,
        *,
        baudrate: int = 9600,
        bytesize: int = 8,
        parity: str = "N",
        stopbits: float = 1,
        rtscts: bool = False,
        xonxoff: bool = False,
        **options: object,
    ) -> None:
        super().__init__(name, **options)  # type: ignore[arg-type]
        try:
            self._port = serial.serial_for_url(
                url,
                baudrate=baudrate,
                bytesize=bytesize,
                parity=_PARITY[parity],
                stopbits=stopbits,
                rtscts=rtscts,
                xonxoff=xonxoff,
                timeout=self.timeout_s,
                write_timeout=self.timeout_s,
            )
        except (serial.SerialException, ValueError) as exc:
            raise TransportError(f"{name}: cannot open serial port {url!r}: {exc}") from exc
        self.url = url
        self._port_timeout_s = self.timeout_s  # what the port waits for now (pyserial's property is slow to read)
        self._buffer = b""
        self._terminator = self.read_termination.encode("ascii")

    @property
    def port(self) -> serial.SerialBase:
        """The underlying pyserial object (tests reach the far end through it)."""
        return self._port

    def _send(self, data: bytes) -> None:
        self._port.write(data)

    def _receive_line(self, timeout_s: float) -> str | None:
        line = self._pop_line() if self._buffer else None
        if line is not None:
            return line
        # The deadline runs on the transport's clock: wall time for hardware, simulated time
        # for the in-process simulators (whose port lets that time pass while it waits).
        if self._port_timeout_s != timeout_s:
            self._port.timeout = self._port_timeout_s = timeout_s
        deadline = self.clock.now() + timeout_s
        while True:
            try:
                chunk = self._port.read(1)  # waits up to the port timeout for a reply to begin
            except serial.SerialTimeoutException:
                chunk = b""
            if chunk:
                self._buffer += chunk
                waiting = self._port.in_waiting  # then take whatever of it has arrived in one read
                if waiting:
                    self._buffer += self._port.read(waiting)
                line = self._pop_line()
                if line is not None:
                    return line
            elif self.clock.now() >= deadline:
                return None

    def _waiting_line(self) -> str | None:
        line = self._pop_line() if self._buffer else None
        if line is not None:
            return line
        try:
            waiting = self._port.in_waiting
            if waiting:
                self._buffer += self._port.read(waiting)
        except (serial.SerialException, OSError):  # a broken port: the query's own write says so
            return None
        return self._pop_line() if waiting else None

    def _pop_line(self) -> str | None:
        index = self._buffer.find(self._terminator)
        if index < 0:
            return None
        line = self._buffer[:index]
        self._buffer = self._buffer[index + len(self._terminator):]
        return line.decode("ascii", errors="replace").strip("\r\n")

    def _close(self) -> None:
        self._port.close()
