"""``ecds-lab simulate`` in a subprocess: our drivers and third-party clients over real sockets and ptys."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from ecds_lab.clock import WallClock
from ecds_lab.drivers.daq970a import DAQ970A
from ecds_lab.drivers.daq970a import VISA_SETTINGS as DAQ_VISA
from ecds_lab.drivers.grbl import SERIAL_SETTINGS as GRBL_SERIAL
from ecds_lab.drivers.grbl import Grbl
from ecds_lab.drivers.hm8118 import HM8118
from ecds_lab.drivers.hm8118 import SERIAL_SETTINGS as HM_SERIAL
from ecds_lab.drivers.hmp import HMP4040
from ecds_lab.drivers.hmp import VISA_SETTINGS as HMP_VISA
from ecds_lab.instruments import BridgeSettings
from ecds_lab.transports.serial_link import SerialTransport
from ecds_lab.transports.visa_link import VisaTransport

pytestmark = pytest.mark.slow
EXAMPLE_STATION = Path(__file__).resolve().parents[2] / "experiments" / "stations" / "simulated_over_network.yaml"


@dataclass
class Served:
    """A running ``ecds-lab simulate``: role -> address as it printed them."""

    process: subprocess.Popen[str]
    addresses: dict[str, str]


def _serve(*options: str) -> Iterator[Served]:
    process = subprocess.Popen([sys.executable, "-m", "ecds_lab.cli", "simulate", "--port-base", "0", *options],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    addresses: dict[str, str] = {}
    assert process.stdout is not None
    for line in process.stdout:
        if line.startswith("serving"):
            break
        role, _driver, _link, address = line.split()
        addresses[role] = address
    else:
        process.kill()
        pytest.fail(f"simulate did not start: {process.stderr.read() if process.stderr else ''}")
    yield Served(process, addresses)
    process.terminate()
    process.wait(timeout=10)


@pytest.fixture(scope="module")
def served_pty() -> Iterator[Served]:
    """Serial instruments on pseudo-terminals (the default)."""
    yield from _serve()


@pytest.fixture(scope="module")
def served_tcp() -> Iterator[Served]:
    """Serial instruments on TCP ports for pyserial's socket://."""
    yield from _serve("--serial", "tcp")


def test_addresses_follow_the_lxi_and_pty_conventions(served_pty: Served, served_tcp: Served) -> None:
    assert served_pty.addresses["bridge"].startswith("/dev/pts/")
    assert served_pty.addresses["slide"].startswith("/dev/pts/")
    for served in (served_pty, served_tcp):
        assert served.addresses["scanner"].startswith("TCPIP::127.0.0.1::")
        assert served.addresses["scanner"].endswith("::SOCKET")
    assert served_tcp.addresses["bridge"].startswith("socket://127.0.0.1:")


def _visa(name: str, address: str, settings: dict) -> VisaTransport:
    return VisaTransport(name, address, clock=WallClock(), **settings)


def test_our_scanner_and_supply_drivers_over_raw_sockets(served_pty: Served) -> None:
    scanner = DAQ970A(_visa("scanner", served_pty.addresses["scanner"], DAQ_VISA))
    supply = HMP4040(_visa("heater", served_pty.addresses["heater"], HMP_VISA))
    try:
        assert scanner.identity().startswith("Keysight Technologies,DAQ970A")
        scanner.configure()
        temperatures = scanner.read_temperatures_c()
        assert list(temperatures) == ["coil", "target", "ambient"]
        assert all(15 < t < 30 for t in temperatures.values())
        supply.identity()
        supply.set_output(3, 5.0, 0.5)  # output 3 has no heater: nothing warms
        supply.enable(3, True)
        assert supply.read_back(3)[0] == pytest.approx(5.0)
        supply.all_off()
        assert supply.read_back(3) == (0.0, 0.0)
    finally:
        scanner.close()
        supply.close()


