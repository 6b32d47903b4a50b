"""FB configurations: the architecture (saved with the model) and the optimisation, with
three presets: `paper` (Table 1 of the paper, for GPUs), `cpu` (fits a couple of hours on
2 cores), `smoke` (seconds, for tests)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

from fbil.envs import get_domain
from fbil.errors import FbilError

BNorm = Literal["l2", "batchnorm", "none"]
Precision = Literal["fp32", "bf16"]
TargetHeads = Literal["min", "mean"]
ActorClamp = Literal["hard", "straight_through"]
Init = Literal["torch", "orthogonal"]
FHeads = Literal["shared", "independent"]


@dataclass(frozen=True)
class FBModelConfig:
    obs_dim: int
    act_dim: int
    z_dim: int = 50
    b_hidden: int = 256  # B: two hidden layers of this width
    b_norm: BNorm = "l2"  # output normalisation of B (paper Table 1)
    f_hidden: int = 1024  # F and actor: hidden width of embeddings and heads
    f_embed: int = 512  # F and actor: width of each embedding
    extra_layer: bool = False  # maze: one more hidden layer after the embeddings
    # Standardise observations by the training data's mean/std before every network. The
    # maze's positions span +-0.3 next to z and actions of unit scale; raw, they barely
    # move the first layers, and the values learned in 30k steps ignored the walls.
    normalize_obs: bool = False
    # F's two heads: "shared" embeddings with two output MLPs (the paper's and Touati et
    # al.'s code), or "independent", two whole F networks, embeddings included (Meta's
    # metamotivo `ForwardMap` with two parallel members), so the heads' errors are less
    # correlated and a mean target (`target_heads="mean"`) is less redundant.
    f_heads: FHeads = "shared"

    def __post_init__(self) -> None:
        if self.f_heads not in ("shared", "independent"):
            raise FbilError(f"unknown f_heads {self.f_heads!r}; valid: shared, independent")


@dataclass(frozen=True)
class FBTrainConfig:
    batch_size: int = 1024
    gamma: float = 0.98
    lr_f: float = 1e-4
    lr_b: float = 1e-4
    lr_actor: float = 1e-4
    tau: float = 0.01  # Polyak rate of the targets (momentum 0.99)
    stddev: float = 0.2  # policy smoothing noise
    stddev_clip: float = 0.3
    ortho_coef: float = 1.0
    z_from_b_ratio: float = 0.5  # share of z drawn as B(s) of a dataset state
    # Share of z drawn as the mean of B over a random subset of the batch's next states
    # (subset size log-uniform in [2, batch]), taken from the Gaussian rows. Reward and
    # demonstration z's (E[r B], E_demo[B]) are such averages: with constants in span B
    # they lean on E[B] (cosine 0.6-0.8 on walker) far beyond single B(s) or Gaussian z's
    # (99th percentile 0.28), so without them the actor never trains on the z's it is
    # asked to serve (scripts/fb_diagnostics.py). 0 = the paper's two sources.
    z_from_b_mean_ratio: float = 0.0
    # Share of z drawn as the mean of B over TRAJ_Z_STATES states of one dataset trajectory
    # segment (length log-uniform in [8, 1000] transitions, cut at its episode's end),
    # taken from the Gaussian rows: the shape of z that ERFB reads off a demonstration,
    # E_demo[B], which neither B of one state nor a Gaussian z resembles. 0: off.
    z_from_traj_ratio: float = 0.0
    # Perturbs each trajectory-mean z: its unit direction plus s * g, g a random unit
    # direction and s uniform in [0, traj_z_noise] per row, then projected. The gradient
    # FB-IL methods move z ~34 degrees off E_demo[B] (cosine 0.83 on walker, session 38),
    # z's F is not trained on unless they happen to come up as Gaussian draws; 0.67 spans
    # that angle (up to 42 degrees). 0: off (needs z_from_traj_ratio > 0).
    traj_z_noise: float = 0.0
    steps: int = 1_000_000
    seed: int = 0
    log_every: int = 250
    checkpoint_seconds: float = 180.0
    snapshot_model: bool = True  # also save the usable model (with Cov B) at checkpoints
    # Keep a usable model every N steps in snapshots/step_N/ (0: none), to follow the
    # zero-shot quality along one run (`fbil zero-shot` on each).
    snapshot_every: int = 0
    precision: Precision = "fp32"  # "bf16": networks under bf16 autocast, losses in fp32
    # n-step target (experimental; 1 = the paper's loss): M(s_t, a_t) is matched to
    # sum_{k<n} gamma^k delta(s_{t+k+1}) + gamma^n M(s_{t+n}, pi_z) along the data's episodes;
    # the measure term uses one k per row drawn with probability ~ gamma^k (unbiased).
    nstep: int = 1
    # Weight of an auxiliary TD loss on Q_z = F(s, a, z)^T z with the implicit reward
    # B(s')^T Cov^-1 z (Cov from the batch), as in Meta's later FB code; 0 = the paper's
    # loss. The FB loss spreads F's capacity over every state's measure; this term presses
    # on the one direction the actor maximises. With nstep > 1 the reward is summed over
    # the same n steps as the FB target.
    q_loss_coef: float = 0.0
    # How the two target heads combine in the FB target: "min" (the paper's pessimism) or
    # "mean" (Meta's later FB code: pessimism only in the actor). A min of two noisy
    # estimates is biased low; the bias compounds over the many backups a far goal needs.
    target_heads: TargetHeads = "min"
    # How the actor loss keeps mu(s, z) + noise inside [-1, 1]: "hard" clamps (no gradient
    # where the noisy action leaves the box, i.e. for most components of a saturated
    # tanh policy), "straight_through" clamps the value and passes the gradient as if
    # unclamped (the reference FB code's truncated-normal policy does this).
    actor_clamp: ActorClamp = "hard"
    # From this step on (0 = never), B and its batch-norm statistics stay fixed and only F
    # and the actor learn: F's target stops moving, so the far field of the measure (slow
    # to propagate through the few room-to-room transitions) can settle. The paper's maze
    # lr_b of 1e-6 keeps B nearly still for most of its 10^6+ steps; this gets there in
    # the steps a CPU affords.
    freeze_b_step: int = 0
    # Polyak average of the whole model (F, B, actor) kept beside the trained one, with
    # this decay per update (0: off); the saved model (and its snapshots) is then the
    # average, the trained weights go to raw/snapshots/. Zero-shot policies of a single
    # run swing by hundreds from one snapshot to the next (walker, 512 units): the last
    # iterate is one point of a noisy path, the average a smoother estimate of it. The
    # first updates use min(decay, (1 + t) / (10 + t)), so the random init fades fast.
    ema_decay: float = 0.0
    # Initial weights: "torch" (PyTorch's default, uniform +-1/sqrt(fan_in) for weights and
    # biases) or "orthogonal" (orthogonal weights, gain 1, zero biases, for every linear
    # layer of F, B and the actor), the reference FB code's initialisation
    # (docs/fb-reference-audit.md).
    init: Init = "torch"

    def __post_init__(self) -> None:
        if self.steps < 1 or self.batch_size < 2:
            raise FbilError(
                f"steps must be >= 1 and batch_size >= 2 (got {self.steps}, {self.batch_size})"
            )
        if self.precision not in ("fp32", "bf16"):
            raise FbilError(f"unknown precision {self.precision!r}; valid: fp32, bf16")
        if self.target_heads not in ("min", "mean"):
            raise FbilError(f"unknown target_heads {self.target_heads!r}; valid: min, mean")
        if self.actor_clamp not in ("hard", "straight_through"):
            raise FbilError(
                f"unknown actor_clamp {self.actor_clamp!r}; valid: hard, straight_through"
            )
        if self.nstep < 1:
            raise FbilError(f"nstep must be >= 1, got {self.nstep}")
        if self.q_loss_coef < 0:
            raise FbilError(f"q_loss_coef must be >= 0 (0: off), got {self.q_loss_coef}")
        ratios = (self.z_from_b_ratio, self.z_from_b_mean_ratio, self.z_from_traj_ratio)
        if min(ratios) < 0 or sum(ratios) > 1:
            raise FbilError(
                "z_from_b_ratio, z_from_b_mean_ratio and z_from_traj_ratio must be >= 0 and "
                f"sum to <= 1 (got {ratios[0]}, {ratios[1]}, {ratios[2]})"
            )
        if self.traj_z_noise < 0 or (self.traj_z_noise > 0 and self.z_from_traj_ratio == 0):
            raise FbilError(
                f"traj_z_noise must be >= 0 and perturbs trajectory z's only (got "
                f"{self.traj_z_noise} with z_from_traj_ratio {self.z_from_traj_ratio}); set "
                "z_from_traj_ratio > 0 too, or traj_z_noise 0"
            )
        if self.snapshot_every < 0:
            raise FbilError(f"snapshot_every must be >= 0 (0: none), got {self.snapshot_every}")
        if not 0 <= self.ema_decay < 1:
            raise FbilError(f"ema_decay must be in [0, 1) (0: off), got {self.ema_decay}")
        if self.init not in ("torch", "orthogonal"):
            raise FbilError(f"unknown init {self.init!r}; valid: torch, orthogonal")
        if self.freeze_b_step < 0:
            raise FbilError(f"freeze_b_step must be >= 0 (0: never), got {self.freeze_b_step}")


PRESETS = ("paper", "cpu", "smoke")

# Paper Table 1 (z_dim, batch, gamma, lr_b, lr_actor, B normalisation).
_PAPER: dict[str, dict[str, Any]] = {
    "walker": {"z_dim": 100, "batch_size": 2048, "gamma": 0.98, "b_norm": "l2"},
    "cheetah": {"z_dim": 50, "batch_size": 2048, "gamma": 0.98, "b_norm": "none"},
    "quadruped": {"z_dim": 50, "batch_size": 1024, "gamma": 0.98, "b_norm": "l2"},
    "point_mass_maze": {
        "z_dim": 100,
        "batch_size": 1024,
        "gamma": 0.99,
        "b_norm": "batchnorm",
        "lr_b": 1e-6,
        "lr_actor": 1e-6,
        "extra_layer": True,
    },
}

# Walker's training recipe (why: the comment at "walker" below), the start of every
# locomotion domain.
_LOCOMOTION_TRAIN: dict[str, Any] = {
    "lr_b": 1e-4,
    "ema_decay": 0.9995,
    "steps": 200_000,
    "init": "orthogonal",
    "actor_clamp": "straight_through",
    "z_from_traj_ratio": 0.25,
}

# The cpu preset's training settings per domain (a domain not listed: B's lr 1e-4).
# Maze (docs/fb-model.md, "The maze settings of the `cpu` preset", and the runs in
# docs/fb-maze-notes.md): with 1e-4, B turns local and values stop at the
# walls; at 1e-5 with 10-step targets values cross the doorways. gamma 0.99 then
# reaches only the start room, 0.998 ignores walls; 0.997 with B frozen from 10k
# steps (F and the actor keep learning) and the auxiliary Q loss is the best found.
_CPU_TRAIN: dict[str, dict[str, Any]] = {
    "point_mass_maze": {
        "lr_b": 1e-5,
        "nstep": 10,
        "gamma": 0.997,
        "q_loss_coef": 0.1,
        "freeze_b_step": 10_000,
        "steps": 200_000,
    },
    # Walker (docs/walker.md, sessions 11-12 and 26): 256-unit F and actor never walked with
    # z_r in 300 000 updates; at 512 units they walk, but the policy for a fixed z swings by
    # hundreds between snapshots; the Polyak-averaged model (ema_decay) is saved instead.
    # The reference code's orthogonal init and straight-through clamp (with z 100, below)
    # beat the same run without them by 175 on the five-task zero-shot mean (session 26).
    # A quarter of the training z's as B means over one trajectory segment (ERFB's shape)
    # raised the K = 1 imitation mean of eight from 21.2-22.3 % to 25.6 % (sessions 27-28).
    # F and the actor at 1 024 units (below) raised it to 35.0 % (session 32), and twice
    # the updates to 49.2 % (session 36; the curve had not flattened at 100 000).
    "walker": _LOCOMOTION_TRAIN,
    # Cheetah and quadruped start from walker's recipe, untried on them (docs/walker.md,
    # "What walker teaches cheetah and quadruped", item 6); z keeps Table 1's size, 50.
    "cheetah": _LOCOMOTION_TRAIN,
    "quadruped": _LOCOMOTION_TRAIN,
}
# The cpu preset's model settings per domain (others: z 50, F and actor 256 units,
# embeddings 128).
_CPU_MODEL: dict[str, dict[str, Any]] = {
    "walker": {"f_hidden": 1024, "f_embed": 256, "z_dim": 100},
    "cheetah": {"f_hidden": 1024, "f_embed": 256, "z_dim": 50},
    "quadruped": {"f_hidden": 1024, "f_embed": 256, "z_dim": 50},
}


def preset(domain: str, name: str) -> tuple[FBModelConfig, FBTrainConfig]:
    """Model and training configs of preset `name` for `domain`."""
    spec = get_domain(domain)
    if name not in PRESETS:
        raise FbilError(f"unknown preset {name!r}; valid presets: {', '.join(PRESETS)}")
    paper = dict(_PAPER[domain])
    model_keys = {"z_dim", "b_norm", "extra_layer"}
    model = FBModelConfig(
        spec.obs_dim, spec.act_dim, **{k: v for k, v in paper.items() if k in model_keys}
    )
    train = FBTrainConfig(
        **{k: v for k, v in paper.items() if k not in model_keys}, steps=2_000_000
    )
    if name == "paper":
        return model, train
    if name == "cpu":
        # Measured on 2 cores: hidden 256 / batch 512 / d 50 is what a couple of hours
        # buys, and bf16 autocast doubles the update rate (benchmarks/fb_update.py). The
        # actor keeps lr 1e-4, since the paper's 1e-6 needs its millions of steps.
        sizes = {"z_dim": 50, "f_hidden": 256, "f_embed": 128, **_CPU_MODEL.get(domain, {})}
        model = replace(model, **sizes, normalize_obs=True)
        train = replace(train, batch_size=512, lr_actor=1e-4, steps=150_000, precision="bf16")
        return model, replace(train, **_CPU_TRAIN.get(domain, {"lr_b": 1e-4}))
    model = replace(model, z_dim=8, b_hidden=32, f_hidden=32, f_embed=16)
    train = replace(train, batch_size=64, lr_b=1e-4, lr_actor=1e-4, steps=200, log_every=20)
    return model, train
