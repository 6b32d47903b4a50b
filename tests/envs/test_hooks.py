"""Domain hooks: what each domain defines, start variants, rebuilt physics, pictures."""

from pathlib import Path

import numpy as np
import pytest

from fbil.envs import DOMAINS, BatchedEnv, RandomPolicy, cheetah, get_domain, walker
from fbil.envs.hooks import ImitationPicture, RenderRequest
from fbil.envs.locomotion import wrap_angle
from fbil.envs.maze_geometry import START_HIGH, START_LOW, random_free_positions
from fbil.envs.render import render_policy
from fbil.errors import FbilError


def test_each_domain_defines_its_hooks() -> None:
    maze = get_domain("point_mass_maze").hooks
    assert set(maze.starts) == {"uniform", "shifted"} and maze.oversampling is not None
    for name in ("walker", "cheetah", "quadruped"):
        hooks = get_domain(name).hooks
        assert set(hooks.starts) == {"shifted"} and hooks.oversampling is None
    for spec in DOMAINS.values():
        assert spec.hooks.coverage is not None and spec.hooks.pictures is not None


def test_maze_start_variants_draw_from_the_first_seed() -> None:
    maze = get_domain("point_mass_maze")
    assert maze.start_states("standard", [0, 1]) is None
    shifted = maze.start_states("shifted", [5, 6, 7])
    assert shifted is not None and shifted.shape == (3, 4)
    expected = np.random.default_rng(5).uniform(START_LOW, START_HIGH, (3, 2))
    np.testing.assert_array_equal(shifted[:, :2], expected)  # the top-right room, at rest
    assert (shifted[:, :2] > 0).all() and (shifted[:, 2:] == 0).all()
    uniform = maze.start_states("uniform", [3, 4])
    assert uniform is not None
    np.testing.assert_array_equal(
        uniform[:, :2], random_free_positions(np.random.default_rng(3), 2)
    )


def test_unknown_or_incomplete_start_requests_are_one_line_errors() -> None:
    with pytest.raises(FbilError, match="'uniform' is not defined for walker; valid: standard"):
        get_domain("walker").start_states("uniform", [0])
    with pytest.raises(FbilError, match="need the expert's policy"):
        get_domain("walker").start_states("shifted", [0])


def test_locomotion_shifted_starts_are_step_500_of_the_policy() -> None:
    def policy(obs: np.ndarray, step: int) -> np.ndarray:
        return np.full((len(obs), 6), 0.3, np.float32)

    starts = get_domain("cheetah").start_states("shifted", [0, 1], "run", policy)
    ran = BatchedEnv("cheetah", "run", 2).rollout(policy, [0, 1], steps=500)
    np.testing.assert_array_equal(starts, ran.physics[:, 500])


@pytest.mark.parametrize(("module", "rootx"), [(walker, 1), (cheetah, 0)])
def test_physics_rebuilt_from_observations_but_the_horizontal_position(
    module: object, rootx: int
) -> None:
    spec = module.DOMAIN  # type: ignore[attr-defined]
    ran = BatchedEnv(spec.name, None, 1).rollout(RandomPolicy(6, 0), [0], steps=200)
    rebuilt = module.physics_from_observation(  # type: ignore[attr-defined]
        ran.observation[0].astype(np.float64)
    )
    diff = rebuilt - ran.physics[0]
    diff[:, rootx] = 0  # the tracking camera ignores it; the observation lacks it
    nq = spec.physics_dim // 2
    diff[:, :nq] = wrap_angle(diff[:, :nq])  # angles may have turned full circles
    assert np.abs(diff).max() < 1e-5


def test_locomotion_keeps_frames_and_draws_strips(tmp_path: Path) -> None:
    pictures = get_domain("walker").hooks.pictures
    assert pictures is not None
    ran = BatchedEnv("walker", "walk", 1).rollout(RandomPolicy(6, 0), [0], steps=50)
    kept = pictures.keep(ran.observation[0], ran.physics[0])
    assert np.shape(kept) == (6, 24)  # observations: walker's physics is rebuilt from them
    rollouts = {"erfb": np.asarray(kept)}
    out = pictures.imitation(
        ImitationPicture(ran.observation[0], ran.physics[0], rollouts, tmp_path / "w.png", "walk")
    )
    assert out is not None and out.read_bytes()[:4] == b"\x89PNG"


def test_quadruped_keeps_physics_states_for_its_strips(tmp_path: Path) -> None:
    """Quadruped's egocentric observation does not say where the body is: its benchmark
    rows keep physics states, and the strips draw them."""
    spec = get_domain("quadruped")
    pictures = spec.hooks.pictures
    assert pictures is not None and pictures.keep(np.zeros((11, 78)), None) is None
    ran = BatchedEnv("quadruped", "stand", 1).rollout(RandomPolicy(12, 0), [0], steps=50)
    kept = pictures.keep(ran.observation[0], ran.physics[0])
    assert np.shape(kept) == (6, spec.physics_dim)
    np.testing.assert_allclose(kept[0], ran.physics[0, 0], atol=1e-5)
    picture = ImitationPicture(
        ran.observation[0], ran.physics[0], {"erfb": np.asarray(kept)}, tmp_path / "q.png", "stand"
    )
    out = pictures.imitation(picture)
    assert out is not None and out.read_bytes()[:4] == b"\x89PNG"


def test_maze_keeps_its_path_and_draws_only_images(tmp_path: Path) -> None:
    pictures = get_domain("point_mass_maze").hooks.pictures
    assert pictures is not None
    obs = np.random.default_rng(0).uniform(-0.2, 0.2, (11, 4))
    assert pictures.keep(obs, None) == obs[::2, :2].round(3).tolist()
    policy = RandomPolicy(2, 0)
    gif = RenderRequest("loop", policy, 0, 1, 10, 3, tmp_path / "m.gif")
    with pytest.raises(FbilError, match="maze pictures are images"):
        render_policy("point_mass_maze", gif)
    returns = render_policy(
        "point_mass_maze", RenderRequest("loop", policy, 0, 2, 10, 3, tmp_path / "m.png")
    )
    assert len(returns) == 2 and (tmp_path / "m.png").is_file()
