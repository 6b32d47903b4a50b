"""`scripts/zero_shot_curve.py`: one row per snapshot and for the run's model, steps in
order, finished steps not evaluated again, and one-line errors for a folder without a run
and for an --out that holds another run's curve."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "zero_shot_curve.py"


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300
    )


def test_curve_rows_per_snapshot_and_resume(
    smoke_model_dir: Path, fixture_data: Path, tmp_path: Path
) -> None:
    run = tmp_path / "run"
    shutil.copytree(smoke_model_dir, run)
    snap = run / "snapshots" / "step_0000030"
    snap.mkdir(parents=True)
    for name in ("model.safetensors", "config.json"):
        shutil.copy(smoke_model_dir / name, snap / name)
    out = tmp_path / "curve.json"
    args = ["--data", str(fixture_data), "--episodes", "1", "--tasks", "loop", "--out", str(out)]
    first = _run(str(run), *args, "--plot", str(tmp_path / "curve.png"))
    assert first.returncode == 0, first.stderr
    rows = json.loads(out.read_text())["rows"]
    final = json.loads((run / "config.json").read_text())["steps"]
    assert [r["step"] for r in rows] == [30, final]
    assert set(rows[0]["returns"]) == {"loop"}
    assert (tmp_path / "curve.png").stat().st_size > 0
    again = _run(str(run), *args)  # nothing left to evaluate
    assert again.returncode == 0 and again.stdout == ""
    assert json.loads(out.read_text())["rows"] == rows
    empty = _run(str(tmp_path / "nothing"), *args)
    assert empty.returncode == 2 and empty.stderr.count("\n") == 1
    assert "no snapshots or model" in empty.stderr
    other = tmp_path / "other_run"
    shutil.copytree(run, other)
    mixed = _run(str(other), *args)  # --out is the first run's curve: never mix two runs
    assert mixed.returncode == 2 and mixed.stderr.count("\n") == 1
    assert "holds the curve of another run" in mixed.stderr
    assert json.loads(out.read_text())["rows"] == rows
