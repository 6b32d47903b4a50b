"""Offline imitation-learning baselines of the paper (issue #22), each an `Imitator` of
family "offline-il" with named budgets ("cpu", "smoke"); see docs/baselines.md."""

from fbil.baselines import (
    bc,
    demodice,
    dwbc,
    goal_td3,
    iqlearn,
    lobsdice,
    oril,
    otr,
    smodice,
    sqil,
    td3il,
)

BASELINES = [bc.IMITATOR, td3il.IMITATOR, *oril.IMITATORS]
BASELINES += [dwbc.IMITATOR, sqil.IMITATOR, demodice.IMITATOR, smodice.IMITATOR]
BASELINES += [lobsdice.IMITATOR, iqlearn.IMITATOR]
BASELINES += [otr.IMITATOR]
BASELINES += [goal_td3.IMITATOR]  # family bfm: a pre-trained goal model

__all__ = ["BASELINES"]
