"""Reading ExORL folders unchanged, and refusing damaged ones by name."""

from pathlib import Path

import numpy as np
import pytest

from fbil.data import load_dataset
from fbil.data.storage import episode_arrays, list_episodes, write_episode
from fbil.errors import FbilError


def _exorl_episode(
    rng: np.random.Generator, t: int, obs_dim: int = 4, act_dim: int = 2, phys_dim: int = 4
) -> dict[str, np.ndarray]:
    """One episode exactly as ExORL stores it: T+1 rows, row 0 the reset step."""
    action = rng.uniform(-1, 1, (t + 1, act_dim)).astype(np.float32)
    action[0] = 0
    return {
        "observation": rng.normal(size=(t + 1, obs_dim)).astype(np.float32),
        "action": action,
        "reward": rng.normal(size=(t + 1, 1)).astype(np.float32),
        "discount": np.ones((t + 1, 1), np.float32),
        "physics": rng.normal(size=(t + 1, phys_dim)),
    }


def _write_exorl(root: Path, episodes: list[dict[str, np.ndarray]]) -> Path:
    buf = root / "datasets" / "point_mass_maze" / "rnd" / "buffer"
    buf.mkdir(parents=True)
    for i, ep in enumerate(episodes):
        t = len(ep["observation"]) - 1
        np.savez_compressed(buf / f"20220101T0000{i:02d}_{i}_{t}.npz", **ep)
    return buf.parent


