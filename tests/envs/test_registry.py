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
