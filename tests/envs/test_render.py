from pathlib import Path

import numpy as np
import pytest

from fbil.envs import RandomPolicy
from fbil.envs.render import locomotion_frames, plot_maze_trajectories, save_frames
from fbil.errors import FbilError

PNG = b"\x89PNG\r\n\x1a\n"


def test_maze_figure_is_a_png(tmp_path: Path) -> None:
    traj = np.cumsum(np.full((50, 2), 0.003), axis=0) - 0.2
    out = plot_maze_trajectories([traj], tmp_path / "maze.png", task="loop", labels=["demo"])
    assert out.read_bytes()[:8] == PNG
    assert not list(tmp_path.glob(".*tmp*"))  # no temporary file left behind


def test_locomotion_frames_render_offscreen(tmp_path: Path) -> None:
    frames = locomotion_frames(
        "walker", "walk", RandomPolicy(6), seed=0, steps=10, n_frames=3, size=(48, 64)
    )
    assert len(frames) == 3 and frames[0].shape == (48, 64, 3)
    assert frames[0].std() > 0  # not a blank image
    strip = save_frames(frames, tmp_path / "strip.png")
    assert strip.read_bytes()[:8] == PNG
    from PIL import Image

    with Image.open(strip) as im:  # palette PNG: committed reports stay small
        assert im.mode == "P" and len(set(np.asarray(im).ravel().tolist())) > 8
    gif = save_frames(frames, tmp_path / "clip.gif")
    assert gif.read_bytes()[:3] == b"GIF"
    with pytest.raises(FbilError, match="unsupported picture type"):
        save_frames(frames, tmp_path / "clip.bmp")


def test_frames_without_the_sky_have_a_black_background() -> None:
    """The report's strips drop the starry skybox (its noise is most of their bytes)."""
    from fbil.envs.env import FbilEnv
    from fbil.envs.render import render_states

    env = FbilEnv("cheetah", "run")
    env.reset(seed=0)
    state = env.physics.get_state()[None]
    (sky,) = render_states("cheetah", "run", state, (48, 64))
    (plain,) = render_states("cheetah", "run", state, (48, 64), sky=False)
    assert sky[:6].max() > 0 and plain[:6].max() == 0  # the top rows: sky, then black
    assert (plain.max(axis=2) > 0).mean() > 0.1  # the body and the floor are drawn
