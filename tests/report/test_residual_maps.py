"""The residual maps of a large campaign show a random share of its readings, and say so in the caption."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from ecds_lab.report import sections
from ecds_lab.storage.data_file import open_data


def _findings(data, residuals: np.ndarray) -> SimpleNamespace:
    fit = SimpleNamespace(residuals_ppm=residuals, n=len(data), rms_ppm=float(np.sqrt(np.mean(residuals**2))),
                          noise_ppm=20.0)
    return SimpleNamespace(main=SimpleNamespace(data=data, fit=fit, material="copper"))


def test_a_campaign_beyond_the_limit_is_shown_in_part_and_the_caption_says_how_much(
        campaign_files: list[Path], monkeypatch: pytest.MonkeyPatch):
    data = next(open_data(p).data for p in campaign_files if open_data(p).run.kind == "target_heating")
    residuals = np.arange(len(data), dtype=float)  # each residual names its reading
    monkeypatch.setattr(sections, "MAX_MAP_POINTS", 50)
    plots = sections.residual_section(_findings(data, residuals))
    shown, shown_residuals = plots[0].args[0], plots[0].args[1]
    assert len(shown) == len(shown_residuals) == 50
    np.testing.assert_array_equal(shown.time_s, data.time_s[shown_residuals.astype(int)])  # rows kept with their own
    assert f"50 of the {len(data):,} readings shown, at random" in plots[-1].caption
    assert f"{len(data)} readings, RMS" in plots[-1].caption  # the fit's figures are of every reading


def test_a_campaign_within_the_limit_is_shown_whole(campaign_files: list[Path]):
    data = next(open_data(p).data for p in campaign_files if open_data(p).run.kind == "target_heating")
    plots = sections.residual_section(_findings(data, np.zeros(len(data))))
    assert len(plots[0].args[0]) == len(data) and "shown, at random" not in plots[-1].caption
