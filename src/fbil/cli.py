"""The `fbil` command line: a thin layer over the library.

Every command that prints figures also takes `--json` and then prints one JSON object on
stdout. User mistakes end in one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from fbil import __version__
from fbil.errors import FbilError

Command = Callable[[argparse.Namespace], int]


def _cmd_tasks(args: argparse.Namespace) -> int:
    from fbil.envs import DOMAINS

    if args.json:
        payload = {
            "domains": {
                d.name: {
                    "obs_dim": d.obs_dim,
                    "act_dim": d.act_dim,
                    "physics_dim": d.physics_dim,
                    "episode_length": d.episode_length,
                    "tasks": d.task_names,
                }
                for d in DOMAINS.values()
            }
        }
        print(json.dumps(payload))
        return 0
    n = sum(len(d.tasks) for d in DOMAINS.values())
    print(f"{len(DOMAINS)} domains, {n} tasks (episodes of 1000 steps, actions in [-1, 1])\n")
    for d in DOMAINS.values():
        print(f"{d.name}  obs {d.obs_dim}  act {d.act_dim}")
        for t in d.tasks.values():
            print(f"  {t.name:<24} {t.description}  [{t.source}]")
    return 0


def _cmd_render(args: argparse.Namespace) -> int:
    from fbil.envs import RandomPolicy, get_domain, get_task
    from fbil.envs.hooks import RenderRequest
    from fbil.envs.render import ANIMATION_SUFFIXES, IMAGE_SUFFIXES, render_policy

    spec = get_domain(args.domain)
    get_task(args.domain, args.task)
    suffix = Path(args.out).suffix.lower()
    if suffix not in IMAGE_SUFFIXES + ANIMATION_SUFFIXES:
        raise FbilError(
            f"unsupported picture type {suffix or '(none)'!r} for {args.out}; use one of "
            f"{', '.join(IMAGE_SUFFIXES + ANIMATION_SUFFIXES)}"
        )
    if args.policy == "random":
        policy: Any = RandomPolicy(spec.act_dim, seed=args.seed)
    else:
        policy = _saved_policy(args.policy, args.model, spec.name, spec.obs_dim, spec.act_dim)
    request = RenderRequest(
        args.task, policy, args.seed, args.episodes, args.steps, args.frames, Path(args.out)
    )
    returns = render_policy(spec.name, request)
    if args.json:
        print(json.dumps({"out": str(args.out), "returns": returns}))
    else:
        print(f"wrote {args.out}")
    return 0


def _saved_policy(path: str, model_dir: str | None, domain: str, obs_dim: int, act_dim: int) -> Any:
    """A policy file of `fbil imitate --out`, checked to act in `domain`."""
    import numpy as np

    from fbil.imitators import load_policy

    if not Path(path).is_file():
        raise FbilError(
            f"unknown policy {path!r}: --policy takes random or a policy file of "
            "`fbil imitate ... --out DIR`"
        )
    model = None
    if model_dir is not None:
        from fbil.fb.model import FBModel

        model = FBModel.load(model_dir)
        if model.domain not in (None, domain):
            raise FbilError(f"the model {model_dir} is for {model.domain}, not {domain}")
    policy = load_policy(path, model)
    try:
        action = policy.act(np.zeros((1, obs_dim), np.float32), 0)
    except RuntimeError:
        action = None
    if action is None or np.shape(action) != (1, act_dim):
        raise FbilError(
            f"{path}: the policy does not act on {domain}'s {obs_dim}-dim observations "
            f"with {act_dim} actions; render it in its own domain"
        )
    policy.reset()
    return policy


def _cmd_collect(args: argparse.Namespace) -> int:
    from fbil.data.collect import collect
    from fbil.data.rnd import RNDConfig

    cfg = RNDConfig(
        num_envs=args.num_envs,
        agents=args.agents,
        updates_per_step=args.updates_per_step,
        stddev=args.stddev,
        stddev_max=args.stddev if args.stddev_max is None else args.stddev_max,
    )
    if args.num_envs % args.agents:
        raise FbilError(
            f"--num-envs ({args.num_envs}) must be a multiple of --agents ({args.agents})"
        )
    manifest = collect(
        args.domain,
        args.explorer,
        args.episodes,
        args.out,
        seed=args.seed,
        resume=args.resume,
        rnd_config=cfg,
        threads=args.threads,
        progress=not args.json,
        command=" ".join(["fbil", *sys.argv[1:]]),
        starts=args.starts,
    )
    if args.json:
        print(json.dumps(manifest))
    else:
        print(
            f"{manifest['episodes']} episodes of {args.domain} in {args.out} "
            f"({manifest['wall_seconds']:.0f} s)"
        )
    return 0


def _cmd_dataset_info(args: argparse.Namespace) -> int:
    from fbil.data import load_dataset
    from fbil.data.coverage import coverage_text, dataset_info, plot_coverage

    dataset = load_dataset(args.dir, domain=args.domain)
    info = dataset_info(dataset)
    if args.plot:
        info["plot"] = str(plot_coverage(dataset, args.plot))
    if args.json:
        print(json.dumps(info))
        return 0
    print(
        f"{info['root']}: {info['domain']}, {info['episodes']} episodes, "
        f"{info['transitions']} transitions"
    )
    norm = info["state_norm"]
    print(
        f"state norm: mean {norm['mean']:.3f}, std {norm['std']:.3f}, "
        f"1-99% [{norm['p01']:.3f}, {norm['p99']:.3f}]"
    )
    for line in coverage_text(info):  # the domain's coverage summary
        print(line)
    if args.plot:
        print(f"plot: {info['plot']}")
    return 0


def _cmd_dataset_merge(args: argparse.Namespace) -> int:
    from fbil.data.dataset import merge_datasets

    merged = merge_datasets(args.out, args.sources, command=" ".join(["fbil", *sys.argv[1:]]))
    if args.json:
        print(json.dumps(merged))
    else:
        parts = ", ".join(f"{p['episodes']} from {p['root']}" for p in merged["merged_from"])
        print(f"{merged['episodes']} {merged['domain']} episodes in {args.out} ({parts})")
    return 0


def _cmd_dataset_oversample(args: argparse.Namespace) -> int:
    from fbil.data.oversample import oversample_crossings

    command = " ".join(["fbil", *sys.argv[1:]])
    made = oversample_crossings(args.src, args.out, args.window, args.copies, command=command)
    if args.json:
        print(json.dumps(made))
    else:
        print(
            f"{made['episodes']} episodes in {args.out}: {made['merged_from'][0]['episodes']} "
            f"from {args.src} + {args.copies} x {made['crossing_windows']} crossing windows"
        )
    return 0


def _parse_setting(item: str, current: Any, value: str) -> Any:
    """A --set value converted to the type of the setting it replaces."""
    from fbil.config import convert_text

    try:
        return convert_text(current, value)
    except ValueError:
        kind = "number" if current is None else type(current).__name__
        raise FbilError(f"--set {item!r}: {value!r} is not a valid {kind}") from None


def _settings(items: list[str] | None, *configs: Any) -> list[dict[str, Any]]:
    """--set KEY=VALUE items split into one override dict per config (first owner wins)."""
    import dataclasses

    out: list[dict[str, Any]] = [{} for _ in configs]
    for item in items or []:
        key, _, value = item.partition("=")
        for cfg, target in zip(configs, out, strict=True):
            if key in {f.name for f in dataclasses.fields(cfg)} and value:
                target[key] = _parse_setting(item, getattr(cfg, key), value)
                break
        else:
            valid = [f.name for c in configs for f in dataclasses.fields(c)]
            raise FbilError(f"--set {item!r}: expected KEY=VALUE, KEY one of {', '.join(valid)}")
    return out


def _check_device(device: str, cuda_available: bool) -> None:
    """`--device`: cpu, cuda or cuda:N, and CUDA only where torch sees a device."""
    kind, _, index = device.partition(":")
    if kind not in ("cpu", "cuda") or (index and (kind == "cpu" or not index.isdigit())):
        raise FbilError(f"--device {device!r}: expected cpu, cuda or cuda:N")
    if kind == "cuda" and not cuda_available:
        raise FbilError(f"--device {device}: no CUDA device here; use --device cpu")


def _device_note(device: str, precision: str, compile: bool) -> str | None:
    """On a GPU the `cpu` presets' bf16 autocast buys nothing, and with --compile it ran
    at 0.14 updates/s (docs/speed.md, "On a GPU"): one line saying so, or None."""
    if not device.startswith("cuda") or precision != "bf16":
        return None
    if compile:
        return (
            "--compile with bf16 on CUDA ran at 0.14 updates/s in fbil's GPU check; "
            "add --set precision=fp32 (docs/speed.md)"
        )
    return (
        "on CUDA bf16 gains nothing over fp32 (walker's was slower): consider --set precision=fp32"
    )


def _cmd_pretrain(args: argparse.Namespace) -> int:
    import dataclasses

    import torch

    from fbil.data import load_dataset
    from fbil.data.storage import read_manifest
    from fbil.fb.config import preset
    from fbil.fb.train import FBTrainer

    _check_device(args.device, torch.cuda.is_available())
    model_cfg, train_cfg = preset(args.domain, args.preset)
    overrides = {
        k: v
        for k, v in (
            ("steps", args.steps),
            ("seed", args.seed),
            ("batch_size", args.batch_size),
            ("checkpoint_seconds", args.checkpoint_seconds),
        )
        if v is not None
    }
    set_train, set_model = _settings(args.set, train_cfg, model_cfg)
    overrides.update(set_train)
    model_cfg = dataclasses.replace(model_cfg, **set_model)
    train_cfg = dataclasses.replace(train_cfg, **overrides)
    dataset = load_dataset(args.data, domain=args.domain)
    note = _device_note(args.device, train_cfg.precision, args.compile)
    if note:
        print(f"fbil: note: {note}", file=sys.stderr)
    trainer = FBTrainer(model_cfg, train_cfg, dataset, device=args.device, compile=args.compile)
    manifest = read_manifest(args.data) or {}
    model = trainer.fit(args.out, resume=args.resume, progress=not args.json, manifest=manifest)
    summary = {
        "out": str(args.out),
        "steps": trainer.step,
        "wall_seconds": model.metadata.get("wall_seconds"),
    }
    print(json.dumps(summary) if args.json else f"model saved in {args.out} ({trainer.step} steps)")
    return 0


def _cmd_pretrain_goal(args: argparse.Namespace) -> int:
    import dataclasses

    from fbil.baselines.goal_td3 import GoalTD3Trainer, goal_preset
    from fbil.data import load_dataset

    cfg = goal_preset(args.domain, args.preset)
    given = (
        ("steps", args.steps),
        ("seed", args.seed),
        ("checkpoint_seconds", args.checkpoint_seconds),
    )
    (overrides,) = _settings(args.set, cfg)
    overrides.update({k: v for k, v in given if v is not None})
    cfg = dataclasses.replace(cfg, **overrides)
    trainer = GoalTD3Trainer(cfg, load_dataset(args.data, domain=args.domain))
    model = trainer.fit(args.out, resume=args.resume, progress=not args.json)
    summary = {
        "out": str(args.out),
        "steps": trainer.step,
        "epsilon": model.config.epsilon,
        "wall_seconds": model.metadata.get("wall_seconds"),
    }
    done = f"goal model saved in {args.out} ({trainer.step} steps)"
    print(json.dumps(summary) if args.json else done)
    return 0


def _cmd_zero_shot(args: argparse.Namespace) -> int:
    from fbil.data import load_dataset
    from fbil.fb.model import FBModel
    from fbil.fb.zero_shot import zero_shot

    model = FBModel.load(args.model)
    dataset = load_dataset(args.data)
    tasks = dataset_tasks = get_domain_tasks(dataset.domain)
    if args.tasks != "all":
        tasks = [t.strip() for t in args.tasks.split(",") if t.strip()]
        for task in tasks or [args.tasks]:
            if task not in dataset_tasks:
                raise FbilError(
                    f"unknown task {task!r} for {dataset.domain}; valid tasks: "
                    f"{', '.join(dataset_tasks)}, all (or several, comma-separated)"
                )
    result = zero_shot(
        model, dataset, tasks, episodes=args.episodes, seed=args.seed, progress=not args.json
    )
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"zero-shot returns of {args.model} ({args.episodes} episodes each)")
    for task, r in result["tasks"].items():
        print(f"  {task:<24} {r['return_mean']:8.1f} ± {r['return_std']:.1f}")
    return 0


def _fit_context(args: argparse.Namespace, names: Sequence[str], demos: Any) -> Any:
    """What the named methods need besides the demos: the FB model (read only when one of
    them imitates through it), the dataset of --data (only when one trains on it), the
    budget, seed and threads."""
    from fbil.imitators import FitContext, get_imitator
    from fbil.imitators.base import check_settings_used

    needed = [get_imitator(n) for n in names]
    check_settings_used(needed, args.budget)
    model = dataset = None
    if any(i.needs_model for i in needed):
        from fbil.fb.model import FBModel

        model = FBModel.load(args.model)
    if args.data is not None and any(i.needs_dataset for i in needed):
        from fbil.data import load_dataset

        dataset = load_dataset(args.data, domain=demos.metadata.get("domain") or None)
    goal = None
    if getattr(args, "goal_model", None) and any(i.needs_goal_model for i in needed):
        from fbil.baselines.goal_model import GoalModel

        goal = GoalModel.load(args.goal_model)
    seed = getattr(args, "seed", 0)
    return FitContext(model, dataset, args.budget, seed, args.threads, goal_model=goal)


def _cmd_imitate(args: argparse.Namespace) -> int:
    from fbil.evaluation.evaluate import demo_draw, fit_all
    from fbil.imitation import Demos
    from fbil.imitators import family_of, principle_of, resolve

    demos = Demos.load(args.demos)
    if args.k is not None:  # the first K, with `fbil evaluate`'s check of K
        demos = demo_draw(demos, args.k, 0)
    selection = resolve(args.methods)
    context = _fit_context(args, selection.names, demos)
    fitted, skipped = fit_all(selection.names, demos, context, selection.group)
    results: dict[str, dict[str, Any]] = {m: {"skipped": why} for m, why in skipped.items()}
    for f in fitted:
        results[f.name] = {
            "family": family_of(f.name),
            "seconds": round(f.seconds, 4),
            **f.policy.describe(),
        }
        _note_divergence(f.name, results[f.name])
    results = {m: results[m] for m in selection.names}  # in the order asked for
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        for f in fitted:
            f.policy.save(out / f"{f.name}{f.policy.suffix}")
    if args.json:
        print(json.dumps({"methods": results}))
        return 0
    print(f"{len(demos)} demonstration(s), model {args.model}")
    print(f"{'method':<10}{'principle':<26}{'seconds':>9}  z (first entries)      |z|")
    for m, r in results.items():
        if "skipped" in r:
            print(f"{m:<10}{principle_of(m):<26}  skipped: {r['skipped']}")
        elif "z_head" in r:
            head = " ".join(f"{v:+.2f}" for v in r["z_head"])
            print(f"{m:<10}{principle_of(m):<26}{r['seconds']:>9.3f}  {head:<22} {r['z_norm']:.2f}")
        else:
            about = ", ".join(f"{k} {v}" for k, v in r.items() if k not in ("seconds", "family"))
            print(f"{m:<10}{principle_of(m):<26}{r['seconds']:>9.3f}  {about}")
    if args.out:
        suffixes = "|".join(sorted({f.policy.suffix for f in fitted}))
        print(f"policies saved in {args.out}/<method>{suffixes}")
    return 0


def _cmd_expert(args: argparse.Namespace) -> int:
    from fbil.agents.expert import train_expert
    from fbil.agents.td3 import TD3Config

    if args.bc_alpha is not None and args.bc_alpha < 0:
        raise FbilError("--bc-alpha must be >= 0 (0: plain TD3)")
    # Measured on the maze: plain offline TD3 beats TD3+BC (alpha 2.5) on reach_top_right.
    alpha = args.bc_alpha or 0.0
    (settings,) = _settings(args.set, TD3Config())
    config = TD3Config(**{"bc_alpha": alpha or None, **settings})
    meta = train_expert(
        args.domain,
        args.task,
        args.mode,
        args.out,
        data=args.data,
        steps=args.steps,
        seed=args.seed,
        config=config,
        resume=args.resume,
        eval_every=args.eval_every,
        num_envs=args.num_envs,
        start_steps=args.start_steps,
        progress=not args.json,
        command=" ".join(["fbil", *sys.argv[1:]]),
        init=args.init,
    )
    if args.json:
        print(json.dumps(meta))
    else:
        print(
            f"expert for {args.domain}/{args.task} in {args.out}: return "
            f"{meta['return_mean']:.1f} ± {meta['return_std']:.1f}"
        )
    return 0


def _cmd_demos(args: argparse.Namespace) -> int:
    from fbil.agents.expert import make_demos

    what = (args.expert_dir, args.episodes, args.out)
    demos = make_demos(*what, start=args.starts, seed=args.seed, physics=args.physics)
    meta = demos.metadata
    if args.json:
        print(json.dumps({"out": args.out, **meta}))
    else:
        print(
            f"{len(demos)} demonstrations of {meta['domain']}/{meta['task']} ({args.starts} "
            f"start) in {args.out}: return {meta['return_mean']:.1f} ± {meta['return_std']:.1f}"
        )
    return 0


def get_domain_tasks(domain: str) -> list[str]:
    from fbil.envs import get_domain

    return get_domain(domain).task_names


def _note_divergence(method: str, fit: dict[str, Any]) -> None:
    """A note on stderr when a trained learner's critic ran away (`value_check`)."""
    if fit.get("q_diverged"):
        print(
            f"fbil: note: {method}'s critic ran away (mean Q {fit['q']:.1f}, above twice the "
            f"{fit['q_bound']:.1f} its rewards allow), so its policy is unreliable; add "
            "td3.clamp_values=true (sac.clamp_values=true for sqil) to --budget",
            file=sys.stderr,
        )


