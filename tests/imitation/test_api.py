"""imitate() and `fbil imitate` on a real (smoke) FB model and real maze episodes."""

import json
import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from fbil.data import list_episodes, load_episode
from fbil.errors import FbilError
from fbil.fb.model import FBModel
from fbil.imitation import (
    MAIN_METHODS,
    Demos,
    ImitationPolicy,
    OptimiserConfig,
    Trajectory,
    from_arrays,
    from_imitation,
    imitate,
)


@pytest.fixture(scope="module")
def demos(fixture_data: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two 200-step maze trajectories with actions, from the fixture episodes."""
    trajs = []
    for f in list_episodes(fixture_data)[:2]:
        ep = load_episode(f.path)
        trajs.append(
            Trajectory(
                ep["observation"][:201],
                ep["action"][1:201],
                ep["reward"][1:201, 0],
                ep["physics"][:201],
            )
        )
    path = tmp_path_factory.mktemp("demos") / "maze.npz"
    Demos(trajs, {"domain": "point_mass_maze", "task": "none"}).save(path)
    return path


def test_every_method_returns_a_projected_z_quickly(smoke_model_dir: Path, demos: Path) -> None:
    model = FBModel.load(smoke_model_dir)
    d = Demos.load(demos)
    fast = OptimiserConfig(steps=30)
    for method in MAIN_METHODS:
        policy = imitate(model, d, method, optimiser=fast)
        norms = policy.z.norm(dim=-1)
        torch.testing.assert_close(norms, torch.full_like(norms, math.sqrt(model.z_dim)))
        assert policy.seconds > 0
        actions = policy.act(np.zeros((3, 4), np.float32), step=5)
        assert actions.shape == (3, 2) and np.all(np.abs(actions) <= 1)
    goal = imitate(model, d, "goalfb")
    assert goal.is_schedule and goal.z.shape == (201, model.z_dim)


def test_policy_json_round_trip_and_step_counter(
    smoke_model_dir: Path, demos: Path, tmp_path: Path
) -> None:
    model = FBModel.load(smoke_model_dir)
    policy = imitate(model, Demos.load(demos), "goalfb", lookahead=5)
    back = ImitationPolicy.load(policy.save(tmp_path / "goal.json"), model)
    torch.testing.assert_close(back.z, policy.z)
    obs = np.full((2, 4), 0.1, np.float32)
    np.testing.assert_array_equal(back.act(obs), policy.act(obs, step=0))  # own counter
    np.testing.assert_array_equal(back.act(obs), policy.act(obs, step=1))
    back.reset()
    np.testing.assert_array_equal(back.act(obs), policy.act(obs, step=0))


def test_demo_files_round_trip(demos: Path, tmp_path: Path) -> None:
    d = Demos.load(demos)
    again = Demos.load(d.save(tmp_path / "again.npz"))
    assert len(again) == 2 and again.metadata["domain"] == "point_mass_maze"
    for a, b in zip(d.trajectories, again.trajectories, strict=True):
        np.testing.assert_array_equal(a.observation, b.observation)
        np.testing.assert_array_equal(a.action, b.action)
        np.testing.assert_array_equal(a.physics, b.physics)


def test_conversions_from_arrays_and_the_imitation_library() -> None:
    obs = [np.zeros((5, 4)), np.ones((3, 4))]
    acts = [np.zeros((4, 2)), np.ones((2, 2))]
    d = from_imitation([SimpleNamespace(obs=o, acts=a) for o, a in zip(obs, acts, strict=True)])
    assert len(d) == 2 and d.has_actions and len(d.trajectories[1]) == 2


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: Demos([]), "no trajectories"),
        (lambda: from_arrays([np.zeros((1, 4))]), "at least two states"),
        (lambda: from_arrays([np.full((5, 4), np.nan)]), "NaN"),
        (lambda: from_arrays([np.zeros((5, 4))], [np.zeros((3, 2))]), "T = 4"),
    ],
)
def test_bad_demos_are_refused(make, message: str) -> None:
    with pytest.raises(FbilError, match=message):
        make().validate()


def _write_npz(path: Path, **arrays: np.ndarray) -> Path:
    np.savez(path, **arrays)
    return path


def _physics_file(path: Path, physics_rows: int, of: list[int] | None) -> Path:
    """Two trajectories of 5 and 6 states with `physics_rows` physics rows (`of`: whose)."""
    arrays = {"observation": np.zeros((11, 4)), "offsets": np.array([0, 5, 11])}
    arrays["physics"] = np.zeros((physics_rows, 3))
    if of is not None:
        arrays["physics_of"] = np.array(of)
    return _write_npz(path, **arrays)


def test_a_demo_file_can_keep_physics_for_some_trajectories_only(tmp_path: Path) -> None:
    """`fbil demos --physics first` keeps the physics states of the demo pictures draw:
    they load back on that trajectory, and the others load without any."""
    obs = [np.full((5, 4), i, np.float32) for i in range(3)]
    demos = from_arrays(obs)
    demos.trajectories[1].physics = np.arange(15.0).reshape(5, 3)
    Demos(demos.trajectories, {}).save(tmp_path / "d.npz")
    back = Demos.load(tmp_path / "d.npz")
    assert [t.physics is None for t in back.trajectories] == [True, False, True]
    np.testing.assert_array_equal(back.trajectories[1].physics, np.arange(15.0).reshape(5, 3))
    np.testing.assert_array_equal(back.trajectories[2].observation, obs[2])


@pytest.mark.parametrize(
    "write, message",
    [
        (lambda p: p.write_bytes(b"not a zip") and p, "not an .npz archive"),
        (lambda p: np.save(p.with_suffix(".npy"), np.zeros(3)) or p.with_suffix(".npy"), "npz"),
        (lambda p: _write_npz(p, observation=np.zeros((11, 4))), "needs arrays"),
        (lambda p: _write_npz(p, observation=np.zeros((11, 4)), offsets=[0, 50]), "rise from 0"),
        (lambda p: _write_npz(p, observation=np.zeros((11, 4)), offsets=[0, 6, 3, 11]), "rise"),
        (lambda p: _write_npz(p, observation=np.zeros((11, 4)), offsets=[0.0, 11.0]), "integer"),
        (lambda p: _physics_file(p, physics_rows=10, of=None), "physics rows do not match"),
        (lambda p: _physics_file(p, physics_rows=5, of=[2]), "physics rows do not match"),
        (lambda p: _physics_file(p, physics_rows=5, of=[0, 0]), "physics rows do not match"),
    ],
)
def test_damaged_demo_files_are_refused_in_one_line(tmp_path: Path, write, message: str) -> None:
    path = write(tmp_path / "demo.npz")
    with pytest.raises(FbilError, match=message) as err:
        Demos.load(path)
    assert "\n" not in str(err.value)


def test_model_and_method_mismatches_are_refused(smoke_model_dir: Path) -> None:
    model = FBModel.load(smoke_model_dir)
    action_free = from_arrays([np.zeros((6, 4))])
    with pytest.raises(FbilError, match="bcfb needs expert actions"):
        imitate(model, action_free, "bcfb")
    with pytest.raises(FbilError, match="valid methods: erfb"):
        imitate(model, action_free, "gail")
    with pytest.raises(FbilError, match="model expects 4"):
        imitate(model, from_arrays([np.zeros((6, 24))]), "erfb")


def test_cli_imitate_prints_times_and_z(smoke_model_dir: Path, demos: Path, tmp_path: Path) -> None:
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "fbil",
            "imitate",
            str(smoke_model_dir),
            str(demos),
            "--methods",
            "erfb,goalfb,bcfb",
            "--json",
            "--out",
            str(tmp_path / "policies"),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    methods = json.loads(res.stdout)["methods"]
    assert set(methods) == {"erfb", "goalfb", "bcfb"}
    for r in methods.values():
        assert r["seconds"] > 0 and r["z_norm"] == pytest.approx(math.sqrt(8), rel=1e-4)
    assert (tmp_path / "policies" / "goalfb.json").is_file()
    bad = subprocess.run(
        [sys.executable, "-m", "fbil", "imitate", str(smoke_model_dir), str(tmp_path / "none.npz")],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "no demonstrations at" in bad.stderr
