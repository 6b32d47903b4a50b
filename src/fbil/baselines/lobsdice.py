"""LobsDICE (Kim et al. 2022a), as the paper's App. B: the shared DICE pipeline of
`dice.py` with a discriminator on state transitions (s, s') and the KL divergence (Table 2),
from action-free demos.

Reward r(s, s') = log D(s, s') - log(1 - D(s, s')); nu minimises
  (1 - gamma) E_s0[nu(s0)] + (1 + alpha) log E_D[exp((r + gamma nu(s') - nu(s)) / (1 + alpha))],
LobsDICE's objective with its closed-form mu: the dual of min_d KL(d(s, s') || d_E(s, s')) +
alpha KL(d || d_D); the policy maximises E_D[w log pi(a|s)]. alpha = 0.1 as the
authors' code (geon-hyeong/imitation-dice, `lfo_default_config.py`; the paper gives none;
fbil used 0.05 until session 15). Gradient penalty of the discriminator: Table 2's LOBSDICE row."""

from __future__ import annotations

from fbil.baselines.dice import DualConfig, dice_imitator

PENALTY = {"walker": 10.0, "cheetah": 10.0, "quadruped": 2.0, "point_mass_maze": 10.0}
DUAL = DualConfig(divergence="kl", alpha=0.1)

IMITATOR = dice_imitator("lobsdice", "ss", "distribution matching (transition)", DUAL, PENALTY)
