"""pyvisa link (pyvisa-py backend by default).

Any VISA resource works: ``TCPIP0::192.168.0.5::5025::SOCKET``, ``USB0::...::INSTR``,
``ASRL/dev/ttyUSB0::INSTR``. pyvisa-py opens ``ASRL<url>::INSTR`` through
pyserial's ``serial_for_url``, so any pyserial URL scheme works as an ASRL resource
(the simulated lab's ``ASRLecdssim://lab/daq970a::INSTR`` goes through the full VISA stack).
"""

from __future__ import annotations

import pyvisa
from pyvisa.resources import MessageBasedResource

from ecds_lab.errors import TransportError
from ecds_lab.transports.base import Transport

_MANAGERS: dict[str, pyvisa.ResourceManager] = {}


def _resource_manager(backend: str) -> pyvisa.ResourceManager:
    if backend not in _MANAGERS:
        _MANAGERS[backend] = pyvisa.ResourceManager(backend)
    return _MANAGERS[backend]


class VisaTransport(Transport):
    """A line link over a pyvisa message-based resource."""

    def __init__(self, name: str, resource: str, *, backend: str = "@py", baudrate: int | None = None,
                 **options: object) -> None:
        super().__init__(name, **options)  # type: ignore[arg-type]
        try:
            opened = _resource_manager(backend).open_resource(
                resource,
                read_termination=self.read_termination,
                write_termination="",
                timeout=round(self.timeout_s * 1000),
            )
            if not isinstance(opened, MessageBasedResource):
                opened.close()
                raise ValueError("not a message-based resource (a line link needs one)")
            if baudrate is not None and hasattr(opened, "baud_rate"):
                opened.baud_rate = baudrate
            self._resource = opened
        except (pyvisa.Error, ValueError, OSError) as exc:
            raise TransportError(f"{name}: cannot open VISA resource {resource!r}: {exc}") from exc
        self.resource_name = resource
        self._timeout_ms = round(self.timeout_s * 1000)
        #: Whether the resource tells how many bytes wait unread (serial ASRL resources do; raw sockets not).
        self._can_peek = hasattr(type(opened), "bytes_in_buffer")

    def _send(self, data: bytes) -> None:
        self._resource.write_raw(data)

    def _receive_line(self, timeout_s: float) -> str | None:
        timeout_ms = round(timeout_s * 1000)
        if self._timeout_ms != timeout_ms:
            self._resource.timeout = self._timeout_ms = timeout_ms
        try:
            return self._resource.read().strip("\r\n")
        except pyvisa.errors.VisaIOError as exc:
            if exc.error_code == pyvisa.constants.StatusCode.error_timeout:
                return None
            raise TransportError(f"{self.name}: VISA read failed: {exc}") from exc

    def _waiting_line(self) -> str | None:
        if not self._can_peek:
            return None
        try:
            waiting = self._resource.bytes_in_buffer  # type: ignore[attr-defined]
        except (pyvisa.Error, NotImplementedError, AttributeError):
            self._can_peek = False  # the backend cannot tell without waiting
            return None
        return self._receive_line(self.timeout_s) if waiting else None

    def _close(self) -> None:
        self._resource.close()
