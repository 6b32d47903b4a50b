"""`scripts/compare_models.py`: per-method mean scores over the kept draws, zero-shot returns
read from `fbil zero-shot --json`, and a one-line error (exit 2) for a missing file."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "compare_models.py"


def _lines(path: Path, rows: list[tuple[str, str, int, float, float]]) -> Path:
    path.write_text(
        "".join(
            json.dumps({"method": m, "task": t, "draw": d, "score": s, "return_mean": r}) + "\n"
            for m, t, d, s, r in rows
        )
    )
    return path


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True)


def test_scores_per_method_on_the_kept_draws(tmp_path: Path) -> None:
    a = _lines(
        tmp_path / "a.jsonl",
        [
            ("erfb", "loop", 0, 0.5, 500.0),
            ("erfb", "loop", 1, 0.7, 700.0),
            ("goalfb", "loop", 0, 0.1, 100.0),
            ("erfb", "loop", 2, 0.0, 0.0),
        ],
    )
    zs = tmp_path / "zs.json"
    zs.write_text(json.dumps({"tasks": {"loop": {"return_mean": 812.5, "return_std": 1.0}}}))
    out = tmp_path / "cmp.json"
    proc = _run("--run", f"A={a},{zs}", "--draws", "0,1", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    got = json.loads(out.read_text())["A"]
    assert got["jobs"] == 3  # draw 2 left out
    assert abs(got["score_pct"]["erfb"] - 60.0) < 1e-9
    assert abs(got["score_pct"]["mean"] - 100 * (0.5 + 0.7 + 0.1) / 3) < 1e-9
    assert got["returns"]["erfb"]["loop"] == 600.0
    assert got["zero_shot"] == {"loop": 812.5}


def test_missing_results_file_is_one_line_exit_2(tmp_path: Path) -> None:
    proc = _run("--run", f"A={tmp_path / 'none.jsonl'}")
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "none.jsonl" in proc.stderr


def test_tasks_and_methods_filters(tmp_path: Path) -> None:
    a = _lines(
        tmp_path / "a.jsonl",
        [
            ("erfb", "loop", 0, 0.5, 500.0),
            ("erfb", "square", 0, 0.9, 900.0),
            ("goalfb", "loop", 0, 0.1, 100.0),
        ],
    )
    out = tmp_path / "cmp.json"
    proc = _run("--run", f"A={a}", "--tasks", "loop", "--methods", "erfb", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    got = json.loads(out.read_text())["A"]
    assert got["jobs"] == 1 and got["score_pct"] == {"erfb": 50.0, "mean": 50.0}
    proc = _run("--run", f"A={a}", "--tasks", "fast_slow")
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0


def test_plot_needs_numeric_names_and_draws_the_curve(tmp_path: Path) -> None:
    a = _lines(tmp_path / "a.jsonl", [("erfb", "loop", 0, 0.5, 500.0)])
    b = _lines(tmp_path / "b.jsonl", [("erfb", "loop", 0, 0.8, 800.0)])
    png = tmp_path / "curve.png"
    proc = _run("--run", f"50000={a}", "--run", f"100000={b}", "--plot", str(png))
    assert proc.returncode == 0, proc.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    proc = _run("--run", f"A={a}", "--plot", str(tmp_path / "x.png"))
    assert proc.returncode == 2 and "numeric" in proc.stderr
    assert not (tmp_path / "x.png").exists()
