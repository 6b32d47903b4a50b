"""OTR: the reward of a hand-computed 2 x 2 transport, the reward of an episode that is the
demonstration (maximal) against perturbed and other episodes, the dataset's relabeling
order, and OTR end to end through `fbil evaluate` at smoke size."""

import json
import math
from pathlib import Path

import numpy as np

from fbil.baselines.otr import OTRConfig, cosine_cost, otr_rewards, relabel, return_scale
from fbil.data import load_dataset
from fbil.data.oversample import oversample_crossings
from fbil.imitation import from_arrays
from tests.baselines.test_baselines import fbil


def test_the_reward_of_a_two_step_episode_matches_the_hand_computed_transport() -> None:
    """Uniform 2 x 2 marginals force P = [[p, 1/2 - p], [1/2 - p, p]], and Sinkhorn's
    P = diag(u) exp(-C / eps) diag(v) fixes p / (1/2 - p) = exp(-(C11 + C22 - C12 - C21)
    / (2 eps)); then c_i = 2 sum_j P_ij C_ij and r_i = alpha exp(-beta c_i / d)."""
    x = np.array([[1.0, 0.0], [0.0, 1.0]])
    y = np.array([[1.0, 0.0], [1.0, 1.0]])
    c = np.array([[0.0, 1 - 1 / math.sqrt(2)], [1.0, 1 - 1 / math.sqrt(2)]])
    np.testing.assert_allclose(cosine_cost(x, y), c, atol=1e-12)
    eps = 0.5
    k = math.exp(-(c[0, 0] + c[1, 1] - c[0, 1] - c[1, 0]) / (2 * eps))
    p = k / (2 * (1 + k))
    cost = [2 * (p * c[0, 0] + (0.5 - p) * c[0, 1]), 2 * ((0.5 - p) * c[1, 0] + p * c[1, 1])]
    cfg = OTRConfig(epsilon=eps, iterations=200, alpha=5.0, beta=5.0)
    expected = [5.0 * math.exp(-5.0 * ci / 2) for ci in cost]
    np.testing.assert_allclose(otr_rewards(x, y, cfg), expected, rtol=1e-9)


def test_the_demonstration_itself_gets_the_maximal_reward(fixture_data: Path) -> None:
    dataset = load_dataset(fixture_data)
    s, e = dataset.episode_start, dataset.episode_end
    demo = dataset.observation[s[0] + 1 : e[0] + 1]
    other = dataset.observation[s[1] + 1 : e[1] + 1]
    cfg = OTRConfig()
    same = otr_rewards(demo, demo, cfg)
    assert same.min() > 0.99 * cfg.alpha and same.max() <= cfg.alpha  # r <= alpha always
    noisy = demo + np.random.default_rng(0).normal(0, 0.02, demo.shape).astype(np.float32)
    for worse in (noisy, other):
        assert otr_rewards(worse, demo, cfg).sum() < same.sum() - 0.5
    # OT matches sets of states: a shuffled episode gets the same rewards, shuffled.
    order = np.random.default_rng(1).permutation(len(demo))
    np.testing.assert_allclose(otr_rewards(demo[order], demo, cfg), same[order], rtol=1e-6)


def test_relabeling_follows_the_datasets_transition_order(fixture_data: Path) -> None:
    dataset = load_dataset(fixture_data)
    s, e = dataset.episode_start, dataset.episode_end
    obs = dataset.observation
    demos = from_arrays([obs[s[2] : e[2] + 1]])  # the demo's states after its first
    cfg = OTRConfig(iterations=30)
    rewards = relabel(dataset, demos, cfg).numpy()
    assert rewards.shape == (dataset.num_transitions,)
    for ep in range(dataset.num_episodes):
        rows = np.flatnonzero((dataset.next_index > s[ep]) & (dataset.next_index <= e[ep]))
        expected = otr_rewards(obs[s[ep] + 1 : e[ep] + 1], obs[s[2] + 1 : e[2] + 1], cfg)
        np.testing.assert_allclose(rewards[rows], expected, rtol=1e-5)
    # Two demos: each episode takes the rewards of the one that rewards it most.
    both = from_arrays([obs[s[2] : e[2] + 1], obs[s[0] : e[0] + 1]])
    best = relabel(dataset, both, cfg).numpy()
    rows0 = np.flatnonzero(dataset.next_index <= e[0])
    assert best[rows0].min() > 0.99 * cfg.alpha
    assert np.all(best.reshape(4, -1).sum(1) >= rewards.reshape(4, -1).sum(1) - 1e-6)


def test_the_return_span_option_stretches_episode_returns_to_the_span(fixture_data: Path) -> None:
    """OTR's reference rescaling: rewards x span / (max - min episode return), so the
    relabeled episodes' returns then differ by exactly `span`; the default leaves them."""
    dataset = load_dataset(fixture_data)
    s, e = dataset.episode_start, dataset.episode_end
    demos = from_arrays([dataset.observation[s[2] : e[2] + 1]])
    plain = relabel(dataset, demos, OTRConfig(iterations=30)).numpy()
    scaled = relabel(dataset, demos, OTRConfig(iterations=30, return_span=1000.0)).numpy()
    returns = np.array(
        [
            scaled[(dataset.next_index > s[ep]) & (dataset.next_index <= e[ep])].sum()
            for ep in range(dataset.num_episodes)
        ]
    )
    assert abs(returns.max() - returns.min() - 1000.0) < 0.1  # float32 sums
    np.testing.assert_allclose(scaled / plain, scaled[0] / plain[0], rtol=1e-5)
    assert return_scale([np.ones(3), np.ones(3)], 1000.0) == 1.0  # equal returns: no scale


def test_otr_runs_end_to_end_from_the_command_line(
    demos_dir: Path,
    fixture_data: Path,
) -> None:
    res = fbil(
        *("evaluate", "no-model", str(demos_dir / "square_free.npz"), "--methods", "otr"),
        *("--data", str(fixture_data), "--budget", "smoke", "--episodes", "1", "--json"),
    )
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)["methods"]["otr"]
    assert out["family"] == "offline-il" and np.isfinite(out["score"])
    assert out["principle"] == "reward (optimal transport)"


def test_oversampled_windows_take_the_rewards_of_the_transitions_they_copy(tmp_path: Path) -> None:
    """A window (a copy of a stretch of an episode) is not transported on its own: its
    transitions get exactly the rewards of the ones they copy, and the whole episodes' are
    those of the dataset without the windows. DICE's initial states leave the windows out."""
    from fbil.baselines.dice import reset_states
    from tests.data.test_oversample import _dataset, _episode

    crossing = _episode(np.linspace(-0.2, 0.2, 21), y=0.1)
    still = _episode(np.full(15, -0.1), y=0.25)
    src = _dataset(tmp_path / "src", [crossing, still], "point_mass_maze")
    oversample_crossings(src, tmp_path / "out", window=3, copies=2)
    data, plain = load_dataset(tmp_path / "out"), load_dataset(src)
    demos = from_arrays([crossing["observation"][::2]])
    cfg = OTRConfig(iterations=50)
    rewards, base = relabel(data, demos, cfg).numpy(), relabel(plain, demos, cfg).numpy()
    np.testing.assert_array_equal(rewards[: plain.num_transitions], base)
    # The crossing episode's transitions into rows 8..14 are the window's seven.
    for copy in (0, 1):
        window = rewards[plain.num_transitions + 7 * copy :][:7]
        np.testing.assert_array_equal(window, base[7:14])
    starts = reset_states(data).numpy()
    np.testing.assert_array_equal(starts, data.observation[data.episode_start[:2]])
