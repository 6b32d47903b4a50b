"""The registry of imitators by name: the nine FB-IL methods, then the baselines.

Callers (evaluate, benchmark, report, demo, the CLI) go through names only; nothing here
or there branches on a family."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

from fbil.errors import FbilError
from fbil.imitation.demos import Demos
from fbil.imitators.base import FAMILIES, FitContext, Fitted, Imitator

ALL = "all"  # the paper's eight FB-IL methods (the main tables)


@cache
def imitators() -> dict[str, Imitator]:
    """Every registered imitator, in report order (FB-IL's main methods first)."""
    from fbil.baselines import BASELINES
    from fbil.imitators.fb import FB_IMITATORS

    found = [*FB_IMITATORS, *BASELINES]
    return {i.name: i for i in found}


def get_imitator(name: str) -> Imitator:
    table = imitators()
    if name not in table:
        raise FbilError(f"unknown method {name!r}; valid: {', '.join(table)}, {_groups()}")
    return table[name]


def principle_of(name: str) -> str:
    """The IL principle of a method ('' for a name no longer registered)."""
    found = imitators().get(name)
    return found.principle if found else ""


def family_of(name: str) -> str:
    found = imitators().get(name)
    return found.family if found else ""


def _groups() -> str:
    return ", ".join([ALL, *FAMILIES])


@dataclass(frozen=True)
class Selection:
    """Resolved method names; `group`: they came from a group name ('all', a family), so
    a method the demonstrations cannot serve is skipped rather than refused."""

    names: list[str]
    group: bool


def resolve(spec: str | Sequence[str]) -> Selection:
    """'all' (FB-IL's eight), a family ('fb-il', 'offline-il', 'bfm'), a comma list or a
    list -> validated method names."""
    names = spec.split(",") if isinstance(spec, str) else list(spec)
    names = [n.strip().lower() for n in names if n.strip()]
    table = imitators()
    if names == [ALL]:
        from fbil.imitation.methods import MAIN_METHODS

        return Selection(list(MAIN_METHODS), True)
    if len(names) == 1 and names[0] in FAMILIES:
        members = [n for n, i in table.items() if i.family == names[0]]
        if not members:
            raise FbilError(f"no {names[0]} methods are registered yet")
        return Selection(members, True)
    unknown = [n for n in names if n not in table]
    if unknown or not names:
        raise FbilError(
            f"unknown method {', '.join(unknown) or '(none)'}; valid: {', '.join(table)}, "
            f"{_groups()}"
        )
    return Selection(names, False)


def fit(name: str, demos: Demos, context: FitContext) -> Fitted:
    return get_imitator(name).fit(demos, context)
