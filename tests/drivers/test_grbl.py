"""GRBL driver: against its emulator through the real pyserial path (waiting, errors, alarms, the firmware
behaviours of issue 16), and byte for byte against literal firmware replies (expected_protocol), each
citing the gnea/grbl source that prints them."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.grbl import ALARMS, ERRORS, SERIAL_SETTINGS, Grbl, parse_status
from ecds_lab.errors import InstrumentError, InvalidSettingError
from ecds_lab.instruments import Positioner
from ecds_lab.simulators.grbl import STOCK_HOMING_CYCLES
from ecds_lab.testing import expected_protocol

ORIGIN_MM = 160.0


@pytest.fixture
def lab(make_lab):
    """A lab whose slide origin matches the driver's: MPos 0 is 160 mm from the target."""
    return make_lab(slide_origin_mm=ORIGIN_MM)


@pytest.fixture
def slide(lab):
    """Connected, homed (x = 159 mm), ready to move."""
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    grbl.home()
    return grbl


def test_link_settings_follow_grbl():
    assert SERIAL_SETTINGS["baudrate"] == 115200
    assert SERIAL_SETTINGS["write_termination"] == "\n"  # CRLF would get two oks per line
    assert SERIAL_SETTINGS["read_termination"] == "\n"
    assert ERRORS[22] == "undefined feed rate" and "soft limit" in ALARMS[2]


def test_is_a_positioner(lab):
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    assert isinstance(grbl, Positioner)
    assert (grbl.min_position_m, grbl.max_position_m) == (0.015, 0.160)


def test_banner_then_unlock_and_home(lab):
    wire = lab.capture("grbl")
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    assert grbl.connect() == "Grbl 1.1h ['$' for help]"
    assert grbl.status().state == "Alarm"  # homing enabled: locked after power-up
    grbl.unlock()
    assert grbl.status().state == "Idle"
    start = lab.clock.now()
    grbl.home()
    assert bytes(wire) == b"??$X\n?$H\n"
    assert lab.clock.now() - start > 1.0  # ok comes only after the cycle
    assert grbl.position_m() == pytest.approx(0.159)  # MPos = -pull-off
    assert lab.lab.slide.homed


def test_identity_reads_build_info(slide, lab):
    wire = lab.capture("grbl")
    assert slide.identity() == "Grbl 1.1h.20190830 [OPT:V,15,128]"
    assert bytes(wire) == b"$I\n"


def test_move_to_ends_idle_at_the_position(lab):
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS), approach="direct")
    grbl.home()
    wire = lab.capture("grbl")
    assert grbl.move_to(0.060) == -1
    assert bytes(wire) == b"?G90 G1 X-100.000 F600\n?"
    status = grbl.status()
    assert status.state == "Idle" and status.mpos_mm[0] == -100.0
    assert grbl.position_m() == pytest.approx(0.060)
    assert lab.lab.distance_m() == pytest.approx(0.060, abs=1e-9)


def test_approach_from_above_overshoots_then_comes_back(slide, lab):
    wire = lab.capture("grbl")
    assert slide.move_to(0.100) == +1
    assert bytes(wire) == b"?G90 G1 X-60.500 F600\n?G90 G1 X-60.000 F600\n?"
    assert lab.lab.slide.last_direction == +1
    assert slide.position_m() == pytest.approx(0.100)


def test_approach_from_below_goes_straight(slide, lab):
    slide.move_to(0.050)
    wire = lab.capture("grbl")
    assert slide.move_to(0.080) == +1
    assert bytes(wire) == b"?G90 G1 X-80.000 F600\n?"


def test_negative_approach_mirrors(lab):
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS), approach="negative")
    grbl.home()
    grbl.move_to(0.050)
    wire = lab.capture("grbl")
    assert grbl.move_to(0.080) == -1
    assert bytes(wire) == b"?G90 G1 X-79.500 F600\n?G90 G1 X-80.000 F600\n?"