@pytest.mark.parametrize("fixture", ["served_pty", "served_tcp"])
def test_our_bridge_and_slide_drivers_over_serial_ports(request: pytest.FixtureRequest, fixture: str) -> None:
    served: Served = request.getfixturevalue(fixture)
    bridge = HM8118(SerialTransport("bridge", served.addresses["bridge"], clock=WallClock(), **HM_SERIAL))
    slide = Grbl(SerialTransport("slide", served.addresses["slide"], clock=WallClock(), **GRBL_SERIAL))
    try:
        assert "HM8118" in bridge.identity()
        bridge.configure(BridgeSettings(function="L-R", circuit="series", voltage_v=1.5, speed="fast"))
        bridge.set_frequency(15000)
        reading = bridge.measure()
        assert 1e-3 < reading.main < 1.0 and reading.frequency_hz == 15000
        slide.connect()
        assert "Grbl" in slide.identity()
    finally:
        bridge.close()
        slide.close()


def test_a_driver_that_does_not_pace_loses_bridge_commands(served_tcp: Served) -> None:
    """The bridge takes one command at a time; a client that sends the next at once loses it."""
    link = SerialTransport("bridge", served_tcp.addresses["bridge"], clock=WallClock(),
                           **{**HM_SERIAL, "min_interval_s": 0.0, "timeout_s": 1.0})
    try:
        link.write("FREQ 2000")
        from ecds_lab.errors import TransportTimeout

        with pytest.raises(TransportTimeout):
            link.query("FREQ?")  # sent right behind the set: lost, so no reply
        WallClock().sleep(0.25)
        assert link.query("FREQ?") == "2000"
    finally:
        link.close()


# -- third-party clients (pip install '.[interop]'); skipped with the reason when absent -----------------

def _require(module: str) -> Callable[..., object]:
    return pytest.importorskip(module, reason=f"{module} is not installed (pip install '.[interop]')")


def test_pymeasure_hmp4040_drives_the_served_supply(served_pty: Served) -> None:
    hmp = _require("pymeasure.instruments.rohdeschwarz.hmp")
    supply = hmp.HMP4040(served_pty.addresses["heater"], read_termination="\n", write_termination="\n",
                         timeout=3000)
    try:
        assert "HMP4040" in supply.id
        supply.selected_channel = 4  # output 4 has no heater wired
        supply.voltage_and_current = (12.5, 0.25)
        assert supply.voltage == pytest.approx(12.5) and supply.current == pytest.approx(0.25)
        assert supply.voltage_and_current == [pytest.approx(12.5), pytest.approx(0.25)]
        assert (supply.min_voltage, supply.max_voltage) == (0.0, pytest.approx(32.05))  # the limits, not 12.5
        assert supply.max_current == pytest.approx(10.01)
        supply.voltage_step = 0.5
        supply.voltage_to_max()
        supply.step_voltage_down()
        assert supply.voltage == pytest.approx(31.55)
        supply.current_step = 0.05
        supply.step_current_up()
        assert supply.current == pytest.approx(0.3)
        assert supply.version == 1999.0
        supply.selected_channel_active = True
        supply.output_enabled = True
        assert supply.output_enabled
        assert supply.measured_voltage == pytest.approx(31.55) and supply.measured_current == 0.0
        supply.output_enabled = False
        supply.beep()
        assert supply.check_errors() == []
    finally:
        supply.adapter.close()


def test_dvg_keysight_3497xa_scans_the_served_scanner(served_pty: Served) -> None:
    protocol = _require("dvg_devices.Keysight_3497xA_protocol_SCPI")
    import pyvisa

    mux = protocol.Keysight_3497xA(served_pty.addresses["scanner"])
    scan_list = "(@101:103)"
    setup = [f"rout:open {scan_list}", f"conf:temp TC,K,{scan_list}", f"unit:temp C,{scan_list}",
             f"sens:temp:tran:tc:rjun:type INT,{scan_list}", f"sens:temp:tran:tc:check ON,{scan_list}",
             f"sens:temp:nplc 1,{scan_list}", f"rout:scan {scan_list}"]
    assert mux.connect(pyvisa.ResourceManager("@py"))
    try:
        assert mux.begin(setup)
        assert mux.diag.slot_1_ctype.endswith(",DAQM901A,0,1.0") and mux.diag.slot_2_ctype == "none"
        assert mux.state.all_scan_list_channels == ["101", "102", "103"]
        assert mux.state.all_errors == []
        mux.init_scan()
        mux.wait_for_OPC()
        assert mux.fetch_scan()
        assert len(mux.state.readings) == 3 and all(15 < t < 30 for t in mux.state.readings)
    finally:
        mux.close()