def _cmd_evaluate(args: argparse.Namespace) -> int:
    from fbil.checkpoint import atomic_write_text
    from fbil.evaluation.evaluate import evaluate
    from fbil.imitation.demos import Demos
    from fbil.imitators import get_imitator, resolve

    demos = Demos.load(args.demos)
    context = _fit_context(args, resolve(args.methods).names, demos)
    out = evaluate(
        context.model,
        demos,
        args.methods,
        k=args.k,
        draw=args.draw,
        episodes=args.episodes,
        seed=args.seed,
        dataset=context.dataset,
        budget=args.budget,
        goal_model=context.goal_model,
    )
    methods = {m: r.as_dict() for m, r in out["results"].items()}
    for m, r in out["results"].items():
        _note_divergence(m, r.fit)
    for m in methods:  # the methods that train: their budget and its whole configuration
        imitator = get_imitator(m)
        if imitator.budgets:
            methods[m].update(imitator.settings(imitator.resolved(context, out["domain"])))
    methods.update({m: {"skipped": why} for m, why in out["skipped"].items()})
    keys = ("expert_return", "task", "k", "episodes")
    payload = json.dumps({**{key: out[key] for key in keys}, "methods": methods})
    if args.out:
        atomic_write_text(args.out, payload + "\n")
    if args.json:
        print(payload)
        return 0
    print(f"{out['domain']}/{out['task']}: K={out['k']} demo(s), {out['episodes']} episodes")
    _print_scores(out)
    if args.out:
        print(f"results: {args.out}")
    return 0


