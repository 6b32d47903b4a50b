import pytest

from fbil.envs import DOMAINS, all_tasks, get_domain, get_task, make_env
from fbil.errors import FbilError

EXPECTED = {
    "point_mass_maze": (
        4,
        2,
        [
            "reach_top_left",
            "reach_top_right",
            "reach_bottom_left",
            "reach_bottom_right",
            "reach_bottom_left_long",
            "loop",
            "square",
            "fast_slow",
        ],
    ),
    "walker": (24, 6, ["stand", "walk", "run", "flip", "spin"]),
    "cheetah": (17, 6, ["run", "run_backward", "walk", "walk_backward"]),
    "quadruped": (78, 12, ["stand", "walk", "run", "jump"]),
}


def test_registry_lists_exactly_the_21_tasks() -> None:
    assert len(all_tasks()) == 21
    assert {d: (s.obs_dim, s.act_dim, s.task_names) for d, s in DOMAINS.items()} == EXPECTED


@pytest.mark.parametrize("domain", list(EXPECTED))
def test_declared_sizes_match_the_simulator(domain: str) -> None:
    spec = get_domain(domain)
    env = make_env(domain, spec.task_names[0], seed=0)
    obs, info = env.reset()
    assert obs.shape == (spec.obs_dim,) and obs.dtype.name == "float32"
    assert info["physics"].shape == (spec.physics_dim,)
    assert env.action_space.shape == (spec.act_dim,)
    # 1000 control steps fill the domain's time limit (dm_control's 20/25/10/20 s).
    assert spec.episode_length * spec.control_timestep == pytest.approx(
        {"point_mass_maze": 20, "walker": 25, "cheetah": 10, "quadruped": 20}[domain]
    )


def test_unknown_names_list_the_valid_ones() -> None:
    with pytest.raises(FbilError, match="valid domains: point_mass_maze, walker"):
        get_domain("humanoid")
    with pytest.raises(FbilError, match="valid tasks: stand, walk, run, flip, spin"):
        get_task("walker", "backflip")
    with pytest.raises(FbilError, match="unknown task"):
        make_env("cheetah", "stand")


@pytest.mark.parametrize(("domain", "task"), all_tasks())
def test_no_state_or_control_pays_more_than_reward_max(domain: str, task: str) -> None:
    """reward_max bounds one step's reward for any state and control: rows drawn at scales
    from the maze's 0.3 m to far beyond any speed or height the physics reaches; only the
    quantities bounded by nature stay in [-1, 1] (an upright cosine, an applied control)."""
    import numpy as np

    from fbil.envs import max_return

    spec, rng, n = get_domain(domain), np.random.default_rng(0), 20_000
    scale = rng.choice([0.05, 0.3, 1.0, 3.0, 10.0, 100.0], size=n)
    quantities = {
        name: rng.uniform(-1, 1, (n, *shape)) * scale.reshape(-1, *[1] * len(shape))
        for name, shape in spec.quantity_shapes.items()
    }
    for name in {"torso_upright", "control"} & set(quantities):
        quantities[name] = np.clip(quantities[name], -1, 1)
    reward = np.asarray(get_task(domain, task).reward(quantities))
    assert reward.shape == (n,) and np.isfinite(reward).all()
    assert reward.max() <= get_task(domain, task).reward_max + 1e-12
    assert max_return(domain, task) == get_task(domain, task).reward_max * spec.episode_length


def test_the_maze_bound_is_reached_at_a_goal_at_rest() -> None:
    """reward_max is not slack: at the goal, still and without control, reach pays 1."""
    import numpy as np

    from fbil.envs import max_return

    task = get_task("point_mass_maze", "reach_bottom_left_long")
    at_rest = {"position": np.array([[-0.15, -0.15]]), "velocity": np.zeros((1, 2))}
    assert task.reward({**at_rest, "control": np.zeros((1, 2))})[0] == task.reward_max == 1.0
    assert max_return("point_mass_maze", "reach_bottom_left_long") == 1000.0
