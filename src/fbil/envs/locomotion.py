"""The locomotion domains' hooks (walker, cheetah, quadruped; see fbil.envs.hooks).

Starts: "shifted" is the state an expert reaches after 500 steps (paper App. E.5).

Coverage answers "is this data diverse, or could random actions have made it?": a few
physical features each domain names (torso height, orientation, speed, rotation), read
from the stored physics states, are summarised over the dataset's states next to the same
features over a handful of random-action episodes rolled out on the spot (a couple of
seconds); and, per task, the share of states its reward pays well (>= 0.5): an FB model
can hardly learn a task whose rewarding states its data never visits.

Pictures: frame strips, rendered from physics states (the report rebuilds a rollout's
physics from its kept observations where the observation holds the whole pose).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fbil.envs.base import Quantities
from fbil.envs.hooks import (
    Coverage,
    CoverageData,
    DomainHooks,
    ImitationPicture,
    Pictures,
    Policy,
    RenderRequest,
)
from fbil.errors import FbilError

SHIFT_STEP = 500  # shifted starts: this step of an expert's episode
MAX_STATES = 50_000  # dataset states summarised (a fixed random subsample beyond)
REFERENCE_EPISODES = 8  # random-action episodes rolled out as the reference
BINS = 40
WELL_PAID = 0.5  # a state "pays well" for a task when its reward reaches this
# A feature goes well past random actions' when its 1-99% range is WIDER times theirs, or
# a share BEYOND of its states lies outside their 1-99% range; it is narrower than theirs
# when its range is at most NARROWER times theirs.
WIDER, BEYOND, NARROWER = 1.5, 0.10, 0.67
KEEP_FRAMES = 6  # frames per row of the report's strips
QUANTILES = {"p01": 1, "p05": 5, "p25": 25, "median": 50, "p75": 75, "p95": 95, "p99": 99}

# (quantities, observations) of N states -> named (N,) features
FeatureFn = Callable[[Quantities, np.ndarray], dict[str, np.ndarray]]


def wrap_angle(radians: np.ndarray) -> np.ndarray:
    """Angles folded into [-pi, pi)."""
    return np.asarray((radians + np.pi) % (2 * np.pi) - np.pi)


def _stats(v: np.ndarray) -> dict[str, float]:
    out = {"min": float(v.min()), "max": float(v.max())}
    out.update({k: float(np.percentile(v, q)) for k, q in QUANTILES.items()})
    out.update(mean=float(v.mean()), std=float(v.std()))
    return {k: round(x, 5) for k, x in out.items()}


def _histograms(data: np.ndarray, ref: np.ndarray) -> dict[str, Any]:
    """Shares of states per bin over a range that holds 99.8% of both sets (the tails
    fall into the end bins)."""
    both = np.concatenate([data, ref])
    lo, hi = np.percentile(both, [0.1, 99.9])
    hi = hi if hi > lo else lo + 1e-6
    edges = np.linspace(lo, hi, BINS + 1)

    def share(v: np.ndarray) -> list[float]:
        counts, _ = np.histogram(np.clip(v, lo, hi), edges)
        return (counts / max(len(v), 1)).round(5).tolist()

    return {"edges": edges.round(5).tolist(), "data": share(data), "random": share(ref)}


def _feature_summary(label: str, data: np.ndarray, ref: np.ndarray) -> dict[str, Any]:
    """A feature's statistics, histogram and how far it reaches past random actions'
    1-99% range (spread: the ratio of the ranges; beyond: the share of states outside;
    TV: the total variation between the two histograms)."""
    r_lo, r_hi = np.percentile(ref, [1, 99])
    d_lo, d_hi = np.percentile(data, [1, 99])
    spread = (d_hi - d_lo) / (r_hi - r_lo) if r_hi > r_lo else float("inf")
    hist = _histograms(data, ref)
    return {
        "label": label,
        **_stats(data),
        "spread_vs_random": round(float(spread), 3),
        "beyond_random": round(float(np.mean((data < r_lo) | (data > r_hi))), 4),
        "tv_vs_random": round(
            0.5 * float(np.abs(np.subtract(hist["data"], hist["random"])).sum()), 4
        ),
        "random": _stats(ref),
        "histogram": hist,
    }


@dataclass(frozen=True)
class Locomotion:
    """What a locomotion domain tells the shared hooks; `hooks()` builds them."""

    domain: str
    features: FeatureFn
    labels: Mapping[str, str]  # feature -> axis label, with its unit
    # (N, obs_dim) -> (N, physics_dim), for domains whose observation holds the whole
    # pose (all but the horizontal position, which the tracking camera ignores)
    physics_from_observation: Callable[[np.ndarray], np.ndarray] | None = None
    # method -> its budget spec measured on this domain (`DomainHooks.baseline_budgets`)
    baseline_budgets: Mapping[str, str] = field(default_factory=dict)
    demo_task: str = "walk"  # `fbil demo --domain D`'s default task (every domain walks)

    def hooks(self) -> DomainHooks:
        return DomainHooks(
            baseline_budgets=self.baseline_budgets,
            demo_task=self.demo_task,
            starts={"shifted": self.shifted_starts},
            coverage=Coverage(self.coverage_summary, self.coverage_text, self.plot_coverage),
            pictures=Pictures(
                render=self.render_strip,
                keep=self.keep_frames,
                imitation=self.imitation_strips,
                imitation_heading="Demonstration (top row) against each method's rollout",
            ),
        )

    # -- starts ----------------------------------------------------------------------
    def shifted_starts(
        self, seeds: Sequence[int], task: str | None = None, policy: Policy | None = None
    ) -> np.ndarray:
        """Where `policy` (the expert) is after SHIFT_STEP steps of each seed's episode."""
        from fbil.envs.rollout import BatchedEnv

        if policy is None:
            raise FbilError(f"shifted starts of {self.domain} need the expert's policy")
        warm = BatchedEnv(self.domain, task, len(seeds)).rollout(policy, seeds, steps=SHIFT_STEP)
        return np.asarray(warm.physics[:, -1])

    # -- coverage --------------------------------------------------------------------
    def dataset_features(self, data: CoverageData) -> tuple[dict[str, np.ndarray], Quantities]:
        """Features and quantities of (a fixed subsample of at most MAX_STATES of) the
        dataset's states."""
        from fbil.envs.relabel import compute_quantities

        rows = data.next_index
        if len(rows) > MAX_STATES:
            rows = np.sort(np.random.default_rng(0).choice(rows, MAX_STATES, replace=False))
            q = compute_quantities(self.domain, data.physics()[rows], data.action[rows])
        else:
            q = data.quantities()
        return self.features(q, np.asarray(data.observation[rows], np.float64)), q

    def random_features(
        self, episodes: int = REFERENCE_EPISODES
    ) -> tuple[dict[str, np.ndarray], Quantities]:
        """Features and quantities of `episodes` uniform-random-action episodes."""
        from fbil.envs.relabel import compute_quantities
        from fbil.envs.rollout import BatchedEnv, RandomPolicy

        env = BatchedEnv(self.domain, None, episodes)
        spec = env.spec
        ran = env.rollout(RandomPolicy(spec.act_dim, seed=0), list(range(episodes)))
        physics = ran.physics[:, 1:].reshape(-1, spec.physics_dim)
        q = compute_quantities(self.domain, physics, ran.action.reshape(-1, spec.act_dim))
        obs = ran.observation[:, 1:].reshape(-1, spec.obs_dim).astype(np.float64)
        return self.features(q, obs), q

    def coverage_summary(
        self, data: CoverageData, reference_episodes: int = REFERENCE_EPISODES
    ) -> dict[str, Any]:
        """Feature distributions and well-paid task shares, against random actions."""
        feats, q = self.dataset_features(data)
        started = time.perf_counter()
        ref_feats, ref_q = self.random_features(reference_episodes)
        seconds = time.perf_counter() - started
        summary: dict[str, Any] = {
            "states_used": len(next(iter(feats.values()))),
            "reference": {
                "policy": "uniform random actions",
                "episodes": reference_episodes,
                "states": len(next(iter(ref_feats.values()))),
                "seconds": round(seconds, 2),
            },
            "quantities": {
                name: _feature_summary(self.labels.get(name, name), v, ref_feats[name])
                for name, v in feats.items()
            },
            "tasks": self._task_shares(q, ref_q),
        }
        summary["verdict"] = _verdict(summary)
        return summary

    def _task_shares(self, q: Quantities, ref_q: Quantities) -> dict[str, dict[str, float]]:
        from fbil.envs.registry import get_domain
        from fbil.envs.relabel import task_reward

        out = {}
        for task in get_domain(self.domain).tasks:
            r, ref = task_reward(self.domain, task, q), task_reward(self.domain, task, ref_q)
            out[task] = {
                "mean_reward": round(float(r.mean()), 5),
                "well_paid": round(float(np.mean(r >= WELL_PAID)), 5),
                "random_mean_reward": round(float(ref.mean()), 5),
                "random_well_paid": round(float(np.mean(ref >= WELL_PAID)), 5),
            }
        return out

    def coverage_text(self, cov: dict[str, Any]) -> list[str]:
        ref = cov["reference"]
        lines = [
            f"coverage: {cov['states_used']} states against {ref['episodes']} episodes of "
            f"{ref['policy']} ({ref['states']} states, rolled out in {ref['seconds']:.1f} s)",
            "  spread: the data's 1-99% range over random's; beyond: its share of states "
            "outside random's 1-99% range; TV: total variation between the histograms",
            f"  {'feature':<36} {'data 1-99%':>20} {'random 1-99%':>20}  spread  beyond  TV",
        ]
        for f in cov["quantities"].values():
            r = f["random"]
            lines.append(
                f"  {f['label']:<36} [{f['p01']:8.3f}, {f['p99']:8.3f}] "
                f"[{r['p01']:8.3f}, {r['p99']:8.3f}]  {f['spread_vs_random']:5.2f}x "
                f"{100 * f['beyond_random']:5.1f}%  {f['tv_vs_random']:.2f}"
            )
        lines.append(f"tasks: share of states paid >= {WELL_PAID} (random actions in brackets)")
        lines += [
            f"  {task:<14} {100 * t['well_paid']:6.2f}%  ({100 * t['random_well_paid']:.2f}%)"
            for task, t in cov["tasks"].items()
        ]
        return [*lines, f"verdict: {cov['verdict']}"]

    def plot_coverage(self, data: CoverageData, cov: dict[str, Any], out: Path) -> Path:
        """One histogram per feature (data filled, random actions outlined) and the
        tasks' well-paid shares."""
        from fbil.envs.render import _pyplot, _save

        feats = list(cov["quantities"].values())
        cols = min(3, len(feats) + 1)
        rows = (len(feats) + cols) // cols
        fig, axes = _pyplot().subplots(rows, cols, figsize=(3.6 * cols, 2.7 * rows), dpi=110)
        flat = np.atleast_1d(axes).ravel()
        for ax, f in zip(flat, feats, strict=False):
            _feature_panel(ax, f)
        _task_panel(flat[len(feats)], cov["tasks"])
        for ax in flat[len(feats) + 1 :]:
            ax.axis("off")
        flat[0].legend(fontsize=7)
        fig.suptitle(
            f"{self.domain}: {data.num_episodes} episodes, {cov['states_used']} states "
            f"against {cov['reference']['episodes']} random-action episodes",
            fontsize=9,
        )
        fig.tight_layout()
        return _save(fig, out)

    # -- pictures --------------------------------------------------------------------
    def render_strip(self, request: RenderRequest) -> list[float]:
        """Frames of one episode of the request's policy: a strip (image) or an animation."""
        from fbil.envs.render import IMAGE_SUFFIXES, locomotion_frames, save_frames

        steps = request.steps or 250
        image = request.out.suffix.lower() in IMAGE_SUFFIXES
        n_frames = request.frames if image else steps // 2 + 1
        frames = locomotion_frames(
            self.domain, request.task, request.policy, request.seed, steps, n_frames
        )
        save_frames(frames, request.out)
        return []

    def keep_frames(
        self, observation: np.ndarray, physics: np.ndarray | None = None
    ) -> list[Any] | None:
        """KEEP_FRAMES evenly spaced states: observations where the domain recovers the
        physics from them (walker, cheetah), else physics states (quadruped, whose
        egocentric observation does not say where the body is); None: neither."""
        picks = _picks(len(observation))
        if self.physics_from_observation is not None:
            return np.asarray(observation)[picks].round(5).tolist()
        if physics is None:
            return None
        return np.asarray(physics)[picks].round(5).tolist()

    def imitation_strips(self, picture: ImitationPicture) -> Path | None:
        """Rows of frames: the demonstration, then each method's kept rollout."""
        from fbil.envs.render import _pyplot, _save, render_states

        to_physics = self.physics_from_observation
        picks = _picks(len(picture.demo_observation))
        if picture.demo_physics is not None:
            demo = np.asarray(picture.demo_physics)[picks]
        elif to_physics is not None:
            demo = to_physics(np.asarray(picture.demo_observation, np.float64)[picks])
        else:
            return None
        strips = {"demonstration": demo}
        as_physics = to_physics or np.asarray  # without it, keep_frames kept physics states
        strips.update(
            {m: as_physics(np.asarray(o, np.float64)) for m, o in picture.rollouts.items()}
        )
        titles = picture.titles or {}
        fig, axes = _pyplot().subplots(
            len(strips), KEEP_FRAMES, figsize=(1.6 * KEEP_FRAMES, 1.3 * len(strips)), dpi=110
        )
        for row, (name, states) in zip(np.atleast_2d(axes), strips.items(), strict=True):
            frames = render_states(self.domain, picture.task, states, (120, 160), sky=False)
            for ax, frame in zip(row, frames, strict=False):
                ax.imshow(frame)
                ax.set_xticks([])
                ax.set_yticks([])
            row[0].set_ylabel(titles.get(name, name), fontsize=7)
        fig.subplots_adjust(wspace=0.02, hspace=0.05)
        return _save(fig, picture.out)


