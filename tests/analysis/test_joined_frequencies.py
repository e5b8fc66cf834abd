"""A campaign joined from runs at 15 kHz and at 500 Hz on the faithful lab (issue 26, starting campaign (b)):
a 5 mm copper plate screens like a perfect conductor Re{coth(gamma d)/gamma} behind its face (docs/physics.md,
"Two frequencies on a thick plate"), about a millimetre deeper at 500 Hz than at 15 kHz, which the one
calibration offset p1 both frequencies share cannot follow."""

from __future__ import annotations

import pytest

from ecds_lab.analysis.diagnosis import run_diagnosis
from ecds_lab.analysis.diagnosis.search import default_candidates
from ecds_lab.data.measurements import Measurements
from ecds_lab.model.effects import library
from ecds_lab.simulators import campaign

POSITIONS_MM = (20, 30, 40, 50, 60, 70, 80, 90, 100)
#: The library's candidates and plate_recession, which a diagnosis tries only when named.
WITH_RECESSION = (*default_candidates(library()), "plate_recession")


def _run(lab, frequency_hz: float) -> Measurements:
    """A sweep at the plate's present temperature and one at 75 C, both directions, two readings a point: starting
    campaign (b). ``target_heating`` switches the heater off and returns, so a run straight after another starts on
    the plate still at 70-75 C: joined this way only the first frequency has a room-temperature sweep."""
    room = campaign.displacement_sweep(lab, POSITIONS_MM, (frequency_hz,), repeats=2)
    hot = campaign.target_heating(lab, (75,), positions_mm=POSITIONS_MM, frequencies_hz=(frequency_hz,), repeats=2)
    return Measurements.concatenate([room, hot])


def _cooled_run(lab, frequency_hz: float) -> Measurements:
    """``_run``, then the plate left to cool back to the room (the heater off for as long as a heating step settles):
    the next frequency's first sweep is at room temperature, as a station run of the target-heating experiment,
    which first holds the plate at its lowest set point, gives it."""
    data = _run(lab, frequency_hz)
    lab.clock.sleep(campaign.settle_time_s(lab, campaign.TARGET_HEATER_OUTPUT))
    return data


def test_a_cold_joined_campaign_claims_the_plate_recession_at_the_copper_skin_depth(field_lab):
    """Room temperature only, nothing switched on: the lab's 5 mm plate recedes by its skin depth's half at each
    frequency; the textbook copper recession (recession_scale 1) takes the baseline's ~10x the noise. Without it
    the default diagnosis finds nothing here (tau_displacement's size undetermined)."""
    lab = field_lab()
    data = Measurements.concatenate([campaign.displacement_sweep(lab, POSITIONS_MM, (f,), repeats=2)
                                     for f in (15000.0, 500.0)])
    result = run_diagnosis(data, candidates=WITH_RECESSION)
    assert result.steps[0].rmse_ppm > 5.0 * result.noise_ppm, result.explanation
    assert result.claimed == ["plate_recession"], result.explanation
    assert result.final.rmse_ppm < 1.5 * result.noise_ppm, result.explanation
    # copper's textbook resistivity at room temperature, within its grades' spread
    assert 0.9 < result.final.fit.values["recession_scale"] < 1.1


@pytest.mark.xfail(strict=True, reason=(
    "the 500 Hz run follows the 15 kHz heating at once, so its first sweep is at 70-75 C, not at room temperature "
    "(_run): only 15 kHz has a cold reference, and a bending's two temperature responses can follow a conductivity "
    "change's; with the plate cooled first the same diagnosis claims it (the test below). Here the default diagnosis "
    "(no plate_recession: it ties with tau_displacement wherever it acts) claims tau_displacement (225 -> 65.5 ppm, "
    "19.5 ppm noise), then target_tau_temperature (-0.0036/K, plate 4.1 mm, 19.1 ppm) and target_bending (-0.47 um/K,"
    " 19.8 ppm) both pass and tie (chi-square gains 1239 and 1173): an honest tie, no longer the false bending "
    "claimed while the conductivity change stayed at the 1 um plate bound. Named as a candidate plate_recession fits "
    "but decides nothing: plate_recession takes 67.5 ppm (recession_scale 1.22, tau_T to its bound), tied with "
    "tau_displacement (65.5 ppm, size undetermined); then target_tau_temperature (-0.0034/K, plate 4.93 mm, scale "
    "1.08) and target_bending (-0.33 um/K, bending_x -0.63, scale 1.22) both pass at 25.2 and 25.1 ppm (1.3x) and "
    "tie: with the plate's thickness and the recession's scale free, one hot temperature at two frequencies does not "
    "separate the two"))
