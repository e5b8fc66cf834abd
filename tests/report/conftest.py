"""Fixtures of the report tests: the simulated campaign's run files, a stand-in diagnosis, and a headless
Chromium driven over the DevTools protocol.

Chromium is Debian's (``apt-get install chromium``; ``.ci/run`` installs it when run as root). It is
driven with ``--remote-debugging-pipe``: DevTools messages are NUL-terminated JSON on file
descriptors 3 (to the browser) and 4 (from it), so no websocket client or other dependency is
needed. Without a browser the browser tests skip, except under ``CI=true``, where that fails.
"""

from __future__ import annotations

import fcntl
import json
import os
import select
import shutil
import subprocess
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from ecds_lab.analysis.fitting import fit
from ecds_lab.data.measurements import Measurements

#: The shipped campaign, as ``ecds-lab demo`` runs it: (experiment, station).
CAMPAIGN = (
    ("displacement_sweep.yaml", "stations/simulated_lab.yaml"),
    ("coil_heating.yaml", "stations/simulated_lab_in_air.yaml"),
    ("spectroscopy.yaml", "stations/simulated_lab_in_air.yaml"),
    ("target_heating_copper.yaml", "stations/simulated_lab.yaml"),
    ("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml"),
)

#: Flags for a headless Chromium on a machine without network: no first-run, sync, updates or pings.
CHROMIUM_FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-default-apps", "--disable-extensions", "--mute-audio", "--hide-scrollbars",
)


@pytest.fixture(scope="session")
def campaign_files(shipped_run: Callable[..., Any]) -> list[Path]:
    """Run files of the whole simulated campaign (each shipped experiment once per test session)."""
    return [shipped_run(experiment, station).path for experiment, station in CAMPAIGN]


def stand_in_diagnosis(data: Measurements, effect: str = "target_tau_temperature") -> SimpleNamespace:
    """A diagnosis with the contract's shape (issue 7) from two real fits: the baseline and baseline + effect.

    The report's tests use it so they neither wait for nor depend on the full diagnosis (which
    fits every library effect); ``test_real_diagnosis_is_shown`` covers the real one.
    """
    base = fit(data)
    plus = fit(data, [effect])
    candidate = SimpleNamespace(effect=effect, fit=plus, delta_bic=plus.bic - base.bic, rmse_ppm=plus.rms_ppm,
                                cv_rmse_ppm=None)
    other = SimpleNamespace(effect="slide_backlash", fit=base, delta_bic=12.0, rmse_ppm=base.rms_ppm,
                            cv_rmse_ppm=base.rms_ppm * 1.1)
    associations = [SimpleNamespace(variable="t_target_c", score=0.4, detail="residual rises with target temperature"),
                    SimpleNamespace(variable="x_mm", score=0.1, detail="mostly near the coil")]
    noise = base.noise_ppm or 20.0
    return SimpleNamespace(noise_ppm=noise, baseline=base, candidates=[candidate, other], associations=associations,
                           verdict="missing_effect", explanation="Stand-in explanation <for the test> & more.",
                           data=data, to_json=lambda: {})


@pytest.fixture(scope="session")
def stand_in() -> Callable[..., SimpleNamespace]:
    """``stand_in(data)``: a diagnosis with the contract's shape, see ``stand_in_diagnosis``."""
    return stand_in_diagnosis


# -- the browser ------------------------------------------------------------------------------------
def chromium_path() -> str | None:
    """Debian's Chromium (``/usr/bin/chromium``), or another ``chromium`` on PATH."""
    if os.access("/usr/bin/chromium", os.X_OK):
        return "/usr/bin/chromium"
    return shutil.which("chromium")


@dataclass
class PageResult:
    """What a page did while it loaded: console messages, exceptions, log entries, requests."""

    console: list[dict[str, Any]] = field(default_factory=list)
    exceptions: list[dict[str, Any]] = field(default_factory=list)
    log: list[dict[str, Any]] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)
    failed_requests: list[dict[str, Any]] = field(default_factory=list)

    def errors(self) -> list[str]:
        """Console errors and warnings, uncaught exceptions, error log entries and failed requests."""
        out = [f"console.{m.get('type')}: {m.get('args')}" for m in self.console if m.get("type") in ("error", "assert",
                                                                                                        "warning")]
        out += [f"exception: {e.get('exceptionDetails', {}).get('text')}" for e in self.exceptions]
        out += [f"log {e['entry'].get('level')}: {e['entry'].get('text')} ({e['entry'].get('url', '')})"
                for e in self.log if e["entry"].get("level") in ("error", "warning")]
        out += [f"request failed: {r.get('errorText')}" for r in self.failed_requests]
        return out