def test_positive_approach_removes_backlash(make_lab):
    sim = make_lab(slide_origin_mm=ORIGIN_MM, effects={"slide_backlash": {"enabled": True, "backlash_um": 40.0}})
    grbl = Grbl(sim.serial("grbl", SERIAL_SETTINGS))
    grbl.home()
    grbl.move_to(0.100)  # from above
    from_above = sim.lab.distance_m()
    grbl.move_to(0.050)
    grbl.move_to(0.100)  # from below
    assert sim.lab.distance_m() == pytest.approx(from_above, abs=1e-12)


def test_no_motion_when_already_there(slide, lab):
    slide.move_to(0.100)
    wire = lab.capture("grbl")
    assert slide.move_to(0.100) == +1
    assert bytes(wire) == b"?"


def test_speed_sets_the_feed(slide, lab):
    wire = lab.capture("grbl")
    slide.move_to(0.150, speed_m_per_s=0.005)
    assert bytes(wire) == b"?G90 G1 X-10.500 F300\n?G90 G1 X-10.000 F300\n?"


@pytest.mark.parametrize("position_m", [0.170, 0.010, -0.001])
def test_position_beyond_travel_raises_before_anything_is_sent(slide, lab, position_m):
    wire = lab.capture("grbl")
    with pytest.raises(InvalidSettingError, match=rf"{position_m * 1e3:g} mm is outside the allowed 15\.\.160 mm"):
        slide.move_to(position_m)
    assert bytes(wire) == b""


def test_bad_driver_options_are_refused(lab):
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    with pytest.raises(InvalidSettingError, match="approach"):
        Grbl(transport, approach="sideways")  # type: ignore[arg-type]
    with pytest.raises(InvalidSettingError, match="min_mm"):
        Grbl(transport, min_mm=200.0)
    with pytest.raises(InvalidSettingError, match="feed"):
        Grbl(transport, feed_mm_per_min=0.0)
    with pytest.raises(InvalidSettingError, match="at least 1 mm/min"):
        Grbl(transport).move_to(0.1, speed_m_per_s=-0.01)


def test_move_while_locked_is_error_9_with_meaning(lab):
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    with pytest.raises(InstrumentError, match=r"'G90 G1 X-60\.500 F600'.*error:9.*G-code lock.*home\(\) or unlock\(\)"):
        grbl.move_to(0.100)


def test_homing_disabled_is_error_5_with_meaning(lab):
    lab.emulator("grbl").settings[22] = 0  # as stored in the controller's EEPROM
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    assert grbl.status().state == "Idle"  # no homing lock without homing
    with pytest.raises(InstrumentError, match=r"'\$H'.*error:5.*homing is not enabled.*\$22=1"):
        grbl.home()


def test_soft_limit_is_alarm_2_and_needs_a_reset(lab):
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS), max_mm=170.0)  # wider than the machine's travel
    grbl.home()
    with pytest.raises(InstrumentError, match=r"ALARM:2.*soft limit"):
        grbl.move_to(0.165)
    with pytest.raises(InstrumentError, match="soft_reset"):
        grbl.position_m()  # GRBL ignores '?' until reset; the driver says so instead of timing out
    wire = lab.capture("grbl")
    assert grbl.soft_reset() == "Grbl 1.1h ['$' for help]"
    assert grbl.status().state == "Alarm"
    grbl.unlock()
    assert grbl.move_to(0.120) == +1
    assert bytes(wire).startswith(b"\x18??$X\n")


def test_stop_holds_then_resets(slide, lab):
    wire = lab.capture("grbl")
    slide.stop()
    assert bytes(wire) == b"!?\x18?"
    assert slide.status().state == "Idle"


def test_stop_during_a_move_keeps_position(slide, lab):
    slide.transport.write("G90 G1 X-101.000 F600")
    assert slide.transport.read_line() == "ok"
    lab.clock.sleep(5.0)
    slide.stop()  # feed hold first, so the reset finds no motion: no ALARM:3
    status = slide.status()
    assert status.state == "Idle" and status.mpos_mm[0] == pytest.approx(-51.0)


