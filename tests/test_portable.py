"""The analysis and the reader need nothing POSIX-only (issue 24, point 12): lab PCs run Windows, and no
Windows runner is available here, so a child process with ``fcntl``, ``termios``, ``pty`` and ``tty``
made unimportable (as on Windows) reads a run file and runs ``ecds-lab fit``, ``ecds-lab diagnose`` and
``ecds-lab report``."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from ecds_lab.cli import main

SESSIONS = Path(__file__).resolve().parent / "data" / "sessions"
POSIX_ONLY = ("fcntl", "termios", "pty", "tty", "resource", "grp", "pwd")


def _without_posix_modules(code: str, blocked: tuple[str, ...] = POSIX_ONLY) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a child whose POSIX-only modules cannot be imported (already loaded or not)."""
    prelude = "import sys\n" + "".join(f"sys.modules[{name!r}] = None\n" for name in blocked)
    return subprocess.run([sys.executable, "-c", prelude + textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=600, check=False)


def test_the_blocked_modules_are_really_unimportable() -> None:
    done = _without_posix_modules("""
        import importlib
        for name in ("fcntl", "termios", "pty"):
            try:
                importlib.import_module(name)
            except ImportError:
                print(name, "blocked")
    """)
    assert done.stdout.split("\n")[:3] == ["fcntl blocked", "termios blocked", "pty blocked"], done.stderr


@pytest.mark.slow
def test_fit_diagnose_and_the_reader_run_without_fcntl(tmp_path: Path) -> None:
    run_file = tmp_path / "sweep.h5"
    run_file.write_bytes((SESSIONS / "sweep.h5").read_bytes())
    csv = tmp_path / "sweep.csv"
    assert main(["export", str(run_file), "-o", str(csv)]) == 0
    done = _without_posix_modules(f"""
        import json
        from ecds_lab.cli import main
        from ecds_lab.storage.reader import read_run

        run = read_run({str(run_file)!r})
        print(json.dumps({{"status": run.status, "rows": len(run.points)}}))
        for command in ("fit", "diagnose"):
            code = main([command, {str(csv)!r}, "--json"])
            print(json.dumps({{"command": command, "exit": code}}))
        code = main(["report", {str(run_file)!r}, "-o", {str(tmp_path / "report.html")!r}])
        print(json.dumps({{"command": "report", "exit": code}}))
        sys.exit(0 if "fcntl" not in sys.modules or sys.modules["fcntl"] is None else 3)
    """)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith('{"status"')
             or line.startswith('{"command"')]
    assert lines[0] == {"status": "completed", "rows": lines[0]["rows"]} and lines[0]["rows"] > 10
    assert {"command": "fit", "exit": 0} in lines
    assert {"command": "diagnose", "exit": 0} in lines
    assert {"command": "report", "exit": 0} in lines and (tmp_path / "report.html").stat().st_size > 10_000


def test_tcp_serving_works_without_ptys_and_pty_serving_is_refused_with_the_way_out() -> None:
    """Serving needs pyserial (the ecdssim:// scheme), whose POSIX backend imports fcntl and termios; on Windows
    it loads its win32 backend instead. So here only what pty serving itself uses is taken away."""
    done = _without_posix_modules("""
        import os
        del os.openpty  # no pseudo-terminals, as on Windows
        from ecds_lab.errors import ConfigError
        from ecds_lab.instruments.kinds import ROLE_NAMES
        from ecds_lab.simulators import serve
        from ecds_lab.station import load_station_config

        config, _ = load_station_config(None)
        drivers = {role: getattr(config, role).driver for role in ROLE_NAMES}
        print("pty available:", serve.PTY_AVAILABLE)
        server = serve.LabServer(config.simulated.lab, drivers, port_base=0, serial="tcp")
        print(server.describe())
        server.close()
        try:
            serve.LabServer(config.simulated.lab, drivers, port_base=0, serial="pty")
        except ConfigError as exc:
            print("refused:", exc)
    """, blocked=("pty", "tty"))
    assert done.returncode == 0, done.stderr[-3000:]
    lines = done.stdout.splitlines()
    assert lines[0] == "pty available: False"
    assert sum(line.split()[-1].startswith(("socket://127.0.0.1:", "TCPIP::127.0.0.1::")) for line in lines[1:5]) == 4
    assert lines[5].startswith("refused: simulate: pseudo-terminals exist only on POSIX") and "--serial tcp" in lines[5]
