"""Environments: the four DMC domains, their 21 tasks, relabeling and batched rollouts.

MuJoCo renders headless through EGL by default here; set MUJOCO_GL yourself to override
(`osmesa` for software rendering, `disable` when never rendering).
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from fbil.envs.base import DomainSpec, TaskSpec
from fbil.envs.env import FbilEnv, make_env
from fbil.envs.registry import DOMAINS, all_tasks, get_domain, get_task, max_return
from fbil.envs.relabel import compute_quantities, relabel, task_reward
from fbil.envs.rollout import BatchedEnv, Episodes, Policy, RandomPolicy, rollout

__all__ = [
    "DOMAINS",
    "BatchedEnv",
    "DomainSpec",
    "Episodes",
    "FbilEnv",
    "Policy",
    "RandomPolicy",
    "TaskSpec",
    "all_tasks",
    "compute_quantities",
    "get_domain",
    "get_task",
    "make_env",
    "max_return",
    "relabel",
    "rollout",
    "task_reward",
]
