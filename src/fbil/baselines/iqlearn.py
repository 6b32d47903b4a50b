"""IQ-Learn (Garg et al. 2021), offline: inverse soft-Q learning with the chi^2
regulariser, the soft-Q critics and tanh-Gaussian actor of `sac.py`.

No reward is learnt: the critic Q defines one, r(s, a, s') = Q(s, a) - gamma V(s'), with the
soft value V(s) = E_{a~pi}[min_i Q_i(s, a) - alpha log pi(a|s)] (V(s') from the target
critics). Each minibatch holds expert rows E and dataset rows D, half and half, and every
critic Q_i minimises

  L(Q) = -E_E[Q(s, a) - gamma V(s')]              (the expert's implied reward, up)
         + E_{E u D}[V(s) - gamma V(s')]           ((1 - gamma) E_p0[V(s0)], telescoped
                                                    over the rows at hand: 'value')
         + 1/(4 c) E_{E u D}[(Q(s, a) - gamma V(s'))^2]   (the chi^2 regulariser, c = 0.5)

(gamma V(s') is multiplied by the row's discount). The actor maximises the soft value,
E[min_i Q_i(s, a~) - alpha log pi(a~|s)], at a fixed temperature alpha = 0.01, as IQ-Learn's
soft actor-critic for continuous actions. The IQ-Learn defaults: c = 0.5 and a fixed
temperature; the FB-IL paper gives no IQ-Learn settings beyond Table 2's common ones."""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from fbil.baselines.common import TrainedPolicy, Transitions, demo_transitions, trained_imitator
from fbil.baselines.sac import SAC, SACConfig, Update, train_sac
from fbil.errors import FbilError
from fbil.imitation.demos import Demos
from fbil.imitators.base import FitContext
from fbil.imitators.budgets import Budgets


@dataclass(frozen=True)
class IQLearnConfig:
    sac: SACConfig = field(default_factory=lambda: SACConfig(temperature=0.01))
    chi2: float = 0.5  # c of the chi^2 term 1/(4c) E[r^2]
    expert_ratio: float = 0.5

    def __post_init__(self) -> None:
        if self.sac.clamp_values:
            raise FbilError(
                "sac.clamp_values bounds a critic by its rewards' range, and IQ-Learn learns "
                "without a reward: drop the setting"
            )


BUDGETS = Budgets(
    cpu=IQLearnConfig(SACConfig(steps=30_000, temperature=0.01)),
    smoke=IQLearnConfig(SACConfig(steps=20, hidden=32, batch_size=64, temperature=0.01)),
)


def iq_loss(
    q: torch.Tensor,
    v: torch.Tensor,
    v_next: torch.Tensor,
    discount: torch.Tensor,
    expert: torch.Tensor,
    gamma: float,
    chi2: float,
) -> torch.Tensor:
    """The module's L(Q), averaged over the critics: q (B, k) for k critics, v and v_next
    (B,) soft values of s and s', discount (B,), expert (B,) bool."""
    y = (gamma * discount * v_next)[:, None]
    reward = q - y
    expert_term = -reward[expert].mean()
    value_term = (v[:, None] - y).mean()
    return expert_term + value_term + (reward**2).mean() / (4 * chi2)


def iq_update(chi2: float) -> Update:
    """IQ-Learn's update with chi^2 constant `chi2`."""

    def update(agent: SAC, batch: Transitions) -> dict[str, float]:
        """One critic step on L(Q), then SAC's actor step."""
        assert batch.action is not None
        v = agent.soft_value(batch.obs, agent.critics)
        with torch.no_grad():
            v_next = agent.soft_value(batch.next_obs, agent.targets)
        q = agent.q(agent.critics, batch.obs, batch.action)
        loss = iq_loss(q, v, v_next, batch.discount, batch.expert, agent.gamma, chi2)
        critic_loss = agent.step(agent.critic_opt, loss)
        q_mean = float(q.detach().mean())
        return {"critic_loss": critic_loss, "q": q_mean, **agent.actor_step(batch.obs)}

    return update


def fit(demos: Demos, context: FitContext) -> TrainedPolicy:
    cfg = BUDGETS[context.budget]
    expert = demo_transitions(demos)
    update = iq_update(cfg.chi2)
    agent, info = train_sac(
        context.dataset,
        update,
        cfg.sac,
        context.seed,
        expert,
        cfg.expert_ratio,
        checkpoint=context.checkpoint,
    )
    return TrainedPolicy("iqlearn", agent.act, agent.state(), info, agent.cfg.precision)


IMITATOR = trained_imitator(
    "iqlearn", "reward (inverse soft-Q)", fit, BUDGETS, needs_actions=True, needs_dataset=True
)
