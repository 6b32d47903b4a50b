"""scripts/goal_lookahead_sweep.py on the committed maze goal model and its demos."""

from pathlib import Path

import pytest

from tests.script_module import load_script

ARTIFACTS = Path(__file__).resolve().parents[1] / "artifacts"
sweep = load_script("goal_lookahead_sweep")


def test_the_k10_column_is_the_benchmarks_goal_td3_score() -> None:
    """The sweep scores the benchmark's own draw, seeds and episodes: at k = 10 it repeats
    `evaluate`'s goal_td3 score; another k is another policy on the same episodes."""
    from fbil.baselines.goal_model import GoalModel
    from fbil.evaluation.evaluate import evaluate
    from fbil.imitation.demos import Demos

    goal = GoalModel.load(ARTIFACTS / "goal_models" / "point_mass_maze")
    demos = Demos.load(ARTIFACTS / "demos" / "point_mass_maze" / "reach_top_left.npz")
    scores = sweep.sweep(goal, demos, "reach_top_left", [10, 1], draws=2, episodes=2, seed=3)
    for draw in (0, 1):
        bench = evaluate(None, demos, "goal_td3", draw=draw, episodes=2, seed=3, goal_model=goal)
        assert scores["10"][draw] == pytest.approx(bench["results"]["goal_td3"].score, abs=1e-9)
    assert len(scores["1"]) == 2


def test_bad_lookaheads_are_one_line_and_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["--goal-model", str(ARTIFACTS / "goal_models" / "point_mass_maze"),
            "--demos", "x", "--lookaheads", "0,10"]  # fmt: skip
    assert sweep.main(args) == 2
    assert (
        capsys.readouterr().err.strip() == "error: --lookaheads must be integers >= 1, got '0,10'"
    )
