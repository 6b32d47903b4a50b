"""scripts/slim_demos.py: a demo file rewritten with physics for its first demo only keeps
everything else bit for bit, is smaller, and bad input is one line and exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fbil.imitation.demos import Demos, Trajectory
from tests.script_module import load_script

slim = load_script("slim_demos")


def _demos(n: int = 3, steps: int = 40) -> Demos:
    rng = np.random.default_rng(0)
    trajs = [
        Trajectory(
            observation=rng.normal(size=(steps + 1, 5)).astype(np.float32),
            action=rng.uniform(-1, 1, size=(steps, 2)).astype(np.float32),
            reward=rng.uniform(size=steps).astype(np.float32),
            physics=rng.normal(size=(steps + 1, 7)),
        )
        for _ in range(n)
    ]
    return Demos(trajs, {"domain": "walker", "task": "walk"})


def test_first_keeps_one_demos_physics_and_every_other_array(tmp_path: Path) -> None:
    path, out = tmp_path / "walk.npz", tmp_path / "slim.json"
    original = _demos()
    original.save(path)
    before = path.stat().st_size
    assert slim.main([str(path), "--physics", "first", "--json", str(out)]) == 0
    again = Demos.load(path)
    assert path.stat().st_size < before
    assert [t.physics is not None for t in again.trajectories] == [True, False, False]
    np.testing.assert_array_equal(again.trajectories[0].physics, original.trajectories[0].physics)
    for s, t in zip(original.trajectories, again.trajectories, strict=True):
        for key in ("observation", "action", "reward"):
            np.testing.assert_array_equal(getattr(s, key), getattr(t, key))
    assert again.metadata == original.metadata
    (record,) = json.loads(out.read_text())
    assert record["bytes_before"] == before and record["physics_kept"] == 1
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


def test_none_drops_all_and_a_second_slim_to_first_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "walk.npz"
    _demos().save(path)
    assert slim.main([str(path), "--physics", "none"]) == 0
    assert all(t.physics is None for t in Demos.load(path).trajectories)
    capsys.readouterr()
    data = path.read_bytes()
    assert slim.main([str(path), "--physics", "first"]) == 2  # nothing left to keep
    assert "no physics states to keep" in capsys.readouterr().err
    assert path.read_bytes() == data  # left as it was


@pytest.mark.parametrize(
    "args, says",
    [
        (["missing.npz"], "no demonstrations at"),
        (["walk.npz", "--physics", "some"], "unknown --physics 'some'"),
        (["not_demos.npz"], "not an .npz archive"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], says: str
) -> None:
    _demos().save(tmp_path / "walk.npz")
    (tmp_path / "not_demos.npz").write_text("hello")
    paths = [str(tmp_path / a) if a.endswith(".npz") else a for a in args]
    assert slim.main(paths) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0]
