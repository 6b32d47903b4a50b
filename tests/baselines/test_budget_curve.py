"""Scaled budgets (`cpu@0.5`: every gradient-step count multiplied, parsed in one place),
`scripts/budget_curve.py` end to end at smoke size, and the curve in `fbil report`
(issue #22 item 2)."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
from pathlib import Path
from typing import Any

import pytest

from fbil.errors import FbilError
from fbil.evaluation.paper import PAPER_RETURNS
from fbil.evaluation.report import write_report
from fbil.imitators import FitContext, get_imitator, imitators, parse_budget, scale_steps

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "budget_curve.py"
TRAINED = [name for name, i in imitators().items() if i.budgets]


def _config(name: str, budget: str) -> dict[str, Any]:
    config: dict[str, Any] = get_imitator(name).settings(FitContext(budget=budget))["config"]
    return config


def _compare(base: dict[str, Any], scaled: dict[str, Any], scale: float, path: str = "") -> int:
    """Assert `scaled` is `base` with each `steps` multiplied; the number of step fields."""
    assert base.keys() == scaled.keys(), path
    found = 0
    for key, value in base.items():
        if isinstance(value, dict):
            found += _compare(value, scaled[key], scale, f"{path}{key}.")
        elif key == "steps":
            assert scaled[key] == max(1, round(value * scale)), f"{path}{key}"
            found += 1
        else:
            assert scaled[key] == value, f"{path}{key}"
            assert "step" not in key or not isinstance(value, int), f"{path}{key} not scaled"
    return found


def test_budget_specs_parse_to_a_name_and_a_scale() -> None:
    names = ("cpu", "smoke")
    assert parse_budget("cpu", names) == ("cpu", 1.0)
    assert parse_budget("cpu@0.25", names) == ("cpu", 0.25)
    assert parse_budget("smoke@2", names) == ("smoke", 2.0)
    assert parse_budget("cpu@1e-1", names) == ("cpu", 0.1)


@pytest.mark.parametrize("name", TRAINED)
@pytest.mark.parametrize("budget, scale", [("cpu", 0.25), ("cpu", 0.5), ("cpu", 2), ("smoke", 0.5)])
def test_a_scaled_budget_multiplies_every_step_count_and_nothing_else(
    name: str, budget: str, scale: float
) -> None:
    base, scaled = _config(name, budget), _config(name, f"{budget}@{scale}")
    assert _compare(base, scaled, scale) >= 1
    assert _config(name, f"{budget}@1") == base


def test_step_counts_are_multiplied_exactly_at_cpu_size() -> None:
    oril = _config("oril", "cpu@0.25")
    assert oril["discriminator"]["steps"] == 5_000 and oril["td3"]["steps"] == 12_500
    assert _config("sqil", "cpu@2")["sac"]["steps"] == 60_000
    assert _config("bc", "smoke@0.5")["steps"] == 25 and _config("bc", "smoke@0.001")["steps"] == 1


def test_the_named_budgets_are_unchanged() -> None:
    from fbil.baselines import bc

    assert list(bc.BUDGETS) == ["cpu", "smoke"] and bc.BUDGETS["smoke"].steps == 50
    assert bc.BUDGETS["cpu"] is scale_steps(bc.BUDGETS["cpu"], 1.0)
    assert get_imitator("bc").settings(FitContext(budget="smoke"))["budget"] == "smoke"


def test_fit_trains_for_the_scaled_steps(
    monkeypatch: pytest.MonkeyPatch,
    demos_dir: Path,
) -> None:
    from fbil.baselines import bc
    from fbil.imitation import Demos

    seen: list[Any] = []
    real = bc.train_bc
    monkeypatch.setattr(bc, "train_bc", lambda o, a, cfg, s: seen.append(cfg) or real(o, a, cfg, s))
    demos = Demos.load(demos_dir / "square.npz")
    get_imitator("bc").fit(demos, FitContext(budget="smoke@0.5"))
    assert seen[0] == dataclasses.replace(bc.BUDGETS["smoke"], steps=25)


@pytest.mark.parametrize(
    "spec, message",
    [
        ("gpu@2", "unknown budget 'gpu@2' for bc; valid: cpu, smoke (or NAME@SCALE"),
        ("cpu@", "bad budget 'cpu@' for bc: the scale after '@' must be a number > 0"),
        ("cpu@abc", "bad budget 'cpu@abc'"),
        ("cpu@0", "bad budget 'cpu@0'"),
        ("cpu@-1", "bad budget 'cpu@-1'"),
        ("cpu@nan", "bad budget 'cpu@nan'"),
        ("cpu@inf", "bad budget 'cpu@inf'"),
        ("cpu@2@3", "bad budget 'cpu@2@3'"),
    ],
)
def test_bad_budget_specs_are_refused_in_one_line(spec: str, message: str) -> None:
    with pytest.raises(FbilError) as caught:
        get_imitator("bc").require(FitContext(budget=spec))
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_a_bad_spec_from_the_command_line_is_one_line_with_exit_code_2(
    capsys: pytest.CaptureFixture[str],
    demos_dir: Path,
) -> None:
    from fbil.cli import main

    args = ["evaluate", "no-model", str(demos_dir / "square.npz"), "--methods", "bc"]
    code = main([*args, "--budget", "smoke@x", "--episodes", "1"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "bad budget 'smoke@x' for bc" in lines[0], lines


def _script() -> Any:
    spec = importlib.util.spec_from_file_location("budget_curve_script", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _args(demos: Path, out: Path, scales: str = "1", draws: str = "1") -> list[str]:
    """The script's arguments for bc on square at smoke size, 1 episode per job."""
    args = ["--methods", "bc", "--tasks", "square", "--scales", scales, "--budget", "smoke"]
    return [*args, "--draws", draws, "--episodes", "1", "--demos", str(demos), "--out", str(out)]


