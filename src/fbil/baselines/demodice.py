"""DemoDICE (Kim et al. 2022b), as the paper's App. B: the shared DICE pipeline of
`dice.py` with a discriminator on (s, a) and the KL divergence.

Reward r(s, a) = log D(s, a) - log(1 - D(s, a)); nu minimises
  (1 - gamma) E_s0[nu(s0)] + (1 + alpha) log E_D[exp((r + gamma nu(s') - nu(s)) / (1 + alpha))],
the dual of min_d KL(d || d_E) + alpha KL(d || d_D) over state-action occupancies d, with
alpha = 0 as the authors' code (geon-hyeong/imitation-dice, `lfd_default_config.py`; the
paper gives none; fbil used 0.05 until session 15); the policy maximises
E_D[w log pi(a|s)], w = d / d_D. Gradient penalty of the discriminator: Table 2's DEMODICE
row. D is the union of the dataset and
the demonstrations, as the authors' code."""

from __future__ import annotations

from fbil.baselines.dice import DualConfig, dice_imitator

PENALTY = {"walker": 10.0, "cheetah": 10.0, "quadruped": 2.0, "point_mass_maze": 10.0}
DUAL = DualConfig(divergence="kl", alpha=0.0)

IMITATOR = dice_imitator("demodice", "sa", "distribution matching", DUAL, PENALTY, union=True)
