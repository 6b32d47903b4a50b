"""The benchmark grid: task x method x demo draw, as independent jobs.

Each finished job appends one JSON line to the results file (all inputs, returns, score,
timings, commit, seed), flushed and fsynced, so a killed run loses at most the jobs in
flight; a rerun skips every job already in the file. Jobs run in a local process pool
(default) or on Ray, for grids that outgrow one machine.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass
from functools import lru_cache
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from fbil import __version__
from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError

BACKENDS = ("local", "ray")


@dataclass(frozen=True)
class Job:
    model: str
    demos: str  # a demo file
    domain: str
    task: str
    demo_set: str  # "standard" or "shifted": where the demos start
    method: str
    draw: int
    k: int
    episodes: int
    seed: int

    @property
    def key(self) -> tuple[Any, ...]:
        return tuple(asdict(self).values())


def demo_file(demos_dir: Path, task: str, demo_set: str) -> Path:
    return demos_dir / (f"{task}.npz" if demo_set == "standard" else f"{task}_{demo_set}.npz")


def make_jobs(
    model: str | Path,
    demos_dir: str | Path,
    domain: str,
    tasks: Sequence[str],
    methods: Sequence[str],
    draws: int,
    k: int,
    episodes: int,
    seed: int = 0,
    demo_set: str = "standard",
) -> list[Job]:
    """The grid, in a fixed order (tasks, then draws, then methods)."""
    if draws < 1 or k < 1 or episodes < 1:
        raise FbilError("--repetitions, --k and --episodes must all be >= 1")
    demos_dir = Path(demos_dir)
    jobs = []
    for task in tasks:
        path = demo_file(demos_dir, task, demo_set)
        if not path.is_file():
            raise FbilError(
                f"no demonstrations for {task} in {demos_dir} (expected {path.name}; "
                "record them with `fbil demos`)"
            )
        for draw in range(draws):
            for method in methods:
                jobs.append(
                    Job(
                        str(model),
                        str(path),
                        domain,
                        task,
                        demo_set,
                        method,
                        draw,
                        k,
                        episodes,
                        seed,
                    )
                )
    return jobs


# -- the results file ------------------------------------------------------------------
def read_results(path: str | Path, repair: bool = True) -> list[dict[str, Any]]:
    """Every finished job in `path`. A truncated last line (a write cut by a kill) is
    dropped, and with `repair` the file is rewritten without it; any other bad line is an
    error, so nothing is silently lost."""
    path = Path(path)
    if not path.exists():
        return []
    text = path.read_text()
    lines = text.split("\n")
    rows, bad_last = [], False
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            if i == len(lines) - 1:  # no newline after it: cut while being written
                bad_last = True
                continue
            raise FbilError(
                f"{path}: line {i + 1} is not valid JSON; fix or delete that line "
                "(its job will then run again)"
            ) from None
    if bad_last and repair:
        atomic_write_text(path, "".join(json.dumps(r) + "\n" for r in rows))
    return rows


def _append(fh: Any, row: dict[str, Any]) -> None:
    fh.write(json.dumps(row) + "\n")
    fh.flush()
    os.fsync(fh.fileno())


def job_key(row: dict[str, Any]) -> tuple[Any, ...]:
    return tuple(row.get(f) for f in Job.__dataclass_fields__)


# -- one job -----------------------------------------------------------------------------
@lru_cache(maxsize=4)
def _model(path: str) -> Any:
    from fbil.fb.model import FBModel

    return FBModel.load(path)


@lru_cache(maxsize=16)
def _demos(path: str) -> Any:
    from fbil.imitation.demos import Demos

    return Demos.load(path)


def run_job(job: Job, commit: str = "unknown") -> dict[str, Any]:
    """Imitate and evaluate one grid cell; the result is one JSON-able row."""
    from fbil.evaluation.evaluate import evaluate, expert_return

    started = time.perf_counter()
    # Scores divide by the expert's return from the *standard* start, where evaluation
    # starts, also for demos recorded elsewhere (paper App. E.5).
    standard = demo_file(Path(job.demos).parent, job.task, "standard")
    expert = expert_return(_demos(str(standard))) if job.demo_set != "standard" else None
    out = evaluate(
        _model(job.model),
        _demos(job.demos),
        [job.method],
        k=job.k,
        draw=job.draw,
        episodes=job.episodes,
        seed=job.seed,
        expert=expert,
    )
    row: dict[str, Any] = asdict(job)
    from fbil.imitation.core import OptimiserConfig

    row.update(expert_return=out["expert_return"], commit=commit, fbil_version=__version__)
    row["optimiser"] = asdict(OptimiserConfig())
    if job.method in out["skipped"]:
        row.update(skipped=out["skipped"][job.method])
    else:
        r = out["results"][job.method]
        row.update(
            principle=r.principle,
            return_mean=r.return_mean,
            return_std=r.return_std,
            returns=r.returns,
            score=r.score,
            seconds=r.seconds,
        )
        if job.domain == "point_mass_maze" and job.draw == 0:
            # One x-y path per (task, method) for the report's pictures (every 2nd step).
            row["trajectory"] = r.trajectory[::2, :2].round(3).tolist()
    row["wall_seconds"] = round(time.perf_counter() - started, 3)
    return row


def _init_worker(threads: int) -> None:
    import torch

    torch.set_num_threads(threads)


# -- the runner --------------------------------------------------------------------------
def run_benchmark(
    jobs: Sequence[Job],
    out: str | Path,
    workers: int = 1,
    backend: str = "local",
    commit: str = "unknown",
    on_result: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Run every job not yet in `out`, appending each result as it finishes."""
    if backend not in BACKENDS:
        raise FbilError(f"unknown backend {backend!r}; valid: {', '.join(BACKENDS)}")
    if workers < 1:
        raise FbilError(f"--workers must be >= 1, got {workers}")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done_rows = read_results(out)
    finished = {job_key(r) for r in done_rows}
    todo = [j for j in jobs if j.key not in finished]
    new_rows: list[dict[str, Any]] = []

    def record(fh: Any, row: dict[str, Any]) -> None:
        _append(fh, row)
        new_rows.append(row)
        if on_result is not None:
            on_result(row)

    with open(out, "a") as fh:
        if not todo:
            return []
        if backend == "ray":
            _run_ray(todo, workers, commit, lambda row: record(fh, row))
        elif workers == 1:
            _init_worker(1)
            for job in todo:
                record(fh, run_job(job, commit))
        else:
            _run_pool(todo, workers, commit, lambda row: record(fh, row))
    return new_rows


