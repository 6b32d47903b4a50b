"""`scripts/compare_models.py`: per-method mean scores over the kept draws, zero-shot returns
read from `fbil zero-shot --json`, several seeds pooled into one curve point (scores the mean
over seeds, zero-shot returns averaged per task), and a one-line error (exit 2) for a missing
file."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

from fbil.errors import FbilError

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


def test_curve_sidecar_is_what_the_report_shows(tmp_path: Path) -> None:
    from fbil.evaluation.training_curve import find_training_curve, training_curve_section

    a = _lines(tmp_path / "a.jsonl", [("erfb", "walk", 0, 0.5, 500.0)])
    b = _lines(tmp_path / "b.jsonl", [("erfb", "walk", 0, 0.25, 250.0)])
    zs = tmp_path / "zs.json"
    zs.write_text(json.dumps({"tasks": {"walk": {"return_mean": 812.5, "return_std": 1.0}}}))
    curve = tmp_path / "training_curve.json"
    runs = ["--run", f"100000={a},{zs}", "--run", f"200000={b}"]
    proc = _run(*runs, "--curve", str(curve), "--domain", "walker", "--committed", "100000")
    assert proc.returncode == 0, proc.stderr
    found = find_training_curve([tmp_path / "results.jsonl"], "walker")
    assert found is not None and found["committed"] == "100000"
    assert find_training_curve([tmp_path / "results.jsonl"], "cheetah") is None
    lines = training_curve_section(found, tmp_path / "report")
    table = "\n".join(lines)
    assert "| 100,000 (committed) | 200,000 |" in table
    assert (
        "| **mean** | 50.0 | 25.0 |" in table and "| zero-shot mean return | 812.5 | – |" in table
    )
    assert (tmp_path / "report" / "training_curve.png").stat().st_size > 0
    assert "--committed 100000" in found["command"]


def test_curve_needs_a_domain_numeric_names_and_a_known_committed_name(tmp_path: Path) -> None:
    a = _lines(tmp_path / "a.jsonl", [("erfb", "walk", 0, 0.5, 500.0)])
    curve = str(tmp_path / "c.json")
    for extra in (
        ["--run", f"100000={a}", "--curve", curve],
        ["--run", f"first={a}", "--curve", curve, "--domain", "walker"],
        ["--run", f"100000={a}", "--curve", curve, "--domain", "walker", "--committed", "5"],
    ):
        proc = _run(*extra)
        assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0, proc.stderr
        assert not Path(curve).exists()


def test_the_report_shows_a_training_curve_next_to_its_results(tmp_path: Path) -> None:
    from fbil.evaluation.report import write_report
    from tests.evaluation.test_report import _rows, _write

    out = tmp_path / "results"
    out.mkdir()
    rows = _rows("point_mass_maze", "erfb", {"loop": (0.5, 0.5)}, (0.01, 0.01))
    results = _write(out / "results.jsonl", rows)
    a = _lines(tmp_path / "a.jsonl", [("erfb", "loop", 0, 0.5, 500.0)])
    b = _lines(tmp_path / "b.jsonl", [("erfb", "loop", 0, 0.75, 750.0)])
    curve = out / "training_curve.json"
    for domain, shown in (("walker", False), ("point_mass_maze", True)):
        runs = ["--run", f"1000={a}", "--run", f"2000={b}"]
        proc = _run(*runs, "--curve", str(curve), "--domain", domain, "--note", "One seed.")
        assert proc.returncode == 0, proc.stderr
        text = write_report(results, tmp_path / f"report_{domain}").read_text()
        assert ("## Imitation against training length" in text) is shown
    assert "| **mean** | 50.0 | 75.0 |" in text and "One seed." in text
    curve.write_text("{not json")
    with pytest.raises(FbilError, match=r"training_curve\.json is not valid JSON"):
        write_report(results, tmp_path / "report_bad")


def _compare() -> ModuleType:
    from tests.script_module import load_script

    return load_script("compare_models")


def _results(path: Path, model: str, scores: dict[str, float]) -> str:
    rows = [
        {
            "model": model,
            "domain": "point_mass_maze",
            "task": "loop",
            "method": m,
            "draw": d,
            "score": s + 0.1 * d,
            "return_mean": 1000 * s,
        }
        for m, s in scores.items()
        for d in (0, 1)
    ]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return str(path)


def _zero_shot(path: Path, returns: dict[str, float]) -> str:
    path.write_text(json.dumps({"tasks": {t: {"return_mean": v} for t, v in returns.items()}}))
    return str(path)


def test_seeds_pool_into_one_curve_point(tmp_path: Path) -> None:
    a = _results(tmp_path / "a.jsonl", "A", {"erfb": 0.2, "goalfb": 0.6})
    b = _results(tmp_path / "b.jsonl", "B", {"erfb": 0.4, "goalfb": 0.2})
    za = _zero_shot(tmp_path / "za.json", {"loop": 100.0, "square": 300.0})
    zb = _zero_shot(tmp_path / "zb.json", {"loop": 300.0, "square": 500.0})
    single = _results(tmp_path / "c.jsonl", "C", {"erfb": 0.1, "goalfb": 0.1})
    curve = tmp_path / "training_curve.json"
    code = _compare().main(
        [
            "--run",
            f"200={a}+{b},{za}+{zb}",
            "--run",
            f"100={single}",
            "--per-task",
            "",
            "--curve",
            str(curve),
            "--domain",
            "point_mass_maze",
            "--committed",
            "200",
        ]
    )
    assert code == 0
    runs = json.loads(curve.read_text())["runs"]
    pooled = runs["200"]
    assert pooled["jobs"] == 8
    # Each seed's draws average to s + 0.05; the seeds' mean is then taken per method.
    assert pooled["score_pct"]["erfb"] == pytest.approx(100 * (0.3 + 0.05))
    assert pooled["score_pct"]["goalfb"] == pytest.approx(100 * (0.4 + 0.05))
    assert pooled["score_pct"]["mean"] == pytest.approx(100 * (0.35 + 0.05))
    assert pooled["zero_shot"] == {"loop": 200.0, "square": 400.0}
    assert "zero_shot" not in runs["100"]


def _pool_case(tmp_path: Path, case: str) -> str:
    """The --run value of one bad pool: zero-shot files of different tasks, a missing
    results file, or results files of different grids."""
    a = _results(tmp_path / "a.jsonl", "A", {"erfb": 0.2, "goalfb": 0.6})
    if case == "tasks":
        za = _zero_shot(tmp_path / "za.json", {"loop": 100.0})
        zb = _zero_shot(tmp_path / "zb.json", {"square": 300.0})
        return f"1={a}+{a},{za}+{zb}"
    if case == "missing":
        return f"1={a}+{tmp_path / 'missing.jsonl'}"
    b = _results(tmp_path / "b.jsonl", "B", {"erfb": 0.4})
    return f"1={a}+{b}"


@pytest.mark.parametrize(
    ("case", "message"),
    [("tasks", "different tasks"), ("missing", "missing.jsonl"), ("grids", "4, 2 lines")],
)
def test_a_bad_pool_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str, message: str
) -> None:
    assert _compare().main(["--run", _pool_case(tmp_path, case)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_gzipped_results_read_as_plain(tmp_path: Path) -> None:
    plain = _results(tmp_path / "a.jsonl", "A", {"erfb": 0.2, "goalfb": 0.6})
    packed = tmp_path / "a.jsonl.gz"
    packed.write_bytes(gzip.compress(Path(plain).read_bytes()))
    cmp = _compare()
    assert cmp.summarise([packed], None, []) == cmp.summarise([Path(plain)], None, [])