def test_reset_during_a_move_is_alarm_3(slide, lab):
    slide.transport.write("G90 G1 X-101.000 F600")
    assert slide.transport.read_line() == "ok"
    lab.clock.sleep(1.0)
    with pytest.raises(InstrumentError, match=r"ALARM:3.*position likely lost"):
        slide.soft_reset()
    assert slide.status().state == "Alarm"


def test_feed_hold_and_resume_finish_the_move(slide, lab):
    slide.transport.write("G90 G1 X-61.000 F600")
    assert slide.transport.read_line() == "ok"
    lab.clock.sleep(2.0)
    slide.feed_hold()
    assert slide.status().state == "Hold:1"  # decelerating at $120 [protocol.c]
    wire = lab.capture("grbl")
    slide.resume()  # waits for Hold:0: '~' during Hold:1 is ignored
    assert bytes(wire).endswith(b"?~") and bytes(wire).count(b"~") == 1
    assert slide.status().state == "Run"
    lab.clock.sleep(5.0)
    assert slide.status().state == "Idle" and slide.position_m() == pytest.approx(0.099)


def test_long_move_sleeps_on_the_clock_and_polls_little(slide, lab):
    slide.move_to(0.150)
    wire = lab.capture("grbl")
    start = lab.clock.now()
    slide.move_to(0.070)  # 80 mm down, then 0.5 mm back up
    elapsed = lab.clock.now() - start
    # trapezoids at the stock 10 mm/s^2: 80 mm at 10 mm/s takes 8 s + 1 s of ramps, 0.5 mm takes 2*sqrt(0.05) s
    assert elapsed == pytest.approx(9.0 + 2 * 0.05 ** 0.5, abs=0.1)
    assert bytes(wire).count(b"?") < 20


def test_slower_controller_is_polled_until_idle(slide, lab):
    lab.emulator("grbl").settings[110] = 300.0  # max rate clamps the feed: the move takes twice as long
    wire = lab.capture("grbl")
    start = lab.clock.now()
    slide.move_to(0.079)
    assert slide.position_m() == pytest.approx(0.079)
    assert lab.clock.now() - start >= (80.5 + 0.5) / 300 * 60
    assert bytes(wire).count(b"?") < 20


def test_status_with_extra_fields_in_any_order():
    status = parse_status("<Run|MPos:-10.000,0.000,0.000|Ov:100,100,100|FS:500,0|Bf:15,128|WCO:1.000,0.000,0.000>")
    assert status.state == "Run" and status.mpos_mm == (-10.0, 0.0, 0.0) and status.feed_mm_per_min == 500.0
    assert status.fields["Bf"] == "15,128" and status.fields["WCO"] == "1.000,0.000,0.000"
    hold = parse_status("<Hold:0|WCO:0.000,0.000,0.000|F:0|MPos:-1.000,0.000,0.000|Pn:X>")
    assert hold.state == "Hold:0" and hold.base_state == "Hold" and hold.feed_mm_per_min == 0.0
    with pytest.raises(ValueError, match=r"\$10=1"):
        parse_status("<Idle|WPos:0.000,0.000,0.000|FS:0,0>")
    with pytest.raises(ValueError):
        parse_status("<Idle|MPos:abc|FS:0,0>")


def test_work_positions_need_setting_10(slide, lab):
    lab.emulator("grbl").settings[10] = 0
    with pytest.raises(InstrumentError, match=r"WPos.*\$10=1"):
        slide.position_m()


def test_crlf_gets_two_oks(lab):
    transport = lab.serial("grbl", SERIAL_SETTINGS, write_termination="\r\n")
    Grbl(transport).connect()
    transport.write("$X")
    lines = [transport.read_line() for _ in range(3)]
    assert lines == ["[MSG:Caution: Unlocked]", "ok", "ok"]


def test_reopening_the_port_resets_the_controller(slide, lab):
    slide.move_to(0.100)
    slide.close()
    again = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    assert again.status().state == "Alarm"  # the Arduino reset: locked, MPos counts from here
    assert again.position_m() == pytest.approx(ORIGIN_MM * 1e-3)
    again.home()
    assert again.position_m() == pytest.approx(0.159)
    assert lab.lab.distance_m() == pytest.approx(0.159)


