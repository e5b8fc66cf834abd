"""``ecds-lab diagnose --each DATA...``: one diagnosis per campaign, in parallel (``ecds_lab.parallel``), a table out.

Each file is opened here (so a cluster across machines needs no shared disk: the readings travel with
the job) and diagnosed on a worker. A file that cannot be opened or diagnosed is a row with its error;
the others go on.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ecds_lab.data.measurements import Measurements
from ecds_lab.data.sensor import SensorConfig
from ecds_lab.errors import EcdsLabError
from ecds_lab.model.effects import EffectRegistry
from ecds_lab.parallel import run_all


@dataclass
class CampaignJob:
    """One campaign to diagnose: its label (the file), readings, sensor, the effects already in the model,
    and the user's effect files as (name, source) so a worker on another machine can load them."""

    label: str
    data: Measurements | None
    sensor: SensorConfig | None
    effects: list[str] = field(default_factory=list)
    effect_sources: list[tuple[str, str]] = field(default_factory=list)
    error: str | None = None


def jobs_for(paths: Sequence[Path], effects: Sequence[str], sensor: str | Path | None,
             effect_files: Sequence[Path] = ()) -> list[CampaignJob]:
    """A job per file; a file that cannot be opened becomes a job that only reports why."""
    from ecds_lab.storage.data_file import open_campaign

    sources = [(Path(p).name, Path(p).read_text()) for p in effect_files]
    jobs = []
    for path in paths:
        try:
            opened = open_campaign([path], sensor)
        except (EcdsLabError, OSError, ValueError) as error:
            jobs.append(CampaignJob(str(path), None, None, error=str(error)))
            continue
        jobs.append(CampaignJob(str(path), opened.data, opened.sensor, list(effects), sources))
    return jobs


def diagnose_job(job: CampaignJob) -> dict[str, Any]:
    """The row of one campaign: verdict, claims, alternatives, residual against noise; or its error."""
    row: dict[str, Any] = {"data": job.label}
    if job.error is not None or job.data is None:
        return {**row, "error": job.error}
    try:
        registry = _registry_with(job.effect_sources)
        from ecds_lab.analysis.diagnosis import diagnose

        report = diagnose(job.data, job.effects, job.sensor, registry=registry)
    except (EcdsLabError, ValueError, ArithmeticError) as error:
        return {**row, "readings": len(job.data), "error": str(error)}
    final = report["steps"][-1] if report.get("steps") else {}
    return {**row, "readings": len(job.data), "verdict": report["verdict"], "claimed": report["claimed"],
            "alternatives": report["alternatives"], "noise_ppm": report["noise_ppm"],
            "rmse_ppm": final.get("rmse_ppm", report["baseline"]["rmse_ppm"]),
            "explanation": report["explanation"]}


def _registry_with(sources: Sequence[tuple[str, str]]) -> EffectRegistry | None:
    """The library plus the user's effect files, written on this worker (None: the library alone)."""
    if not sources:
        return None
    from ecds_lab.model.plugins import with_effects_files

    folder = Path(tempfile.gettempdir()) / "ecds_lab_batch_effects"
    folder.mkdir(exist_ok=True)
    paths = []
    for name, text in sources:
        path = folder / name
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
        paths.append(path)
    return with_effects_files(paths)


def diagnose_each(paths: Sequence[Path], effects: Sequence[str] = (), sensor: str | Path | None = None, *,
                  effect_files: Sequence[Path] = (), scheduler: str | None = None,
                  workers: int | None = None) -> list[dict[str, Any]]:
    """One diagnosis row per file, in the files' order."""
    return run_all(diagnose_job, jobs_for(paths, effects, sensor, effect_files), scheduler=scheduler,
                   workers=workers)


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """The rows as a plain text table: file, readings, verdict, claims (or the error)."""
    header = ("data", "readings", "verdict", "residual/noise", "claimed / alternatives / error")
    lines = []
    for row in rows:
        if row.get("error"):
            lines.append((row["data"], str(row.get("readings", "-")), "error", "-", row["error"]))
            continue
        ratio = row["rmse_ppm"] / row["noise_ppm"] if row["noise_ppm"] else float("inf")
        said = ", ".join(row["claimed"]) or "-"
        if row["alternatives"]:
            said += "; alternatives: " + "; ".join(" or ".join(group) for group in row["alternatives"])
        lines.append((row["data"], str(row["readings"]), row["verdict"], f"{ratio:.2f}x", said))
    widths = [max(len(header[i]), *(len(line[i]) for line in lines)) for i in range(4)]
    out = ["  ".join(h.ljust(w) for h, w in zip(header, widths, strict=False)) + "  " + header[4]]
    for line in lines:
        out.append("  ".join(c.ljust(w) for c, w in zip(line, widths, strict=False)) + "  " + line[4])
    failed = sum(1 for row in rows if row.get("error"))
    out.append(f"{len(rows)} campaign(s), {failed} with an error")
    return "\n".join(out)
