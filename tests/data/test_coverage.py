"""Coverage summaries through the domains' hooks: the maze's grid numbers as before, the
locomotion summary against random actions, and what a domain without hooks gets."""

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fbil.data import load_dataset
from fbil.data.collect import collect
from fbil.data.coverage import coverage_text, coverage_tracker, dataset_info, plot_coverage
from fbil.data.oversample import oversample_crossings
from fbil.data.storage import episode_arrays, write_episode, write_manifest
from fbil.envs import DOMAINS, BatchedEnv, RandomPolicy
from fbil.envs.hooks import DomainHooks
from fbil.errors import FbilError

WALKER_FEATURES = {"torso_height", "torso_angle", "horizontal_velocity", "angular_momentum"}


def test_maze_coverage_numbers_are_those_of_the_fixture(fixture_data: Path) -> None:
    info = dataset_info(load_dataset(fixture_data))
    cov = info["coverage"]
    assert (cov["free_cells"], cov["visited_cells"], cov["rooms_visited"]) == (
        356,
        15,
        ["top_left"],
    )
    assert cov["room_fraction"]["top_left"] == pytest.approx(15 / 89)
    assert cov["doorway_crossings"]["transitions"] == 0
    lines = coverage_text(info)
    assert lines[0].startswith("coverage: 4.2% of 356 free cells (20x20 grid)")
    assert coverage_tracker("point_mass_maze").summary() == "0% cells"


def test_walker_coverage_from_the_command_line(tmp_path: Path) -> None:
    data, plot = tmp_path / "walker", tmp_path / "cov.png"
    collect("walker", "random", 2, data, progress=False)
    args = ["dataset-info", str(data), "--json", "--plot", str(plot)]
    res = subprocess.run([sys.executable, "-m", "fbil", *args], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    info = json.loads(res.stdout)
    cov = info["coverage"]
    assert cov["states_used"] == 2000 and cov["reference"]["episodes"] == 8
    assert set(cov["quantities"]) == WALKER_FEATURES
    heights = load_dataset(data).quantities()["torso_height"]
    assert cov["quantities"]["torso_height"]["max"] == pytest.approx(heights.max(), abs=1e-5)
    for f in cov["quantities"].values():
        assert f["min"] <= f["p01"] <= f["median"] <= f["p99"] <= f["max"]
        h = f["histogram"]
        assert len(h["edges"]) == len(h["data"]) + 1 == len(h["random"]) + 1
        assert sum(h["data"]) == pytest.approx(1, abs=1e-3)
    assert set(cov["tasks"]) == {"stand", "walk", "run", "flip", "spin"}
    assert "features go well past random actions'" in cov["verdict"]
    assert plot.read_bytes()[:4] == b"\x89PNG"
    text = "\n".join(coverage_text(info))
    assert "torso height (m)" in text and "verdict:" in text


def test_faster_data_goes_past_random_actions(tmp_path: Path) -> None:
    """States with four times random actions' velocities: speed and angular momentum
    reach far past the reference, the torso's height does not."""
    ran = BatchedEnv("walker", None, 2).rollout(RandomPolicy(6, 1), [10, 11], steps=300)
    physics = ran.physics.copy()
    physics[..., 9:] *= 4  # qvel
    for i in range(2):
        arrays = episode_arrays(ran.observation[i], ran.action[i], ran.reward[i], physics[i])
        write_episode(tmp_path, i, arrays)
    write_manifest(tmp_path, {"domain": "walker"})
    dataset = load_dataset(tmp_path)
    cov = dataset_info(dataset)["coverage"]
    feats = cov["quantities"]
    assert feats["horizontal_velocity"]["spread_vs_random"] > 2
    assert feats["angular_momentum"]["beyond_random"] > 0.2
    assert feats["torso_height"]["spread_vs_random"] < 1.5
    assert "(horizontal_velocity, angular_momentum)" in cov["verdict"]
    assert plot_coverage(dataset, tmp_path / "c.png").is_file()  # drawn from the same summary


def test_a_domain_without_hooks_gets_the_generic_parts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    collect("cheetah", "random", 1, tmp_path / "c", progress=False)
    monkeypatch.setitem(
        DOMAINS, "cheetah", dataclasses.replace(DOMAINS["cheetah"], hooks=DomainHooks())
    )
    dataset = load_dataset(tmp_path / "c")
    info = dataset_info(dataset)
    assert "coverage" not in info and info["transitions"] == 1000
    assert coverage_text(info) == []
    tracker = coverage_tracker("cheetah")
    tracker.update(dataset.observation)
    assert tracker.summary().startswith("|s| std")
    with pytest.raises(FbilError, match="defines no coverage picture"):
        plot_coverage(dataset, tmp_path / "x.png")
    with pytest.raises(FbilError, match="oversampling is defined only in point_mass_maze"):
        oversample_crossings(tmp_path / "c", tmp_path / "o")
    with pytest.raises(FbilError, match="--starts uniform is defined for point_mass_maze only"):
        collect("cheetah", "random", 1, tmp_path / "u", starts="uniform", progress=False)


def test_uniform_starts_spread_the_maze_episodes(tmp_path: Path) -> None:
    from fbil.envs.maze_geometry import random_free_positions

    collect("point_mass_maze", "random", 2, tmp_path, starts="uniform", progress=False)
    first = load_dataset(tmp_path).observation[[0, 1001], :2]
    expected = random_free_positions(np.random.default_rng(0), 2)  # episode seeds 0, 1
    np.testing.assert_allclose(first, expected, atol=1e-6)