# -- the firmware behaviours of issue 16, driver against the emulator --------------------------------
def test_connect_waits_for_the_banner_after_the_bootloader(lab):
    lab.emulator("grbl").boot_delay_s = 1.9  # DTR reset, then the bootloader: the banner comes late
    wire = lab.capture("grbl")
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    assert grbl.connect() == "Grbl 1.1h ['$' for help]"
    assert bytes(wire) == b"?"  # no Ctrl-X racing the boot, so no second banner
    assert lab.clock.now() >= 1.9


def test_reset_after_a_soft_limit_waits_for_the_prompt(lab):
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS), max_mm=170.0)
    grbl.home()
    with pytest.raises(InstrumentError, match=r"ALARM:2"):
        grbl.move_to(0.165)
    alarm_at = lab.clock.now()
    grbl.stop()  # a Ctrl-X within 500 ms of the alarm would be discarded by the firmware
    events = grbl.transport.transcript.events
    prompt = next(e for e in events if e.text == "[MSG:Reset to continue]")
    reset = next(e for e in events if e.text == "\x18")
    assert reset.clock_s >= prompt.clock_s >= alarm_at + 0.5 - 1e-9
    assert grbl.status().state == "Alarm"


def test_commands_during_a_hold_are_refused_not_queued(slide, lab):
    slide.transport.write("G90 G1 X-61.000 F600")
    assert slide.transport.read_line() == "ok"
    lab.clock.sleep(2.0)
    slide.feed_hold()
    wire = lab.capture("grbl")
    for call in (slide.identity, slide.unlock, slide.home):
        with pytest.raises(InstrumentError, match=r"feed hold.*resume\(\) or stop\(\)"):
            call()
    assert bytes(wire) == b""
    with pytest.raises(InstrumentError, match=r"feed hold.*resume\(\) or stop\(\)"):
        slide.move_to(0.080)
    assert bytes(wire) == b"?"  # only the status that showed the hold
    slide.resume()
    lab.clock.sleep(6.0)
    assert slide.identity().startswith("Grbl 1.1h")  # in step: no stale reply after the resume
    assert slide.position_m() == pytest.approx(0.099)


def test_a_line_left_unanswered_in_a_hold_is_flushed(slide, lab):
    slide.transport.write_bytes(b"!")  # a hold the driver did not ask for (a button on the controller)
    with pytest.raises(InstrumentError, match=r"no reply within 2 s.*flushed with a soft reset"):
        slide.unlock()
    slide.transport.write_bytes(b"~")
    lab.clock.sleep(1.0)
    assert slide.identity().startswith("Grbl 1.1h")  # the queued $X never answers later
    assert slide.status().state == "Idle"


def test_stock_homing_cycle_fails_once_with_the_build_option(lab):
    lab.emulator("grbl").homing_cycles = STOCK_HOMING_CYCLES  # Z first, and the slide has no Z switch
    grbl = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    with pytest.raises(InstrumentError, match=r"ALARM:9.*HOMING_CYCLE_0 \(1<<X_AXIS\).*config\.h") as failure:
        grbl.home()
    assert "controller reset" not in str(failure.value)
    assert grbl.status().state == "Alarm"  # no second, spurious error: the reset was read through
    grbl.unlock()
    assert grbl.status().state == "Idle"


def test_axes_stock_grbl_lacks_are_refused(lab):
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    for axis in ("A", "B", "C", "XY"):
        with pytest.raises(InvalidSettingError, match=r"one of X, Y, Z; stock GRBL 1\.1 has three axes"):
            Grbl(transport, axis=axis)
    assert Grbl(transport, axis="y").axis == "Y"


