"""Campaign outcomes: one record per case, the JSON manifest, the summary table.

``<out>/<campaign>.manifest.json`` is rewritten atomically (temporary file, then ``os.replace``)
after every finished case, so it is never half-written; it only lags behind the run files.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from dataclasses import asdict, dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal

from sacflow.campaign.expansion import CampaignCase
from sacflow.config.schema import Campaign

__all__ = ["CampaignSummary", "CaseRecord", "Manifest", "Status"]

Status = Literal["pending", "done", "failed", "skipped"]


@dataclass(frozen=True)
class CaseRecord:
    """Outcome of one case, as stored in the manifest (``path`` relative to its folder)."""

    index: int
    name: str
    case_id: str
    parameters: dict[str, Any]
    path: Path
    status: Status = "pending"
    error: str | None = None
    traceback: str | None = None
    wall_time: float | None = None
    cpu_time: float | None = None
    steps: int | None = None
    resumed_steps: int | None = None

    def to_json(self) -> dict[str, Any]:
        """Return a JSON-ready dict; ``path`` is the file name next to the manifest."""
        return {**asdict(self), "path": self.path.name}


@dataclass(frozen=True)
class CampaignSummary:
    """Outcome of a campaign: one record per case, in campaign order."""

    name: str
    out_dir: Path
    manifest: Path
    records: tuple[CaseRecord, ...]
    wall_time: float
    workers: int = 0
    dashboard: str | None = field(default=None, compare=False)

    @property
    def failed(self) -> tuple[CaseRecord, ...]:
        """Records of the failed cases."""
        return tuple(r for r in self.records if r.status == "failed")

    @property
    def paths(self) -> list[Path]:
        """Run files of the cases that are complete."""
        return [r.path for r in self.records if r.status in ("done", "skipped")]

    def counts(self) -> dict[str, int]:
        """Count the cases per status."""
        counts = Counter(r.status for r in self.records)
        return {status: counts.get(status, 0) for status in ("done", "skipped", "failed")}

    def table(self) -> str:
        """Return the summary table, one line per case, then the totals."""
        width = max([len(r.name) for r in self.records] + [4])
        lines = [f"{'#':>3}  {'case':<{width}}  {'case_id':<12}  {'status':<7}  steps  wall [s]"]
        for r in self.records:
            steps = "-" if r.steps is None else str(r.steps)
            wall = "-" if r.wall_time is None or r.status == "skipped" else f"{r.wall_time:.1f}"
            line = f"{r.index:>3}  {r.name:<{width}}  {r.case_id:<12}  {r.status:<7}  {steps:>5}"
            line += f"  {wall:>8}"
            if r.error:
                first = r.error.splitlines()[0]
                line += f"  {first[:60]}{'...' if len(first) > 60 else ''}"
            lines.append(line)
        counts = ", ".join(f"{n} {status}" for status, n in self.counts().items())
        lines.append(f"{self.name}: {counts} in {self.wall_time:.1f} s; manifest {self.manifest}")
        return "\n".join(lines)


class Manifest:
    """``<out>/<campaign>.manifest.json``, rewritten atomically after every change.

    Records start ``pending``; a case the previous manifest in ``out_dir`` had ``done`` or
    ``skipped`` keeps the wall and CPU time of the run that did it.
    """

    def __init__(self, campaign: Campaign, cases: list[CampaignCase], out_dir: Path) -> None:
        self.campaign = campaign
        self.path = out_dir / f"{campaign.name}.manifest.json"
        for stale in out_dir.glob(f".{self.path.name}.*.tmp"):  # a campaign killed mid-write
            stale.unlink(missing_ok=True)
        previous = self._previous()
        self.records: dict[int, CaseRecord] = {}
        for c in cases:
            record = CaseRecord(c.index, c.name, c.case_id, c.parameters, out_dir / f"{c.name}.nc")
            old = previous.get(c.case_id, {})
            if old.get("status") in ("done", "skipped"):  # keep the time of the run that did it
                record = replace(
                    record, wall_time=old.get("wall_time"), cpu_time=old.get("cpu_time")
                )
            self.records[c.index] = record

    def _previous(self) -> dict[str, dict[str, Any]]:
        try:
            cases = json.loads(self.path.read_text())["cases"]
            return {c["case_id"]: c for c in cases}
        except (OSError, ValueError, KeyError, TypeError):
            return {}

    def update(self, index: int, **changes: Any) -> None:
        """Change fields of the record of case ``index`` (in memory; see :meth:`write`)."""
        self.records[index] = replace(self.records[index], **changes)

    def write(self) -> None:
        """Write the manifest: a temporary file, flushed to disk, then renamed over it."""
        records = list(self.records.values())
        data = {
            "campaign": self.campaign.name,
            "description": self.campaign.description,
            "updated": datetime.now(UTC).isoformat(timespec="seconds"),
            "counts": dict(Counter(r.status for r in records)),
            "cases": [r.to_json() for r in records],
        }
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        with open(tmp, "w") as f:
            json.dump(data, f, indent=2, default=str)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)