def test_exorl_folder_loads_with_transitions_aligned(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    eps = [_exorl_episode(rng, t) for t in (5, 7, 3)]
    data = load_dataset(_write_exorl(tmp_path, eps))
    assert data.domain == "point_mass_maze"  # inferred from the sizes: no manifest
    assert data.num_episodes == 3 and data.num_transitions == 5 + 7 + 3
    batch = data.sample(64, rng)
    starts = np.cumsum([0] + [len(e["observation"]) for e in eps])
    for k, j in enumerate(batch.index):
        e = int(np.searchsorted(starts, j, side="right") - 1)
        t = j - starts[e]
        assert t >= 1  # the reset row is never a transition's target
        ep = eps[e]
        np.testing.assert_array_equal(batch.obs[k], ep["observation"][t - 1])
        np.testing.assert_array_equal(batch.action[k], ep["action"][t])
        np.testing.assert_array_equal(batch.next_obs[k], ep["observation"][t])
        assert batch.discount[k] == ep["discount"][t, 0]


def test_future_states_stay_in_their_episode(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    data = load_dataset(_write_exorl(tmp_path, [_exorl_episode(rng, 20) for _ in range(4)]))
    idx = data.sample(2000, rng).index
    fut = data.sample_future(idx, 0.9, rng)
    assert np.all(fut >= idx) and np.all(fut <= data.state_episode_end[idx])
    assert np.all(
        np.searchsorted(data.episode_start, fut, side="right")
        == np.searchsorted(data.episode_start, idx, side="right")
    )
    assert (fut > idx).mean() > 0.5  # geometric offsets, mostly ahead


def test_fbil_writes_what_it_reads(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    obs = rng.normal(size=(11, 4)).astype(np.float32)
    arrays = episode_arrays(
        obs, rng.uniform(-1, 1, (10, 2)), np.arange(10.0), rng.normal(size=(11, 4))
    )
    path = write_episode(tmp_path, 0, arrays)
    assert path.name.endswith("_0_10.npz") and path.parent.name == "buffer"
    assert [f.index for f in list_episodes(tmp_path)] == [0]
    data = load_dataset(tmp_path, domain="point_mass_maze")
    np.testing.assert_array_equal(data.observation, obs)
    assert data.action[0].tolist() == [0.0, 0.0]


def test_empty_folder_is_refused(tmp_path: Path) -> None:
    (tmp_path / "buffer").mkdir()
    with pytest.raises(FbilError, match="no episodes in"):
        load_dataset(tmp_path)
    with pytest.raises(FbilError, match="no dataset at"):
        load_dataset(tmp_path / "missing")


@pytest.mark.parametrize(
    "defect", ["truncated", "garbage", "npy", "mismatched", "missing_key", "nan"]
)
def test_damaged_files_are_named(tmp_path: Path, defect: str) -> None:
    rng = np.random.default_rng(3)
    root = _write_exorl(tmp_path, [_exorl_episode(rng, 6), _exorl_episode(rng, 6)])
    bad = sorted((root / "buffer").glob("*.npz"))[1]
    if defect == "truncated":
        bad.write_bytes(bad.read_bytes()[:100])
    elif defect == "garbage":
        bad.write_bytes(b"not a zip file at all")
    elif defect == "npy":  # a plain .npy under the episode's name: np.load gives an array
        with bad.open("wb") as f:
            np.save(f, np.zeros(3))
    else:
        ep = _exorl_episode(rng, 6)
        if defect == "mismatched":
            ep["action"] = ep["action"][:-2]
        elif defect == "missing_key":
            del ep["physics"]
        else:
            ep["observation"][3, 1] = np.nan
        np.savez_compressed(bad, **ep)
    with pytest.raises(FbilError) as err:
        load_dataset(root)
    message = str(err.value)
    assert bad.name in message and "\n" not in message


def test_dataset_of_another_domain_is_refused(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    root = _write_exorl(tmp_path, [_exorl_episode(rng, 5)])
    with pytest.raises(FbilError, match=r"holds point_mass_maze data .* not walker"):
        load_dataset(root, domain="walker")
    odd = _write_exorl(tmp_path / "odd", [_exorl_episode(rng, 5, obs_dim=7)])
    with pytest.raises(FbilError, match="cannot tell the domain"):
        load_dataset(odd)


FIXTURE = Path(__file__).parents[1] / "fixtures" / "exorl" / "point_mass_maze" / "rnd"


def test_committed_exorl_fixture_loads_and_relabels(tmp_path: Path) -> None:
    import shutil

    shutil.copytree(FIXTURE, tmp_path / "rnd")  # relabeling writes a cache beside the data
    data = load_dataset(tmp_path / "rnd")  # no manifest: the domain comes from array sizes
    assert data.domain == "point_mass_maze"
    assert data.num_episodes == 4 and data.num_transitions == 4000
    # The maze observes (x, y, vx, vy), which is its physics state.
    np.testing.assert_array_equal(data.observation, data.physics().astype(np.float32))
    r = data.reward("reach_top_left")
    assert r.shape == (4000,) and r.dtype == np.float32 and r.max() > 0


def test_merged_folder_holds_every_episode_in_order(tmp_path: Path) -> None:
    from fbil.data.dataset import merge_datasets

    rng = np.random.default_rng(3)
    a = [_exorl_episode(rng, t) for t in (5, 7)]
    b = [_exorl_episode(rng, t) for t in (4, 6, 3)]
    src_a = _write_exorl(tmp_path / "a", a)
    src_b = _write_exorl(tmp_path / "b", b)
    out = tmp_path / "merged"
    manifest = merge_datasets(out, [src_a, src_b], command="fbil dataset-merge a b")
    data = load_dataset(out)
    assert data.domain == "point_mass_maze" and manifest["episodes"] == 5
    assert [p["episodes"] for p in manifest["merged_from"]] == [2, 3]
    assert data.num_transitions == 5 + 7 + 4 + 6 + 3
    np.testing.assert_array_equal(
        data.observation, np.concatenate([e["observation"] for e in a + b])
    )  # the first source's episodes, then the second's, each whole
    assert sorted(p.name for p in out.iterdir()) == ["buffer", "manifest.json"]


def test_merge_refuses_mixed_domains_and_an_existing_folder(tmp_path: Path) -> None:
    from fbil.data.dataset import merge_datasets

    rng = np.random.default_rng(4)
    maze = _write_exorl(tmp_path / "a", [_exorl_episode(rng, 5)])
    cheetah = _write_exorl(tmp_path / "b", [_exorl_episode(rng, 5, 17, 6, 18)])
    with pytest.raises(FbilError, match="different or unknown domains"):
        merge_datasets(tmp_path / "m", [maze, cheetah])
    assert not (tmp_path / "m").exists()
    (tmp_path / "m").mkdir()
    with pytest.raises(FbilError, match="already exists"):
        merge_datasets(tmp_path / "m", [maze, maze])