# -- exact bytes, no simulator: every command the driver sends, against gnea/grbl's replies -----------
BANNER = b"\r\nGrbl 1.1h ['$' for help]\r\n"
LOCKED = b"[MSG:'$H'|'$X' to unlock]\r\n"  # protocol.c: MESSAGE_ALARM_LOCK after a reset in Alarm
ALARM_STATUS = b"<Alarm|MPos:0.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>\r\n"
IDLE_AT_PULLOFF = b"<Idle|MPos:-1.000,0.000,0.000|FS:0,0>\r\n"
#: connect(): the banner on its own (report.c report_init_message), then one '?'.
CONNECT = [(None, BANNER + LOCKED), (b"?", ALARM_STATUS)]


def protocol(pairs, **kwargs):
    return expected_protocol(Grbl, pairs, link_settings=SERIAL_SETTINGS, **kwargs)


def test_protocol_connect_takes_the_banner_without_a_reset():
    with protocol(CONNECT) as grbl:
        assert grbl.connect() == "Grbl 1.1h ['$' for help]"


def test_protocol_connect_resets_only_when_no_banner_comes():
    # a port that does not reset the Arduino on open (no DTR): silence, then Ctrl-X (system.c/protocol.c)
    with protocol([(b"\x18", BANNER + LOCKED), (b"?", ALARM_STATUS)]) as grbl:
        assert grbl.connect() == "Grbl 1.1h ['$' for help]"
        assert grbl.transport.clock.now() >= 5.0  # BANNER_WAIT_S, not a fixed 2 s


def test_protocol_connect_takes_a_late_second_banner():
    with protocol([(None, BANNER), (b"?", BANNER + b"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n")]) as grbl:
        assert grbl.connect() == "Grbl 1.1h ['$' for help]"


def test_protocol_connect_reports_lost_settings():
    # settings.c: a failed EEPROM read prints error:7 (STATUS_SETTING_READ_FAIL) and restores defaults
    with (protocol([(None, b"error:7\r\n" + BANNER)]) as grbl,
          pytest.raises(InstrumentError, match=r"error:7.*stock \$ settings")):
        grbl.connect()


def test_protocol_identity_is_dollar_i():
    # report.c report_build_info: [VER:...], [OPT:...], then ok
    pairs = [*CONNECT, (b"$I\n", b"[VER:1.1h.20190830:]\r\n[OPT:V,15,128]\r\nok\r\n")]
    with protocol(pairs) as grbl:
        assert grbl.identity() == "Grbl 1.1h.20190830 [OPT:V,15,128]"


def test_protocol_unlock_is_dollar_x():
    # system.c '$X' in Alarm: MESSAGE_ALARM_UNLOCK, then ok
    with protocol([*CONNECT, (b"$X\n", b"[MSG:Caution: Unlocked]\r\nok\r\n")]) as grbl:
        grbl.unlock()


def test_protocol_home_is_dollar_h_with_ok_at_the_end():
    with protocol([*CONNECT, (b"$H\n", b"ok\r\n")]) as grbl:
        grbl.home()


def test_protocol_failed_homing_reads_the_reset_through():
    # limits.c: ALARM:9 (EXEC_ALARM_HOMING_FAIL_APPROACH) + mc_reset; system.c still returns STATUS_OK for $H,
    # so "ok" precedes main.c's banner; protocol.c then prints the alarm lock
    reply = b"ALARM:9\r\nok\r\n" + BANNER + LOCKED
    with protocol([*CONNECT, (b"$H\n", reply), (b"?", ALARM_STATUS)]) as grbl:
        with pytest.raises(InstrumentError, match=r"ALARM:9.*HOMING_CYCLE_0 \(1<<X_AXIS\)"):
            grbl.home()
        assert grbl.status().state == "Alarm"


def test_protocol_homing_disabled_is_error_5():
    with protocol([*CONNECT, (b"$H\n", b"error:5\r\n")]) as grbl, pytest.raises(InstrumentError, match="error:5"):
        grbl.home()


def test_protocol_move_is_one_g1_line_then_polls():
    pairs = [
        *CONNECT,
        (b"?", IDLE_AT_PULLOFF),
        (b"G90 G1 X-10.000 F600\n", b"ok\r\n"),  # ok when planned, not when done (motion_control.c mc_line)
        (b"?", b"<Run|MPos:-9.800,0.000,0.000|FS:120,0>\r\n"),
        (b"?", b"<Idle|MPos:-10.000,0.000,0.000|FS:0,0>\r\n"),
    ]
    with protocol(pairs, approach="direct") as grbl:
        assert grbl.move_to(0.150) == -1


