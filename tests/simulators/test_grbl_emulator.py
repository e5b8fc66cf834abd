"""GRBL emulator against what gnea/grbl 1.1h does, through the real pyserial path, raw lines only.

Each test names the firmware source whose behaviour it checks (grbl/protocol.c, motion_control.c,
limits.c, system.c, report.c, config.h, defaults.h). The same raw exchanges were run against the
firmware itself (grbl-sim on a pty) outside the repository.
"""

from __future__ import annotations

import pytest

from ecds_lab.drivers.grbl import SERIAL_SETTINGS
from ecds_lab.errors import TransportTimeout
from ecds_lab.simulators.grbl import STOCK_HOMING_CYCLES, STOCK_SETTINGS

BANNER = "Grbl 1.1h ['$' for help]"


@pytest.fixture
def lab(make_lab):
    return make_lab(slide_origin_mm=160.0)


@pytest.fixture
def link(lab):
    """A raw link to GRBL once it has booted, unlocked, at MPos 0 (160 mm from the target)."""
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    read_all(transport, 2.0)  # the banner after the bootloader
    assert ask(transport, "$X") == ["[MSG:Caution: Unlocked]", "ok"]
    return transport


def read_all(transport, quiet_s: float = 0.3) -> list[str]:
    """Every line until the controller stays quiet for ``quiet_s`` (simulated time)."""
    lines = []
    while True:
        try:
            lines.append(transport.read_line(quiet_s))
        except TransportTimeout:
            return lines


def ask(transport, line: str, quiet_s: float = 0.3) -> list[str]:
    transport.write(line)
    return read_all(transport, quiet_s)


def status(transport) -> str:
    transport.write_bytes(b"?")
    return transport.read_line(0.1)


def mpos_x(report: str) -> float:
    return float(report.split("MPos:")[1].split(",")[0])


def feed(report: str) -> float:
    return float(report.split("FS:")[1].split(",")[0])


# -- connect: the banner after the bootloader (main.c, report.c) ----------------------------------------
def test_banner_comes_after_the_boot_delay_and_input_meanwhile_is_lost(lab):
    lab.emulator("grbl").boot_delay_s = 1.8
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    transport.write("$I")  # the bootloader, not GRBL, is listening
    assert transport.read_line(3.0) == ""
    assert transport.read_line(0.1) == BANNER
    assert lab.clock.now() == pytest.approx(1.8)
    assert read_all(transport) == ["[MSG:'$H'|'$X' to unlock]"]  # homing enabled: locked (HOMING_INIT_LOCK)


# -- settings and the commands GRBL accepts (system.c, report.c, defaults.h) ---------------------------
def test_dollar_dollar_lists_all_34_settings_with_stock_defaults(lab):
    lab.emulator("grbl").settings = dict(STOCK_SETTINGS)
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    read_all(transport, 2.0)
    lines = ask(transport, "$$")
    assert lines[-1] == "ok" and len(lines) == 35
    assert lines[:11] == ["$0=10", "$1=25", "$2=0", "$3=0", "$4=0", "$5=0", "$6=0", "$10=1", "$11=0.010",
                          "$12=0.002", "$13=0"]
    assert lines[11:22] == ["$20=0", "$21=0", "$22=0", "$23=0", "$24=25.000", "$25=500.000", "$26=250",
                            "$27=1.000", "$30=1000", "$31=0", "$32=0"]
    assert lines[22:34] == ["$100=250.000", "$101=250.000", "$102=250.000", "$110=500.000", "$111=500.000",
                            "$112=500.000", "$120=10.000", "$121=10.000", "$122=10.000", "$130=200.000",
                            "$131=200.000", "$132=200.000"]


def test_the_slides_eeprom_differs_from_stock_only_where_it_must(link):
    lines = ask(link, "$$")
    assert {"$20=1", "$22=1", "$110=1000.000", "$130=145.000"} <= set(lines) and len(lines) == 35


def test_parameters_startup_lines_and_build_info(link):
    zero = "0.000,0.000,0.000"
    assert ask(link, "$#") == [*(f"[G{n}:{zero}]" for n in range(54, 60)), f"[G28:{zero}]", f"[G30:{zero}]",
                               f"[G92:{zero}]", "[TLO:0.000]", f"[PRB:{zero}:0]", "ok"]
    assert ask(link, "$N") == ["$N0=", "$N1=", "ok"]
    assert ask(link, "$N0=G21") == ["ok"]
    assert ask(link, "$N") == ["$N0=G21", "$N1=", "ok"]
    assert ask(link, "$I") == ["[VER:1.1h.20190830:]", "[OPT:V,15,128]", "ok"]
    assert ask(link, "$") == ["[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]", "ok"]


