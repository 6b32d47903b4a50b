"""FB pre-training: the FB loss, orthonormality of B, and the actor, on a dataset.

One update, top to bottom (SPEC §4), for a batch of transitions (s_i, a_i, s'_i):
  z_i      Gaussian on the sphere, or (half the rows) B of another next state of the batch,
           or (z_from_b_mean_ratio) the mean of B over a random subset of the batch's next states
           or (z_from_traj_ratio) the mean of B over states of one dataset trajectory segment,
           with traj_z_noise > 0 its unit direction plus a random vector of norm <= traj_z_noise
  M^k_ij = F^k(s_i, a_i, z_i)^T B(s'_j)                                (both heads)
  T_ij   = min_k Fbar^k(s'_i, a'_i, z_i)^T Bbar(s'_j), a'_i = mu(s'_i, z_i) + clipped noise
           (target_heads="mean": the mean of the two heads instead of the min)
  L_FB   = sum_k 1/2 mean_{i!=j} (M^k_ij - gamma T_ij)^2 - mean_i M^k_ii
  L_orth = mean_{i!=j} (b_i^T b_j)^2 - 2 mean_i |b_i|^2,  b_i = B(s'_i)
  L_actor = -mean_i min_k F^k(s_i, a~_i, z_i)^T z_i,  a~_i = mu(s_i, z_i) + clipped noise
           (clamped to [-1, 1]; actor_clamp="straight_through": gradient as if unclamped)
  optional (q_loss_coef > 0): L_Q = sum_k 1/2 mean_i (F^k(s_i, a_i, z_i)^T z_i - y_i)^2,
  y_i = b_i^T Cov^-1 z_i + gamma min_k Fbar^k(s'_i, a'_i, z_i)^T z_i, Cov = B^T B / n
ema_decay > 0: after each update, ema <- ema + (1 - decay_t) (model - ema) for every weight of
F, B and the actor, decay_t = min(decay, (1 + t) / (10 + t)); the saved model is the average.
Off-diagonal means are taken as (sum - trace) / (n (n - 1)): no masks; the sums of
squares go through d x d Gram matrices (F^T F, B^T B) and T B, so that M (n x n per head)
and B B^T are never formed (offdiag_residual_sq).
"""

from __future__ import annotations

import contextlib
import copy
import csv
import dataclasses
import json
import math
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, NamedTuple

import torch
from torch import nn
from tqdm.auto import tqdm

from fbil.checkpoint import load_state, save_state
from fbil.compile import compiled
from fbil.config import config_from_dict
from fbil.csvlog import last_wall_seconds, truncate_log
from fbil.data import Dataset
from fbil.errors import FbilError
from fbil.fb.config import FBModelConfig, FBTrainConfig
from fbil.fb.model import CONFIG, FBModel, orthogonal_init
from fbil.progress import progress_bar
from fbil.stopping import StopSignals

CHECKPOINT, LOG = "checkpoint.safetensors", "train_log.csv"
# z_from_traj_ratio: states averaged per trajectory z, and the segment lengths' range.
TRAJ_Z_STATES, TRAJ_Z_SPAN = 16, (8, 1000)
LOG_FIELDS = (
    "step",
    "fb_loss",
    "fb_diag",
    "fb_offdiag",
    "ortho_loss",
    "ortho_error",
    "actor_q",
    "q_loss",
    "steps_per_s",
    "wall_seconds",
)


def _offdiag_mean_sq(x: torch.Tensor) -> torch.Tensor:
    """mean_{i != j} x_ij^2 over the last two dims."""
    n = x.shape[-1]
    diag = x.diagonal(dim1=-2, dim2=-1)
    # x * x, not x.pow(2): the same numbers, ~3x faster forward and backward on CPU.
    total = (x * x).sum((-2, -1)) - (diag * diag).sum(-1)
    return total / (n * (n - 1))


