"""SMODICE (Ma et al. 2022), as the paper's App. B: the shared DICE pipeline of `dice.py`
with a state discriminator, from action-free demos. The dual's divergence is KL, the
authors' code's (JasonMa2016/SMODICE) default for observation-only imitation; Table 2's
chi^2 is `--set dual.divergence=chi2`. KL became the default in session 25: on loop, two
draws each, KL returned 194.2 and chi^2 130.0 (docs/baselines.md).

Reward R(s') = log D(s') - log(1 - D(s')) on the transition's next state (the paper's rewards
are r(s_{t+1})); with e = R + gamma nu(s') - nu(s), nu minimises
  KL:    (1 - gamma) E_s0[nu(s0)] + log E_D[exp(e)],
  chi^2: (1 - gamma) E_s0[nu(s0)] + E_D[f*(e)],
f*(y) = y^2 / 2 + y the conjugate of f(x) = (x - 1)^2 / 2 (the authors' chi^2, unclipped in
the loss; until session 15 fbil used the conjugate restricted to x >= 0, `chi2_plus`, which
gives rows with y < -1 no gradient). The policy maximises E_D[w log pi(a|s)] with
w = softmax(e) * batch size (KL) or w = max(0, e + 1) (chi^2). Gradient penalty: Table 2's
SMODICE row."""

from __future__ import annotations

from fbil.baselines.dice import DualConfig, dice_imitator

PENALTY = {"walker": 2.0, "cheetah": 10.0, "quadruped": 2.0, "point_mass_maze": 10.0}
DUAL = DualConfig(divergence="kl", alpha=0.0)

IMITATOR = dice_imitator("smodice", "s", "distribution matching (state)", DUAL, PENALTY)