def test_a_joined_500_hz_and_15_khz_campaign_fits_and_claims_the_conductivity_change(field_lab):
    lab = field_lab(plate={"conductivity": {"enabled": True}})
    data = Measurements.concatenate([_run(lab, 15000.0), _run(lab, 500.0)])
    assert_the_conductivity_change_is_claimed(run_diagnosis(data))


def assert_the_conductivity_change_is_claimed(result) -> None:
    """The conductivity change claimed, no bending beside it, the residual near the noise, copper's tempco."""
    assert "target_tau_temperature" in result.claimed, result.explanation
    assert "target_bending" not in result.claimed, result.explanation
    # one tau_T and one calibration for both frequencies left ~10x the noise (chi-square ~5000 over ~150 readings)
    assert result.final.rmse_ppm <= 3.0 * result.noise_ppm, result.explanation
    # copper's conductivity falls ~0.39 %/K, its tau_T with it
    assert -0.006 < result.final.fit.values["tau_tempco"] < -0.002


def test_a_joined_campaign_with_a_cold_sweep_at_each_frequency_claims_the_conductivity_change(field_lab):
    """The xfail above with the plate cooled between the frequencies: each frequency has its own room-temperature
    reference, and a conductivity change (its set-back growing as f^-1/2 on a thick plate) no longer leaves a bending
    the same two temperature responses to fit. The default diagnosis claims it (measured: 20.0 ppm, 1.02x the noise,
    -0.0036/K, plate 5.05 mm; the bending 89.9 ppm)."""
    lab = field_lab(plate={"conductivity": {"enabled": True}})
    data = Measurements.concatenate([_cooled_run(lab, 15000.0), _cooled_run(lab, 500.0)])
    assert_the_conductivity_change_is_claimed(run_diagnosis(data))


def test_with_the_recession_named_a_joined_bending_campaign_claims_the_bending(field_lab):
    """The lab's plate bends toward the coil when hot: a conductivity change would have to rise with temperature to
    mimic it (tau_tempco +0.004/K), and at two frequencies it fits worse; the bending is claimed, nothing else.
    (Worse in the valley it reaches from the plate thickness's default, 10 mm: 28.9 ppm at 11.3 mm against the
    bending's 22.1. Started at the 4.2 mm plate_recession found, it reaches 22.0 ppm, +0.0037/K, and would tie: the
    xfail below.)"""
    lab = field_lab(plate={"bending": {"enabled": True}})
    data = Measurements.concatenate([_run(lab, 15000.0), _run(lab, 500.0)])
    result = run_diagnosis(data, candidates=WITH_RECESSION)
    assert result.claimed == ["target_bending"], result.explanation
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm, result.explanation


@pytest.mark.xfail(strict=True, reason=(
    "a false bending: with a third frequency (5 kHz) the baseline leaves 630 ppm, plate_recession is claimed (57 ppm,"
    " scale 1.22, plate 4.39 mm) and then target_bending (24.0 ppm, -0.4 um/K) while target_tau_temperature ends at "
    "53.6 ppm in a 13 mm-thick valley (scale 0.91, -0.0050/K): it starts the plate thickness it shares with "
    "plate_recession at that effect's default, 10 mm, not at the 4.39 mm found, and is not refitted once the bending "
    "is near the noise. Started there (measured) it reaches 23.8 ppm (5.15 mm, scale 1.05, -0.0035/K) and ties with "
    "the bending (chi-square gains 845 and 818): the 500 Hz and 5 kHz runs start on the plate still at 70-75 C "
    "(_run), so three temperature responses meet three unknowns either way (tempco or bending, thickness, scale). The"
    " recession's next term, -(Im c)^2/2 d2k^2/dx^2 (with Re csch^2(gamma d)/gamma^2 beside it), does not separate "
    "them: with it (and that start) the conductivity change fits 18.9 ppm with the textbook copper (scale 1.02, "
    "5.00 mm, -0.0035/K) and the bending 18.9 ppm too (scale 1.11)"))
