"""Changed settings of a baseline's budget (`cpu,dual.divergence=kl`, the CLI's `--set`):
one leaf of the nested configuration replaced and converted to its type, the config's own
checks run, every mistake a one-line error, and the spec recorded in the results line."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Literal

import pytest

from fbil.config import override, setting_paths
from fbil.errors import FbilError
from fbil.evaluation.benchmark import make_jobs, run_job
from fbil.imitators import FitContext, get_imitator, parse_budget
from fbil.imitators.budgets import resolve_auto, scaled_spec, split_settings, with_settings


@dataclasses.dataclass(frozen=True)
class Inner:
    steps: int = 10
    lr: float = 1e-3
    kind: Literal["a", "b"] = "a"
    flag: bool = False
    weight: float | None = None

    def __post_init__(self) -> None:
        if self.lr <= 0:
            raise FbilError(f"lr must be > 0, got {self.lr}")


@dataclasses.dataclass(frozen=True)
class Outer:
    inner: Inner = dataclasses.field(default_factory=Inner)
    name: str = "x"


def test_override_replaces_one_leaf_converted_to_its_type() -> None:
    base = Outer()
    assert override(base, "inner.steps", "7") == Outer(Inner(steps=7))
    assert override(base, "inner.lr", "3e-4").inner.lr == pytest.approx(3e-4)
    assert override(base, "inner.kind", "b").inner.kind == "b"
    assert override(base, "inner.flag", "true").inner.flag is True
    assert override(base, "inner.weight", "2").inner.weight == 2.0  # None: a number
    assert override(base, "name", "y") == Outer(name="y")
    assert base == Outer()  # frozen: a new config, the old one unchanged
    assert setting_paths(base) == [
        "inner.steps",
        "inner.lr",
        "inner.kind",
        "inner.flag",
        "inner.weight",
        "name",
    ]


@pytest.mark.parametrize(
    "path, value, message",
    [
        ("inner.foo", "1", "unknown setting 'inner.foo'; valid: inner.steps, inner.lr"),
        ("inner", "1", "unknown setting 'inner'; valid:"),  # a group, not a setting
        ("name.x", "1", "unknown setting 'name.x'"),
        ("inner.steps", "1.5", "setting inner.steps='1.5': not a valid int"),
        ("inner.flag", "maybe", "setting inner.flag='maybe': not a valid bool"),
        ("inner.kind", "c", "setting inner.kind='c': valid values are a, b"),
        ("inner.lr", "-1", "lr must be > 0, got -1.0"),  # the config's own check
    ],
)
def test_a_bad_override_is_one_line_naming_the_valid_ones(
    path: str, value: str, message: str
) -> None:
    with pytest.raises(FbilError) as caught:
        override(Outer(), path, value)
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_specs_carry_a_scale_and_settings() -> None:
    assert split_settings("cpu@0.5,dual.lr=3e-4, dual.alpha = 1") == (
        "cpu@0.5",
        [("dual.lr", "3e-4"), ("dual.alpha", "1")],
    )
    assert with_settings("cpu", ["dual.divergence=kl"]) == "cpu,dual.divergence=kl"
    assert with_settings("cpu@2", None) == "cpu@2"
    assert scaled_spec("cpu,dual.divergence=kl", 0.5) == "cpu@0.5,dual.divergence=kl"
    assert scaled_spec("cpu,dual.divergence=kl", 1) == "cpu,dual.divergence=kl"
    # an already scaled budget (a domain's `auto`, e.g. cpu@6) scales again by the product
    assert scaled_spec("cpu@6,td3.clamp_values=true", 0.01) == "cpu@0.06,td3.clamp_values=true"
    # a step count set by a changed setting scales with the rest (sqil's cheetah `auto`)
    assert scaled_spec("cpu,sac.clamp_values=true,sac.steps=200000", 0.005) == (
        "cpu@0.005,sac.clamp_values=true,sac.steps=1000"
    )
    with pytest.raises(FbilError, match="not a number"):
        scaled_spec("cpu@x", 0.5)
    assert parse_budget("cpu@0.5,dual.lr=1", ("cpu",)) == ("cpu", 0.5)
    for bad in ("cpu,x", "cpu,=1", "cpu,x=", "cpu,"):
        with pytest.raises(FbilError, match="each setting after ',' is PATH=VALUE"):
            split_settings(bad)


def test_a_budget_with_settings_is_the_scaled_budget_with_them_applied() -> None:
    smodice = get_imitator("smodice")

    def config(spec: str) -> dict:  # type: ignore[type-arg]
        return dict(smodice.settings(FitContext(budget=spec))["config"])

    cpu = config("cpu")
    assert cpu["dual"]["divergence"] == "kl"  # SMODICE's default since session 25
    changed = config("cpu@0.5,dual.divergence=chi2,discriminator.steps=7")
    assert changed["dual"]["divergence"] == "chi2"
    assert changed["dual"]["steps"] == cpu["dual"]["steps"] // 2  # scaled
    assert changed["discriminator"]["steps"] == 7  # a changed step count is absolute
    rest = {k: v for k, v in changed["dual"].items() if k not in ("divergence", "steps")}
    assert rest == {k: v for k, v in cpu["dual"].items() if k not in ("divergence", "steps")}
    assert smodice.settings(FitContext(budget="cpu,dual.divergence=chi2"))["budget"] == (
        "cpu,dual.divergence=chi2"
    )


def test_a_setting_the_method_lacks_is_refused_naming_the_method() -> None:
    with pytest.raises(FbilError) as caught:
        get_imitator("bc").require(FitContext(budget="cpu,dual.lr=1"))
    text = str(caught.value)
    assert "budget 'cpu,dual.lr=1' for bc: unknown setting 'dual.lr'; valid: steps" in text


def test_an_explicit_gradient_penalty_wins_over_table_2s(
    monkeypatch: pytest.MonkeyPatch,
    demos_dir: Path,
    fixture_data: Path,
) -> None:
    from fbil.baselines import dice
    from fbil.data import load_dataset
    from fbil.imitation import Demos

    seen: list[float | None] = []
    real = dice.train_discriminator

    def spy(kind, demos, data, cfg, seed):  # type: ignore[no-untyped-def]
        seen.append(cfg.gradient_penalty)
        return real(kind, demos, data, dataclasses.replace(cfg, steps=1), seed)

    monkeypatch.setattr(dice, "train_discriminator", spy)
    demos = Demos.load(demos_dir / "square_free.npz")
    data = load_dataset(fixture_data)
    for spec in ("smoke@0.05", "smoke@0.05,discriminator.gradient_penalty=0.5"):
        get_imitator("smodice").fit(demos, FitContext(dataset=data, budget=spec))
    assert seen == [10.0, 0.5]  # Table 2's maze weight for SMODICE, then the --set one


def test_the_spec_is_recorded_in_the_results_line(
    demos_dir: Path,
    fixture_data: Path,
) -> None:
    jobs = make_jobs(
        None,
        demos_dir,
        "point_mass_maze",
        ["square"],
        ["bc"],
        draws=1,
        k=1,
        episodes=1,
        budget="smoke@0.1,lr=0.002",
    )
    row = run_job(jobs[0])
    assert row["budget"] == "smoke@0.1,lr=0.002"
    assert row["config"]["lr"] == 0.002 and row["config"]["steps"] == 5
    json.dumps(row)


def test_set_from_the_command_line(
    capsys: pytest.CaptureFixture[str],
    demos_dir: Path,
) -> None:
    from fbil.cli import main

    args = ["evaluate", "no-model", str(demos_dir / "square.npz"), "--episodes", "1"]
    # Methods that do not train: --set would change nothing.
    assert main([*args, "--methods", "erfb", "--set", "steps=1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "none of erfb does: drop --set" in err[0], err
    # A setting of another method's budget.
    assert main([*args, "--methods", "bc", "--set", "dual.lr=1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "for bc: unknown setting 'dual.lr'" in err[0], err
    # A well-formed change: trained and recorded.
    out = ["--budget", "smoke@0.1", "--set", "lr=0.002", "--methods", "bc", "--json"]
    assert main([*args, *out]) == 0
    bc = json.loads(capsys.readouterr().out)["methods"]["bc"]
    assert bc["budget"] == "smoke@0.1,lr=0.002" and bc["config"]["lr"] == 0.002


def test_auto_budget_is_the_one_measured_for_the_method_on_the_domain() -> None:
    """`auto` resolves per method and domain through the domain's `baseline_budgets`
    hook, keeps changed settings after the measured ones, and falls back to `cpu`."""
    assert resolve_auto("auto", "td3il", "walker") == "cpu@5"
    assert resolve_auto("auto", "iqlearn", "walker") == "cpu,sac.steps=200000"
    assert resolve_auto("auto", "otr", "cheetah") == "cpu@6,td3.clamp_values=true"
    assert resolve_auto("auto", "sqil", "cheetah") == "cpu,sac.clamp_values=true,sac.steps=200000"
    assert resolve_auto("auto", "iqlearn", "cheetah") == "cpu,sac.steps=200000"  # no clamp
    assert resolve_auto("auto,td3.tau=0.02", "oril", "walker") == "cpu@5,td3.tau=0.02"
    assert resolve_auto("auto", "td3il", "point_mass_maze") == "cpu"  # none measured
    assert resolve_auto("auto", "bc", "walker") == "cpu"
    assert resolve_auto("auto", "td3il", None) == "cpu"
    assert resolve_auto("cpu@2", "td3il", "walker") == "cpu@2"  # an explicit spec stays
    td3il, erfb = get_imitator("td3il"), get_imitator("erfb")
    assert td3il.resolved(FitContext(), "cheetah").budget == "cpu@6,td3.clamp_values=true"
    assert td3il.settings(td3il.resolved(FitContext(), "walker"))["config"]["td3"]["steps"] == (
        250_000
    )
    assert erfb.resolved(FitContext(), "walker") == FitContext()  # no budget: unchanged


def test_benchmark_jobs_hold_the_resolved_budget(tmp_path: Path) -> None:
    """`fbil benchmark`'s jobs (and so their keys and lines) hold the budget that runs,
    not `auto`: walker's td3il at cpu@5, bc at cpu, an FB-IL method none."""
    demos = Path(__file__).parents[2] / "artifacts" / "demos" / "walker"
    jobs = make_jobs(
        tmp_path, demos, "walker", ["stand"], ["td3il", "bc", "erfb"], 1, 1, 1,
        data=tmp_path, budget="auto",
    )  # fmt: skip
    assert {j.method: j.budget for j in jobs} == {"td3il": "cpu@5", "bc": "cpu", "erfb": None}
    from fbil.cli import benchmark_plan

    assert benchmark_plan(jobs, 1, "r.jsonl") == (
        "benchmark: 3 jobs, 1 lines already in r.jsonl; td3il at cpu@5; bc at cpu"
    )


@pytest.mark.parametrize("domain", ["point_mass_maze", "walker", "cheetah", "quadruped"])
def test_every_measured_budget_of_a_domain_builds_its_methods_config(domain: str) -> None:
    """A domain's `baseline_budgets` are read only when a user runs that baseline there:
    each must name a baseline that trains and build its config (a misspelt setting or an
    unknown budget would otherwise fail minutes into a benchmark)."""
    from fbil.envs import get_domain

    for method, spec in get_domain(domain).hooks.baseline_budgets.items():
        imitator = get_imitator(method)
        assert imitator.budgets, method
        context = imitator.resolved(FitContext(), domain)
        assert context.budget == spec
        assert imitator.settings(context)["config"], (method, spec)