def _print_scores(out: dict[str, Any]) -> None:
    """The expert's return, then one row per method: principle, time, return, score."""
    print(f"expert return: {out['expert_return']:.1f}")
    print(f"{'method':<10}{'IL principle':<26}{'time to policy':>15}{'return':>18}{'score':>8}")
    for m, r in out["results"].items():
        ret = f"{r.return_mean:.1f} ± {r.return_std:.1f}"
        print(f"{m:<10}{r.principle:<26}{r.seconds:>13.3f} s{ret:>18}{100 * r.score:>7.1f}%")
    for m, why in out["skipped"].items():
        print(f"{m:<10}skipped: {why}")


def _names(comma_list: str) -> list[str]:
    """The names of a comma list, spaces around them dropped ("walk, run" -> walk, run)."""
    return [n.strip() for n in comma_list.split(",") if n.strip()] or [comma_list]


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from fbil.envs import get_domain, get_task
    from fbil.evaluation.benchmark import make_jobs, read_results, run_benchmark
    from fbil.evaluation.evaluate import resolve_methods
    from fbil.fb.train import git_commit
    from fbil.progress import progress_bar

    spec = get_domain(args.domain)
    tasks = spec.task_names if args.tasks == "all" else _names(args.tasks)
    for t in tasks:
        get_task(args.domain, t)
    jobs = make_jobs(
        args.model,
        args.demos,
        args.domain,
        tasks,
        resolve_methods(args.methods),
        args.draws,
        args.k,
        args.episodes,
        seed=args.seed,
        demo_set=args.demo_set,
        data=args.data,
        budget=args.budget,
        goal_model=args.goal_model,
        first_draw=args.first_draw,
    )
    before = len(read_results(args.out))
    print(benchmark_plan(jobs, before, args.out), flush=True)
    bar = progress_bar(
        total=len(jobs),
        initial=min(before, len(jobs)),
        desc="benchmark",
        unit="job",
        disable=args.quiet,
    )

    def on_result(row: dict[str, Any]) -> None:
        bar.update(1)
        if "score" in row:
            bar.set_postfix(last=f"{row['task']}/{row['method']} {100 * row['score']:.0f}%")

    new = run_benchmark(
        jobs, args.out, args.workers, args.backend, git_commit(), on_result, args.threads
    )
    bar.close()
    print(f"{len(new)} jobs run, {len(jobs) - len(new)} already in {args.out}")
    return 0