def test_restoring_defaults_resets_to_the_stock_settings(link):
    assert ask(link, "$RST=$") == ["[MSG:Restoring defaults]", "ok", "", BANNER]
    lines = ask(link, "$$")
    assert "$22=0" in lines and "$130=200.000" in lines
    assert ask(link, "$RST=x") == ["error:3"]


def test_check_mode_parses_without_moving_and_resets_when_left(link):
    assert ask(link, "$C") == ["[MSG:Enabled]", "ok"]
    assert ask(link, "G0 X-50") == ["ok"]
    assert status(link).startswith("<Check|MPos:0.000,")
    assert ask(link, "$C") == ["[MSG:Disabled]", "ok", "", BANNER]  # mc_reset when toggled off


def test_sleep_then_reset_locks(link):
    assert ask(link, "$SLP") == ["ok", "[MSG:Sleeping]"]
    assert status(link).startswith("<Sleep|")
    assert ask(link, "G0 X-1") == []  # the suspend loop reads no lines
    link.write_bytes(b"\x18")
    assert read_all(link) == ["", BANNER, "[MSG:'$H'|'$X' to unlock]"]  # sleep re-initialises as Alarm


def test_gcode_words_a_slide_sender_uses(link, lab):
    assert ask(link, "M5") == ["ok"]
    assert ask(link, "G20") == ["ok"]
    assert ask(link, "G53 G0 X-1") == ["ok"]  # inches: 25.4 mm, machine coordinates
    lab.clock.sleep(10.0)
    assert mpos_x(status(link)) == pytest.approx(-25.4)
    assert ask(link, "G21 G1 Y-2 F100") == ["ok"]
    lab.clock.sleep(5.0)
    assert status(link).startswith("<Idle|MPos:-25.400,-2.000,0.000")
    assert ask(link, "$G") == ["[GC:G1 G54 G17 G21 G90 G94 M5 M9 T0 F100 S0]", "ok"]


def test_dwell_answers_after_its_time(link, lab):
    link.write("G4 P0.5")
    start = lab.clock.now()
    assert link.read_line(2.0) == "ok"
    assert lab.clock.now() - start == pytest.approx(0.5)


@pytest.mark.parametrize(("line", "reply"), [
    ("G1 X-10", "error:22"), ("G2 X-1", "error:20"), ("G1 Q5", "error:20"), ("G1 X-1.2.3", "error:1"),
    ("G1 X1 X2", "error:25"), ("G0 G1 X-1", "error:24"), ("G90 G91", "error:21"), ("$Z", "error:2"),
    ("$Q", "error:2"), ("G1 A1 F100", "error:20"), ("G4", "error:28"), ("G4 P1 X-1", "error:31"),
    ("x-5 (rapid)", "ok"), ("G21 G17 G94 G91 G1 X-1 F100", "ok"), ("G1 X-1 F100 ; comment", "ok"), ("", "ok"),
])
def test_gcode_errors_as_gcode_c_returns_them(link, line, reply):
    assert ask(link, line)[0] == reply


def test_long_line_overflows(link):
    assert ask(link, "G1 X-1 F100 " + "(" + "x" * 90 + ")") == ["ok"]  # comments are dropped before counting
    assert ask(link, "G1X-1F100" + "0" * 80) == ["error:11"]


@pytest.mark.parametrize(("padding", "reply"), [(70, "ok"), (71, "error:11")])
def test_the_limit_counts_what_is_left_after_spaces_tabs_and_slashes(link, padding, reply):
    """protocol.c keeps at most 79 characters, counted after dropping whitespace, control characters and '/'."""
    line = "g1\tx-1 / f100" + "0" * padding  # 9 characters kept before the padding
    assert ask(link, line) == [reply]


def test_settings_need_idle_and_the_dollar_dollar_report_too(link, lab):
    assert ask(link, "G1 X-30 F600") == ["ok"]
    assert ask(link, "$$") == ["error:8"]  # "Takes too long to print" during a cycle
    assert ask(link, "$I") == ["error:8"]
    assert ask(link, "$G")[-1] == "ok"  # allowed in any state
    lab.clock.sleep(5.0)
    assert ask(link, "$I")[-1] == "ok"


