"""The `fbil` command line: a thin layer over the library.

Every command that prints figures also takes `--json` and then prints one JSON object on
stdout. User mistakes end in one line on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
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
    from fbil.envs import RandomPolicy, get_domain, get_task, rollout
    from fbil.envs.render import (
        ANIMATION_SUFFIXES,
        IMAGE_SUFFIXES,
        locomotion_frames,
        plot_maze_trajectories,
        save_frames,
    )

    spec = get_domain(args.domain)
    get_task(args.domain, args.task)
    if args.policy != "random":
        raise FbilError(f"unknown policy {args.policy!r}; valid policies: random")
    suffix = Path(args.out).suffix.lower()
    if suffix not in IMAGE_SUFFIXES + ANIMATION_SUFFIXES:
        raise FbilError(
            f"unsupported picture type {suffix or '(none)'!r} for {args.out}; use one of "
            f"{', '.join(IMAGE_SUFFIXES + ANIMATION_SUFFIXES)}"
        )
    policy = RandomPolicy(spec.act_dim, seed=args.seed)
    if spec.name == "point_mass_maze":
        if suffix not in IMAGE_SUFFIXES:
            raise FbilError("maze pictures are images: use .png, .pdf, .svg or .jpg")
        seeds = list(range(args.seed, args.seed + args.episodes))
        episodes = rollout(spec.name, args.task, policy, seeds, args.steps)
        plot_maze_trajectories(list(episodes.observation), args.out, task=args.task)
        returns = episodes.returns.tolist()
    else:
        steps = args.steps or 250
        n_frames = args.frames if suffix in IMAGE_SUFFIXES else steps // 2 + 1
        frames = locomotion_frames(spec.name, args.task, policy, args.seed, steps, n_frames)
        save_frames(frames, args.out)
        returns = []
    if args.json:
        print(json.dumps({"out": str(args.out), "returns": returns}))
    else:
        print(f"wrote {args.out}")
    return 0


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
    from fbil.data.coverage import dataset_info, plot_coverage

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
    cov = info["coverage"]
    if info["domain"] == "point_mass_maze":
        print(
            f"coverage: {100 * cov['grid_fraction']:.1f}% of {cov['free_cells']} free cells "
            f"({cov['grid']} grid); rooms visited: {', '.join(cov['rooms_visited'])}"
        )
        for room, frac in cov["room_fraction"].items():
            print(f"  {room:<13} {100 * frac:5.1f}%")
    else:
        for name, q in cov.items():
            if isinstance(q, dict):
                print(
                    f"  {name:<22} 1-99%: [{q['p01']:8.3f}, {q['p99']:8.3f}]  max {q['max']:8.3f}"
                )
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
    try:
        if isinstance(current, bool):
            if value.lower() not in ("true", "false", "1", "0"):
                raise ValueError(value)
            return value.lower() in ("true", "1")
        return float(value) if current is None else type(current)(value)
    except ValueError:
        kind = type(current).__name__
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


def _cmd_pretrain(args: argparse.Namespace) -> int:
    import dataclasses

    import torch

    from fbil.data import load_dataset
    from fbil.data.storage import read_manifest
    from fbil.fb.config import preset
    from fbil.fb.train import FBTrainer

    if args.threads:
        torch.set_num_threads(args.threads)
    if args.device.startswith("cuda") and not torch.cuda.is_available():
        raise FbilError("--device cuda: no CUDA device here; use --device cpu")
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
    trainer = FBTrainer(model_cfg, train_cfg, dataset, device=args.device)
    manifest = read_manifest(args.data) or {}
    model = trainer.fit(args.out, resume=args.resume, progress=not args.json, manifest=manifest)
    summary = {
        "out": str(args.out),
        "steps": trainer.step,
        "wall_seconds": model.metadata.get("wall_seconds"),
    }
    print(json.dumps(summary) if args.json else f"model saved in {args.out} ({trainer.step} steps)")
    return 0


def _cmd_zero_shot(args: argparse.Namespace) -> int:
    from fbil.data import load_dataset
    from fbil.fb.model import FBModel
    from fbil.fb.zero_shot import zero_shot

    if args.threads:
        import torch

        torch.set_num_threads(args.threads)
    model = FBModel.load(args.model)
    dataset = load_dataset(args.data)
    tasks = dataset_tasks = get_domain_tasks(dataset.domain)
    if args.task != "all":
        tasks = [t.strip() for t in args.task.split(",") if t.strip()]
        for task in tasks or [args.task]:
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


def _cmd_imitate(args: argparse.Namespace) -> int:
    import torch

    from fbil.fb.model import FBModel
    from fbil.imitation import MAIN_METHODS, METHODS, Demos, imitate

    if args.threads:
        torch.set_num_threads(args.threads)
    model = FBModel.load(args.model)
    demos = Demos.load(args.demos)
    if args.demos_per_run is not None:
        demos = demos.select(range(min(args.demos_per_run, len(demos))))
    methods = MAIN_METHODS if args.method == "all" else args.method.split(",")
    for m in methods:
        if m not in METHODS:
            raise FbilError(f"unknown method {m!r}; valid methods: {', '.join(METHODS)}, all")
    results: dict[str, dict[str, object]] = {}
    policies = {}
    for m in methods:
        if METHODS[m].needs_actions and not demos.has_actions:
            results[m] = {"skipped": "needs expert actions; the demonstrations have none"}
            continue
        policy = imitate(model, demos, m)
        policies[m] = policy
        z = policy.z
        results[m] = {
            "seconds": round(policy.seconds, 4),
            "z_norm": float(z.norm(dim=-1).mean()),
            "z_head": [round(float(v), 4) for v in (z[0] if policy.is_schedule else z)[:4]],
            "schedule_steps": int(z.shape[0]) if policy.is_schedule else None,
            **{k: v for k, v in policy.info.items() if isinstance(v, int | float)},
        }
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        for m, policy in policies.items():
            policy.save(out / f"{m}.json")
    if args.json:
        print(json.dumps({"methods": results}))
        return 0
    print(f"{len(demos)} demonstration(s), model {args.model}")
    print(f"{'method':<10}{'principle':<26}{'seconds':>9}  z (first entries)      |z|")
    for m, r in results.items():
        if "skipped" in r:
            print(f"{m:<10}{METHODS[m].principle:<26}  skipped: {r['skipped']}")
            continue
        head = " ".join(f"{v:+.2f}" for v in r["z_head"])  # type: ignore[attr-defined]
        print(
            f"{m:<10}{METHODS[m].principle:<26}{r['seconds']:>9.3f}  {head:<22} {r['z_norm']:.2f}"
        )
    if args.out:
        print(f"policies saved in {args.out}/<method>.json")
    return 0


def _cmd_expert(args: argparse.Namespace) -> int:
    import torch

    from fbil.agents.expert import train_expert

    if args.threads:
        torch.set_num_threads(args.threads)
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

    demos = make_demos(args.expert_dir, args.episodes, args.out, start=args.start, seed=args.seed)
    meta = demos.metadata
    if args.json:
        print(json.dumps({"out": args.out, **meta}))
    else:
        print(
            f"{len(demos)} demonstrations of {meta['domain']}/{meta['task']} ({args.start} "
            f"start) in {args.out}: return {meta['return_mean']:.1f} ± {meta['return_std']:.1f}"
        )
    return 0


def get_domain_tasks(domain: str) -> list[str]:
    from fbil.envs import get_domain

    return get_domain(domain).task_names


def _cmd_evaluate(args: argparse.Namespace) -> int:
    import torch

    from fbil.evaluation.evaluate import evaluate
    from fbil.fb.model import FBModel
    from fbil.imitation.demos import Demos

    if args.threads:
        torch.set_num_threads(args.threads)
    model = FBModel.load(args.model)
    demos = Demos.load(args.demos)
    out = evaluate(
        model,
        demos,
        args.method,
        k=args.demos_per_run,
        draw=args.draw,
        episodes=args.episodes,
        seed=args.seed,
    )
    methods = {m: r.as_dict() for m, r in out["results"].items()}
    methods.update({m: {"skipped": why} for m, why in out["skipped"].items()})
    if args.json:
        print(
            json.dumps(
                {
                    "expert_return": out["expert_return"],
                    "task": out["task"],
                    "k": out["k"],
                    "episodes": out["episodes"],
                    "methods": methods,
                }
            )
        )
        return 0
    print(f"{out['domain']}/{out['task']}: K={out['k']} demo(s), {out['episodes']} episodes")
    _print_scores(out)
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


def _cmd_benchmark(args: argparse.Namespace) -> int:
    from tqdm.auto import tqdm

    from fbil.envs import get_domain, get_task
    from fbil.evaluation.benchmark import make_jobs, read_results, run_benchmark
    from fbil.evaluation.evaluate import resolve_methods
    from fbil.fb.train import git_commit

    spec = get_domain(args.domain)
    tasks = spec.task_names if args.tasks == "all" else args.tasks.split(",")
    for t in tasks:
        get_task(args.domain, t)
    jobs = make_jobs(
        args.model,
        args.demos,
        args.domain,
        tasks,
        resolve_methods(args.methods),
        args.repetitions,
        args.k,
        args.episodes,
        seed=args.seed,
        demo_set=args.demo_set,
    )
    before = len(read_results(args.out))
    bar = tqdm(
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

    new = run_benchmark(jobs, args.out, args.workers, args.backend, git_commit(), on_result)
    bar.close()
    print(f"{len(new)} jobs run, {len(jobs) - len(new)} already in {args.out}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    import time

    import torch

    from fbil.evaluation.demo import run_demo

    started = time.perf_counter()
    if args.threads:
        torch.set_num_threads(args.threads)
    out = run_demo(args.task, args.methods, args.episodes, args.out)
    print(
        f"fbil demo: imitating one expert demonstration of point_mass_maze/{out['task']} "
        f"with the committed cpu FB model ({out['episodes']} evaluation episodes per method)"
    )
    _print_scores(out)
    print(f"figure: {out['picture']}")
    print(f"total: {time.perf_counter() - started:.1f} s")
    return 0


def _cmd_report(args: argparse.Namespace) -> int:
    from fbil.evaluation.report import write_report

    path = write_report(args.results, args.out)
    print(f"report: {path}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fbil",
        description="Fast imitation learning with forward-backward behavior foundation models.",
    )
    parser.add_argument("--version", action="version", version=f"fbil {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("tasks", help="list domains, tasks and their sizes")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_tasks)

    p = sub.add_parser("render", help="picture of a policy acting in a task")
    p.add_argument("domain")
    p.add_argument("task")
    p.add_argument("--policy", default="random", help="policy to roll out (default: random)")
    p.add_argument("--out", required=True, help="maze: .png/.pdf/.svg; others also .gif/.mp4")
    p.add_argument("--episodes", type=int, default=5, help="maze: trajectories drawn")
    p.add_argument("--steps", type=int, default=None, help="steps per episode")
    p.add_argument("--frames", type=int, default=8, help="locomotion strip: frames shown")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_render)
    p = sub.add_parser("collect", help="collect a reward-free dataset (ExORL layout)")
    p.add_argument("domain")
    p.add_argument("--explorer", default="rnd", help="rnd (default) or random")
    p.add_argument("--episodes", type=int, required=True)
    p.add_argument("--out", required=True, help="dataset folder (episodes go to OUT/buffer)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--resume", action="store_true", help="continue an interrupted collection")
    p.add_argument("--num-envs", type=int, default=8, help="environments stepped in lockstep")
    p.add_argument("--agents", type=int, default=4, help="rnd: independent explorers")
    p.add_argument("--updates-per-step", type=int, default=1, help="rnd: updates per round")
    p.add_argument("--stddev", type=float, default=0.2, help="rnd: exploration noise")
    p.add_argument(
        "--stddev-max",
        type=float,
        default=None,
        help="rnd: noise of the last agent (agents spread from --stddev to this)",
    )
    p.add_argument(
        "--starts",
        default="standard",
        help="standard (the domain's start) or uniform (maze: anywhere in the four rooms)",
    )
    p.add_argument("--threads", type=int, default=None, help="torch threads")
    p.add_argument("--json", action="store_true", help="print the manifest as JSON")
    p.set_defaults(func=_cmd_collect)

    p = sub.add_parser("dataset-info", help="size, ranges and coverage of a dataset")
    p.add_argument("dir")
    p.add_argument("--domain", default=None, help="check the data is of this domain")
    p.add_argument("--plot", default=None, help="write a coverage figure (PNG)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_dataset_info)
    p = sub.add_parser("dataset-merge", help="one dataset folder from several of one domain")
    p.add_argument("sources", nargs="+", help="dataset folders, in the order to number them")
    p.add_argument("--out", required=True, help="new dataset folder (must not exist)")
    p.add_argument("--json", action="store_true", help="print the manifest as JSON")
    p.set_defaults(func=_cmd_dataset_merge)
    p = sub.add_parser(
        "dataset-oversample",
        help="maze: a dataset with extra copies of the windows around doorway crossings",
    )
    p.add_argument("src", help="maze dataset folder")
    p.add_argument("--out", required=True, help="new dataset folder (must not exist)")
    p.add_argument("--window", type=int, default=30, help="steps kept on each side")
    p.add_argument("--copies", type=int, default=4, help="extra copies of each window")
    p.add_argument("--json", action="store_true", help="print the manifest as JSON")
    p.set_defaults(func=_cmd_dataset_oversample)
    p = sub.add_parser("pretrain", help="pre-train an FB model on a dataset")
    p.add_argument("domain")
    p.add_argument("--data", required=True, help="dataset folder")
    p.add_argument("--preset", default="cpu", help="paper, cpu (default) or smoke")
    p.add_argument("--out", required=True, help="model folder")
    p.add_argument("--steps", type=int, default=None, help="gradient steps (preset default)")
    p.add_argument("--batch-size", type=int, default=None)
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--device", default="cpu", help="cpu or cuda")
    p.add_argument("--threads", type=int, default=None, help="torch threads")
    p.add_argument("--resume", action="store_true", help="continue from OUT's checkpoint")
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a training setting, e.g. --set lr_b=1e-6 (repeatable)",
    )
    p.add_argument(
        "--checkpoint-seconds",
        type=float,
        default=None,
        help="seconds between checkpoints (default 180)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_pretrain)

    p = sub.add_parser("zero-shot", help="zero-shot returns of a model from task rewards")
    p.add_argument("model")
    p.add_argument("--data", required=True, help="dataset to infer z_r from")
    p.add_argument("--task", default="all")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_zero_shot)
    p = sub.add_parser("imitate", help="imitation policies from demonstrations")
    p.add_argument("model", help="FB model folder")
    p.add_argument("demos", help="demo file (.npz)")
    p.add_argument("--method", default="all", help="a method, a comma list, or all")
    p.add_argument("--demos-per-run", type=int, default=None, help="use the first K demos")
    p.add_argument("--out", default=None, help="folder for the policies (<method>.json)")
    p.add_argument("--threads", type=int, default=None, help="torch threads")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_imitate)
    p = sub.add_parser("expert", help="train a TD3 expert for a task")
    p.add_argument("domain")
    p.add_argument("task")
    p.add_argument("--mode", default="offline", help="offline (needs --data) or online")
    p.add_argument("--data", default=None, help="dataset to relabel (offline)")
    p.add_argument("--out", required=True)
    p.add_argument("--steps", type=int, default=100_000, help="gradient steps")
    p.add_argument("--eval-every", type=int, default=10_000)
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
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--resume", action="store_true")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_expert)

    p = sub.add_parser("demos", help="record demonstrations of a trained expert")
    p.add_argument("expert_dir")
    p.add_argument("--episodes", type=int, required=True)
    p.add_argument("--out", required=True, help="demo file (.npz)")
    p.add_argument("--start", default="standard", help="standard or shifted (App. E.5)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_demos)

    p = sub.add_parser("evaluate", help="imitate from K demos and score each method")
    p.add_argument("model")
    p.add_argument("demos")
    p.add_argument("--method", default="all", help="a method, a comma list, or all")
    p.add_argument("--demos-per-run", type=int, default=1, help="K: demonstrations used")
    p.add_argument("--draw", type=int, default=0, help="which group of K demos to use")
    p.add_argument("--episodes", type=int, default=10, help="evaluation episodes per method")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_evaluate)

    p = sub.add_parser("benchmark", help="the task x method x demo-draw grid, resumable")
    p.add_argument("--domain", required=True)
    p.add_argument("--model", required=True)
    p.add_argument("--demos", required=True, help="folder of <task>.npz demo files")
    p.add_argument("--methods", default="all")
    p.add_argument("--tasks", default="all", help="all or a comma list")
    p.add_argument("--k", type=int, default=1, help="demonstrations per imitation")
    p.add_argument("--repetitions", type=int, default=5, help="demo draws per task")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--demo-set", default="standard", help="standard or shifted demos")
    p.add_argument("--out", required=True, help="results file (.jsonl), appended")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--backend", default="local", help="local (process pool) or ray")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_benchmark)

    p = sub.add_parser("demo", help="imitate a maze demo with every method (shipped model)")
    p.add_argument("--task", default="loop", help="maze task whose committed demo to imitate")
    p.add_argument("--methods", default="all", help="all or a comma list")
    p.add_argument("--episodes", type=int, default=10, help="evaluation episodes per method")
    p.add_argument("--out", default="fbil-demo", help="folder for the figure")
    p.add_argument("--threads", type=int, default=None)
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("report", help="Markdown + figures from benchmark results")
    p.add_argument("results", nargs="+", help="results file(s) of one domain")
    p.add_argument("--out", required=True, help="report folder")
    p.set_defaults(func=_cmd_report)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    command: Command = args.func
    try:
        return command(args)
    except FbilError as exc:
        print(f"fbil: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("fbil: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `fbil tasks | head`
        sys.stderr.close()
        return 0
