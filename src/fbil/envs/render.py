"""Pictures: the maze seen from above with trajectories, locomotion as frames.

Maze figures are drawn with matplotlib from the same geometry constants the MJCF is built
from; locomotion frames come from MuJoCo's offscreen renderer (MUJOCO_GL=egl headless).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fbil.envs import maze
from fbil.envs.env import FbilEnv
from fbil.envs.hooks import RenderRequest
from fbil.envs.registry import get_task
from fbil.envs.rollout import BatchedEnv, Policy
from fbil.errors import FbilError

IMAGE_SUFFIXES = (".png", ".pdf", ".svg", ".jpg")
ANIMATION_SUFFIXES = (".gif", ".mp4")


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def draw_maze(ax: Any, task: str | None = None) -> None:
    """Walls, rooms and (if a task is given) its goal or route, on a matplotlib axis."""
    from matplotlib.patches import Circle, Rectangle

    a, t, arm = maze.ARENA_HALF, maze.WALL_HALF_THICKNESS, maze.ARM_HALF_LENGTH
    wall: dict[str, Any] = {"color": "#3b4252", "zorder": 3}
    for x, y, w, h in (
        (-a - 2 * t, -a - 2 * t, 2 * t, 2 * a + 4 * t),
        (a, -a - 2 * t, 2 * t, 2 * a + 4 * t),
        (-a, -a - 2 * t, 2 * a, 2 * t),
        (-a, a, 2 * a, 2 * t),
        (-arm, -t, 2 * arm, 2 * t),
        (-t, -arm, 2 * t, 2 * arm),
    ):
        ax.add_patch(Rectangle((x, y), w, h, **wall))
    ax.add_patch(Rectangle((-a, -a), 2 * a, 2 * a, color="#eceff4", zorder=0))
    if task is not None:
        spec = get_task("point_mass_maze", task)
        if spec.path is not None:
            path = np.asarray(spec.path)
            ax.plot(path[:, 0], path[:, 1], "--", color="#d08770", lw=1.5, zorder=1)
            for p, q in itertools.pairwise(path):
                mid = (p + q) / 2
                ax.annotate(
                    "",
                    xy=mid + (q - p) * 0.05,
                    xytext=mid - (q - p) * 0.05,
                    arrowprops={"arrowstyle": "->", "color": "#d08770", "lw": 1.5},
                    zorder=1,
                )
        if spec.goal is not None:
            ax.add_patch(Circle(spec.goal, 0.02, color="#bf616a", zorder=4, alpha=0.8))
        ax.set_title(f"point_mass_maze / {task}", fontsize=10)
    m = a + 2 * t
    ax.set_xlim(-m, m)
    ax.set_ylim(-m, m)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def plot_maze_trajectories(
    trajectories: Sequence[np.ndarray],
    out: str | Path,
    task: str | None = None,
    labels: Sequence[str] | None = None,
) -> Path:
    """Save a top-down figure of (T, >=2) x-y trajectories over the maze walls."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(4.5, 4.5), dpi=120)
    draw_maze(ax, task)
    cmap = plt.get_cmap("tab10")
    for i, traj in enumerate(trajectories):
        xy = np.asarray(traj)[:, :2]
        label = labels[i] if labels is not None else None
        ax.plot(xy[:, 0], xy[:, 1], color=cmap(i % 10), lw=1.0, alpha=0.85, zorder=2, label=label)
        ax.plot(*xy[0], "o", color=cmap(i % 10), ms=4, zorder=5)
    if labels is not None:
        ax.legend(fontsize=7, loc="upper right", framealpha=0.8)
    return _save(fig, out)


def plot_imitation_panels(
    demo: np.ndarray,
    rollouts: dict[str, np.ndarray],
    out: str | Path,
    task: str | None = None,
    titles: dict[str, str] | None = None,
) -> Path:
    """One small maze panel per method: the demonstration (red) against the method's
    rollout (green), as the paper's Fig. 6."""
    plt = _pyplot()
    n = max(len(rollouts), 1)
    cols = min(4, n)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(2.6 * cols, 2.7 * rows), dpi=110)
    flat = np.atleast_1d(axes).ravel()
    for ax, (name, xy) in zip(flat, rollouts.items(), strict=False):
        draw_maze(ax, task)
        d, r = np.asarray(demo)[:, :2], np.asarray(xy)[:, :2]
        ax.plot(d[:, 0], d[:, 1], color="tab:red", lw=1.2, alpha=0.8, label="demo")
        ax.plot(r[:, 0], r[:, 1], color="tab:green", lw=1.0, alpha=0.9, label="imitation")
        ax.plot(*r[0], "o", color="tab:green", ms=3)
        ax.set_title((titles or {}).get(name, name), fontsize=8)
    for ax in flat[len(rollouts) :]:
        ax.axis("off")
    flat[0].legend(fontsize=6, loc="lower left", framealpha=0.8)
    fig.tight_layout()
    return _save(fig, out)