# -- the planner and acceleration (motion_control.c mc_line, planner.c, stepper.c) -----------------------
def test_moves_queue_and_ok_means_planned(link, lab):
    start = lab.clock.now()
    assert ask(link, "G1 X-10 F600", 0.01) == ["ok"]
    assert ask(link, "G1 X-20", 0.01) == ["ok"]  # answered at once: the second does not replace the first
    assert lab.clock.now() - start < 0.1
    lab.clock.sleep(1.9)
    report = status(link)
    assert report.startswith("<Run|") and -10.0 < mpos_x(report) < -8.0  # still on the first block
    lab.clock.sleep(3.0)
    assert status(link).startswith("<Idle|MPos:-20.000,")


@pytest.mark.parametrize(("target", "printed"), [
    ("-0.0004", "0.000"), ("-0.0006", "-0.001"), ("-12.3456", "-12.346"), ("-12.3444", "-12.344"),
])
def test_positions_print_rounded_to_three_decimals_without_a_negative_zero(link, lab, target, printed):
    """report.c prints MPos with 3 decimals; a position just below zero prints as 0.000, not -0.000."""
    assert ask(link, f"G1 X{target} F600") == ["ok"]
    lab.clock.sleep(5.0)
    assert status(link).startswith(f"<Idle|MPos:{printed},0.000,0.000|")


def test_a_full_planner_holds_the_next_line_back(link, lab):
    for n in range(1, 16):
        assert ask(link, f"G1 X-{n} F600", 0.01) == ["ok"]
    link.write("G1 X-16")
    with pytest.raises(TransportTimeout):
        link.read_line(0.3)  # 15 blocks planned (BLOCK_BUFFER_SIZE 16 keeps one free): mc_line waits
    assert link.read_line(1.0) == "ok"  # once the first move is done


def test_feed_ramps_at_the_acceleration_setting(link, lab):
    assert ask(link, "G1 X-50 F600", 0.01) == ["ok"]
    lab.clock.sleep(0.5)
    assert feed(status(link)) == pytest.approx(300, abs=10)  # 10 mm/s^2 for 0.5 s (+ the 0.01 s read)
    lab.clock.sleep(2.0)
    assert feed(status(link)) == pytest.approx(600)


# -- feed hold (protocol.c protocol_exec_rt_system / protocol_exec_rt_suspend) -------------------------
def moving(link, lab, target: str = "X-60") -> float:
    """Start a move at 600 mm/min and let it reach full speed; returns MPos then."""
    assert ask(link, f"G1 {target} F600", 0.01) == ["ok"]
    lab.clock.sleep(2.0)
    return mpos_x(status(link))


def test_a_hold_decelerates_then_completes(link, lab):
    here = moving(link, lab)
    link.write_bytes(b"!")
    assert status(link).startswith("<Hold:1|")
    lab.clock.sleep(0.5)
    report = status(link)
    assert report.startswith("<Hold:1|") and feed(report) == pytest.approx(300, abs=10)
    lab.clock.sleep(0.6)
    report = status(link)
    assert report.startswith("<Hold:0|") and feed(report) == 0
    assert mpos_x(report) == pytest.approx(here - 5.0, abs=0.05)  # v^2/2a = 5 mm of coasting


def test_resume_during_hold_1_is_ignored(link, lab):
    moving(link, lab)
    link.write_bytes(b"!")
    lab.clock.sleep(0.3)
    link.write_bytes(b"~")  # cycle start only once SUSPEND_HOLD_COMPLETE is set
    lab.clock.sleep(1.5)
    assert status(link).startswith("<Hold:0|")
    link.write_bytes(b"~")
    lab.clock.sleep(0.1)
    assert status(link).startswith("<Run|")


def test_lines_during_hold_0_wait_until_resume(link, lab):
    moving(link, lab)
    link.write_bytes(b"!")
    lab.clock.sleep(1.5)
    link.write("$I")
    link.write("G1 X-10")
    with pytest.raises(TransportTimeout):
        link.read_line(3.0)  # held in the serial buffer: the main loop is suspended
    link.write_bytes(b"~")
    assert read_all(link, 0.05) == ["error:8", "ok"]  # $I now meets a running cycle; the G1 is planned
    lab.clock.sleep(20.0)
    assert status(link).startswith("<Idle|MPos:-10.000,")  # first to -60, then back to -10


