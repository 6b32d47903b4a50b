"""The benchmark grid: task x method x demo draw, as independent jobs.

Each finished job appends one JSON line to the results file (all inputs, returns, score,
timings, commit, seed), flushed and fsynced, so a killed run loses at most the jobs in
flight; a rerun skips every job already in the file. A method that trains saves its
training loop every few minutes (`fit_checkpoint`), so a job killed in flight loses at
most those minutes: the rerun resumes its training where it stopped. Jobs run in a local
process pool (default) or on Ray, for grids that outgrow one machine.

Ctrl-C (SIGINT) stops a run at once: queued jobs are dropped, running workers are
terminated, and every line already written stays (a line being written is finished first).
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import asdict, dataclass
from functools import lru_cache
from multiprocessing import get_context
from multiprocessing.connection import Connection, wait
from pathlib import Path
from typing import Any

from fbil import __version__
from fbil.artifacts import machine
from fbil.checkpoint import atomic_write_text
from fbil.errors import FbilError

BACKENDS = ("local", "ray")
Record = Callable[[dict[str, Any]], None]  # called with each finished job's row


@dataclass(frozen=True)
class Shared:
    """What every job of a run shares: the code's commit and the fits' checkpoint folder."""

    commit: str
    fits: str | None = None


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
    data: str | None = None  # the unsupervised dataset, for methods that train on it
    budget: str | None = None  # the budget, for methods that train
    goal_model: str | None = None  # the pre-trained goal model, for goal_td3

    @property
    def key(self) -> tuple[Any, ...]:
        return tuple(asdict(self).values())


def _job_inputs(
    methods: Sequence[str],
    model: Any,
    data: str | Path | None,
    budget: str,
    goal_model: str | Path | None,
    domain: str,
) -> dict[str, tuple[str | None, str | None, str | None]]:
    """Per method, the (data, budget, goal model) of its jobs: those it uses, else None
    (checked: a method that needs one of them refuses its absence). An `auto` budget is
    resolved here, per method and domain, so jobs and lines hold the budget that ran."""
    from fbil.imitators import FitContext, get_imitator
    from fbil.imitators.base import check_settings_used

    check_settings_used([get_imitator(m) for m in methods], budget)
    inputs = {}
    for method in methods:
        imitator = get_imitator(method)
        context = imitator.resolved(FitContext(model, data, budget, goal_model=goal_model), domain)
        imitator.require(context)
        inputs[method] = (
            str(data) if imitator.needs_dataset else None,
            context.budget if imitator.budgets else None,
            str(goal_model) if imitator.needs_goal_model else None,
        )
    return inputs


def demo_file(demos_dir: Path, task: str, demo_set: str) -> Path:
    return demos_dir / (f"{task}.npz" if demo_set == "standard" else f"{task}_{demo_set}.npz")


def load_task_demos(demos_dir: str | Path, tasks: str, domain: str | None) -> dict[str, Any]:
    """Each task's standard demo file in `demos_dir` (task -> Demos), for a comma list of
    tasks or `all` (the domain's tasks); a one-line error names the missing files."""
    from fbil.envs import get_domain
    from fbil.imitation.demos import Demos

    if tasks == "all":
        if domain is None:
            raise FbilError("the model does not say its domain; pass the tasks by name")
        names = list(get_domain(domain).task_names)
    else:
        names = [t.strip() for t in tasks.split(",") if t.strip()]
    files = [demo_file(Path(demos_dir), t, "standard") for t in names]
    missing = [f.name for f in files if not f.is_file()]
    if missing or not files:
        found = ", ".join(missing) or tasks
        raise FbilError(f"no demo file {found} in {demos_dir}; check the tasks")
    return {t: Demos.load(f) for t, f in zip(names, files, strict=True)}


def make_jobs(
    model: str | Path | None,
    demos_dir: str | Path,
    domain: str,
    tasks: Sequence[str],
    methods: Sequence[str],
    draws: int,
    k: int,
    episodes: int,
    seed: int = 0,
    demo_set: str = "standard",
    data: str | Path | None = None,
    budget: str = "auto",
    goal_model: str | Path | None = None,
    first_draw: int = 0,
) -> list[Job]:
    """The grid, in a fixed order (tasks, then draws, then methods), with the demo draws
    first_draw .. first_draw + draws - 1. `data`, `budget` and `goal_model` go to the jobs
    of the methods that use them (a method that needs a dataset without `data` is refused
    here, before any job runs)."""
    if draws < 1 or k < 1 or episodes < 1:
        raise FbilError("--draws, --k and --episodes must all be >= 1")
    if first_draw < 0:
        raise FbilError(f"--first-draw must be >= 0 (0: the first draw), got {first_draw}")
    inputs = _job_inputs(methods, model, data, budget, goal_model, domain)
    demos_dir = Path(demos_dir)
    jobs = []
    for task in tasks:
        path = demo_file(demos_dir, task, demo_set)
        if not path.is_file():
            raise FbilError(
                f"no demonstrations for {task} in {demos_dir} (expected {path.name}; "
                "record them with `fbil demos`)"
            )
        for draw in range(first_draw, first_draw + draws):
            for method in methods:
                jobs.append(
                    Job(
                        "" if model is None else str(model),
                        str(path),
                        domain,
                        task,
                        demo_set,
                        method,
                        draw,
                        k,
                        episodes,
                        seed,
                        *inputs[method],
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


@lru_cache(maxsize=2)
def _goal_model(path: str) -> Any:
    from fbil.baselines.goal_model import GoalModel

    return GoalModel.load(path)


@lru_cache(maxsize=2)
def _dataset(path: str) -> Any:
    from fbil.data import load_dataset

    return load_dataset(path)


def run_job(job: Job, commit: str = "unknown", fits: str | None = None) -> dict[str, Any]:
    """Imitate and evaluate one grid cell; the result is one JSON-able row. `fits`: a
    folder where a method that trains keeps its fit's checkpoint (`fit_checkpoint`), so
    that a killed job resumes its training where it stopped."""
    from fbil.evaluation.evaluate import evaluate, expert_return
    from fbil.imitators import FitContext, get_imitator

    started = time.perf_counter()
    imitator = get_imitator(job.method)
    # Scores divide by the expert's return from the *standard* start, where evaluation
    # starts, also for demos recorded elsewhere (paper App. E.5).
    standard = demo_file(Path(job.demos).parent, job.task, "standard")
    expert = expert_return(_demos(str(standard))) if job.demo_set != "standard" else None
    context = FitContext(
        _model(job.model) if imitator.needs_model else None,
        _dataset(job.data) if job.data else None,
        job.budget or "cpu",
        job.seed,
        goal_model=_goal_model(job.goal_model) if job.goal_model else None,
    )
    checkpoint = fit_checkpoint(job, imitator, context, fits)
    out = evaluate(
        context.model,
        _demos(job.demos),
        [job.method],
        k=job.k,
        draw=job.draw,
        episodes=job.episodes,
        seed=job.seed,
        expert=expert,
        dataset=context.dataset,
        budget=context.budget,
        skip_unfit=True,
        goal_model=context.goal_model,
        checkpoint=checkpoint,
    )
    row: dict[str, Any] = asdict(job)
    row.update(expert_return=out["expert_return"], commit=commit, fbil_version=__version__)
    row.update(family=imitator.family, **imitator.settings(context))
    # Which data and which kind of CPU: a grid's lines are comparable only on one dataset,
    # and runs repeat exactly only on one kind of CPU (docs/datasets.md).
    # A goal model's data is its method's (recorded since session 33; older models: None).
    digest = context.dataset.digest() if context.dataset is not None else None
    if digest is None and context.goal_model is not None:
        digest = context.goal_model.metadata.get("data_digest")
    row.update(data_digest=digest)
    row.update(machine=machine())
    if job.method in out["skipped"]:
        row.update(skipped=out["skipped"][job.method])
    else:
        _add_result(row, job, out["results"][job.method])
    row["wall_seconds"] = round(time.perf_counter() - started, 3)
    if checkpoint is not None:
        if checkpoint.resumed_at:  # the steps its training resumed from, after kills
            row["resumed_at"] = checkpoint.resumed_at
        checkpoint.discard()
    return row


def fit_checkpoint(job: Job, imitator: Any, context: Any, fits: str | None) -> Any:
    """The checkpoint of `job`'s fit in the folder `fits`, for a method that trains;
    its signature holds the job and the method's resolved settings and data, so a file
    left by other code or data is never resumed."""
    from fbil.checkpoint import FitCheckpoint

    if fits is None or not imitator.budgets:
        return None
    digest = context.dataset.digest() if context.dataset is not None else None
    signature = json.dumps([asdict(job), imitator.settings(context), digest], sort_keys=True)
    name = hashlib.sha256(signature.encode()).hexdigest()[:16]
    path = Path(fits) / f"{job.method}_{job.task}_d{job.draw}_s{job.seed}_{name}.safetensors"
    return FitCheckpoint(path, signature)


def _add_result(row: dict[str, Any], job: Job, r: Any) -> None:
    from fbil.envs import get_domain

    row.update(
        principle=r.principle,
        return_mean=r.return_mean,
        return_std=r.return_std,
        returns=r.returns,
        score=r.score,
        seconds=r.seconds,
    )
    if r.fit:
        row["fit"] = r.fit
    pictures = get_domain(job.domain).hooks.pictures
    kept = None
    if pictures is not None and drawn_by_report(row):
        kept = pictures.keep(r.trajectory, r.physics)
    if kept is not None:
        # What the domain's report picture needs of the first evaluation episode, per
        # (task, method): the maze's x-y path (every 2nd step), locomotion's frames.
        row["trajectory"] = kept


def drawn_by_report(row: dict[str, Any]) -> bool:
    """Whether `fbil report` draws this line's first episode: the first draw of the
    standard K = 1 grid. Other lines keep no trajectory (it is most of a line's bytes)."""
    return row["draw"] == 0 and row["k"] == 1 and row["demo_set"] == "standard"


def _init_worker(threads: int) -> None:
    import torch

    torch.set_num_threads(threads)


@contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Hold a Ctrl-C until the block is done (a results line is never cut in two)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if caught:
            raise KeyboardInterrupt


# -- the runner --------------------------------------------------------------------------
def run_benchmark(
    jobs: Sequence[Job],
    out: str | Path,
    workers: int = 1,
    backend: str = "local",
    commit: str = "unknown",
    on_result: Callable[[dict[str, Any]], None] | None = None,
    threads: int = 1,
) -> list[dict[str, Any]]:
    """Run every job not yet in `out`, appending each result as it finishes (`threads`:
    torch threads per worker). The methods that train keep their fits' checkpoints in a
    folder beside `out` (`.<name>.fits/`), so a job killed during its training resumes
    there on the next run; a job's file goes when its line is written, the folder when
    it is empty."""
    if backend not in BACKENDS:
        raise FbilError(f"unknown backend {backend!r}; valid: {', '.join(BACKENDS)}")
    if workers < 1 or threads < 1:
        raise FbilError(f"--workers and --threads must be >= 1, got {workers} and {threads}")
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    done_rows = read_results(out)
    finished = {job_key(r) for r in done_rows}
    todo = [j for j in jobs if j.key not in finished]
    new_rows: list[dict[str, Any]] = []
    fits = str(out.parent / f".{out.name}.fits")

    def record(fh: Any, row: dict[str, Any]) -> None:
        with _sigint_deferred():
            _append(fh, row)
            new_rows.append(row)
        if on_result is not None:
            on_result(row)

    with open(out, "a") as fh:
        if not todo:
            return []
        if backend == "ray":
            _run_ray(todo, workers, threads, Shared(commit, fits), lambda row: record(fh, row))
        elif workers == 1:
            _init_worker(threads)
            for job in todo:
                record(fh, run_job(job, commit, fits))
        else:
            _run_pool(todo, workers, threads, Shared(commit, fits), lambda row: record(fh, row))
    with suppress(OSError):  # not empty (a job failed) or never made
        Path(fits).rmdir()
    return new_rows


def _exit_on_sigterm(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)  # a clean exit: no semaphores left to the tracker


def _worker_loop(conn: Connection, threads: int, shared: Shared) -> None:
    """A pool worker: run the jobs the parent sends until it sends None."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent alone handles Ctrl-C
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    _init_worker(threads)
    try:
        while (job := conn.recv()) is not None:
            try:
                result: tuple[bool, Any] = (True, run_job(job, shared.commit, shared.fits))
            except Exception as exc:  # re-raised in the parent, as a pool would
                result = (False, exc)
            conn.send(result)
    except (EOFError, BrokenPipeError):  # the parent is gone: nothing left to do
        return


def _start_workers(n: int, threads: int, shared: Shared) -> dict[Connection, Any]:
    # spawn, not fork: a forked PyTorch with OpenMP threads can deadlock in the child.
    ctx = get_context("spawn")
    workers: dict[Connection, Any] = {}
    # Started with SIGINT ignored (inherited through exec), so that a Ctrl-C to the whole
    # process group, even during their start-up, reaches this process alone.
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        for _ in range(n):
            conn, child = ctx.Pipe()
            proc = ctx.Process(target=_worker_loop, args=(child, threads, shared), daemon=True)
            proc.start()
            child.close()
            workers[conn] = proc
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)
    return workers


def _stop_workers(workers: dict[Connection, Any], grace: float = 0.0) -> None:
    """Wait up to `grace` seconds for the workers to exit, then terminate the rest (all of
    them, at once, after Ctrl-C or a failed job)."""
    for proc in workers.values():
        proc.join(timeout=grace)
        if proc.is_alive():
            proc.terminate()
    for proc in workers.values():
        proc.join(timeout=3)
        if proc.is_alive():
            proc.kill()
            proc.join()


def _run_pool(
    jobs: Sequence[Job], workers: int, threads: int, shared: Shared, record: Record
) -> None:
    """Jobs handed out one at a time from this process, so none is queued in a worker:
    stopping the run drops the queue here and terminates the workers."""
    queue = deque(jobs)
    procs = _start_workers(min(workers, len(queue)), threads, shared)
    try:
        busy = set(procs)
        for conn in busy:
            conn.send(queue.popleft())
        while busy:
            for conn in busy.intersection(wait(list(busy))):
                try:
                    ok, payload = conn.recv()
                except EOFError:
                    code = procs[conn].exitcode
                    raise RuntimeError(f"a benchmark worker died (exit code {code})") from None
                if not ok:
                    raise payload
                record(payload)
                if queue:
                    conn.send(queue.popleft())
                else:
                    conn.send(None)
                    busy.discard(conn)
    except BaseException:  # Ctrl-C, a failed job: the queue is dropped with this frame
        _stop_workers(procs)
        raise
    _stop_workers(procs, grace=10.0)


def _run_ray(
    jobs: Sequence[Job], workers: int, threads: int, shared: Shared, record: Record
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
        _init_worker(threads)
        return run_job(job, shared.commit, shared.fits)

    pending = [remote_job.remote(job) for job in jobs]
    try:
        while pending:
            finished, pending = ray.wait(pending, num_returns=1)
            for ref in finished:
                record(ray.get(ref))
    finally:
        for ref in pending:  # Ctrl-C or a failed job: cancel the rest
            ray.cancel(ref, force=True)
