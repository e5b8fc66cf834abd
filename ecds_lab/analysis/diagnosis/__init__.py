"""Diagnosis: where the model fails, which effects are missing, and how far adding them helps.

One module per job:

- ``search``: the robust start (fit, noise, glitches excluded and listed) and the forward selection
  over the effects of an ``EffectRegistry`` (default: the library and installed packages' effects);
- ``checks``: the checks a claim must pass (evidence weighed by each reading's noise and the readings'
  design effect, identifiable key parameters, a plausible size) and when candidates are tied;
- ``held_out``: the screening subsample, grouped folds and the held-out error, with its margin;
- ``verdict`` and ``explanation``: the verdict, the explanation in words, the suggested measurements
  and the text summary of the JSON.

See docs/diagnosis.md for how it decides and the JSON it prints.
"""

from __future__ import annotations

from ecds_lab.analysis.diagnosis.explanation import explain, format_diagnosis
from ecds_lab.analysis.diagnosis.result import Candidate, Diagnosis, Step
from ecds_lab.analysis.diagnosis.search import MAX_STEPS, diagnose, run_diagnosis
from ecds_lab.analysis.diagnosis.verdict import ADEQUATE_RATIO, FAILING_RATIO

__all__ = ["ADEQUATE_RATIO", "FAILING_RATIO", "MAX_STEPS", "Candidate", "Diagnosis", "Step", "diagnose", "explain",
           "format_diagnosis", "run_diagnosis"]