def _run_pool(
    jobs: Iterable[Job], workers: int, commit: str, record: Callable[[dict[str, Any]], None]
) -> None:
    # spawn, not fork: a forked PyTorch with OpenMP threads can deadlock in the child.
    ctx = get_context("spawn")
    with ProcessPoolExecutor(workers, ctx, initializer=_init_worker, initargs=(1,)) as pool:
        pending = {pool.submit(run_job, job, commit) for job in jobs}
        while pending:
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                record(fut.result())


def _run_ray(
    jobs: Sequence[Job], workers: int, commit: str, record: Callable[[dict[str, Any]], None]
) -> None:
    try:
        import ray
    except ImportError:
        raise FbilError(
            "--backend ray needs Ray: pip install 'fbil[ray]' (or pip install ray)"
        ) from None
    if not ray.is_initialized():
        # RAY_ADDRESS joins an existing cluster; without it a local instance starts.
        address = os.environ.get("RAY_ADDRESS")
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, log_to_driver=False, include_dashboard=False)

    @ray.remote(num_cpus=1)
    def remote_job(job: Job) -> dict[str, Any]:
        _init_worker(1)
        return run_job(job, commit)

    pending = [remote_job.remote(job) for job in jobs]
    while pending:
        finished, pending = ray.wait(pending, num_returns=1)
        for ref in finished:
            record(ray.get(ref))