@pytest.fixture(scope="module")
def curve_dir(demos_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The script at smoke@0.5 and smoke for bc on one task, 1 draw x 1 episode."""
    out = tmp_path_factory.mktemp("curve")
    args = _args(demos_dir, out, "0.5,1")
    assert _script().main(args) == 0
    return out


def test_the_script_writes_the_curve_and_its_figure(curve_dir: Path) -> None:
    curve = json.loads((curve_dir / "budget_curve.json").read_text())
    assert (curve_dir / "budget_curve.png").stat().st_size > 1000
    assert curve["domain"] == "point_mass_maze" and curve["tasks"] == ["square"]
    assert curve["budget"] == "smoke" and curve["draws"] == 1 and curve["episodes"] == 1
    bc = curve["methods"]["bc"]
    paper = PAPER_RETURNS["point_mass_maze"]
    assert bc["paper_score_pct"] == pytest.approx(
        100 * paper["bc"]["square"] / paper["expert"]["square"]
    )
    assert [p["budget"] for p in bc["points"]] == ["smoke@0.5", "smoke"]
    assert [p["steps"] for p in bc["points"]] == [{"": 25}, {"": 50}]
    for p in bc["points"]:
        assert p["seconds_median"] > 0 and p["jobs"] == 1 and p["draws"] == 1
        assert set(p["task_scores_pct"]) == {"square"}
        assert p["score_pct"] == pytest.approx(p["task_scores_pct"]["square"])
    lines = (curve_dir / "results_smoke@0.5.jsonl").read_text().splitlines()
    assert json.loads(lines[0])["config"]["steps"] == 25


def test_a_rerun_skips_finished_jobs_and_bad_scales_are_one_line(
    curve_dir: Path,
    demos_dir: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    before = (curve_dir / "results_smoke.jsonl").read_text()
    args = _args(demos_dir, curve_dir, "0.5,1")
    assert _script().main(args) == 0
    assert capsys.readouterr().out.count("0 jobs run") == 2
    assert (curve_dir / "results_smoke.jsonl").read_text() == before
    again = json.loads((curve_dir / "budget_curve.json").read_text())
    empty = curve_dir.parent / "no_run"
    assert _script().main([*args[:-1], str(empty), "--no-run"]) == 2  # nothing to draw
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no finished jobs of bc" in err[0], err
    assert not list(empty.glob("*"))
    assert _script().main([*args, "--no-run"]) == 0  # the lines there: the same curve
    assert "jobs run" not in capsys.readouterr().out
    assert json.loads((curve_dir / "budget_curve.json").read_text())["methods"] == again["methods"]
    assert _script().main([*args[:5], "0,1", *args[6:]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad budget 'smoke@0'" in err[0], err


def test_the_report_shows_the_curve_next_to_the_results(curve_dir: Path, tmp_path: Path) -> None:
    results = curve_dir / "results_smoke.jsonl"
    text = write_report(results, tmp_path / "with").read_text()
    assert "## Baselines: score against training budget" in text
    assert "| bc | smoke@0.5 | steps 25 |" in text and "| bc | smoke | steps 50 |" in text
    assert "![score against budget](budget_curve.png)" in text
    assert (tmp_path / "with" / "budget_curve.png").is_file()
    # Elsewhere, without a curve beside it: no such part, unless the curve is passed.
    alone = tmp_path / "alone" / "results.jsonl"
    alone.parent.mkdir()
    alone.write_text(results.read_text())
    assert "score against training budget" not in write_report(alone, tmp_path / "w").read_text()
    passed = write_report(alone, tmp_path / "p", curve_dir / "budget_curve.json").read_text()
    assert "## Baselines: score against training budget" in passed
    other = tmp_path / "walker_curve.json"
    curve = json.loads((curve_dir / "budget_curve.json").read_text())
    other.write_text(json.dumps({**curve, "domain": "walker"}))
    with pytest.raises(FbilError, match=r"the budget curve .* is of walker"):
        write_report(alone, tmp_path / "x", other)


def test_reuse_takes_the_matching_jobs_of_a_results_file_instead_of_running_them(
    curve_dir: Path,
    demos_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`--reuse FILE`: FILE's lines of the grid's own jobs are copied, not rerun; lines of
    other jobs (another draw count or budget) are left out."""
    source = tmp_path / "grid.jsonl"
    lines = (curve_dir / "results_smoke.jsonl").read_text().splitlines()
    other = {**json.loads(lines[0]), "draw": 7}  # a job the curve does not run
    source.write_text("\n".join([*lines, lines[0], json.dumps(other)]) + "\n")
    out = tmp_path / "curve"
    args = _args(demos_dir, out)
    assert _script().main([*args, "--reuse", str(source)]) == 0
    printed = capsys.readouterr().out
    assert "smoke: 1 jobs reused" in printed and "smoke: 0 jobs run" in printed
    assert (out / "results_smoke.jsonl").read_text().splitlines() == lines[:1]
    assert _script().main([*args, "--reuse", str(source)]) == 0  # nothing twice
    assert "smoke: 0 jobs reused" in capsys.readouterr().out


def test_reuse_skips_lines_of_another_data_sample(
    curve_dir: Path,
    demos_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A line of the same job on another regeneration of the data (another `data_digest`)
    is rerun, not copied: a curve never mixes two samples."""
    line = json.loads((curve_dir / "results_smoke.jsonl").read_text().splitlines()[0])
    source = tmp_path / "grid.jsonl"
    source.write_text(json.dumps({**line, "data_digest": "0123456789abcdef"}) + "\n")
    out = tmp_path / "curve"
    args = _args(demos_dir, out)
    assert _script().main([*args, "--reuse", str(source)]) == 0
    printed = capsys.readouterr().out
    assert "smoke: 0 jobs reused" in printed and "smoke: 1 jobs run" in printed


def test_merge_keeps_the_other_methods_with_their_tasks(
    curve_dir: Path,
    demos_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    old = json.loads((curve_dir / "budget_curve.json").read_text())
    other = {**old["methods"]["bc"], "points": old["methods"]["bc"]["points"][:1]}
    other.pop("tasks", None)  # an entry from before per-method tasks: the curve's tasks
    committed = tmp_path / "committed.json"
    committed.write_text(
        json.dumps({**old, "tasks": ["loop"], "methods": {"sqil": other, "bc": other}})
    )
    out = tmp_path / "curve"
    args = _args(demos_dir, out)
    assert _script().main([*args, "--merge", str(committed)]) == 0
    merged = json.loads((out / "budget_curve.json").read_text())
    assert list(merged["methods"]) == ["sqil", "bc"] and merged["tasks"] == ["loop", "square"]
    assert merged["methods"]["sqil"]["tasks"] == ["loop"]
    assert merged["methods"]["sqil"]["points"] == other["points"]
    assert merged["methods"]["bc"]["tasks"] == ["square"]
    assert [p["budget"] for p in merged["methods"]["bc"]["points"]] == ["smoke"]
    text = write_report(out / "results_smoke.jsonl", tmp_path / "report").read_text()
    assert "| sqil | smoke@0.5 |" in text and "| bc | smoke |" in text
    # Another draw count cannot be merged: refused in one line before any job runs.
    capsys.readouterr()
    twice = _args(demos_dir, out, draws="2")
    assert _script().main([*twice, "--merge", str(committed)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another draws" in err[0], err
    assert not (tmp_path / "curve" / "results_smoke.jsonl").read_text().count('"draw": 1')


def _entry(*points: tuple[float, float, float]) -> dict[str, Any]:
    return {
        "points": [
            {"scale": s, "budget": f"cpu@{s:g}", "score_pct": score, "ci95_pct": ci}
            for s, score, ci in points
        ]
    }


@pytest.mark.parametrize(
    "points, reading, change",
    [
        (((1.0, 50.0, 2.0), (2.0, 58.0, 3.0)), "rises", 8.0),
        (((1.0, 50.0, 12.0), (2.0, 58.0, 1.0)), "flat", 8.0),  # within the draws' interval
        (((0.5, 10.0, 1.0), (1.0, 70.0, 4.0), (2.0, 50.0, 9.0)), "falls", -20.0),  # from cpu
        (((1.0, 50.0, float("nan")), (2.0, 46.0, 1.0)), "flat", -4.0),  # the 5-point floor
        (((0.25, 20.0, 1.0), (0.5, 40.0, 1.0)), "rises", 20.0),  # no cpu point: the smallest
    ],
)
def test_the_curve_reading_compares_the_largest_budget_with_the_named_one(
    points: tuple[tuple[float, float, float], ...], reading: str, change: float
) -> None:
    from fbil.evaluation.budget_curve import curve_reading, reading_table

    r = curve_reading(_entry(*points))
    assert r is not None and r["reading"] == reading and r["change"] == pytest.approx(change)
    table = reading_table({"methods": {"m": _entry(*points)}})
    assert any(line.startswith("| m |") and reading in line for line in table)
    noted = {**_entry(*points), "note": "seen again later"}
    assert any("seen again later" in line for line in reading_table({"methods": {"m": noted}}))
    assert curve_reading(_entry((1.0, 50.0, 2.0))) is None  # one point: no reading
    assert reading_table({"methods": {"m": _entry((1.0, 50.0, 2.0))}}) == []