def offdiag_residual_sq(f: torch.Tensor, b: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """mean_{i != j} (f_i^T b_j - T_ij)^2 per head, for f (k, n, d), b (n, d), T (n, n),
    without forming F B^T: sum_ij (F B^T)_ij^2 = <F^T F, B^T B> (d x d products) and
    sum_ij (F B^T)_ij T_ij = <F, T B> (one n x n x d product for all heads). The same
    number as `_offdiag_mean_sq(f @ b.T - target)` up to rounding, at about a third of the
    n x n work forward and backward (the n x n products are the slowest part of the update
    at batch 512 and d 50-100: K = d is too small for an efficient matmul)."""
    n = b.shape[0]
    m_diag = (f * b).sum(-1)  # (k, n): M_ii
    t_diag = target.diagonal()
    full_mm = (torch.matmul(f.transpose(-2, -1), f) * (b.T @ b)).sum((-2, -1))
    full_mt = (f * (target @ b)).sum((-2, -1))
    full_tt = (target * target).sum()
    total = (
        full_mm
        - (m_diag * m_diag).sum(-1)
        - 2 * (full_mt - (m_diag * t_diag).sum(-1))
        + (full_tt - (t_diag * t_diag).sum())
    )
    return total / (n * (n - 1))


def episode_last_transition(next_index: torch.Tensor) -> torch.Tensor:
    """For each transition t (rows of `next_index`), the last transition of its episode:
    t and t + 1 are in one episode when their next states are consecutive."""
    breaks = torch.nonzero(next_index[1:] != next_index[:-1] + 1).flatten()
    last = torch.tensor([len(next_index) - 1], device=next_index.device)
    ends = torch.cat([breaks, last])
    episode = torch.zeros(len(next_index), dtype=torch.long, device=next_index.device)
    episode[breaks + 1] = 1
    return ends[episode.cumsum(0)]


def segment_states(
    next_index: torch.Tensor, episode_last: torch.Tensor, n: int, gen: torch.Generator
) -> torch.Tensor:
    """State indices (n x TRAJ_Z_STATES) of n random trajectory segments, as training draws
    them: a uniform start transition, a log-uniform span in TRAJ_Z_SPAN cut at the episode's
    end, and TRAJ_Z_STATES uniform positions in it. Three draws from `gen` (CPU), in order."""
    dev = next_index.device
    start = torch.randint(0, len(next_index), (n,), generator=gen).to(dev)
    lo, hi = TRAJ_Z_SPAN
    span = torch.exp(torch.rand(n, generator=gen) * math.log(hi / lo)) * lo
    room = (episode_last[start] - start + 1).float()
    span = torch.minimum(span.to(dev), room)
    frac = torch.rand(n, TRAJ_Z_STATES, generator=gen).to(dev)
    at = start[:, None] + (frac * span[:, None]).long().clamp_max(room[:, None].long() - 1)
    return next_index[at]


def git_commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            cwd=Path(__file__).parent,
            timeout=5,
        )
        return out.stdout.strip() or "unknown"
    except OSError:
        return "unknown"


class Batch(NamedTuple):
    """One update's transitions and random draws (far_obs: s_{t+k+1}, n-step only)."""

    obs: torch.Tensor
    action: torch.Tensor
    next_obs: torch.Tensor
    boot_obs: torch.Tensor  # where the target bootstraps: s_{t+1}, or s_{t+n} for n-step
    far_obs: torch.Tensor | None
    z_gauss: torch.Tensor  # Gaussian z before projection
    perm: torch.Tensor  # which next state's B a row takes as its z
    use_b: torch.Tensor  # rows whose z is B of a next state
    # z_from_b_mean_ratio > 0: rows whose z is a mean of B over a subset of next states,
    # and each row's subset weights (n, n), rows summing to 1.
    use_mean: torch.Tensor | None
    mean_weights: torch.Tensor | None
    noise: torch.Tensor  # (2, n, act_dim): target-policy and actor smoothing noise
    # z_from_traj_ratio > 0: rows whose z is a mean of B over one trajectory segment, and
    # each row's TRAJ_Z_STATES states of its segment (n, TRAJ_Z_STATES, obs_dim).
    use_traj: torch.Tensor | None = None
    traj_obs: torch.Tensor | None = None
    # traj_z_noise > 0: each row's perturbation of its unit trajectory mean (n, d).
    traj_noise: torch.Tensor | None = None