def benchmark_plan(jobs: Sequence[Any], before: int, out: str) -> str:
    """The line `fbil benchmark` prints first: how many jobs, how many lines are already
    in `out`, and the budget each training method runs at (never `auto`), so a wrong budget
    shows before hours of training instead of in the first results line."""
    budgets = {j.method: j.budget for j in jobs if j.budget}
    shown = "".join(f"; {m} at {b}" for m, b in budgets.items())
    return f"benchmark: {len(jobs)} jobs, {before} lines already in {out}{shown}"


def _cmd_demo(args: argparse.Namespace) -> int:
    import time

    from fbil.evaluation.demo import demo_tasks, run_demo

    started = time.perf_counter()
    for task in demo_tasks(args.tasks, domain=args.domain):
        out = run_demo(task, args.methods, args.episodes, args.out, domain=args.domain)
        print(
            f"fbil demo: imitating one expert demonstration of {args.domain}/{out['task']} "
            f"with the committed cpu FB model ({out['episodes']} evaluation episodes per "
            "method)"
        )
        _print_scores(out)
        if out["picture"] is not None:  # a domain whose rollouts keep nothing to draw
            print(f"figure: {out['picture']}")
    print(f"total: {time.perf_counter() - started:.1f} s")
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from fbil.evaluation.report import write_report

    path = write_report(args.results, args.out, args.budget_curve)
    print(f"report: {path}")
    return 0


