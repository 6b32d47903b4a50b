"""What imitate() does around the losses, on the exact finite MDP: gradient methods start
at the ERFB z, and each demonstration counts equally whatever its length (paper,
footnote 3: sample a trajectory, then a state in it)."""

import numpy as np
import pytest
import torch

from fbil.imitation import METHODS, OptimiserConfig, from_arrays, imitate
from fbil.imitation.core import DemoBatch, prepare
from fbil.imitation.methods import bc, bellman, kl, matching
from fbil.imitation.methods.reward import erfb, rerfb
from tests.imitation.tabular import TabularFB

pytestmark = pytest.mark.usefixtures("float64")

GRADIENT_METHODS = [name for name, m in METHODS.items() if m.gradient]


def demo_arrays(fb: TabularFB) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Two demos of one policy, of very different lengths (3 and 40 transitions), that visit
    states in different proportions."""
    z = fb.project_z(torch.randn(fb.z_dim, generator=torch.Generator().manual_seed(4)))
    s1, a1 = fb.rollout(z, 3, start=5, seed=7)
    s2, a2 = fb.rollout(z, 40, start=0, seed=8)
    return [np.eye(fb.S)[s1], np.eye(fb.S)[s2]], [np.eye(fb.A)[a1], np.eye(fb.A)[a2]]


def test_gradient_methods_start_from_the_erfb_z(fb: TabularFB) -> None:
    """With a budget of zero steps every gradient method returns its warm start, which must
    be the ERFB z (paper App. E.2); one step moves it by at most the learning rate."""
    obs, act = demo_arrays(fb)
    demos = from_arrays(obs, act)
    z_erfb = imitate(fb, demos, "erfb").z
    assert GRADIENT_METHODS  # the registry marks them
    for method in GRADIENT_METHODS:
        none = OptimiserConfig(steps=0, batch_size=None, precision="fp32")
        torch.testing.assert_close(imitate(fb, demos, method, optimiser=none).z, z_erfb)
        one = OptimiserConfig(steps=1, lr=1e-3, batch_size=None, precision="fp32")
        moved = imitate(fb, demos, method, optimiser=one).z - z_erfb
        assert float(moved.abs().max()) < 2e-3, method


def _single_losses(fb: TabularFB, batch: DemoBatch, z: torch.Tensor) -> dict[str, float]:
    kl_cfg = OptimiserConfig(lr=0.0, steps=1, batch_size=None, precision="fp32")
    return {
        "bc": float(bc.bc_loss(fb, batch, z)),
        "fm": float(matching.fm_loss(fb, batch, z)),
        "dm": float(matching.dm_loss(fb, batch, z)),
        "bbell": float(bellman.bbell_loss(fb, batch, z)),
        "fbloss": float(bellman.fbloss_loss(fb, batch, z)),
        "kl": float(kl.klfb(fb, batch, z, kl_cfg)[1]["loss_first"]),
    }


def test_each_demonstration_counts_equally_whatever_its_length(fb: TabularFB) -> None:
    """rho_e = (rho_1 + rho_2) / 2 over the two demos: every loss of both demos is the mean
    of the losses of each alone, ERFB's E_{rho_e}[B] the mean of each demo's mean B, and
    minibatches draw rows of each demo half of the time."""
    obs, act = demo_arrays(fb)
    both = prepare(fb, from_arrays(obs, act), fb.gamma)
    alone = [prepare(fb, from_arrays([o], [a]), fb.gamma) for o, a in zip(obs, act, strict=True)]
    for i in range(2):
        assert float(both.weight[both.traj == i].sum()) == pytest.approx(0.5, abs=1e-6)

    z = fb.project_z(torch.randn(fb.z_dim, generator=torch.Generator().manual_seed(9)))
    got = _single_losses(fb, both, z)
    parts = [_single_losses(fb, one, z) for one in alone]
    for name, value in got.items():
        assert value == pytest.approx((parts[0][name] + parts[1][name]) / 2, rel=1e-5), name

    mean_b = [fb.backward(torch.as_tensor(o[1:])).mean(0) for o in obs]
    torch.testing.assert_close(erfb(fb, both)[0], fb.project_z((mean_b[0] + mean_b[1]) / 2))
    e_bbt = sum(fb.B[o[1:].argmax(1)].T @ fb.B[o[1:].argmax(1)] / (len(o) - 1) for o in obs) / 2
    expected = fb.cov_b @ torch.linalg.solve(fb.cov_b + e_bbt, (mean_b[0] + mean_b[1]) / 2)
    torch.testing.assert_close(rerfb(fb, both)[0], fb.project_z(expected))

    rows = both.sample(20_000, torch.Generator().manual_seed(0))
    assert float((rows.traj == 0).double().mean()) == pytest.approx(0.5, abs=0.02)