def _picks(length: int) -> np.ndarray:
    return np.linspace(0, length - 1, KEEP_FRAMES).round().astype(int)


def _verdict(cov: dict[str, Any]) -> str:
    feats = cov["quantities"]
    past = [
        n
        for n, f in feats.items()
        if f["spread_vs_random"] >= WIDER or f["beyond_random"] >= BEYOND
    ]
    narrow = [n for n, f in feats.items() if f["spread_vs_random"] <= NARROWER]
    unpaid = [t for t, s in cov["tasks"].items() if s["well_paid"] < 0.001]
    text = f"{len(past)} of {len(feats)} features go well past random actions'"
    text += f" ({', '.join(past)})" if past else " (the data looks like random actions)"
    if narrow:
        text += f"; narrower than random actions': {', '.join(narrow)}"
    return (
        text
        + "; "
        + (
            f"tasks paid >= {WELL_PAID} in under 0.1% of states: {', '.join(unpaid)}"
            if unpaid
            else f"every task is paid >= {WELL_PAID} in at least 0.1% of states"
        )
    )


def _feature_panel(ax: Any, f: dict[str, Any]) -> None:
    h = f["histogram"]
    edges = np.asarray(h["edges"])
    ax.stairs(h["data"], edges, fill=True, color="#5e81ac", alpha=0.8, label="dataset")
    ax.stairs(h["random"], edges, color="#3b4252", lw=1.2, label="random actions")
    ax.set_xlabel(f["label"], fontsize=8)
    ax.set_ylabel("share of states", fontsize=7)
    ax.tick_params(labelsize=7)


def _task_panel(ax: Any, tasks: dict[str, dict[str, float]]) -> None:
    names = list(tasks)
    x = np.arange(len(names))
    ax.bar(x - 0.2, [100 * tasks[t]["well_paid"] for t in names], 0.4, color="#5e81ac")
    ax.bar(x + 0.2, [100 * tasks[t]["random_well_paid"] for t in names], 0.4, color="#3b4252")
    ax.set_xticks(x, names, fontsize=7, rotation=30)
    ax.set_ylabel(f"% of states paid >= {WELL_PAID}", fontsize=7)
    ax.tick_params(labelsize=7)
