"""The simulated lab on the network: each emulator behind a real port that any client can open.

``ecds-lab simulate`` builds one SimulatedLab from a simulated station YAML and serves its
instruments until Ctrl-C:
  - SCPI instruments (the kinds whose simulated link is VISA: scanner, supply) each on a raw TCP
    socket on 127.0.0.1, the LXI convention (port 5025 and up): VISA ``TCPIP::127.0.0.1::5025::SOCKET``;
  - serial instruments (bridge, slide) each on a pseudo-terminal (``/dev/pts/N``, opened like a USB
    serial port by pyserial, a GRBL sender or a terminal), or with ``serial="tcp"`` on a TCP port that
    pyserial opens as ``socket://127.0.0.1:PORT``.
Time in the lab runs with the wall clock (``RunningClock``): a scan takes its 0.3 s, a heater warms
the target in real minutes. The emulators are the same line-based firmware models the in-process
``ecdssim://`` port reaches; here one selector loop moves their bytes, so nothing runs concurrently.
A pseudo-terminal has no "port opened" signal, so a serial emulator there sees ``on_open`` (GRBL's
reset and banner) once, when serving starts; over TCP it sees it at every connection, as an
Arduino's DTR reset does at every port opening. Pseudo-terminals are POSIX-only (``os.openpty``, ``tty``:
imported only when one is opened); TCP serving works on every platform, and is ``ecds-lab simulate``'s
default where there are no ptys.
"""

from __future__ import annotations

import contextlib
import os
import selectors
import socket
import sys
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Literal

from ecds_lab.clock import SimulatedClock
from ecds_lab.errors import ConfigError
from ecds_lab.instruments.kinds import ROLE_NAMES, kind
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.emulator import LineEmulator
from ecds_lab.simulators.lab import SimulatedLab

SerialMode = Literal["pty", "tcp"]
#: First raw-socket port (LXI / SCPI-RAW convention).
LXI_PORT = 5025
HOST = "127.0.0.1"
#: Whether this system has pseudo-terminals (POSIX); elsewhere serial instruments are served over TCP.
PTY_AVAILABLE = hasattr(os, "openpty")
#: Longest the loop sleeps with nothing to do (s): how late a reply due at a given time can be sent.
_POLL_S = 0.02


class RunningClock(SimulatedClock):
    """Simulated time that runs with the wall clock (real_time_factor 1) while the lab is served."""

    def __init__(self, start: float = 0.0) -> None:
        super().__init__(start, real_time_factor=1.0)
        self._origin = time.monotonic()

    def now(self) -> float:
        return self._t + (time.monotonic() - self._origin)

    def sleep(self, seconds: float) -> None:
        """Time passes by itself; sleeping only waits for it."""
        if seconds > 0:
            time.sleep(seconds)


@dataclass
class Endpoint:
    """One served instrument: its emulator and the port a client reaches it on."""

    role: str
    driver: str
    emulator: LineEmulator
    link: Literal["serial", "visa"]
    address: str = ""
    listener: socket.socket | None = None
    clients: list[socket.socket] = field(default_factory=list)
    master_fd: int | None = None
    slave_fd: int | None = None
    #: The client that last sent something gets the replies (one at a time, as on a real port).
    reply_to: socket.socket | None = None

    def describe(self) -> str:
        return f"{self.role:<8} {self.driver:<8} {self.link:<6} {self.address}"


