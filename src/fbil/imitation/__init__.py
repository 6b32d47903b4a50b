"""FB-IL: imitation policies from demonstrations through a pre-trained FB model."""

from fbil.imitation.api import imitate
from fbil.imitation.core import ImitationPolicy, OptimiserConfig
from fbil.imitation.demos import Demos, Trajectory, from_arrays, from_imitation
from fbil.imitation.methods import MAIN_METHODS, METHODS

__all__ = [
    "MAIN_METHODS",
    "METHODS",
    "Demos",
    "ImitationPolicy",
    "OptimiserConfig",
    "Trajectory",
    "from_arrays",
    "from_imitation",
    "imitate",
]