def _save(fig: Any, out: str | Path) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp{out.suffix}")
    fig.savefig(tmp, bbox_inches="tight")
    _pyplot().close(fig)
    if out.suffix.lower() == ".png":
        _to_palette(tmp)
    tmp.replace(out)  # never leave a half-written picture behind
    return out


def _to_palette(path: Path) -> None:
    """Rewrite a PNG with an adaptive 256-colour palette: rendered frame strips shrink ~3x
    (1.5 MB to ~0.5 MB for a walker report's), which keeps committed reports small."""
    from PIL import Image

    with Image.open(path) as im:
        rgb = im.convert("RGB")
    quantized = rgb.quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    quantized.save(path, "PNG", optimize=True)


def locomotion_frames(
    domain: str,
    task: str,
    policy: Policy,
    seed: int,
    steps: int,
    n_frames: int,
    size: tuple[int, int] = (240, 320),
) -> list[np.ndarray]:
    """Roll out one episode and render `n_frames` evenly spaced frames of it."""
    episodes = BatchedEnv(domain, task, 1).rollout(policy, [seed], steps)
    picks = np.linspace(0, steps, n_frames).round().astype(int)
    return render_states(domain, task, episodes.physics[0, picks], size)


def render_states(
    domain: str,
    task: str,
    states: np.ndarray,
    size: tuple[int, int] = (240, 320),
    sky: bool = True,
) -> list[np.ndarray]:
    """One frame (H, W, 3) per physics state, from the domain's camera. `sky=False` draws
    a black background instead of the starry skybox, whose noise is most of a committed
    frame strip's bytes (a palette PNG of a cheetah frame: 10.6 KB with it, 3.3 KB without)."""
    env = FbilEnv(domain, task)
    h, w = size
    flags = None if sky else {"skybox": False}
    frames = []
    for state in states:
        env.set_physics_state(state)
        frame = env.physics.render(
            h, w, camera_id=env.domain.camera_id, render_flag_overrides=flags
        )
        frames.append(np.asarray(frame))
    return frames


def save_frames(frames: list[np.ndarray], out: str | Path, fps: int = 20) -> Path:
    """A strip of frames as an image, or an animation for .gif / .mp4."""
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix in IMAGE_SUFFIXES:
        plt = _pyplot()
        fig, axes = plt.subplots(1, len(frames), figsize=(2.2 * len(frames), 2), dpi=120)
        for ax, frame in zip(np.atleast_1d(axes), frames, strict=True):
            ax.imshow(frame)
            ax.axis("off")
        fig.subplots_adjust(wspace=0.02, left=0, right=1, top=1, bottom=0)
        return _save(fig, out)
    if suffix in ANIMATION_SUFFIXES:
        import imageio.v2 as imageio

        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_name(f".{out.name}.tmp{suffix}")
        try:
            options: dict[str, Any] = {"duration": 1000 / fps} if suffix == ".gif" else {}
            imageio.mimsave(str(tmp), list[Any](frames), **options)
        except Exception as exc:  # mp4 needs imageio-ffmpeg
            tmp.unlink(missing_ok=True)
            raise FbilError(
                f"cannot write {out.name}: {exc}; write a .gif or .png, or pip install "
                "imageio-ffmpeg for .mp4"
            ) from None
        tmp.replace(out)
        return out
    raise FbilError(
        f"unsupported picture type {suffix!r} for {out}; use one of "
        f"{', '.join(IMAGE_SUFFIXES + ANIMATION_SUFFIXES)}"
    )


def render_policy(domain: str, request: RenderRequest) -> list[float]:
    """`fbil render`: the domain's picture of a policy (the maze: x-y paths of
    `request.episodes` episodes, an image; locomotion: `request.frames` frames of one
    episode, or an animation); returns the returns of the episodes it drew (empty where
    the picture shows none)."""
    from fbil.envs.registry import get_domain

    pictures = get_domain(domain).hooks.pictures
    if pictures is None:
        raise FbilError(f"{domain} defines no pictures")
    return pictures.render(request)
