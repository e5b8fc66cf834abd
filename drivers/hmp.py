"""Rohde & Schwarz (Hameg) HMP-series power supply driving the heaters (SCPI).

Sources (facts cited where used; the HMP SCPI manual body was not available):
  [HMP-DS]  R&S HMP datasheet table (as reproduced on ascendant.com.tw): HMP4040 4 x 0-32 V,
            10 A, 160 W per channel; 1 mV programming resolution
  [pym-HMP] pymeasure pymeasure/instruments/rohdeschwarz/hmp.py (class HMP4040)
  [qc-HMP]  QCoDeS/Qcodes_contrib_drivers drivers/RohdeSchwarz/private/HMP.py
  [sigrok]  sigrokproject/libsigrok src/hardware/scpi-pps/profiles.c (rs_hmp4040_cmd, pps_profiles[])
  [chk]     charkster/hmp4040 hmp4040.py (power-on readbacks, OUTP:SEL / OUTP:GEN wording)
Every per-output command acts on the output selected with ``INST OUT<n>`` [pym-HMP, sigrok].
``OUTP:SEL`` arms the selected output, ``OUTP:GEN`` is the master switch for all armed outputs,
``OUTP ON|OFF`` arms and switches the selected output in one step [pym-HMP, qc-HMP, chk, sigrok].
The identity's vendor is ``HAMEG`` or ``ROHDE&SCHWARZ`` [sigrok pps_profiles].
"""

from __future__ import annotations

from typing import Any, ClassVar

from ecds_lab.drivers.instrument import Control, Instrument, SCPIInstrument, in_range, integer_in_range
from ecds_lab.drivers.replies import Field, ReplyFormat, ask_checked
from ecds_lab.errors import HeaterNotOff, InvalidSettingError
from ecds_lab.transports.base import Transport

#: A switched-off output measures no current; below this it counts as off (the HMP4040's current
#: read-back resolution is 1 mA at < 1 A [HMP-DS]; a margin of a few counts).
OFF_CURRENT_A = 0.005

VENDORS: tuple[str, ...] = ("HAMEG", "ROHDE&SCHWARZ")
ON_OFF = {False: "OFF", True: "ON"}

#: RS-232 / USB virtual COM: 9600 8N1 with RTS/CTS, "otherwise the PSU might not process every
#: command" (public serial script); LF out, CR/LF stripped from replies [qc-HMP, chk].
SERIAL_SETTINGS: dict[str, Any] = {
    "baudrate": 9600, "bytesize": 8, "parity": "N", "stopbits": 1, "rtscts": True,
    "write_termination": "\n", "read_termination": "\n", "timeout_s": 2.0,
}
#: LAN (port 5025), USB-TMC or GPIB through VISA: LF terminator [qc-HMP].
VISA_SETTINGS: dict[str, Any] = {"write_termination": "\n", "read_termination": "\n", "timeout_s": 2.0}


def _on_off(reply: str) -> str:
    """``OUTP?`` and ``OUTP:GEN?`` answer 0/1 [chk]; the wire value for sets is OFF/ON.

    Anything else is refused (a truncated or foreign reply must never read as "off").
    """
    value = reply.strip().upper()
    if value in ("1", "ON"):
        return "ON"
    if value in ("0", "OFF"):
        return "OFF"
    raise ValueError(f"expected 0 or 1, got {reply!r}")


class Bounded(Control[float]):
    """A Control whose upper limit is an attribute of the driver (it differs per HMP model)."""

    def __init__(self, get_command: str, set_command: str, doc: str, *, low: float, high: str,
                 unit: str = "", whole: bool = False) -> None:
        super().__init__(get_command, set_command, doc, parse=int if whole else float)
        self.low, self.high, self.unit, self.whole = low, high, unit, whole

    def encode(self, instrument: Instrument, value: Any) -> Any:
        label = f"{instrument.name}.{self.name}"
        high = getattr(instrument, self.high)
        check = integer_in_range(int(self.low), int(high)) if self.whole else in_range(self.low, high, self.unit)
        return check(value, label)