class LabServer:
    """Serve a simulated station's instruments on local ports; ``serve_forever`` until stopped."""

    def __init__(self, lab: LabConfig, drivers: Mapping[str, str], *, port_base: int = LXI_PORT,
                 serial: SerialMode = "pty", host: str = HOST) -> None:
        """``drivers`` maps each role (bridge, slide, ...) to the instrument kind that serves it."""
        if serial not in ("pty", "tcp"):
            raise ValueError(f"serial must be 'pty' or 'tcp', got {serial!r}")
        if serial == "pty" and not PTY_AVAILABLE:
            raise ConfigError("simulate: pseudo-terminals exist only on POSIX systems; serve the serial instruments "
                              "over TCP (--serial tcp)")
        self.lab = SimulatedLab(lab, RunningClock())
        self.host = host
        self.selector = selectors.DefaultSelector()
        self.endpoints: list[Endpoint] = []
        self._stop = threading.Event()
        for role in ROLE_NAMES:
            row = kind(drivers[role])
            self.endpoints.append(Endpoint(role, drivers[role], row.emulator_class()(self.lab), row.simulated_link))
        next_port = port_base
        try:  # SCPI instruments take the first ports (5025, 5026, ...), serial ones over TCP the next
            for endpoint in sorted(self.endpoints, key=lambda e: e.link != "visa"):
                if endpoint.link == "serial" and serial == "pty":
                    self._open_pty(endpoint)
                else:
                    self._listen(endpoint, next_port)
                    next_port = next_port + 1 if port_base else 0
        except Exception:
            self.close()
            raise

    # -- ports ----------------------------------------------------------------------------------
    def _listen(self, endpoint: Endpoint, port: int) -> None:
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            listener.bind((self.host, port))
        except OSError as exc:
            listener.close()
            raise ConfigError(f"simulate: cannot listen on {self.host}:{port} for the {endpoint.role} "
                              f"({endpoint.driver}): {exc}; choose another --port-base") from exc
        listener.listen()
        listener.setblocking(False)
        endpoint.listener = listener
        bound = listener.getsockname()[1]
        endpoint.address = (f"TCPIP::{self.host}::{bound}::SOCKET" if endpoint.link == "visa"
                            else f"socket://{self.host}:{bound}")
        self.selector.register(listener, selectors.EVENT_READ, ("accept", endpoint))

    def _open_pty(self, endpoint: Endpoint) -> None:
        import tty  # POSIX-only (termios): imported only where a pseudo-terminal is opened

        master, slave = os.openpty()
        tty.setraw(slave)  # no echo, no CR/LF translation: bytes pass as on a USB serial port
        os.set_blocking(master, False)
        endpoint.master_fd, endpoint.slave_fd = master, slave
        endpoint.address = os.ttyname(slave)
        self.selector.register(master, selectors.EVENT_READ, ("pty", endpoint))
        endpoint.emulator.on_open()

    # -- the loop -------------------------------------------------------------------------------
    def describe(self) -> str:
        """One line per instrument: role, driver, link kind, address."""
        return "\n".join(endpoint.describe() for endpoint in self.endpoints)

    def stop(self) -> None:
        self._stop.set()

    def serve_forever(self) -> None:
        """Move bytes between clients and emulators until ``stop`` (or Ctrl-C in the caller)."""
        while not self._stop.is_set():
            for key, _ in self.selector.select(self._wait()):
                action, endpoint = key.data
                if action == "accept":
                    self._accept(endpoint)
                elif action == "client":
                    self._from_client(endpoint, key.fileobj)  # type: ignore[arg-type]
                else:
                    self._from_pty(endpoint)
            for endpoint in self.endpoints:
                self._send_replies(endpoint)

    def _wait(self) -> float:
        now = self.lab.clock.now()
        due = [t for t in (e.emulator.next_reply_time() for e in self.endpoints) if t is not None]
        return min([_POLL_S, *(max(0.0, t - now) for t in due)])

    def _accept(self, endpoint: Endpoint) -> None:
        assert endpoint.listener is not None
        with contextlib.suppress(BlockingIOError):
            client, _ = endpoint.listener.accept()
            client.setblocking(False)
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            endpoint.clients.append(client)
            self.selector.register(client, selectors.EVENT_READ, ("client", endpoint))
            if endpoint.link == "serial":
                endpoint.reply_to = client
                endpoint.emulator.on_open()

    def _from_client(self, endpoint: Endpoint, client: socket.socket) -> None:
        try:
            data = client.recv(4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._drop(endpoint, client)
            return
        endpoint.reply_to = client
        self._feed(endpoint, data)

    def _from_pty(self, endpoint: Endpoint) -> None:
        assert endpoint.master_fd is not None
        try:
            data = os.read(endpoint.master_fd, 4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:  # no client has the terminal open
            return
        if data:
            self._feed(endpoint, data)

    @staticmethod
    def _feed(endpoint: Endpoint, data: bytes) -> None:
        """Hand bytes to the emulator; a fault in one emulator is reported and the others keep serving."""
        try:
            endpoint.emulator.receive(data)
        except Exception as exc:  # an emulator bug must not take the whole lab down
            print(f"simulate: {endpoint.driver} failed on {data!r}: {exc!r}", file=sys.stderr, flush=True)

    def _send_replies(self, endpoint: Endpoint) -> None:
        data = endpoint.emulator.take_ready()
        if not data:
            return
        if endpoint.master_fd is not None:
            with contextlib.suppress(OSError):
                os.write(endpoint.master_fd, data)
        elif endpoint.reply_to is not None:
            try:
                endpoint.reply_to.sendall(data)
            except OSError:
                self._drop(endpoint, endpoint.reply_to)

    def _drop(self, endpoint: Endpoint, client: socket.socket) -> None:
        with contextlib.suppress(KeyError, ValueError):
            self.selector.unregister(client)
        if client in endpoint.clients:
            endpoint.clients.remove(client)
        if endpoint.reply_to is client:
            endpoint.reply_to = None
        client.close()

    def close(self) -> None:
        """Close every socket and terminal."""
        for endpoint in self.endpoints:
            for client in list(endpoint.clients):
                self._drop(endpoint, client)
            if endpoint.listener is not None:
                with contextlib.suppress(KeyError, ValueError):
                    self.selector.unregister(endpoint.listener)
                endpoint.listener.close()
            for fd in (endpoint.master_fd, endpoint.slave_fd):
                if fd is not None:
                    with contextlib.suppress(OSError):
                        os.close(fd)
            endpoint.master_fd = endpoint.slave_fd = None
        self.selector.close()
