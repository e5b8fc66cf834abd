"""``ecds-lab diagnose --each``: one diagnosis per campaign, in parallel on a local Dask cluster, a table out."""

from __future__ import annotations

import json

import pytest

from ecds_lab.cli import main
from ecds_lab.simulators import campaign
from ecds_lab.simulators.config import LabConfig
from ecds_lab.simulators.lab import SimulatedLab

pytest.importorskip("dask.distributed", reason="the cluster extra (dask.distributed) is not installed")


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    """Two CSV campaigns: the exact-model lab without and with a backlash, and a file that is no campaign."""
    folder = tmp_path_factory.mktemp("each")
    paths = []
    for name, effects in (("plain", {}), ("backlash", {"slide_backlash": {"enabled": True}})):
        lab = SimulatedLab(LabConfig(seed=4, effects=effects))
        data = campaign.displacement_sweep(lab, campaign.PAPER_POSITIONS_MM, (15000.0,))
        path = folder / f"{name}.csv"
        data.to_csv(path)
        paths.append(path)
    broken = folder / "broken.csv"
    broken.write_text("time_s,x_mm\n1,2\n")
    return paths, broken


def test_each_campaign_is_diagnosed_on_two_workers(campaigns, capsys):
    (plain, backlash), _ = campaigns
    assert main(["diagnose", "--each", str(plain), str(backlash), "--workers", "2", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [row["data"] for row in rows] == [str(plain), str(backlash)]
    assert rows[0]["verdict"] == "adequate" and rows[0]["claimed"] == []
    assert rows[1]["claimed"] == ["slide_backlash"]
    # The same campaign diagnosed alone gives the same answer as in the batch.
    assert main(["diagnose", str(backlash), "--json"]) == 0
    alone = json.loads(capsys.readouterr().out)
    assert alone["claimed"] == rows[1]["claimed"] and alone["noise_ppm"] == rows[1]["noise_ppm"]


def test_a_bad_file_is_its_own_row_and_the_batch_goes_on(campaigns, capsys):
    (plain, _), broken = campaigns
    assert main(["diagnose", "--each", str(plain), str(broken), "--workers", "1"]) == 1
    table = capsys.readouterr().out
    lines = table.splitlines()
    assert lines[1].startswith(str(plain)) and "adequate" in lines[1]
    assert lines[2].startswith(str(broken)) and "error" in lines[2]
    assert lines[-1] == "2 campaign(s), 1 with an error"


def test_scheduler_without_each_is_refused(campaigns, capsys):
    (plain, _), _ = campaigns
    assert main(["diagnose", str(plain), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert "--each" in capsys.readouterr().err


def test_an_unreachable_scheduler_is_named(campaigns, capsys):
    (plain, backlash), _ = campaigns
    assert main(["diagnose", "--each", str(plain), str(backlash), "--scheduler", "tcp://127.0.0.1:9"]) == 2
    assert "tcp://127.0.0.1:9" in capsys.readouterr().err
