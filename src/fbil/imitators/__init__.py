"""Imitators: every imitation algorithm (FB-IL methods, offline-IL baselines, other
behaviour foundation models) behind one interface and one registry of names."""

from fbil.imitators.base import FAMILIES, FitContext, Fitted, Imitator, Policy
from fbil.imitators.budgets import Budgets, parse_budget, scale_steps
from fbil.imitators.files import load_policy
from fbil.imitators.registry import (
    Selection,
    family_of,
    fit,
    get_imitator,
    imitators,
    principle_of,
    resolve,
)

__all__ = [
    "FAMILIES",
    "Budgets",
    "FitContext",
    "Fitted",
    "Imitator",
    "Policy",
    "Selection",
    "family_of",
    "fit",
    "get_imitator",
    "imitators",
    "load_policy",
    "parse_budget",
    "principle_of",
    "resolve",
    "scale_steps",
]