class HMP4040(SCPIInstrument):
    """An HMP supply: one Control per command of the selected output, plus the HeaterSupply interface."""

    model = "HMP4040"

    selected_output = Bounded("INST:NSEL?", "INST OUT{}", "Output the per-output commands act on (1..outputs).",
                              low=1, high="outputs", whole=True)
    voltage_v = Bounded("VOLT?", "VOLT {:.3f}", "Set voltage of the selected output; 1 mV resolution [HMP-DS].",
                        low=0.0, high="max_voltage_v", unit=" V")
    current_limit_a = Bounded("CURR?", "CURR {:.4f}", "Current limit of the selected output.",
                              low=0.0, high="max_current_a", unit=" A")
    output: Control[bool] = Control("OUTP?", "OUTP {}", "Selected output armed and switched (ON) or disarmed (OFF).",
                                    mapping=ON_OFF, parse=_on_off)
    armed: Control[bool] = Control("OUTP:SEL?", "OUTP:SEL {}", "Selected output armed for the master switch.",
                                   mapping=ON_OFF, parse=_on_off)
    master: Control[bool] = Control("OUTP:GEN?", "OUTP:GEN {}", "Master switch of all armed outputs.",
                                    mapping=ON_OFF, parse=_on_off)

    def __init__(self, transport: Transport, *, outputs: int = 4, max_voltage_v: float = 32.0,
                 max_current_a: float = 10.0, max_power_w: float = 160.0) -> None:
        super().__init__(transport)
        self.outputs = integer_in_range(1, 4)(outputs, f"{self.name}.outputs")
        self.max_voltage_v = float(max_voltage_v)
        self.max_current_a = float(max_current_a)
        self.max_power_w = float(max_power_w)
        self.detected_model: str | None = None

    def _command(self, control: str, value: Any) -> str:
        """The set command of a Control for ``value``, validated but not sent."""
        descriptor: Control[Any] = getattr(type(self), control)
        return (descriptor.set_command or "").format(descriptor.encode(self, value))

    # -- HeaterSupply interface ----------------------------------------------------------------
    def identity(self) -> str:
        """``*IDN?``; refuses anything but an HMP from Hameg or R&S."""
        reply = self.ask("*IDN?")
        fields = [field.strip().upper() for field in reply.split(",")]
        if len(fields) < 2 or fields[0] not in VENDORS or not fields[1].startswith("HMP"):
            raise self.fail("*IDN?", reply, "not a Hameg / Rohde & Schwarz HMP supply")
        self.detected_model = fields[1]
        return reply

    def set_output(self, output: int, voltage_v: float, current_limit_a: float) -> None:
        """Voltage and current limit of one output; every limit is checked before anything is sent."""
        commands = [self._command("selected_output", output), self._command("voltage_v", voltage_v),
                    self._command("current_limit_a", current_limit_a)]
        power = float(voltage_v) * float(current_limit_a)
        if power > self.max_power_w * (1 + 1e-9):
            raise InvalidSettingError(
                f"{self.name}: {voltage_v:g} V x {current_limit_a:g} A = {power:g} W exceeds the "
                f"{self.max_power_w:g} W an output can deliver [HMP-DS]")
        for command in commands:
            self.write(command)
        self.check_errors("; ".join(commands))

    def enable(self, output: int, on: bool) -> None:
        """Arm and switch one output on (``OUTP ON`` also turns the master switch on), or disarm it."""
        commands = [self._command("selected_output", output), self._command("output", bool(on))]
        for command in commands:
            self.write(command)
        self.check_errors("; ".join(commands))

    #: The read-back queries with the format of their replies: volts with 3 decimals, amps with 4
    #: (``12.000``, ``1.5000`` [chk]); the bounds are the sigrok maxima (32.050 V, 10.010 A [sigrok])
    #: plus read-back noise around zero. A measurement may be asked again.
    MEASUREMENTS: ClassVar[dict[str, ReplyFormat]] = {
        "MEAS:VOLT?": ReplyFormat((Field("voltage", r"[+-]?\d+\.\d{3}", -0.1, 32.1),)),
        "MEAS:CURR?": ReplyFormat((Field("current", r"[+-]?\d+\.\d{4}", -0.02, 10.02),)),
    }

    def _measure(self, query: str) -> float:
        """One read-back, checked against its format (re-queried once if garbled)."""
        return ask_checked(self, query, self.MEASUREMENTS[query])[1][0]

    def _read(self, query: str, parse: Any) -> Any:
        """One state query whose reply is checked; InstrumentError names command and reply."""
        reply = self.ask(query)
        try:
            return parse(reply)
        except ValueError as exc:
            raise self.fail(query, reply, f"reply does not have the expected format: {exc}") from None

    def read_back(self, output: int) -> tuple[float, float]:
        """Measured voltage (V) and current (A) at an output."""
        self.write(self._command("selected_output", output))
        volts = self._measure("MEAS:VOLT?")
        amps = self._measure("MEAS:CURR?")
        return volts, amps

    def verify_off(self, outputs: tuple[int, ...]) -> None:
        """After ``all_off``: the master switch reads off, and each heater output reads off and draws no current.

        Raises HeaterNotOff naming the outputs still on; a supply that does not answer raises its
        TransportError (the caller treats both as "not confirmed off").
        """
        problems = []
        if self._read("OUTP:GEN?", _on_off) != "OFF":
            problems.append("master switch (OUTP:GEN?) still reads on")
        for output in outputs:
            self.write(self._command("selected_output", output))
            state = self._read("OUTP?", _on_off)
            amps = self._measure("MEAS:CURR?")
            if state != "OFF" or amps > OFF_CURRENT_A:
                problems.append(f"output {output} reads {state} and measures {amps:g} A")
        if problems:
            raise HeaterNotOff(f"{self.name}: " + "; ".join(problems))

    def all_off(self) -> None:
        """Master switch off, then disarm every output, without reading anything back.

        ``OUTP:GEN OFF`` comes first and does not depend on the selected output, so the heaters go
        off even if earlier commands failed; no reply or error-queue entry left over from those
        failures is read here. Disarming afterwards stops a later ``OUTP ON`` on one output (which
        turns the master switch on again) from reviving the others.
        """
        self.write(self._command("master", False))
        for output in range(1, self.outputs + 1):
            self.write(self._command("selected_output", output))
            self.write(self._command("armed", False))
