"""GRBL driver against its emulator through the real pyserial path: exact bytes, waiting, errors, alarms."""

from __future__ import annotations

import pytest

from ecds_lab.drivers.grbl import ALARMS, ERRORS, SERIAL_SETTINGS, Grbl, parse_status
from ecds_lab.errors import InstrumentError, InvalidSettingError
from ecds_lab.instruments import Positioner

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
    assert slide.status().state == "Hold:0"
    slide.resume()
    assert slide.status().state == "Run"
    lab.clock.sleep(5.0)
    assert slide.status().state == "Idle" and slide.position_m() == pytest.approx(0.099)


def test_long_move_sleeps_on_the_clock_and_polls_little(slide, lab):
    slide.move_to(0.150)
    wire = lab.capture("grbl")
    start = lab.clock.now()
    slide.move_to(0.070)  # 80 mm down, then 0.5 mm back up
    elapsed = lab.clock.now() - start
    assert elapsed == pytest.approx((80.5 + 0.5) / 600 * 60, abs=0.2)
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


def test_emulator_reports_wco_then_ov_and_buffer_state(slide, lab):
    lab.emulator("grbl").settings[10] = 3  # MPos plus buffer state
    slide.soft_reset()  # reads the first report after the reset itself
    second, third = slide.status().raw, slide.status().raw
    first = [e.text for e in slide.transport.transcript.events if e.text.startswith("<")][-3]
    assert first == "<Idle|MPos:-1.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>"
    assert second == "<Idle|MPos:-1.000,0.000,0.000|Bf:15,128|FS:0,0|Ov:100,100,100>"
    assert third == "<Idle|MPos:-1.000,0.000,0.000|Bf:15,128|FS:0,0>"
    assert slide.position_m() == pytest.approx(0.159)


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


def test_emulator_gcode_errors(lab):
    transport = lab.serial("grbl", SERIAL_SETTINGS)
    Grbl(transport).unlock()
    replies = {}
    for line in ("G1 X-10", "G2 X-1", "G1 Q5", "G1 X-1.2.3", "G1 X1 X2", "G0 G1 X-1", "$Q", "x-5 (rapid)",
                 "G21 G17 G94 G91 G1 X1 F100"):
        transport.write(line)
        replies[line] = transport.read_line()
    assert replies == {
        "G1 X-10": "error:22", "G2 X-1": "error:20", "G1 Q5": "error:20", "G1 X-1.2.3": "error:1",
        "G1 X1 X2": "error:25", "G0 G1 X-1": "error:21", "$Q": "error:3", "x-5 (rapid)": "ok",
        "G21 G17 G94 G91 G1 X1 F100": "ok",
    }
    transport.write("$$")  # refused while moving, as GRBL does
    assert transport.read_line() == "error:8"
    lab.clock.sleep(5.0)
    transport.write("$$")
    settings = [transport.read_line() for _ in range(9)]
    assert settings[:3] == ["$10=1", "$20=1", "$22=1"] and "$130=145.000" in settings and settings[-1] == "ok"


def test_reopening_the_port_resets_the_controller(slide, lab):
    slide.move_to(0.100)
    slide.close()
    again = Grbl(lab.serial("grbl", SERIAL_SETTINGS))
    assert again.status().state == "Alarm"  # the Arduino reset: locked, MPos counts from here
    assert again.position_m() == pytest.approx(ORIGIN_MM * 1e-3)
    again.home()
    assert again.position_m() == pytest.approx(0.159)
    assert lab.lab.distance_m() == pytest.approx(0.159)
