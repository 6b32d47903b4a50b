"""The four domains and their 21 tasks, by name."""

from __future__ import annotations

from fbil.envs import cheetah, maze, quadruped, walker
from fbil.envs.base import DomainSpec, TaskSpec
from fbil.errors import FbilError

DOMAINS: dict[str, DomainSpec] = {
    d.name: d for d in (maze.DOMAIN, walker.DOMAIN, cheetah.DOMAIN, quadruped.DOMAIN)
}


def get_domain(name: str) -> DomainSpec:
    try:
        return DOMAINS[name]
    except KeyError:
        raise FbilError(f"unknown domain {name!r}; valid domains: {', '.join(DOMAINS)}") from None


def get_task(domain: str, task: str) -> TaskSpec:
    spec = get_domain(domain)
    try:
        return spec.tasks[task]
    except KeyError:
        raise FbilError(
            f"unknown task {task!r} for domain {domain!r}; valid tasks: {', '.join(spec.tasks)}"
        ) from None


def all_tasks() -> list[tuple[str, str]]:
    """Every (domain, task) pair, in registry order."""
    return [(d.name, t) for d in DOMAINS.values() for t in d.tasks]


def max_return(domain: str, task: str) -> float:
    """The most any policy can return in one episode of `task`: the per-step bound of its
    reward times the episode length. A figure above it cannot come from this reward."""
    return get_task(domain, task).reward_max * get_domain(domain).episode_length
