"""The NeXus view of run files: a viewer following @default finds a sensible plot, live and after a kill."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from ecds_lab.data.columns import INDEX

SWEEP = "displacement_sweep.yaml"


def default_plot(f: h5py.File) -> h5py.Group:
    """Follow @default from the root to an NXdata group, as a generic viewer does."""
    group: h5py.Group = f
    while group.attrs.get("NX_class") != "NXdata":
        group = group[group.attrs["default"]]
    return group


def signal_and_axis(plot: h5py.Group) -> tuple[h5py.Dataset, h5py.Dataset]:
    axes = plot.attrs["axes"]
    return plot[plot.attrs["signal"]], plot[axes[0] if not isinstance(axes, str) else axes]


def test_a_sweep_file_plots_ls_against_x_for_one_frequency_by_default(shipped_run):
    path = shipped_run(SWEEP).path
    with h5py.File(path, "r") as f:
        plot = default_plot(f)
        signal_ds, axis = signal_and_axis(plot)
        table = f["entry/points"][()]
        assert (signal_ds.name.rsplit("/", 1)[1], axis.name.rsplit("/", 1)[1]) == ("ls_h", "x_commanded_mm")
        assert (signal_ds.attrs["units"], axis.attrs["units"]) == ("H", "mm")
        first = table[0, INDEX["freq_hz"]]
        mine = table[table[:, INDEX["freq_hz"]] == first]
        np.testing.assert_array_equal(signal_ds[()], mine[:, INDEX["ls_h"]])
        np.testing.assert_array_equal(axis[()], mine[:, INDEX["x_commanded_mm"]])
        # one NXdata per frequency, each holding only its own rows
        per_frequency = [g for g in f["entry"].values() if g.attrs.get("NX_class") == "NXdata" and g.name != plot.name
                         and g.name.startswith("/entry/ls_vs_x")]
        assert len(per_frequency) == 1
        other = table[table[:, INDEX["freq_hz"]] != first]
        np.testing.assert_array_equal(per_frequency[0]["ls_h"][()], other[:, INDEX["ls_h"]])
        assert f["entry/start_time"][()].decode() <= f["entry/end_time"][()].decode()


@pytest.mark.parametrize(("experiment", "station", "signal", "axis"), [
    ("coil_heating.yaml", None, "ls_h", "time_s"),
    ("target_heating_steel.yaml", "stations/simulated_lab_steel.yaml", "ls_h", "time_s"),
    ("spectroscopy.yaml", None, "z_abs_ohm", "freq_hz"),
])
def test_heating_and_spectroscopy_files_default_to_their_own_plot(shipped_run, experiment, station, signal, axis):
    path = shipped_run(experiment, station).path
    with h5py.File(path, "r") as f:
        signal_ds, axis_ds = signal_and_axis(default_plot(f))
        table = f["entry/points"][()]
        assert signal_ds.name.endswith(signal) and axis_ds.name.endswith(axis)
        if signal == "ls_h":  # heating: Ls against time at one frequency, temperatures beside it
            mine = table[table[:, INDEX["freq_hz"]] == table[0, INDEX["freq_hz"]]]
            np.testing.assert_array_equal(signal_ds[()], mine[:, INDEX["ls_h"]])
            np.testing.assert_array_equal(axis_ds[()], mine[:, INDEX["time_s"]])
            assert list(default_plot(f).attrs["auxiliary_signals"]) == ["t_coil_c", "t_target_c"]
            assert len(f["entry/temperatures_vs_time/t_coil_c"]) == len(table)
            table = mine
        assert len(signal_ds) == len(axis_ds) == len(table) > 0
        assert np.isfinite(axis_ds[()]).all() and np.isfinite(signal_ds[()]).all()
        if signal == "z_abs_ohm":
            expected = np.hypot(table[:, INDEX["rs_ohm"]], 2 * np.pi * table[:, INDEX["freq_hz"]]
                                * table[:, INDEX["ls_h"]])
            np.testing.assert_allclose(signal_ds[()], expected, rtol=1e-12)


def test_a_killed_sweep_shows_the_points_measured_so_far_in_its_default_plot(tmp_path, experiments_dir, yaml_copy):
    slow = yaml_copy("stations/simulated_lab.yaml", lambda d: d["simulated"].update(real_time_factor=0.02))
    path = tmp_path / "killed.h5"
    process = subprocess.Popen([sys.executable, "-m", "ecds_lab.cli", "run", str(experiments_dir / SWEEP),
                                "--station", str(slow), "-o", str(path), "-q"],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        rows = 0
        while rows < 12:
            assert process.poll() is None, "the run ended before it was killed"
            assert time.monotonic() < deadline, "the run wrote too few rows in 60 s"
            time.sleep(0.05)
            try:
                with h5py.File(path, "r", swmr=True) as f:
                    rows = len(f["entry/points"])
            except (OSError, KeyError):
                rows = 0
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    # h5py only: a killed writer leaves the superblock's write flags set, which SWMR-read accepts
    with h5py.File(path, "r", swmr=True) as f:
        table = f["entry/points"][()]
        signal_ds, axis = signal_and_axis(default_plot(f))
        first = table[table[:, INDEX["freq_hz"]] == table[0, INDEX["freq_hz"]]]
        assert len(table) >= 12 and f["entry"].attrs["status"] == "running"
        assert len(signal_ds) >= len(first) >= 6
        np.testing.assert_array_equal(signal_ds[: len(first)], first[:, INDEX["ls_h"]])
        np.testing.assert_array_equal(axis[: len(first)], first[:, INDEX["x_commanded_mm"]])
        assert np.isfinite(signal_ds[: len(first)]).all()


@pytest.mark.parametrize(("experiment", "station"), [(SWEEP, None), ("coil_heating.yaml", None),
                                                     ("spectroscopy.yaml", None)])
def test_punx_finds_no_errors(shipped_run, experiment, station):
    """punx (pip install punx) validates against the NeXus definitions it ships; skipped where absent."""
    punx = shutil.which("punx") or (Path(sys.executable).parent / "punx")
    if not Path(punx).exists():
        pytest.skip("punx is not installed (pip install punx)")
    path = shipped_run(experiment, station).path
    report = subprocess.run([str(punx), "validate", str(path)], capture_output=True, text=True, timeout=300)
    counts = dict(re.findall(r"^(ERROR|OK)\s+(\d+)\s", report.stdout, re.MULTILINE))
    assert counts.get("ERROR") == "0" and int(counts.get("OK", "0")) > 100, report.stdout[-3000:]