def test_with_the_recession_named_three_frequencies_claim_the_conductivity_change(field_lab):
    lab = field_lab(plate={"conductivity": {"enabled": True}})
    data = Measurements.concatenate([_run(lab, f) for f in (15000.0, 500.0, 5000.0)])
    result = run_diagnosis(data, candidates=WITH_RECESSION)
    assert "target_tau_temperature" in result.claimed, result.explanation
    assert "target_bending" not in result.claimed, result.explanation


@pytest.mark.xfail(strict=True, reason=(
    "with the plate cooled between the frequencies plate_recession (604 -> 174 ppm, plate 4.86 mm) and then "
    "target_tau_temperature (57.3 ppm, plate 12.5 mm, -0.0024/K) are added, both judged partial and the residual "
    "'outside the library': the conductivity change starts the thickness it shares with plate_recession at that "
    "effect's default, 10 mm, not at the 4.86 mm found; from there and from its 8 mm start it ends at 12.5 mm, from "
    "its 10 um start it stays at 10 um (587 ppm). Started at the 4.86 mm found (measured) it reaches 24.0 ppm (1.22x;"
    " 5.26 mm, scale 1.03, -0.0037/K), the bending 75.7 ppm, and both are claimed; but the same start lets a rising "
    "conductivity (+0.0037/K, 22.0 ppm) tie with the bending on the joined bending campaign (22.1 ppm), which only a "
    "bound tau_tempco <= 0 for a non-magnetic plate decides"))
def test_with_the_recession_named_three_cooled_frequencies_claim_the_conductivity_change(field_lab):
    """Three frequencies, each with its own room-temperature sweep: the conductivity change's set-back grows as
    f^-1/2 on the thick plate (less at 500 Hz, where the 5 mm plate is under two skin depths), a bending's does not."""
    lab = field_lab(plate={"conductivity": {"enabled": True}})
    data = Measurements.concatenate([_cooled_run(lab, f) for f in (15000.0, 500.0, 5000.0)])
    result = run_diagnosis(data, candidates=WITH_RECESSION)
    assert "target_tau_temperature" in result.claimed, result.explanation
    assert "target_bending" not in result.claimed, result.explanation
    assert result.final.rmse_ppm <= 1.5 * result.noise_ppm, result.explanation
    assert -0.006 < result.final.fit.values["tau_tempco"] < -0.002


def test_diagnose_on_the_command_line_tries_the_recession_when_named(field_lab, tmp_path, capsys):
    """``ecds-lab diagnose --try plate_recession`` on the cold joined campaign's CSV claims it; without ``--try`` it
    is not tried; a name the library lacks is refused in one line naming it."""
    import json

    from ecds_lab.cli import main

    lab = field_lab()
    data = Measurements.concatenate([campaign.displacement_sweep(lab, POSITIONS_MM, (f,), repeats=2)
                                     for f in (15000.0, 500.0)])
    csv = tmp_path / "cold.csv"
    data.to_csv(csv)
    assert main(["diagnose", str(csv), "--try", "plate_recession", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["claimed"] == ["plate_recession"]
    assert main(["diagnose", str(csv), "--json"]) == 0
    assert "plate_recession" not in json.dumps(json.loads(capsys.readouterr().out)["ranking"])
    assert main(["diagnose", str(csv), "--try", "plate_recesion"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "plate_recesion" in err[0]