# -- the parser: one builder per subcommand, shared options from parent parsers ----------
THREADS_HELP = (
    "torch threads (benchmark: per worker); 1 so that fbil processes sharing a few cores "
    "don't slow each other down; raise it when this process has the cores to itself"
)


class _HelpFormatter(argparse.HelpFormatter):
    """Ends each option's help with its default, where it has one worth showing."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if default is None or default is False or default == argparse.SUPPRESS:
            return text
        if not action.option_strings or "%(default)" in text:
            return text
        return f"{text} (default: %(default)s)"


def _parent(*options: tuple[str, dict[str, Any]]) -> argparse.ArgumentParser:
    parent = argparse.ArgumentParser(add_help=False)
    for name, kwargs in options:
        parent.add_argument(name, **kwargs)
    return parent


_OUT_FILE = [("--out", "file")]
_OUT_FOLDER = [("--out", "folder")]
_JSON = _parent(("--json", {"action": "store_true", "help": "print one JSON object"}))
_THREADS = _parent(("--threads", {"type": int, "default": 1, "help": THREADS_HELP}))
_SEED = _parent(("--seed", {"type": int, "default": 0, "help": "random seed"}))


def _command(
    sub: Any,
    name: str,
    func: Command,
    about: str,
    *,
    with_json: bool = True,
    threads: bool = False,
    seed: bool = False,
    outputs: Sequence[tuple[str, str]] = (),
) -> argparse.ArgumentParser:
    """A subcommand with the shared options asked for; `outputs`: (option, "file" or
    "folder"), each checked to be writable before the command runs."""
    flags = (with_json, threads, seed)
    parents = [parent for parent, on in zip((_JSON, _THREADS, _SEED), flags, strict=True) if on]
    p: argparse.ArgumentParser = sub.add_parser(
        name, help=about, description=about, parents=parents, formatter_class=_HelpFormatter
    )
    p.set_defaults(func=func, outputs=outputs)
    return p


def _add_render(sub: Any) -> None:
    p = _command(
        sub,
        "render",
        _cmd_render,
        "picture of a policy acting in a task",
        seed=True,
        outputs=_OUT_FILE,
    )
    p.add_argument("domain")
    p.add_argument("task")
    p.add_argument(
        "--policy",
        default="random",
        help="random, or a policy file of `fbil imitate --out` (.json or .safetensors)",
    )
    p.add_argument("--model", default=None, help="FB model folder, for an FB-IL policy file")
    p.add_argument("--out", required=True, help="maze: .png/.pdf/.svg; others also .gif/.mp4")
    p.add_argument("--episodes", type=int, default=5, help="maze: trajectories drawn")
    p.add_argument("--steps", type=int, default=None, help="steps per episode")
    p.add_argument("--frames", type=int, default=8, help="locomotion strip: frames shown")


def _add_collect(sub: Any) -> None:
    about = "collect a reward-free dataset (ExORL layout)"
    p = _command(sub, "collect", _cmd_collect, about, threads=True, seed=True, outputs=_OUT_FOLDER)
    p.add_argument("domain")
    p.add_argument("--explorer", default="rnd", help="rnd or random")
    p.add_argument("--episodes", type=int, required=True, help="episodes to collect in all")
    p.add_argument("--out", required=True, help="dataset folder (episodes go to OUT/buffer)")
    p.add_argument("--resume", action="store_true", help="continue an interrupted collection")
    p.add_argument("--num-envs", type=int, default=8, help="environments stepped in lockstep")
    p.add_argument("--agents", type=int, default=4, help="rnd: independent explorers")
    p.add_argument("--updates-per-step", type=int, default=1, help="rnd: updates per round")
    p.add_argument("--stddev", type=float, default=0.2, help="rnd: exploration noise")
    p.add_argument(
        "--stddev-max",
        type=float,
        default=None,
        help="rnd: noise of the last agent (agents spread from --stddev to this; "
        "default: --stddev)",
    )
    p.add_argument(
        "--starts",
        default="standard",
        help="standard (the domain's start) or uniform (maze: anywhere in the four rooms)",
    )


def _add_datasets(sub: Any) -> None:
    about = "size, ranges and coverage of a dataset"
    p = _command(sub, "dataset-info", _cmd_dataset_info, about, outputs=[("--plot", "file")])
    p.add_argument("dir")
    p.add_argument("--domain", default=None, help="check the data is of this domain")
    p.add_argument("--plot", default=None, help="write a coverage figure (PNG)")
    about = "one dataset folder from several of one domain"
    p = _command(sub, "dataset-merge", _cmd_dataset_merge, about, outputs=_OUT_FOLDER)
    p.add_argument("sources", nargs="+", help="dataset folders, in the order to number them")
    p.add_argument("--out", required=True, help="new dataset folder (must not exist)")
    about = "maze: a dataset with extra copies of the windows around doorway crossings"
    p = _command(sub, "dataset-oversample", _cmd_dataset_oversample, about, outputs=_OUT_FOLDER)
    p.add_argument("src", help="maze dataset folder")
    p.add_argument("--out", required=True, help="new dataset folder (must not exist)")
    p.add_argument("--window", type=int, default=30, help="steps kept on each side")
    p.add_argument("--copies", type=int, default=4, help="extra copies of each window")


def _add_compile(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--compile",
        action="store_true",
        help="torch.compile the FB losses (same training; ~1 min to compile; measured no "
        "faster at the cpu preset sizes on 2 cores, see docs/speed.md)",
    )


def _pretrain_command(
    sub: Any, name: str, func: Command, about: str, presets: str, out: str
) -> argparse.ArgumentParser:
    """A pre-training verb: DOMAIN, --data, --preset, --out and --steps."""
    p = _command(sub, name, func, about, threads=True, outputs=_OUT_FOLDER)
    p.add_argument("domain")
    p.add_argument("--data", required=True, help="dataset folder")
    p.add_argument("--preset", default="cpu", help=presets)
    p.add_argument("--out", required=True, help=out)
    p.add_argument("--steps", type=int, default=None, help="gradient steps (preset default)")
    return p


def _add_pretrain(sub: Any) -> None:
    about = "pre-train an FB model on a dataset"
    p = _pretrain_command(
        sub, "pretrain", _cmd_pretrain, about, "paper, cpu or smoke", "model folder"
    )
    p.add_argument("--batch-size", type=int, default=None, help="(preset default)")
    p.add_argument("--seed", type=int, default=None, help="(preset default)")
    p.add_argument("--device", default="cpu", help="cpu or cuda")
    _add_compile(p)
    _add_run_options(p, "lr_b=1e-6")


def _add_run_options(p: argparse.ArgumentParser, example: str) -> None:
    """--resume, --set and --checkpoint-seconds of a resumable training run."""
    p.add_argument("--resume", action="store_true", help="continue from OUT's checkpoint")
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help=f"override a training setting, e.g. --set {example} (repeatable)",
    )
    p.add_argument(
        "--checkpoint-seconds",
        type=float,
        default=None,
        help="seconds between checkpoints (default 180)",
    )


def _add_pretrain_goal(sub: Any) -> None:
    about = "pre-train GOAL-TD3's goal-conditioned policy on a dataset (HER)"
    p = _pretrain_command(
        sub, "pretrain-goal", _cmd_pretrain_goal, about, "cpu or smoke", "goal model folder"
    )
    p.add_argument("--seed", type=int, default=None, help="(preset default)")
    _add_run_options(p, "epsilon=0.02")


def _add_zero_shot(sub: Any) -> None:
    about = "zero-shot returns of a model from task rewards"
    p = _command(sub, "zero-shot", _cmd_zero_shot, about, threads=True, seed=True)
    p.add_argument("model")
    p.add_argument("--data", required=True, help="dataset to infer z_r from")
    p.add_argument("--tasks", default="all", help="all, a task or a comma list")
    p.add_argument("--episodes", type=int, default=20, help="episodes per task")


def _add_training_inputs(p: argparse.ArgumentParser) -> None:
    """--data and --budget, for the methods that train (the offline-IL baselines)."""
    p.add_argument(
        "--data",
        default=None,
        help="unsupervised dataset folder, for methods that train on it (the offline-IL "
        "baselines but bc)",
    )
    p.add_argument(
        "--budget",
        default="auto",
        help="training budget of methods that train: auto (the one measured for the method "
        "on the domain, else cpu), cpu, or smoke (seconds, for tests); NAME@SCALE multiplies "
        "its gradient steps (cpu@0.5, cpu@2)",
    )
    p.add_argument(
        "--set",
        dest="budget_settings",
        action="append",
        metavar="PATH=VALUE",
        help="change one setting of the budget of the methods that train, e.g. --set "
        "dual.divergence=kl (repeatable; recorded in the budget, cpu,dual.divergence=kl)",
    )
    p.add_argument(
        "--goal-model",
        default=None,
        help="pre-trained goal model folder, for goal_td3 (from `fbil pretrain-goal`)",
    )


def _add_imitate(sub: Any) -> None:
    about = "imitation policies from demonstrations"
    p = _command(sub, "imitate", _cmd_imitate, about, threads=True, seed=True, outputs=_OUT_FOLDER)
    p.add_argument("model", help="FB model folder (read only for FB-IL methods)")
    p.add_argument("demos", help="demo file (.npz)")
    p.add_argument("--methods", default="all", help="all, a method or a comma list")
    p.add_argument("--k", type=int, default=None, help="use the first K demos (default: all)")
    _add_training_inputs(p)
    p.add_argument(
        "--out", default=None, help="folder for the policies (<method>.json or .safetensors)"
    )


def _add_expert(sub: Any) -> None:
    about = "train a TD3 expert for a task"
    p = _command(sub, "expert", _cmd_expert, about, threads=True, seed=True, outputs=_OUT_FOLDER)
    p.add_argument("domain")
    p.add_argument("task")
    p.add_argument("--mode", default="offline", help="offline (needs --data) or online")
    p.add_argument(
        "--data",
        default=None,
        help="dataset relabeled with the task: all of the data (offline), or part of each "
        "minibatch beside the replay buffer (online; share: --set offline_share=0.5)",
    )
    p.add_argument("--out", required=True, help="expert folder")
    p.add_argument("--steps", type=int, default=100_000, help="gradient steps")
    p.add_argument("--eval-every", type=int, default=10_000, help="gradient steps")
    p.add_argument(
        "--num-envs",
        type=int,
        default=1,
        help="online: environments stepped per gradient step (1: one update per env step)",
    )
    p.add_argument(
        "--start-steps",
        type=int,
        default=10_000,
        help="online: env steps of uniform random actions before learning starts",
    )
    p.add_argument(
        "--init",
        default=None,
        metavar="EXPERT_DIR",
        help="online: start from this expert's networks and input statistics (fine-tuning)",
    )
    p.add_argument(
        "--bc-alpha",
        type=float,
        default=None,
        help="TD3+BC's alpha, for offline training (default 0: plain TD3)",
    )
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a TD3 setting, e.g. --set tau=0.02 (repeatable)",
    )
    p.add_argument("--resume", action="store_true", help="continue from OUT's checkpoint")


def _add_demos(sub: Any) -> None:
    about = "record demonstrations of a trained expert"
    p = _command(sub, "demos", _cmd_demos, about, threads=True, seed=True, outputs=_OUT_FILE)
    p.add_argument("expert_dir")
    p.add_argument("--episodes", type=int, required=True, help="demonstrations to record")
    p.add_argument("--out", required=True, help="demo file (.npz)")
    p.add_argument(
        "--starts", default="standard", help="where episodes start: standard or shifted (App. E.5)"
    )
    p.add_argument(
        "--physics",
        default="all",
        help="which demos keep their physics states: all (exact reward relabeling), first "
        "(only the one pictures draw; a smaller file), or none",
    )


def _add_evaluate(sub: Any) -> None:
    about = "imitate from K demos and score each method"
    p = _command(sub, "evaluate", _cmd_evaluate, about, threads=True, seed=True, outputs=_OUT_FILE)
    p.add_argument("model", help="FB model folder (read only for FB-IL methods)")
    p.add_argument("demos")
    p.add_argument("--methods", default="all", help="all, a method or a comma list")
    p.add_argument("--k", type=int, default=1, help="demonstrations per imitation")
    p.add_argument(
        "--draw", type=int, default=0, help="which of the file's groups of K demos to use"
    )
    p.add_argument("--episodes", type=int, default=10, help="evaluation episodes per method")
    _add_training_inputs(p)
    p.add_argument("--out", default=None, help="also write the JSON object to this file")


def _add_benchmark(sub: Any) -> None:
    about = "the task x method x demo-draw grid, resumable"
    p = _command(
        sub,
        "benchmark",
        _cmd_benchmark,
        about,
        with_json=False,
        threads=True,
        seed=True,
        outputs=_OUT_FILE,
    )
    p.add_argument("--domain", required=True, help="the demos' domain")
    p.add_argument("--model", default=None, help="FB model folder (for FB-IL methods)")
    p.add_argument("--demos", required=True, help="folder of <task>.npz demo files")
    p.add_argument("--methods", default="all", help="all, a method or a comma list")
    p.add_argument("--tasks", default="all", help="all, a task or a comma list")
    p.add_argument("--k", type=int, default=1, help="demonstrations per imitation")
    p.add_argument("--draws", type=int, default=5, help="demo draws (groups of K) per task")
    p.add_argument(
        "--first-draw", type=int, default=0, help="index of the first draw (0: from the start)"
    )
    p.add_argument("--episodes", type=int, default=20, help="evaluation episodes per job")
    p.add_argument("--demo-set", default="standard", help="standard or shifted demos")
    _add_training_inputs(p)
    p.add_argument("--out", required=True, help="results file (.jsonl), appended")
    p.add_argument("--workers", type=int, default=1, help="jobs run in parallel")
    p.add_argument("--backend", default="local", help="local (process pool) or ray")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_demo(sub: Any) -> None:
    from fbil.evaluation.demo import DEFAULT_DOMAIN, DEFAULT_OUT

    about = "imitate a committed demo with every FB-IL method (shipped model)"
    p = _command(sub, "demo", _cmd_demo, about, with_json=False, threads=True, outputs=_OUT_FOLDER)
    p.add_argument(
        "--domain",
        default=DEFAULT_DOMAIN,
        help="a domain with a shipped model and demos (artifacts/models/DOMAIN)",
    )
    p.add_argument(
        "--tasks",
        default=None,
        help="task(s) whose committed demo to imitate: a task, a comma list or all "
        "(default: loop on the maze, walk on a locomotion domain)",
    )
    p.add_argument("--methods", default="all", help="all, a method or a comma list")
    p.add_argument("--episodes", type=int, default=10, help="evaluation episodes per method")
    p.add_argument("--out", default=DEFAULT_OUT, help="folder for the figures")


def _add_report(sub: Any) -> None:
    about = "Markdown + figures from benchmark results"
    p = _command(sub, "report", _cmd_report, about, with_json=False, outputs=_OUT_FOLDER)
    p.add_argument("results", nargs="+", help="results file(s), one domain per file")
    p.add_argument("--out", required=True, help="report folder")
    p.add_argument(
        "--budget-curve",
        default=None,
        help="budget_curve.json of scripts/budget_curve.py (default: one next to a results "
        "file, if any)",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fbil",
        description="Fast imitation learning with forward-backward behavior foundation models.",
    )
    parser.add_argument("--version", action="version", version=f"fbil {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _command(sub, "tasks", _cmd_tasks, "list domains, tasks and their sizes")
    for add in (
        _add_render,
        _add_collect,
        _add_datasets,
        _add_pretrain,
        _add_pretrain_goal,
        _add_zero_shot,
        _add_imitate,
        _add_expert,
        _add_demos,
        _add_evaluate,
        _add_benchmark,
        _add_demo,
        _add_report,
    ):
        add(sub)
    return parser


# -- running a command -------------------------------------------------------------------
def _check_writable(path: str, kind: str, option: str) -> None:
    """Refuse, before any work, an output path (a file or a folder) that can't be written.

    A probe file is made and removed where the output will go: permission bits say
    nothing for root, while a read-only mount, /proc or a file in the path refuse root too.
    """
    target, fix = Path(path), f"choose another {option}"
    if target.is_dir() if kind == "file" else target.is_file():
        found = "a folder" if kind == "file" else "a file"
        raise FbilError(f"{option} {path} is {found}, not a {kind}; {fix}")
    if target.is_file():
        try:
            with open(target, "a"):
                pass
        except OSError as exc:
            raise FbilError(f"cannot write {option} {path}: {exc.strerror}; {fix}") from None
        return
    folder = target if target.is_dir() else target.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise FbilError(f"cannot write {option} {path}: {folder} is not a folder; {fix}")
    try:
        fd, probe = tempfile.mkstemp(prefix=".fbil-write-check-", dir=folder)
    except OSError as exc:
        raise FbilError(
            f"cannot write {option} {path}: no file can be made in {folder} ({exc.strerror}); {fix}"
        ) from None
    os.close(fd)
    os.unlink(probe)


def _prepare(args: argparse.Namespace) -> None:
    """Before any work: every output path writable, then torch's thread count."""
    for option, kind in args.outputs:
        value = getattr(args, option.lstrip("-").replace("-", "_"))
        if value is not None:
            _check_writable(str(value), kind, option)
    if getattr(args, "budget_settings", None):
        from fbil.imitators.budgets import with_settings

        args.budget = with_settings(args.budget, args.budget_settings)
    threads = getattr(args, "threads", None)
    if threads is not None:
        if threads < 1:
            raise FbilError(f"--threads must be >= 1, got {threads}")
        import torch

        torch.set_num_threads(threads)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    command: Command = args.func
    try:
        _prepare(args)
        return command(args)
    except FbilError as exc:
        print(f"fbil: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # a training run's TrainingStopped says where it saved
        print(f"fbil: {exc}" if str(exc) else "fbil: interrupted", file=sys.stderr)
        return int(getattr(exc, "exit_code", 130))
    except BrokenPipeError:  # e.g. `fbil tasks | head`
        sys.stderr.close()
        return 0
