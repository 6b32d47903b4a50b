"""CSV training logs that survive a kill: resuming drops the rows logged after the
checkpoint it resumes from, so every step appears once."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path


def truncate_log(log: Path, step: int, fields: Sequence[str]) -> None:
    if not log.exists():
        return
    with open(log, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if int(r["step"]) <= step]
    with open(log, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fields)
        writer.writeheader()
        writer.writerows(rows)


def last_wall_seconds(log: Path) -> float:
    if not log.exists():
        return 0.0
    with open(log, newline="") as fh:
        rows = list(csv.DictReader(fh))
    return float(rows[-1]["wall_seconds"]) if rows else 0.0
