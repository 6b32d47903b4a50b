"""Mutation check of the FB-IL exactness tests (not part of CI; a few minutes on 2 cores).

Each mutation is a one-line bug applied to a fresh copy of src/ (with the tests beside
it); the exact tests are then run against the copy (PYTHONPATH puts the copy's `fbil`
ahead of the editable install), stopping at the first failure. A mutation is caught when
some test fails. The unmutated copy must pass first.

    nice -n 10 python scripts/mutation_check.py [--only ID,ID] [--markdown]

Prints one row per mutation: id, what it breaks, the first failing test (or SURVIVED).
Exit status 1 if any mutation survives or a pattern no longer matches the source (the
source changed: update the mutation).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TESTS = [  # fast, exact tests first: -x stops at the first failure
    "tests/imitation/test_exact.py",
    "tests/imitation/test_exact_bc_kl.py",
    "tests/imitation/test_exact_pipeline.py",
    "tests/imitation/test_real_model_exact.py",
    "tests/fb/test_fb_exact.py",
]
IMIT = "src/fbil/imitation"


@dataclass(frozen=True)
class Mutation:
    id: str
    what: str
    path: str
    old: str
    new: str


MUTATIONS = [
    # -- order, transpose, matrix-vs-elementwise (invisible with a diagonal Cov B) ------
    Mutation(
        "rerfb-order",
        "RERFB (C+E)^-1 C E[B] instead of C (C+E)^-1 E[B]",
        f"{IMIT}/methods/reward.py",
        "z = c @ torch.linalg.solve(c + e_bbt, e_b)",
        "z = torch.linalg.solve(c + e_bbt, c @ e_b)",
    ),
    Mutation(
        "rerfb-diag-second-moment",
        "RERFB E[B B^T] replaced by its diagonal",
        f"{IMIT}/methods/reward.py",
        "e_bbt = (w * b).T @ b",
        "e_bbt = torch.diag((w * b * b).sum(0))",
    ),
    Mutation(
        "bbell-c2-elementwise",
        "BBELLFB C^2 computed elementwise (C * C)",
        f"{IMIT}/methods/bellman.py",
        "quad = ((delta @ c.T) ** 2).sum(-1)",
        "quad = ((delta @ (c * c)) * delta).sum(-1)",
    ),
    Mutation(
        "fm-diag-cov",
        "FMFB uses only the diagonal of Cov B",
        f"{IMIT}/methods/matching.py",
        "(f @ model.cov_b.T - batch.g)",
        "(f * model.cov_b.diagonal() - batch.g)",
    ),
    # -- BC and the model's log-likelihood ----------------------------------------------
    Mutation(
        "bc-next-state",
        "BC pairs a_t with s_{t+1}",
        f"{IMIT}/methods/bc.py",
        "model.log_prob(batch.obs,",
        "model.log_prob(batch.next_obs,",
    ),
    Mutation(
        "logprob-sign",
        "FBModel.log_prob sign flipped",
        "src/fbil/fb/model.py",
        "return -((mu - _as_tensor(action)) ** 2).sum(-1)",
        "return ((mu - _as_tensor(action)) ** 2).sum(-1)",
    ),
    Mutation(
        "logprob-std",
        "FBModel.log_prob divides by 2 sigma, not 2 sigma^2",
        "src/fbil/fb/model.py",
        "/ (2 * self.policy_std**2)",
        "/ (2 * self.policy_std)",
    ),
    Mutation(
        "logprob-l1",
        "FBModel.log_prob with an L1 distance instead of a squared one",
        "src/fbil/fb/model.py",
        "return -((mu - _as_tensor(action)) ** 2).sum(-1)",
        "return -((mu - _as_tensor(action)).abs()).sum(-1)",
    ),
    # -- KLFB -------------------------------------------------------------------------
    Mutation(
        "kl-sign",
        "KLFB loss sign flipped",
        f"{IMIT}/methods/kl.py",
        "return -(w * torch.log(",
        "return (w * torch.log(",
    ),
    Mutation(
        "kl-no-discount",
        "KLFB drops gamma^k",
        f"{IMIT}/methods/kl.py",
        "batch.weight[:, None] * batch.gamma ** k.clamp(min=0).float()",
        "batch.weight[:, None] * torch.ones_like(k, dtype=batch.weight.dtype)",
    ),
    Mutation(
        "kl-past-pairs",
        "KLFB also pairs s_t with past states (k < 0)",
        f"{IMIT}/methods/kl.py",
        "ahead = same & (k >= 0)",
        "ahead = same",
    ),
    # -- warm start and weighting ------------------------------------------------------
    Mutation(
        "warm-start-random",
        "gradient methods start from a random z0, not ERFB's",
        f"{IMIT}/api.py",
        'options["z0"], _ = reward.erfb(model, batch)',
        'options["z0"] = model.project_z(__import__("torch").randn(model.z_dim))',
    ),
    Mutation(
        "warm-start-ignored",
        "the optimiser ignores z0",
        f"{IMIT}/core.py",
        "z = model.project_z(z0.detach()).clone().requires_grad_(True)",
        "z = model.project_z(torch.randn_like(z0)).clone().requires_grad_(True)",
    ),
    Mutation(
        "per-transition-weights",
        "rho_e weights transitions, not demonstrations",
        f"{IMIT}/core.py",
        "w.append(torch.full((n,), 1.0 / (n * len(demos))))",
        "w.append(torch.full((n,), 1.0 / sum(len(x) for x in demos.trajectories)))",
    ),
    Mutation(
        "minibatch-uniform-rows",
        "minibatches draw rows uniformly, ignoring rho_e",
        f"{IMIT}/core.py",
        "rows = torch.multinomial(self.weight, n, replacement=True, generator=generator)",
        "rows = torch.randint(len(self.weight), (n,), generator=generator)",
    ),
    # -- the bf16 path -----------------------------------------------------------------
    Mutation(
        "bf16-z-param",
        "under bf16, z itself is held (and updated) in bf16",
        f"{IMIT}/core.py",
        "z = model.project_z(z0.detach()).clone().requires_grad_(True)",
        "z = model.project_z(z0.detach()).to(torch.bfloat16 if cfg.precision == 'bf16' "
        "else z0.dtype).clone().requires_grad_(True)",
    ),
    # -- bugs the original exact tests already caught (kept as controls) ----------------
    Mutation(
        "fm-no-cov",
        "FMFB without Cov B",
        f"{IMIT}/methods/matching.py",
        "(f @ model.cov_b.T - batch.g)",
        "(f - batch.g)",
    ),
    Mutation(
        "dm-inverse-cov",
        "DMFB with Cov B^-1",
        f"{IMIT}/methods/matching.py",
        "((f @ model.cov_b) * f)",
        "((f @ torch.linalg.inv(model.cov_b)) * f)",
    ),
    Mutation(
        "bbell-c-not-c2",
        "BBELLFB C instead of C^2",
        f"{IMIT}/methods/bellman.py",
        "quad = ((delta @ c.T) ** 2).sum(-1)",
        "quad = ((delta @ c) * delta).sum(-1)",
    ),
    Mutation(
        "bellman-no-stop-gradient",
        "Bellman losses without the stop-gradient",
        f"{IMIT}/methods/bellman.py",
        "with torch.no_grad():  # the target side",
        "if True:  # the target side",
    ),
    Mutation(
        "features-gamma-1",
        "discounted features with gamma = 1",
        f"{IMIT}/core.py",
        "lfilter([1.0], [1.0, -gamma], x, axis=0)",
        "lfilter([1.0], [1.0, -1.0], x, axis=0)",
    ),
    Mutation(
        "swapped-s-next",
        "B(s_t) used for B(s_{t+1})",
        f"{IMIT}/core.py",
        "b_next = model.backward(o[1:])",
        "b_next = model.backward(o[:-1])",
    ),
    Mutation(
        "goal-off-by-one",
        "GOALFB looks k+1 steps ahead",
        f"{IMIT}/methods/goal.py",
        "torch.arange(length + 1) + lookahead - 1",
        "torch.arange(length + 1) + lookahead",
    ),
    # -- FB training (src/fbil/fb/train.py) ------------------------------------------------
    Mutation(
        "fb-no-half",
        "FB loss without the 1/2 on the squared term",
        "src/fbil/fb/train.py",
        "fb_offdiag = 0.5 * _offdiag_mean_sq(",
        "fb_offdiag = _offdiag_mean_sq(",
    ),
    Mutation(
        "fb-target-wrong-b",
        "FB target uses B of the bootstrap state, not of s'_j",
        "src/fbil/fb/train.py",
        "b_tgt = self.b_target(batch.next_obs).float()",
        "b_tgt = self.b_target(batch.boot_obs).float()",
    ),
    Mutation(
        "fb-nstep-discount",
        "n-step target discounted by gamma, not gamma^n",
        "src/fbil/fb/train.py",
        "discount = cfg.gamma**cfg.nstep",
        "discount = cfg.gamma",
    ),
    Mutation(
        "fb-nstep-mass",
        "n-step measure term without its mass sum_{k<n} gamma^k",
        "src/fbil/fb/train.py",
        "fb_diag = -self.measure_mass * (f * b_far)",
        "fb_diag = -(f * b_far)",
    ),
]


def copy_tree(dest: Path) -> None:
    shutil.copytree(ROOT / "src", dest / "src", ignore=shutil.ignore_patterns("__pycache__"))
    (dest / "tests").mkdir()
    for name in ("__init__.py", "conftest.py"):
        shutil.copy(ROOT / "tests" / name, dest / "tests" / name)
    for sub in ("imitation", "fb"):
        shutil.copytree(
            ROOT / "tests" / sub, dest / "tests" / sub, ignore=shutil.ignore_patterns("__pycache__")
        )
    shutil.copy(ROOT / "pyproject.toml", dest / "pyproject.toml")


def run_tests(work: Path) -> tuple[int, str]:
    env = dict(os.environ, PYTHONPATH=f"{work / 'src'}{os.pathsep}{work}", OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-rf", "-p", "no:cacheprovider", *TESTS]
    res = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=900)
    failed = re.findall(r"^(?:FAILED|ERROR) (\S+)", res.stdout, re.MULTILINE)
    return res.returncode, failed[0] if failed else ""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", help="comma-separated mutation ids")
    parser.add_argument("--markdown", action="store_true", help="print a markdown table")
    args = parser.parse_args()
    chosen = MUTATIONS
    if args.only:
        wanted = set(args.only.split(","))
        chosen = [m for m in MUTATIONS if m.id in wanted]
    bad = 0
    with tempfile.TemporaryDirectory(prefix="fbil-mutation-") as tmp:
        work = Path(tmp)
        copy_tree(work)
        check = subprocess.run(
            [sys.executable, "-c", "import fbil; print(fbil.__file__)"],
            env=dict(os.environ, PYTHONPATH=str(work / "src")),
            capture_output=True,
            text=True,
        )
        if not check.stdout.startswith(str(work)):
            print(f"the copy's fbil is not the one imported: {check.stdout}", file=sys.stderr)
            return 2
        start = time.perf_counter()
        rc, failed = run_tests(work)
        if rc != 0:
            print(f"the unmutated tests fail ({failed}); fix them first", file=sys.stderr)
            return 2
        print(f"baseline: all pass ({time.perf_counter() - start:.0f} s)", file=sys.stderr)
        rows = []
        for m in chosen:
            target = work / m.path
            original = target.read_text()
            if original.count(m.old) != 1:
                rows.append((m, "PATTERN NOT FOUND (source changed)"))
                bad += 1
                continue
            target.write_text(original.replace(m.old, m.new))
            start = time.perf_counter()
            try:
                rc, failed = run_tests(work)
            finally:
                target.write_text(original)
            seconds = time.perf_counter() - start
            outcome = failed if rc != 0 else "SURVIVED"
            if rc == 0:
                bad += 1
            rows.append((m, outcome))
            print(f"{m.id:28s} {outcome}  ({seconds:.0f} s)", file=sys.stderr)
    if args.markdown:
        print("| mutation | bug | first failing test |")
        print("|---|---|---|")
        for m, outcome in rows:
            what = m.what.replace("|", "\\|")
            print(f"| `{m.id}` | {what} | `{outcome}` |")
    else:
        for m, outcome in rows:
            print(f"{m.id:28s} {outcome}")
    print(f"{len(rows) - bad} of {len(rows)} mutations caught", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