class FBTrainer:
    def __init__(
        self,
        model_config: FBModelConfig,
        train_config: FBTrainConfig,
        dataset: Dataset,
        device: str = "cpu",
        compile: bool = False,
    ) -> None:
        self.mcfg, self.cfg, self.dataset = model_config, train_config, dataset
        self.device = torch.device(device)
        torch.manual_seed(train_config.seed)
        self.model = FBModel(model_config).train()
        if train_config.init == "orthogonal":
            orthogonal_init(self.model)
        if model_config.normalize_obs:
            self.model.set_obs_stats(dataset.observation)
        self.model.to(self.device)
        self.f_target = copy.deepcopy(self.model.forward_net).requires_grad_(False)
        self.b_target = copy.deepcopy(self.model.backward_net).requires_grad_(False)
        # fused: one kernel per step for all parameters instead of a Python loop over
        # them; ~7 % more updates/s at the cpu maze size (benchmarks/fb_update.py).
        self.opt_fb = torch.optim.Adam(
            [
                {"params": self.model.forward_net.parameters(), "lr": train_config.lr_f},
                {"params": self.model.backward_net.parameters(), "lr": train_config.lr_b},
            ],
            fused=True,
        )
        self.opt_actor = torch.optim.Adam(
            self.model.actor.parameters(), lr=train_config.lr_actor, fused=True
        )
        self.gen = torch.Generator(device="cpu").manual_seed(train_config.seed)
        # The averaged model (ema_decay > 0): what is saved for inference.
        self.ema: FBModel | None = None
        if train_config.ema_decay > 0:
            self.ema = copy.deepcopy(self.model).requires_grad_(False).eval()
        # The dataset as tensors, once: sampling is then pure tensor indexing.
        self.obs = torch.from_numpy(dataset.observation).to(self.device)
        self.action = torch.from_numpy(dataset.action).to(self.device)
        self.next_index = torch.from_numpy(dataset.next_index).to(self.device)
        self.step = 0
        self.measure_mass = 1.0
        # The two loss functions, compiled by torch.compile (inductor) when asked: the
        # update is bound by many small kernels at CPU sizes, which inductor fuses.
        self._fb_losses = self.fb_losses
        self._actor_loss = self.actor_loss
        if compile:
            self._fb_losses = compiled(self.fb_losses)
            self._actor_loss = compiled(self.actor_loss)
        self.sqrt_d = math.sqrt(model_config.z_dim)
        self._index_episodes()

    def _index_episodes(self) -> None:
        """Row sets for n-step targets and trajectory z's, from the dataset's next_index."""
        if self.cfg.nstep > 1:
            k = self.cfg.nstep
            p = torch.arange(len(self.next_index) - k + 1, device=self.device)
            # Rows whose next k transitions stay inside one episode.
            self.nstep_rows = p[self.next_index[p + k - 1] == self.next_index[p] + k - 1]
            w = self.cfg.gamma ** torch.arange(k, dtype=torch.float64)
            self.k_probs = (w / w.sum()).float()
            self.measure_mass = float(w.sum())  # sum_{k<n} gamma^k
        if self.cfg.z_from_traj_ratio > 0:
            self.episode_last = episode_last_transition(self.next_index)

    # -- one update, in named steps -----------------------------------------------------
    def update(self) -> dict[str, torch.Tensor]:
        """One gradient step: sample, FB (+ orthonormality, + Q) step, actor step, targets."""
        batch = self.sample()
        fb_metrics, z = self.update_fb(batch)
        actor_metrics = self.update_actor(batch, z)
        self.update_targets()
        self.update_ema()
        self.step += 1
        return {**fb_metrics, **actor_metrics}

    def sample(self) -> Batch:
        """A batch of transitions and every random draw of the update, in a fixed order
        from the trainer's generator (so the compiled and eager paths see the same draws)."""
        cfg, n, gen = self.cfg, self.cfg.batch_size, self.gen
        far_obs = None
        if cfg.nstep == 1:
            rows = torch.randint(0, len(self.next_index), (n,), generator=gen).to(self.device)
        else:
            pick = torch.randint(0, len(self.nstep_rows), (n,), generator=gen)
            rows = self.nstep_rows[pick.to(self.device)]
            k = torch.multinomial(self.k_probs, n, replacement=True, generator=gen)
            far_obs = self.obs[self.next_index[rows + k.to(self.device)]]  # s_{t+k+1}
        j = self.next_index[rows]
        next_obs = self.obs[j]
        boot_obs = next_obs if cfg.nstep == 1 else self.obs[self.next_index[rows + cfg.nstep - 1]]
        z_gauss = torch.randn(n, self.mcfg.z_dim, generator=gen)
        perm = torch.randperm(n, generator=gen)
        u = torch.rand(n, generator=gen)
        use_b = u < cfg.z_from_b_ratio
        use_mean = mean_weights = None
        if cfg.z_from_b_mean_ratio > 0:  # extra draws only then: other runs keep their stream
            use_mean = (u >= cfg.z_from_b_ratio) & (
                u < cfg.z_from_b_ratio + cfg.z_from_b_mean_ratio
            )
            size = torch.exp(torch.rand(n, 1, generator=gen) * math.log(n / 2)) * 2  # [2, n]
            pick = (torch.rand(n, n, generator=gen) < size / n).float()
            pick[:, 0] += pick.sum(1) == 0  # never an empty subset
            mean_weights = pick / pick.sum(1, keepdim=True)
        use_traj, traj_obs = self._sample_traj(u) if cfg.z_from_traj_ratio > 0 else (None, None)
        # Two draws (target policy, then actor), as separate calls: one call of twice the
        # size would not give the same numbers.
        shape = (n, self.mcfg.act_dim)
        noise = torch.stack([torch.randn(shape, generator=gen) for _ in range(2)]) * cfg.stddev
        traj_noise = None
        if cfg.traj_z_noise > 0:  # after every other draw: runs without it keep their stream
            g = nn.functional.normalize(torch.randn(n, self.mcfg.z_dim, generator=gen), dim=-1)
            traj_noise = (torch.rand(n, 1, generator=gen) * cfg.traj_z_noise * g).to(self.device)
        to = self.device
        return Batch(
            self.obs[j - 1],
            self.action[j],
            next_obs,
            boot_obs,
            far_obs,
            z_gauss.to(to),
            perm.to(to),
            use_b.to(to),
            None if use_mean is None else use_mean.to(to),
            None if mean_weights is None else mean_weights.to(to),
            noise.clamp(-cfg.stddev_clip, cfg.stddev_clip).to(to),
            None if use_traj is None else use_traj.to(to),
            traj_obs,
            traj_noise,
        )

    def _sample_traj(self, u: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Rows whose z is a trajectory mean (by the shared uniform draw u), and each row's
        TRAJ_Z_STATES states of one segment of one episode (extra draws, after the others)."""
        cfg, n = self.cfg, self.cfg.batch_size
        low = cfg.z_from_b_ratio + cfg.z_from_b_mean_ratio
        use_traj = (u >= low) & (u < low + cfg.z_from_traj_ratio)
        return use_traj, self.obs[segment_states(self.next_index, self.episode_last, n, self.gen)]

    def _combine_heads(self, x: torch.Tensor) -> torch.Tensor:
        """The two target heads (dim 0) as one target: their min, or their mean."""
        # Elementwise over the two heads: a min-reduction over a leading dim of size 2 is
        # ~10x slower on CPU (1.4 ms for the n x n target at batch 512).
        if self.cfg.target_heads == "min":
            return torch.minimum(x[0], x[1])
        return 0.5 * (x[0] + x[1])

    def b_frozen(self) -> bool:
        return 0 < self.cfg.freeze_b_step <= self.step

    def update_fb(self, batch: Batch) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
        """One Adam step of F and B on L_FB + ortho_coef L_orth (+ q_loss_coef L_Q)."""
        frozen = self.b_frozen()
        if frozen:  # eval mode: batch norm uses (and keeps) its running statistics
            self.model.backward_net.eval()
            self.b_target.eval()
        out = self._fb_losses(batch, frozen)
        self.opt_fb.zero_grad(set_to_none=True)
        out["loss"].backward()
        self.opt_fb.step()
        z = out.pop("z")
        del out["loss"]
        return out, z

    def update_actor(self, batch: Batch, z: torch.Tensor) -> dict[str, torch.Tensor]:
        """One Adam step of the actor on L_actor (F receives no gradient)."""
        # F's parameters leave the graph for this loss: F receives no gradient, and the
        # compiled backward then computes no weight gradients for F only to drop them.
        self.model.forward_net.requires_grad_(False)
        try:
            loss, q = self._actor_loss(batch.obs, z, batch.noise[1])
            self.opt_actor.zero_grad(set_to_none=True)
            loss.backward()
        finally:
            self.model.forward_net.requires_grad_(True)
        self.opt_actor.step()
        return {"actor_q": q}

    @torch.no_grad()
    def update_targets(self) -> None:
        """Polyak averaging of F and B's targets (batch-norm statistics copied)."""
        m = self.model
        pairs = [(m.forward_net, self.f_target), (m.backward_net, self.b_target)]
        self._polyak(pairs, self.cfg.tau)

    @torch.no_grad()
    def update_ema(self) -> None:
        """The model's Polyak average (ema_decay > 0; batch-norm statistics copied)."""
        if self.ema is None:
            return
        rate = 1.0 - min(self.cfg.ema_decay, (1.0 + self.step) / (10.0 + self.step))
        m, ema = self.model, self.ema
        pairs = [(m.forward_net, ema.forward_net), (m.backward_net, ema.backward_net)]
        self._polyak([*pairs, (m.actor, ema.actor)], rate)

    def _polyak(self, pairs: list[tuple[nn.Module, nn.Module]], rate: float) -> None:
        """avg <- avg + rate (net - avg) for each (net, avg) pair's parameters; with batch
        norm, the buffers (its running statistics; the input statistics are constants)
        are copied, not averaged."""
        for net, avg in pairs:
            torch._foreach_lerp_(list(avg.parameters()), list(net.parameters()), rate)
            if self.mcfg.b_norm == "batchnorm":
                for ab, b in zip(avg.buffers(), net.buffers(), strict=True):
                    ab.copy_(b)

    # -- the losses: pure functions of a batch (what `compile` compiles) ----------------
    def _autocast(self) -> torch.autocast:
        # bf16 autocast runs the networks' matmuls at ~2-3x the fp32 rate on AVX-512 CPUs;
        # the n x n Gram products and the losses stay in fp32 (M reaches 1e3, and the TD
        # error is a small difference of large numbers).
        bf16 = self.cfg.precision == "bf16"
        return torch.autocast(self.device.type, torch.bfloat16, enabled=bf16)

    def fb_losses(self, batch: Batch, frozen: bool) -> dict[str, torch.Tensor]:
        """L_FB, L_orth, L_Q and their total `loss`, with the z of each row (`z`)."""
        cfg, m, amp = self.cfg, self.model, self._autocast()
        with amp, torch.set_grad_enabled(not frozen):
            b_next = m.backward_net(batch.next_obs).float()  # (n, d)
        z = torch.where(batch.use_b[:, None], b_next.detach()[batch.perm], batch.z_gauss)
        if batch.use_mean is not None and batch.mean_weights is not None:
            z_mean = batch.mean_weights @ b_next.detach()
            z = torch.where(batch.use_mean[:, None], z_mean, z)
        if batch.use_traj is not None and batch.traj_obs is not None:
            rows = torch.nonzero(batch.use_traj).flatten()  # B of the chosen rows' states only
            _, k, obs_dim = batch.traj_obs.shape
            training = m.backward_net.training
            m.backward_net.eval()  # batch norm: running statistics, left unchanged
            with torch.no_grad(), amp:
                b_traj = m.backward_net(batch.traj_obs[rows].reshape(-1, obs_dim)).float()
            m.backward_net.train(training)
            z_traj = b_traj.reshape(len(rows), k, -1).mean(1)
            if batch.traj_noise is not None:  # traj_z_noise: a perturbed unit mean
                z_traj = nn.functional.normalize(z_traj, dim=-1) + batch.traj_noise[rows]
            z = z.index_copy(0, rows, z_traj)
        z = self.sqrt_d * nn.functional.normalize(z, dim=-1)
        with torch.no_grad(), amp:
            next_action = (m.actor(batch.boot_obs, z) + batch.noise[0]).clamp(-1, 1)
            f_tgt = self.f_target(batch.boot_obs, z, next_action).float()  # (2, n, d)
            b_tgt = self.b_target(batch.next_obs).float()
        with amp:
            f = m.forward_net(batch.obs, z, batch.action).float()  # (2, n, d)
        target = self._combine_heads(torch.matmul(f_tgt, b_tgt.T)).detach()  # (n, n)
        discount = cfg.gamma**cfg.nstep
        # M = F B^T (2, n, n) is never formed: see offdiag_residual_sq.
        fb_offdiag = 0.5 * offdiag_residual_sq(f, b_next, discount * target).sum()
        b_far = b_next
        if batch.far_obs is None:
            fb_diag = -(f * b_next).sum(-1).mean(-1).sum()
        else:
            with amp, torch.set_grad_enabled(not frozen):
                b_far = m.backward_net(batch.far_obs).float()
            fb_diag = -self.measure_mass * (f * b_far).sum(-1).mean(-1).sum()
        # mean_{i!=j} (b_i^T b_j)^2 - 2 mean_i |b_i|^2, through the d x d Gram B^T B.
        n, d = b_next.shape
        sq_norms = (b_next * b_next).sum(-1)
        gram_bb = b_next.T @ b_next
        offdiag_cov = ((gram_bb * gram_bb).sum() - (sq_norms * sq_norms).sum()) / (n * (n - 1))
        ortho_loss = offdiag_cov - 2 * sq_norms.mean()
        q_loss = torch.zeros((), device=f.device)
        if cfg.q_loss_coef > 0:
            q_loss = self._q_loss(f, f_tgt.detach(), b_next.detach(), b_far.detach(), z)
        gram = gram_bb.detach() / n
        eye = torch.eye(d, device=gram.device)
        return {
            "loss": fb_offdiag + fb_diag + cfg.ortho_coef * ortho_loss + cfg.q_loss_coef * q_loss,
            "z": z.detach(),
            "fb_loss": (fb_offdiag + fb_diag).detach(),
            "fb_diag": fb_diag.detach(),
            "fb_offdiag": fb_offdiag.detach(),
            "ortho_loss": ortho_loss.detach(),
            "ortho_error": torch.linalg.matrix_norm(gram - eye),
            "q_loss": q_loss.detach(),
        }

    def _q_loss(
        self,
        f: torch.Tensor,
        f_tgt: torch.Tensor,
        b_next: torch.Tensor,
        b_far: torch.Tensor,
        z: torch.Tensor,
    ) -> torch.Tensor:
        """L_Q: the TD error of F^T z with the implicit reward B(s)^T Cov^-1 z, summed like
        the FB target's measure term (one k per row, weight sum_{k<n} gamma^k) for n-step."""
        cfg, n = self.cfg, f.shape[1]
        mass = 1.0 if cfg.nstep == 1 else self.measure_mass
        # In float64: a batch's Cov can be ill-conditioned (1e7 on data from one corner);
        # Cov^-1 z is then huge and b^T (Cov^-1 z) cancels badly in fp32.
        b64 = b_next.double()
        inv_z = torch.linalg.solve(b64.T @ b64 / n, z.T.double()).T
        reward = (mass * (b_far.double() * inv_z).sum(-1)).float()
        y = reward + cfg.gamma**cfg.nstep * self._combine_heads((f_tgt * z).sum(-1))
        return 0.5 * ((f * z).sum(-1) - y).pow(2).mean(-1).sum()

    def actor_loss(
        self, obs: torch.Tensor, z: torch.Tensor, noise: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """L_actor = -mean min_k F^k(s, mu(s, z) + noise, z)^T z, and that mean Q."""
        m = self.model
        with self._autocast():
            noisy = m.actor(obs, z) + noise
            pi_action = noisy.clamp(-1, 1)
            if self.cfg.actor_clamp == "straight_through":  # value clamped, gradient not
                pi_action = noisy + (pi_action - noisy).detach()
            f_pi = m.forward_net(obs, z, pi_action).float()
        q = (f_pi * z).sum(-1).min(0).values.mean()
        return -q, q.detach()

    # -- Cov B ----------------------------------------------------------------------------
    @torch.no_grad()
    def compute_cov_b(self, chunk: int = 65_536, model: FBModel | None = None) -> torch.Tensor:
        """E_{s~rho}[B(s) B(s)^T] over every next state of the dataset (eval mode), for
        `model` (default: the trained one)."""
        net = (model or self.model).backward_net
        was_training = net.training
        net.eval()
        d = self.mcfg.z_dim
        acc = torch.zeros(d, d, dtype=torch.float64, device=self.device)
        for start in range(0, len(self.next_index), chunk):
            b = net(self.obs[self.next_index[start : start + chunk]]).double()
            acc += b.T @ b
        net.train(was_training)
        return (acc / len(self.next_index)).float()

    # -- checkpoints ---------------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        ema = {} if self.ema is None else {"ema": self.ema.state_dict()}
        return {
            **ema,
            "model": self.model.state_dict(),
            "f_target": self.f_target.state_dict(),
            "b_target": self.b_target.state_dict(),
            "opt_fb": self.opt_fb.state_dict(),
            "opt_actor": self.opt_actor.state_dict(),
            "gen": self.gen.get_state(),
            "step": self.step,
            "model_config": dataclasses.asdict(self.mcfg),
            "train_config": dataclasses.asdict(self.cfg),
        }

    def load(self, state: dict[str, Any]) -> None:
        try:
            self.model.load_state_dict(state["model"])
            self.f_target.load_state_dict(state["f_target"])
            self.b_target.load_state_dict(state["b_target"])
            self.opt_fb.load_state_dict(state["opt_fb"])
            self.opt_actor.load_state_dict(state["opt_actor"])
            if self.ema is not None:
                # A checkpoint saved without an average starts it from the trained weights.
                self.ema.load_state_dict(state.get("ema", state["model"]))
        except (KeyError, RuntimeError) as exc:
            first = str(exc).strip().splitlines()[0]
            raise FbilError(f"checkpoint does not match this model ({first})") from None
        # Adam's state dict carries the learning rates it was saved with; the config wins,
        # so `--resume --set lr_f=...` continues with the new rate instead of ignoring it.
        cfg = self.cfg
        for opt, rates in ((self.opt_fb, (cfg.lr_f, cfg.lr_b)), (self.opt_actor, (cfg.lr_actor,))):
            for group, lr in zip(opt.param_groups, rates, strict=True):
                group["lr"] = lr
        self.gen.set_state(state["gen"])
        self.step = int(state["step"])

    # -- the loop ----------------------------------------------------------------------
    def fit(
        self,
        out: str | Path,
        resume: bool = False,
        progress: bool = True,
        manifest: dict[str, Any] | None = None,
    ) -> FBModel:
        """Train to `cfg.steps`, checkpointing atomically; returns the frozen model (also
        saved in `out` with Cov B)."""
        out = Path(out)
        self._open_run(out, resume)
        log = out / LOG
        wall_before = last_wall_seconds(log)
        new_log = not log.exists()
        with open(log, "a", newline="") as fh:
            writer = csv.DictWriter(fh, LOG_FIELDS)
            if new_log:
                writer.writeheader()
            bar = progress_bar(
                total=self.cfg.steps,
                initial=self.step,
                disable=not progress,
                desc="pretrain",
                unit="step",
            )
            with StopSignals() as stop:
                wall = self._loop(out, fh, writer, bar, manifest, wall_before, stop)
                bar.close()
        save_state(out / CHECKPOINT, self.state())
        self._save_model(out, manifest, wall)
        if stop:
            raise stop.stopped(out, self.step)
        return FBModel.load(out)

    def _open_run(self, out: Path, resume: bool) -> None:
        """Load the checkpoint on resume (same model config), or refuse to overwrite."""
        ckpt = out / CHECKPOINT
        if resume:
            if not ckpt.is_file():
                raise FbilError(f"--resume: no checkpoint in {out} (start without --resume)")
            state = load_state(ckpt)
            saved = config_from_dict(FBModelConfig, state["model_config"], "model config")
            if saved != self.mcfg:
                raise FbilError(f"{ckpt}: saved with another model config; use the same preset")
            self.load(state)
            truncate_log(out / LOG, self.step, LOG_FIELDS)
        elif ckpt.exists() or (out / "model.safetensors").exists():  # never overwrite
            raise FbilError(f"{out} already holds a model: pass --resume or choose another --out")
        self.model.metadata["dataset_history"] = self._dataset_history(out, resume)
        out.mkdir(parents=True, exist_ok=True)

    def _loop(
        self,
        out: Path,
        fh: Any,
        writer: csv.DictWriter,
        bar: Any,
        manifest: dict[str, Any] | None,
        wall_before: float,
        stop: StopSignals,
    ) -> float:
        """Updates until cfg.steps (or a stop signal): log rows, snapshots, timed
        checkpoints; the wall time."""
        started = last_ckpt = last_log = time.perf_counter()
        steps_at_log = self.step
        while self.step < self.cfg.steps and not stop:
            metrics = self.update()
            now = time.perf_counter()
            wall = wall_before + now - started
            if self.step % self.cfg.log_every == 0 or self.step == self.cfg.steps:
                rate = (self.step - steps_at_log) / max(now - last_log, 1e-9)
                row = {k: round(float(v), 6) for k, v in metrics.items()}
                row.update(step=self.step, steps_per_s=round(rate, 2), wall_seconds=round(wall, 1))
                writer.writerow(row)
                fh.flush()
                bar.set_postfix(
                    fb=f"{row['fb_loss']:.3g}",
                    orth=f"{row['ortho_error']:.2f}",
                    q=f"{row['actor_q']:.3g}",
                )
                bar.update(self.step - bar.n)
                last_log, steps_at_log = now, self.step
            every = self.cfg.snapshot_every
            if every and self.step % every == 0:
                name = Path("snapshots") / f"step_{self.step:07d}"
                self._save_model(out / name, manifest, wall)
                if self.ema is not None:  # the trained weights too, to compare
                    self._save_model(out / "raw" / name, manifest, wall, raw=True)
            if now - last_ckpt >= self.cfg.checkpoint_seconds:
                fh.flush()
                save_state(out / CHECKPOINT, self.state())
                if self.cfg.snapshot_model:
                    self._save_model(out, manifest, wall)
                last_ckpt = time.perf_counter()
        bar.update(self.step - bar.n)
        return wall_before + time.perf_counter() - started

    def _dataset_history(self, out: Path, resume: bool) -> list[dict[str, Any]]:
        """The datasets the run has read so far, plus this one if it changed on resume.

        Resuming on other data is how a model is fine-tuned, so it is allowed; it is said
        once on stderr and kept in the model's metadata, so the model names every dataset
        it was trained on, not only the last."""
        here = str(self.dataset.root)
        saved: dict[str, Any] = {}
        # On resume, no model may be saved beside the checkpoint yet: then start afresh.
        with contextlib.suppress(OSError, ValueError):
            saved = json.loads((out / CONFIG).read_text()) if resume else {}
        history = list(saved.get("dataset_history") or [])
        if not history and saved.get("dataset"):  # models saved before the history existed
            history = [{"dataset": str(saved["dataset"]), "from_step": 0}]
        if not history:
            return [{"dataset": here, "from_step": 0}]
        last = history[-1]["dataset"]
        if Path(last).resolve() != Path(here).resolve():
            tqdm.write(
                f"note: resuming at step {self.step} on {here}; the checkpoint was trained "
                f"on {last} (fine-tuning on new data; both are kept in the model's metadata)",
                file=sys.stderr,
            )
            history.append({"dataset": here, "from_step": self.step})
        return history

    def _save_model(
        self, out: Path, manifest: dict[str, Any] | None, wall: float, raw: bool = False
    ) -> None:
        """The inference model as it is now (the average when ema_decay > 0, unless `raw`),
        with Cov B over the whole dataset."""
        model = self.model if raw or self.ema is None else self.ema
        if model is self.ema:
            model.metadata = dict(self.model.metadata, ema_decay=self.cfg.ema_decay)
        model.cov_b.copy_(self.compute_cov_b(model=model))
        model.metadata.update(
            train_config=dataclasses.asdict(self.cfg),
            steps=self.step,
            dataset=str(self.dataset.root),
            dataset_manifest=manifest or {},
            git_commit=git_commit(),
            wall_seconds=round(wall, 1),
        )
        model.save(out)