def test_the_example_station_opens_on_the_served_lab(served_tcp: Served) -> None:
    """experiments/stations/simulated_over_network.yaml with its ports moved to the ones the server chose."""
    from ecds_lab.station import load_station_config, open_station

    config, _ = load_station_config(EXAMPLE_STATION)
    assert config.simulated is None  # a real-lab station: wall clock, real transports
    links = {"bridge": ("url", "serial"), "slide": ("url", "serial"), "scanner": ("resource", "visa"),
             "heater": ("resource", "visa")}
    update = {}
    for role, (field, _kind) in links.items():
        instrument = getattr(config, role)
        link = instrument.link.model_copy(update={field: served_tcp.addresses[role]})
        update[role] = instrument.model_copy(update={"link": link})
    station = open_station(config.model_copy(update=update))
    try:
        assert "HM8118" in station.bridge.identity()
        station.scanner.configure()
        assert set(station.scanner.read_temperatures_c()) == {"coil", "target", "ambient"}
        assert station.heater.identity().startswith("ROHDE&SCHWARZ,HMP4040")
    finally:
        station.close()


def _simulate(*options: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "ecds_lab.cli", "simulate", *options],
                          capture_output=True, text=True, timeout=60)


def test_a_real_lab_station_is_refused_with_the_reason() -> None:
    result = _simulate("--station", str(EXAMPLE_STATION))
    assert result.returncode == 2
    assert "no 'simulated' section" in result.stderr and result.stdout == ""


def test_a_port_in_use_is_named(served_pty: Served) -> None:
    port = served_pty.addresses["scanner"].split("::")[2]
    result = _simulate("--port-base", port)
    assert result.returncode == 2
    assert f"cannot listen on 127.0.0.1:{port} for the scanner (daq970a)" in result.stderr


# -- GRBL's power-up lines over TCP ------------------------------------------------------------------
def _power_up_lines(address: str, *, timeout_s: float = 5.0) -> list[str]:
    """Connect to the served slide (pyserial's socket://, as a sender would) and read its lines up to the
    alarm lock message; the connection is the Arduino's DTR reset."""
    import socket
    import time

    host, port = address.removeprefix("socket://").rsplit(":", 1)
    lines: list[str] = []
    buffer = b""
    with socket.create_connection((host, int(port)), timeout=timeout_s) as sock:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            buffer += sock.recv(4096)
            *complete, buffer = buffer.split(b"\n")
            lines += [line.decode().strip("\r") for line in complete]
            if any(line.startswith("[MSG:") for line in lines):
                return lines
    pytest.fail(f"no alarm lock message within {timeout_s} s; lines so far: {lines}")


def test_grbl_power_up_lines_keep_the_firmwares_order_on_every_tcp_connect() -> None:
    """Each connect resets the served GRBL: the banner comes first (grbl/main.c report_init_message), the alarm
    lock message after it (grbl/protocol.c protocol_main_loop, $22 homing lock on). Lines due at the same instant
    on a clock running with the wall clock must not swap (issue 24, point 8)."""
    import threading

    from ecds_lab.instruments.kinds import ROLE_NAMES
    from ecds_lab.simulators.grbl import BANNER, UNLOCK_PROMPT
    from ecds_lab.simulators.serve import LabServer
    from ecds_lab.station import load_station_config

    config, _ = load_station_config(None)
    assert config.simulated is not None
    server = LabServer(config.simulated.lab, {role: getattr(config, role).driver for role in ROLE_NAMES},
                       port_base=0, serial="tcp")
    slide = next(endpoint for endpoint in server.endpoints if endpoint.role == "slide")
    slide.emulator.boot_delay_s = 0.01  # type: ignore[attr-defined]  # the bootloader's wait, short for 50 connects
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        orders = [_power_up_lines(slide.address) for _ in range(50)]
    finally:
        server.stop()
        thread.join(timeout=5)
        server.close()
    assert all(lines == ["", BANNER, UNLOCK_PROMPT] for lines in orders), \
        [lines for lines in orders if lines != ["", BANNER, UNLOCK_PROMPT]][:3]
