"""Recipes compared (issue #23): arms of model seeds summarised over the methods every arm
has, in the paper's order, the one-seed arm without a spread, the report's section, and
the script's one-line errors; synthetic model folders and results lines only."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fbil.errors import FbilError
from fbil.evaluation.recipes import build_arm, build_recipes, recipes_section
from fbil.evaluation.report import write_report
from tests.evaluation.test_seeds import _model, _results
from tests.script_module import load_script

recipes_table = load_script("recipes_table")
model_seeds = load_script("model_seeds")


@pytest.fixture
def arms(tmp_path: Path) -> dict[str, str]:
    """Arm A: two seeds in a seeds.json; arm B: one model with its results file."""
    runs = []
    for seed, (reach, erfb, goalfb) in enumerate([(400.0, 0.4, 0.6), (600.0, 0.6, 1.0)]):
        model = _model(tmp_path, f"a{seed}", seed, {"reach_a": reach, "loop": 200.0})
        runs.append(f"--run={model}={_results(tmp_path, model, erfb, goalfb)}")
    assert model_seeds.main([*runs, "--out", str(tmp_path / "seeds_a.json")]) == 0
    single = _model(tmp_path, "b0", 7, {"reach_a": 900.0, "loop": 360.0})
    return {
        "A": str(tmp_path / "seeds_a.json"),
        "B": f"{single}@{_results(tmp_path, single, 0.9, 0.3)}",
    }


def test_arms_side_by_side_in_the_script_and_the_report(
    arms: dict[str, str], tmp_path: Path
) -> None:
    out = tmp_path / "results"
    out.mkdir()
    argv = [f"--arm=A={arms['A']}", f"--arm=B={arms['B']}", "--describe=B=one seed only"]
    assert recipes_table.main([*argv, "--zero-shot-tasks", "reach_a", "--out", str(out)]) == 0
    recipes = json.loads((out / "recipes.json").read_text())
    assert recipes["methods"] == ["erfb", "goalfb"]  # the paper's order, not the file's
    a, b = recipes["arms"]
    assert a["seeds"] == [0, 1] and b["seeds"] == [7]
    assert a["zero_shot_mean"]["mean"] == pytest.approx(500.0)  # reach_a only, not loop
    assert a["zero_shot_mean"]["std"] == pytest.approx(141.421, abs=1e-3)
    assert a["mean_of_methods"]["mean"] == pytest.approx(0.65)  # seeds 0.5 and 0.8
    assert a["mean_of_methods"]["std"] == pytest.approx(0.212132, abs=1e-6)
    assert b["mean_of_methods"]["mean"] == pytest.approx(0.6)
    results = out / "results.jsonl"
    results.write_text(Path(arms["B"].split("@")[1]).read_text())
    text = write_report(results, tmp_path / "report").read_text()
    assert "## Recipes compared" in text
    assert "| A | 0, 1 | 500.0 ± 141.4 | 50.0 ± 14.1 | 80.0 ± 28.3 | **65.0 ± 21.2** |" in text
    assert "| B | 7 | 900.0 | 90.0 | 30.0 | **60.0** |" in text  # one seed: no spread
    assert "| paper (10 GPU-trained models) | – | – | 72.8 | 88.6 | 80.7 |" in text
    assert "- **B**: one seed only" in text
    assert "ERFB's return from one demo" not in text  # no ERFB return on reach_a: no ratios


def test_erfb_against_zero_shot_per_task(arms: dict[str, str], tmp_path: Path) -> None:
    argv = [f"--arm=A={arms['A']}", f"--arm=B={arms['B']}", "--zero-shot-tasks", "loop"]
    assert recipes_table.main([*argv, "--out", str(tmp_path / "r.json")]) == 0
    a, b = json.loads((tmp_path / "r.json").read_text())["arms"]
    # ERFB returns 0.4 and 0.6 of the expert's 200 on loop; zero-shot 200 on both seeds.
    assert a["ratio_to_zero_shot"]["erfb"] == {"loop": pytest.approx(0.5)}
    assert b["ratio_to_zero_shot"]["erfb"] == {"loop": pytest.approx(0.5)}  # 180 / 360
    text = "\n".join(recipes_section(json.loads((tmp_path / "r.json").read_text())))
    assert "| recipe | loop |" in text and "| A | 0.50 |" in text and "| B | 0.50 |" in text


def test_arms_must_compare(tmp_path: Path) -> None:
    entry = {"model": "m", "seed": 0, "domain": "point_mass_maze", "zero_shot_mean": 1.0,
             "zero_shot": {}, "scores": {"erfb": 0.5}}  # fmt: skip
    arm = build_arm("x", "", [entry], [])
    with pytest.raises(FbilError, match="at least 2 arms"):
        build_recipes([arm], [])
    with pytest.raises(FbilError, match="names repeat"):
        build_recipes([arm, arm], [])
    walker = build_arm("w", "", [{**entry, "domain": "walker"}], [])
    with pytest.raises(FbilError, match="mix domains"):
        build_recipes([arm, walker], [])
    other = build_arm("y", "", [{**entry, "scores": {"bcfb": 0.5}}], [])
    with pytest.raises(FbilError, match="share no method"):
        build_recipes([arm, other], [])
    with pytest.raises(FbilError, match="no zero-shot return for reach_a"):
        build_arm("z", "", [entry], ["reach_a"])


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--arm=A"], "give NAME=VALUE"),
        (["--arm=C=nowhere.json"], "no such seeds file"),
        (["--describe=D=what"], "--describe names no arm: D"),
    ],
)
def test_script_mistakes_are_one_line_errors(
    arms: dict[str, str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
    message: str,
) -> None:
    base = [f"--arm=A={arms['A']}", f"--arm=B={arms['B']}"]
    out = tmp_path / "r.json"
    assert recipes_table.main([*base, *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_no_ratio_where_the_model_fails_with_the_true_reward(tmp_path: Path) -> None:
    """A zero-shot return near 0 would make any ERFB return a huge ratio: none is shown."""
    runs = []
    for seed, loop in enumerate([200.0, 10.0]):  # seed 1 fails loop with z_r
        model = _model(tmp_path, f"c{seed}", seed, {"reach_a": 500.0, "loop": loop})
        runs.append(f"--run={model}={_results(tmp_path, model, 0.4, 0.6)}")
    assert model_seeds.main([*runs, "--out", str(tmp_path / "seeds_c.json")]) == 0
    single = _model(tmp_path, "d0", 3, {"reach_a": 500.0, "loop": 400.0})
    argv = [f"--arm=C={tmp_path / 'seeds_c.json'}", f"--arm=D={single}@" + str(
        _results(tmp_path, single, 0.5, 0.5))]  # fmt: skip
    out = tmp_path / "r.json"
    assert recipes_table.main([*argv, "--zero-shot-tasks", "loop", "--out", str(out)]) == 0
    c, d = json.loads(out.read_text())["arms"]
    assert c["ratio_to_zero_shot"]["erfb"] == {"loop": None}
    assert d["ratio_to_zero_shot"]["erfb"] == {"loop": pytest.approx(0.25)}  # 100 / 400
    text = "\n".join(recipes_section(json.loads(out.read_text())))
    assert "| C | z_r < 50 |" in text and "| D | 0.25 |" in text
    assert "fails the task with the true reward" in text
