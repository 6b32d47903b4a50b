"""SMODICE (Ma et al. 2022), as the paper's App. B: the shared DICE pipeline of `dice.py`
with a state discriminator and the chi^2 divergence (Table 2), from action-free demos.

Reward R(s') = log D(s') - log(1 - D(s')) on the transition's next state (the paper's rewards
are r(s_{t+1})); nu minimises
  (1 - gamma) E_s0[nu(s0)] + E_D[f*(R + gamma nu(s') - nu(s))],
f*(y) = y^2 / 2 + y the conjugate of f(x) = (x - 1)^2 / 2 (the chi^2 of the authors' code,
JasonMa2016/SMODICE, unclipped in the loss; until session 15 fbil used the conjugate
restricted to x >= 0, `chi2_plus`, which gives rows with y < -1 no gradient); the policy
maximises E_D[w log pi(a|s)] with w = max(0, R + gamma nu(s') - nu(s) + 1). Gradient
penalty: Table 2's SMODICE row."""

from __future__ import annotations

from fbil.baselines.dice import DualConfig, dice_imitator

PENALTY = {"walker": 2.0, "cheetah": 10.0, "quadruped": 2.0, "point_mass_maze": 10.0}
DUAL = DualConfig(divergence="chi2", alpha=0.0)

IMITATOR = dice_imitator("smodice", "s", "distribution matching (state)", DUAL, PENALTY)