def test_protocol_move_that_times_out_is_flushed():
    # no ok (a hold queues the line, protocol.c): Ctrl-X empties the serial buffer and planner (main.c), so
    # the G1 cannot run after a later '~'; the reset's banner keeps the link in step
    pairs = [*CONNECT, (b"?", IDLE_AT_PULLOFF), (b"G90 G1 X-10.000 F600\n", None), (b"\x18", BANNER)]
    with protocol(pairs, approach="direct") as grbl, pytest.raises(InstrumentError, match="flushed"):
        grbl.move_to(0.150)


def test_protocol_resume_waits_for_hold_0():
    pairs = [
        *CONNECT,
        (b"!", None),
        (b"?", b"<Hold:1|MPos:-5.000,0.000,0.000|FS:300,0>\r\n"),  # protocol.c: still decelerating
        (b"?", b"<Hold:0|MPos:-5.450,0.000,0.000|FS:0,0>\r\n"),  # SUSPEND_HOLD_COMPLETE: '~' now counts
        (b"~", None),
    ]
    with protocol(pairs) as grbl:
        grbl.connect()
        grbl.feed_hold()
        grbl.resume()


def test_protocol_resume_waits_when_the_hold_has_not_begun():
    # the '?' can be served before the '!' in the same pass of protocol_exec_rt_system (report first)
    pairs = [*CONNECT, (b"!", None), (b"?", b"<Run|MPos:-5.000,0.000,0.000|FS:600,0>\r\n"),
             (b"?", b"<Hold:0|MPos:-6.000,0.000,0.000|FS:0,0>\r\n"), (b"~", None)]
    with protocol(pairs) as grbl:
        grbl.connect()
        grbl.feed_hold()
        grbl.resume()


def test_protocol_soft_reset_skips_a_stray_ok():
    # the status of the line a reset interrupted is printed before the banner (protocol.c main loop)
    pairs = [*CONNECT, (b"\x18", b"ok\r\n" + BANNER + LOCKED), (b"?", ALARM_STATUS)]
    with protocol(pairs) as grbl:
        assert grbl.soft_reset() == "Grbl 1.1h ['$' for help]"


def test_protocol_soft_reset_while_moving_reports_alarm_3():
    pairs = [*CONNECT, (b"\x18", b"ALARM:3\r\n" + BANNER + LOCKED), (b"?", ALARM_STATUS)]
    with protocol(pairs) as grbl, pytest.raises(InstrumentError, match=r"ALARM:3"):
        grbl.soft_reset()


def test_protocol_reset_after_alarm_2_waits_for_the_prompt():
    # limits.c limits_soft_check -> ALARM:2; protocol.c prints it, waits 500 ms (report_alarm_message),
    # then "[MSG:Reset to continue]" and only then listens for a reset; the line's ok follows the reset
    pairs = [
        *CONNECT,
        (b"?", IDLE_AT_PULLOFF),
        (b"G90 G1 X5.000 F600\n", b"ALARM:2\r\n"),
        (None, b"[MSG:Reset to continue]\r\n"),
        (b"\x18", b"ok\r\n" + BANNER + LOCKED),
        (b"?", ALARM_STATUS),
    ]
    with protocol(pairs, approach="direct", max_mm=170.0) as grbl:
        with pytest.raises(InstrumentError, match="ALARM:2"):
            grbl.move_to(0.165)
        grbl.soft_reset()


def test_protocol_stop_is_hold_then_reset():
    pairs = [*CONNECT, (b"!", None), (b"?", b"<Hold:0|MPos:-5.000,0.000,0.000|FS:0,0>\r\n"),
             (b"\x18", BANNER), (b"?", b"<Idle|MPos:-5.000,0.000,0.000|FS:0,0>\r\n")]
    with protocol(pairs) as grbl:
        grbl.connect()
        grbl.stop()