def test_lines_during_hold_1_are_still_planned(link, lab):
    moving(link, lab)
    link.write_bytes(b"!")
    assert ask(link, "G1 X-10", 0.05) == ["ok"]  # sys.suspend is set only when the hold completes
    assert ask(link, "$I", 0.05) == ["error:8"]


def test_a_hold_when_idle_is_complete_at_once(link):
    link.write_bytes(b"!")
    assert status(link).startswith("<Hold:0|")
    link.write_bytes(b"~")
    assert status(link).startswith("<Idle|")


# -- resets and alarms (protocol.c, motion_control.c mc_reset, limits.c limits_soft_check) ------------------
def test_soft_limit_discards_an_early_reset_and_prints_the_prompt(link, lab):
    link.write("G1 X-200 F600")  # beyond $130=145
    assert link.read_line(0.1) == "ALARM:2"
    alarm_at = lab.clock.now()
    link.write_bytes(b"?\x18")  # both ignored: no reports in the critical loop, the reset is discarded
    assert link.read_line(1.0) == "[MSG:Reset to continue]"
    assert lab.clock.now() - alarm_at == pytest.approx(0.5)
    with pytest.raises(TransportTimeout):
        link.read_line(1.0)
    link.write_bytes(b"\x18")
    assert read_all(link) == ["ok", "", BANNER, "[MSG:'$H'|'$X' to unlock]"]  # the G1's ok, then main()


def test_soft_limit_while_moving_stops_under_control_first(link, lab):
    moving(link, lab)
    link.write("G1 X-200")
    assert status(link).startswith("<Hold:1|")
    lines = read_all(link, 1.2)
    assert lines == ["ALARM:2", "[MSG:Reset to continue]"]


def test_reset_while_moving_is_alarm_3_after_which_the_banner_waits(link, lab):
    moving(link, lab)
    link.write_bytes(b"\x18")
    assert link.read_line(0.1) == "ALARM:3"
    reset_at = lab.clock.now()
    assert read_all(link, 1.0) == ["", BANNER, "[MSG:'$H'|'$X' to unlock]"]
    events = [e for e in link.transcript.events if e.text == BANNER]
    assert events[-1].clock_s - reset_at == pytest.approx(0.5)  # report_alarm_message's delay


# -- homing (system.c $H, motion_control.c mc_homing_cycle, limits.c limits_go_home, config.h) -------------
def test_status_during_homing_is_answered_when_the_cycle_ends(lab):
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    read_all(transport, 2.0)  # the banner after the bootloader
    transport.write("$H")
    transport.write_bytes(b"?")
    transport.write_bytes(b"?")  # one flag: one report
    lines = read_all(transport, 5.0)
    assert len(lines) == 2 and lines[0].startswith("<Home|MPos:") and lines[1] == "ok"
    assert status(transport).startswith("<Idle|MPos:-1.000,")


def test_stock_homing_cycle_homes_z_first_and_fails_without_a_z_switch(lab):
    lab.emulator("grbl").homing_cycles = STOCK_HOMING_CYCLES
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    read_all(transport, 2.0)  # the banner after the bootloader
    transport.write("$H")
    start = lab.clock.now()
    assert transport.read_line(60.0) == "ALARM:9"
    assert lab.clock.now() - start == pytest.approx(1.5 * 200 / 500 * 60)  # the Z search: 1.5 x $132 at $25
    assert read_all(transport, 1.0) == ["ok", "", BANNER, "[MSG:'$H'|'$X' to unlock]"]
    assert status(transport).startswith("<Alarm|MPos:0.000,0.000,300.000")
    assert not lab.lab.slide.homed


def test_reset_during_homing_is_alarm_6(lab):
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    read_all(transport, 2.0)  # the banner after the bootloader
    transport.write("$H")
    lab.clock.sleep(0.5)
    transport.write_bytes(b"\x18")
    assert read_all(transport, 1.0) == ["ALARM:6", "ok", "", BANNER, "[MSG:'$H'|'$X' to unlock]"]


def test_status_report_refreshes_wco_then_ov_and_buffer_state(lab):
    lab.emulator("grbl").settings[10] = 3  # MPos plus buffer state
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    read_all(transport, 2.0)  # the banner after the bootloader
    first, second, third = status(transport), status(transport), status(transport)
    assert first == "<Alarm|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>"
    assert second == "<Alarm|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|Ov:100,100,100>"
    assert third == "<Alarm|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0>"
