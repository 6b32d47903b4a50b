"""Offline imitation-learning baselines of the paper (issue #22), each an `Imitator` of
family "offline-il" with named budgets ("cpu", "smoke"); see docs/baselines.md."""

from fbil.baselines import bc, oril, td3il

BASELINES = [bc.IMITATOR, td3il.IMITATOR, *oril.IMITATORS]

__all__ = ["BASELINES"]