class Chromium:
    """A headless Chromium process and one DevTools session on a page, over the debugging pipe."""

    def __init__(self, executable: str, profile: Path, timeout_s: float = 30.0) -> None:
        self.timeout_s = timeout_s
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()
        # The browser wants the pipe on descriptors 3 and 4; park our ends above 9, then let bash move them.
        child_in = fcntl.fcntl(to_browser_r, fcntl.F_DUPFD, 10)
        child_out = fcntl.fcntl(from_browser_w, fcntl.F_DUPFD, 10)
        os.close(to_browser_r)
        os.close(from_browser_w)
        script = f'exec "$@" 3<&{child_in} 4>&{child_out} {child_in}<&- {child_out}>&-'
        args = [executable, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", "--remote-debugging-pipe", "about:blank"]
        self._log = (profile.parent / "chromium-stderr.log").open("wb")
        self.process = subprocess.Popen(["/bin/bash", "-c", script, "bash", *args], pass_fds=(child_in, child_out),
                                        stdin=subprocess.DEVNULL, stdout=self._log, stderr=self._log)
        os.close(child_in)
        os.close(child_out)
        self._buffer = b""
        self._next_id = 0
        self.events: list[dict[str, Any]] = []
        self.session = ""

    # -- protocol ------------------------------------------------------------------------------
    def send(self, method: str, params: dict[str, Any] | None = None, *, session: bool = True) -> dict[str, Any]:
        """Send a command and wait for its reply; events that arrive meanwhile are kept in ``events``."""
        self._next_id += 1
        message: dict[str, Any] = {"id": self._next_id, "method": method, "params": params or {}}
        if session and self.session:
            message["sessionId"] = self.session
        os.write(self._to_browser, json.dumps(message).encode() + b"\0")
        while True:
            reply = self._receive()
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_for(self, method: str) -> dict[str, Any]:
        """Wait for an event (already received or still to come)."""
        while True:
            for event in self.events:
                if event.get("method") == method:
                    return event
            self.events.append(self._receive())

    def _receive(self) -> dict[str, Any]:
        deadline = time.monotonic() + self.timeout_s
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            ready, _, _ = select.select([self._from_browser], [], [], max(left, 0))
            if not ready:
                raise TimeoutError(f"no DevTools message from Chromium within {self.timeout_s:.0f} s")
            chunk = os.read(self._from_browser, 1 << 20)
            if not chunk:
                raise EOFError(f"Chromium closed the DevTools pipe (exit code {self.process.poll()})")
            self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(raw)

    # -- pages ---------------------------------------------------------------------------------
    def open(self, url: str, width: int = 1280, height: int = 900) -> PageResult:
        """Open ``url`` in a new page and wait for its load event; returns what the page logged."""
        target = self.send("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
        self.session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.send(f"{domain}.enable")
        self.send("Emulation.setDeviceMetricsOverride", {"width": width, "height": height, "deviceScaleFactor": 1,
                                                         "mobile": False})
        self.events.clear()
        self.send("Page.navigate", {"url": url})
        self.wait_for("Page.loadEventFired")
        self.send("Runtime.evaluate", {"expression": "1", "awaitPromise": True})  # let queued events arrive
        result = PageResult()
        for event in self.events:
            method, params = event.get("method"), event.get("params", {})
            if method == "Runtime.consoleAPICalled":
                result.console.append({"type": params.get("type"),
                                       "args": [a.get("value", a.get("description")) for a in params.get("args", [])]})
            elif method == "Runtime.exceptionThrown":
                result.exceptions.append(params)
            elif method == "Log.entryAdded":
                result.log.append(params)
            elif method == "Network.requestWillBeSent":
                result.requests.append(params["request"]["url"])
            elif method == "Network.loadingFailed":
                result.failed_requests.append(params)
        return result

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (JSON-able)."""
        reply = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True, "awaitPromise": True})
        if "exceptionDetails" in reply:
            raise RuntimeError(f"page script failed: {reply['exceptionDetails']}")
        return reply["result"].get("value")

    def screenshot(self, path: Path) -> Path:
        """A PNG of the whole page (not only the window)."""
        import base64

        size = self.send("Page.getLayoutMetrics")["cssContentSize"]
        shot = self.send("Page.captureScreenshot", {"format": "png", "captureBeyondViewport": True,
                                                    "clip": {"x": 0, "y": 0, "width": size["width"],
                                                             "height": size["height"], "scale": 1}})
        path.write_bytes(base64.b64decode(shot["data"]))
        return path

    def close(self) -> None:
        try:
            self.send("Browser.close", session=False)
        except (OSError, EOFError, TimeoutError, RuntimeError):
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        os.close(self._to_browser)
        os.close(self._from_browser)
        self._log.close()


@pytest.fixture
def chromium(tmp_path: Path) -> Iterator[Chromium]:
    """A headless Chromium; skipped where none is installed, but a failure under CI=true."""
    executable = chromium_path()
    if executable is None:
        message = ("Chromium is not installed (need /usr/bin/chromium: apt-get install chromium); "
                   "the HTML report is not checked in a browser")
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"CI=true: {message}")
        pytest.skip(message)
    browser = Chromium(executable, tmp_path / "chromium-profile")
    try:
        yield browser
    finally:
        browser.close()


@dataclass
class CampaignReport:
    path: Path
    html: str
    seconds: float


@pytest.fixture(scope="session")
def campaign_report(campaign_files: list[Path], tmp_path_factory: pytest.TempPathFactory) -> CampaignReport:
    """The report of the whole simulated campaign, with the stand-in diagnosis of its copper data."""
    from ecds_lab.report.findings import target_groups
    from ecds_lab.report.html import write_report
    from ecds_lab.report.inputs import load_inputs

    inputs = [i for i in load_inputs(campaign_files) if not i.is_spectroscopy]
    main = target_groups(inputs)[0]
    output = tmp_path_factory.mktemp("report") / "report.html"
    began = time.perf_counter()
    write_report(campaign_files, output, diagnosis=stand_in_diagnosis(main.data))
    seconds = time.perf_counter() - began
    return CampaignReport(output, output.read_text(encoding="utf-8"), seconds)
