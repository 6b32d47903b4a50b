import numpy as np
import pytest

from fbil.envs import BatchedEnv, RandomPolicy, get_domain, make_env, rollout
from fbil.errors import FbilError


class _LinearPolicy:
    """Deterministic in the observation, so each environment's episode is independent of
    which batch it ran in."""

    def __init__(self, obs_dim: int, act_dim: int) -> None:
        self.w = np.random.default_rng(0).normal(size=(obs_dim, act_dim)).astype(np.float32)
        self.steps: list[int] = []

    def __call__(self, obs: np.ndarray, step: int) -> np.ndarray:
        self.steps.append(step)
        # Row by row, not a BLAS matmul, whose rounding may depend on the batch size.
        return np.tanh((obs[:, :, None] * self.w[None]).sum(axis=1))


@pytest.mark.parametrize("domain", ["point_mass_maze", "walker"])
def test_batched_rollout_equals_one_environment_at_a_time(domain: str) -> None:
    spec = get_domain(domain)
    task = spec.task_names[0]
    batched = rollout(domain, task, _LinearPolicy(spec.obs_dim, spec.act_dim), [3, 4, 5], 60)
    for i, seed in enumerate([3, 4, 5]):
        single = rollout(domain, task, _LinearPolicy(spec.obs_dim, spec.act_dim), [seed], 60)
        np.testing.assert_array_equal(batched.observation[i], single.observation[0])
        np.testing.assert_array_equal(batched.reward[i], single.reward[0])
        np.testing.assert_array_equal(batched.physics[i], single.physics[0])


def test_rollout_matches_a_plain_gymnasium_loop() -> None:
    policy = _LinearPolicy(4, 2)
    ep = rollout("point_mass_maze", "reach_top_left", policy, [11], 50)
    env = make_env("point_mass_maze", "reach_top_left")
    obs, _ = env.reset(seed=11)
    for t in range(50):
        np.testing.assert_array_equal(obs, ep.observation[0, t])
        obs, r, *_ = env.step(policy(obs[None], t)[0])
        assert r == ep.reward[0, t]


def test_episode_arrays_shapes_and_step_index() -> None:
    policy = _LinearPolicy(17, 6)
    ep = rollout("cheetah", "run", policy, [0, 1], 30)
    assert ep.observation.shape == (2, 31, 17) and ep.observation.dtype == np.float32
    assert ep.action.shape == (2, 30, 6) and ep.reward.shape == (2, 30)
    assert ep.physics.shape == (2, 31, 18)
    assert policy.steps == list(range(30))
    assert ep.returns.shape == (2,) and len(ep) == 2


def test_full_episodes_last_1000_steps() -> None:
    ep = rollout("point_mass_maze", "loop", RandomPolicy(2, seed=0), [0])
    assert ep.action.shape[1] == 1000


def test_same_seeds_same_episodes() -> None:
    a = rollout("quadruped", "stand", RandomPolicy(12, seed=5), [1, 2], 20)
    b = rollout("quadruped", "stand", RandomPolicy(12, seed=5), [1, 2], 20)
    np.testing.assert_array_equal(a.physics, b.physics)


def test_bad_policies_and_arguments_are_refused() -> None:
    env = BatchedEnv("walker", "walk", 2)
    with pytest.raises(FbilError, match=r"shape \(2, 3\), expected \(2, 6\)"):
        env.rollout(lambda o, t: np.zeros((2, 3)), [0, 1], 5)
    with pytest.raises(FbilError, match="NaN"):
        env.rollout(lambda o, t: np.full((2, 6), np.nan), [0, 1], 5)
    with pytest.raises(FbilError, match="one seed per environment"):
        env.rollout(RandomPolicy(6), [0], 5)
    with pytest.raises(FbilError, match="steps must be"):
        env.rollout(RandomPolicy(6), [0, 1], 0)
