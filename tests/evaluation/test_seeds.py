"""Model seeds (issue #23): per-seed zero-shot and scores, their mean and spread, the
default model's rule, the script's one-line errors and the report's section, on synthetic
model folders and results lines (no training, no rollouts)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

import pytest

from fbil.errors import FbilError
from fbil.evaluation.report import write_report
from fbil.evaluation.seeds import build_seeds, choose, seed_entry
from tests.evaluation.test_report import _rows, _write

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "model_seeds.py"


def _model(tmp: Path, name: str, seed: int, zero_shot: dict[str, float]) -> Path:
    model = tmp / name
    model.mkdir()
    (model / "config.json").write_text(json.dumps({"train_config": {"seed": seed}}))
    tasks = {t: {"return_mean": r, "return_std": 1.0, "episodes": 5} for t, r in zero_shot.items()}
    (model / "zero_shot.json").write_text(json.dumps({"tasks": tasks}))
    return model


def _results(tmp: Path, model: Path, erfb: float, goalfb: float) -> Path:
    rows: list[dict[str, Any]] = []
    for method, score in (("erfb", erfb), ("goalfb", goalfb)):
        for r in _rows("point_mass_maze", method, {"loop": (score, score)}, (0.01, 0.01)):
            rows.append({**r, "model": str(model)})
    # A line of another model in the same file is not this seed's.
    other = {**rows[0], "model": str(tmp / "elsewhere"), "score": 0.0}
    return _write(tmp / f"{model.name}.jsonl", [*rows, other])


@pytest.fixture
def three_seeds(tmp_path: Path) -> list[tuple[Path, Path]]:
    runs = []
    for seed, (reach, loop, erfb, goalfb) in enumerate(
        [(500.0, 100.0, 0.4, 0.8), (700.0, 0.0, 0.6, 0.9), (600.0, 900.0, 0.5, 0.7)]
    ):
        model = _model(tmp_path, f"s{seed}", seed, {"reach_a": reach, "loop": loop})
        runs.append((model, _results(tmp_path, model, erfb, goalfb)))
    return runs


def test_seed_summary_means_spreads_and_the_median_rule(
    three_seeds: list[tuple[Path, Path]],
) -> None:
    entries = [seed_entry(m, r, ["reach_a"]) for m, r in three_seeds]
    assert [e["seed"] for e in entries] == [0, 1, 2]
    assert entries[0]["scores"] == {"erfb": pytest.approx(0.4), "goalfb": pytest.approx(0.8)}
    assert entries[2]["zero_shot_mean"] == 600.0  # the reach subset only, not loop
    seeds = build_seeds(entries, "median_zero_shot", ["reach_a"])
    assert seeds["domain"] == "point_mass_maze" and seeds["zero_shot_mean"]["n"] == 3
    assert seeds["zero_shot_mean"]["mean"] == pytest.approx(600.0)
    assert seeds["zero_shot_mean"]["std"] == pytest.approx(100.0)  # sample std of 500/600/700
    assert seeds["scores"]["erfb"]["mean"] == pytest.approx(0.5)
    assert seeds["scores"]["goalfb"]["min"] == pytest.approx(0.7)
    assert seeds["chosen"] == str(three_seeds[2][0])  # zero-shot 600: the median seed
    # All tasks by default: the means are then 300 / 350 / 750, and the median is seed 1.
    assert choose([seed_entry(m, r) for m, r in three_seeds], "median_zero_shot") == str(
        three_seeds[1][0]
    )
    # `first` keeps the model given first (a committed seed), whatever the others score.
    assert choose(entries[::-1], "first") == str(three_seeds[2][0])
    with pytest.raises(FbilError, match="unknown rule 'best'"):
        choose(entries, "best")
    with pytest.raises(FbilError, match="at least 2 models"):
        build_seeds(entries[:1], "median_zero_shot", [])


def test_the_script_writes_seeds_json_and_the_report_shows_it(
    three_seeds: list[tuple[Path, Path]], tmp_path: Path
) -> None:
    spec = importlib.util.spec_from_file_location("model_seeds", SCRIPT)
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    out = tmp_path / "results"
    out.mkdir()
    runs = [f"--run={m}={r}" for m, r in three_seeds]
    assert script.main([*runs, "--zero-shot-tasks", "reach_a", "--out", str(out)]) == 0
    seeds = json.loads((out / "seeds.json").read_text())
    assert seeds["chosen"] == str(three_seeds[2][0]) and len(seeds["seeds"]) == 3
    # The default model's results next to seeds.json: the report gains the section.
    results = out / "results.jsonl"
    results.write_text(three_seeds[2][1].read_text())
    text = write_report(results, tmp_path / "report").read_text()
    assert "## Model seeds" in text and "`median_zero_shot`" in text
    assert "| **mean ± std over seeds** | 600.0 ± 100.0 | 50.0 ± 10.0 | 80.0 ± 10.0 |" in text
    assert f"`{three_seeds[2][0]}` (2) (default) | 600.0 | 50.0 | 70.0 |" in text


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("no_zero_shot", "no readable zero-shot returns"),
        ("bad_run", "give MODEL_DIR=RESULTS_FILE"),
        ("missing_task", "has no return for nowhere"),
    ],
)
def test_script_mistakes_are_one_line_errors(
    three_seeds: list[tuple[Path, Path]],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: str,
    message: str,
) -> None:
    spec = importlib.util.spec_from_file_location("model_seeds", SCRIPT)
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    runs = [f"--run={m}={r}" for m, r in three_seeds]
    extra: list[str] = []
    if change == "no_zero_shot":
        (three_seeds[0][0] / "zero_shot.json").unlink()
    elif change == "bad_run":
        runs[0] = f"--run={three_seeds[0][0]}"
    else:
        extra = ["--zero-shot-tasks", "nowhere"]
    assert script.main([*runs, *extra, "--out", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not (tmp_path / "s.json").exists()


def _arm(measures: list[float], reach: float) -> dict[str, Any]:
    """A seeds.json with one model per measure: two methods whose mean is the measure."""
    zero_shot = {t: reach for t in ("reach_top_left", "reach_top_right")}
    zero_shot |= {"reach_bottom_left": reach + 10, "reach_bottom_right": reach - 10, "loop": 0.0}
    return {
        "seeds": [
            {
                "model": f"m{i}",
                "scores": {"erfb": m - 0.1, "goalfb": m + 0.1, "bc": 0.9},
                "zero_shot": zero_shot,
            }
            for i, m in enumerate(measures)
        ]
    }


def test_the_recipe_rule_needs_a_gap_above_the_spread_and_a_zero_shot_floor() -> None:
    from fbil.evaluation.seeds import recipe_decision

    base = _arm([0.40, 0.44], 580.0)
    # Per model, the mean of erfb, goalfb and bc: (2 m + 0.9) / 3; ahead by more than the spread.
    won = recipe_decision(base, _arm([0.47, 0.47, 0.47], 600.0))
    assert won["decision"] == "replace the baseline by the candidate"
    assert won["difference"] == pytest.approx((0.47 * 2 + 0.9) / 3 - (0.42 * 2 + 0.9) / 3)
    assert won["threshold"] == pytest.approx(0.04 / 2**0.5 * 2 / 3)  # std of the 3-method means
    assert won["candidate"]["zero_shot_mean"] == pytest.approx(600.0)
    # Ahead by less than the spread: not told apart.
    close = recipe_decision(base, _arm([0.43, 0.45], 600.0))
    assert close["decision"].startswith("keep the baseline: the arms are not told apart")
    # Ahead, but its zero-shot reach mean is under 500.
    low = recipe_decision(base, _arm([0.50, 0.50], 480.0))
    assert "zero-shot mean is under 500" in low["decision"]
    # One seed in an arm: no spread, no decision.
    assert recipe_decision(base, _arm([0.9], 600.0))["decision"].startswith("undecided")


def test_the_decision_script_reads_two_seed_files(tmp_path: Path, capsys: Any) -> None:
    from tests.script_module import load_script

    mod = load_script("recipe_decision")
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(_arm([0.40, 0.44], 580.0)))
    b.write_text(json.dumps(_arm([0.47, 0.47], 600.0)))
    out = tmp_path / "decision.json"
    assert mod.main(["--baseline", str(a), "--candidate", str(b), "--out", str(out)]) == 0
    assert "replace the baseline by the candidate" in capsys.readouterr().out
    assert json.loads(out.read_text())["candidate"]["n"] == 2
    (tmp_path / "bad.json").write_text("[1, 2]")
    assert mod.main(["--baseline", str(tmp_path / "bad.json"), "--candidate", str(b)]) == 2
    assert "not a seeds.json" in capsys.readouterr().err
