"""scripts/goal_tracking_probe.py on the committed maze FB and goal models and a demo."""

from pathlib import Path

import numpy as np
import pytest

from tests.script_module import load_script

ARTIFACTS = Path(__file__).resolve().parents[1] / "artifacts"
probe = load_script("goal_tracking_probe")


def test_a_tracker_started_in_the_demo_starts_on_it_and_scores_a_share_of_it() -> None:
    from fbil.baselines.goal_model import GoalModel
    from fbil.fb.model import FBModel
    from fbil.imitation.demos import Demos

    fb = FBModel.load(ARTIFACTS / "models" / "point_mass_maze")
    goal = GoalModel.load(ARTIFACTS / "goal_models" / "point_mass_maze")
    demos = Demos.load(ARTIFACTS / "demos" / "point_mass_maze" / "loop.npz").select([0, 1])
    last = len(demos.trajectories[0]) - 20
    out = probe.track(fb, goal, demos, "loop", last)
    assert set(out) == {"goal_td3", "goalfb"}
    for row in out.values():
        # 21 states compared, the first one the demo's own: the mean distance is small
        # against the goal radius, and a share of the demo's return is a finite number.
        assert 0.0 <= row["distance"] < goal.config.epsilon
        assert 0.0 <= row["within"] <= 1.0 and np.isfinite(row["return_share"])


def test_a_start_past_the_demo_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    args = [
        "--model", str(ARTIFACTS / "models" / "point_mass_maze"),
        "--goal-model", str(ARTIFACTS / "goal_models" / "point_mass_maze"),
        "--demos", str(ARTIFACTS / "demos" / "point_mass_maze"),
        "--tasks", "loop", "--demos-used", "1", "--starts", "5000",
    ]  # fmt: skip
    assert probe.main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "past the demos'" in err[0]


def test_in_the_data_the_maze_goal_policies_get_closer_than_zero_actions(
    fixture_data: Path,
) -> None:
    from fbil.baselines.goal_model import GoalModel
    from fbil.data import load_dataset
    from fbil.fb.model import FBModel

    fb = FBModel.load(ARTIFACTS / "models" / "point_mass_maze")
    goal = GoalModel.load(ARTIFACTS / "goal_models" / "point_mass_maze")
    out = probe.reach(fb, goal, load_dataset(fixture_data), "loop", 40, 10)
    assert set(out) == {"goal_td3", "goalfb", "zero_action"}
    assert all(0.0 <= r["reached"] <= 1.0 for r in out.values())
    # Both trained goal reachers end nearer their goals than a point mass left to drift.
    assert out["goal_td3"]["closest"] < out["zero_action"]["closest"]
    assert out["goalfb"]["closest"] < out["zero_action"]["closest"]
