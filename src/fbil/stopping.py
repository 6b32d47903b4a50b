"""A clean stop for long training loops: the first Ctrl-C (SIGINT) or SIGTERM only sets a
flag, which the loop reads between two updates; the run then writes its checkpoint at that
whole step and raises `TrainingStopped`, so a rerun with `--resume` continues from there
instead of from the last timed checkpoint (up to `checkpoint_seconds` earlier). A second
signal acts at once, as without this.

    with StopSignals() as stop:
        while step < steps and not stop:
            ...
    save the checkpoint; if stop: raise stop.stopped(out, step)
"""

from __future__ import annotations

import signal
import threading
from pathlib import Path
from types import FrameType, TracebackType
from typing import Any

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class TrainingStopped(KeyboardInterrupt):
    """A training run stopped by a signal, after saving its checkpoint. A KeyboardInterrupt,
    so that code which stops on Ctrl-C still does; `exit_code` is 128 + the signal."""

    def __init__(self, message: str, signum: int) -> None:
        super().__init__(message)
        self.exit_code = 128 + signum


class StopSignals:
    """Within the block, SIGINT and SIGTERM set a flag (`bool(self)`) instead of acting. Off
    the main thread, where Python cannot install handlers, it does nothing (never set)."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self._previous: dict[int, Any] = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for signum in SIGNALS:
                self._previous[signum] = signal.signal(signum, self._handle)
        return self

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is None:
            self.signum = signum
        # The next signal gets the handlers from before: a second Ctrl-C stops at once.
        for number, previous in self._previous.items():
            signal.signal(number, previous)

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        for number, previous in self._previous.items():
            signal.signal(number, previous)
        self._previous.clear()

    def __bool__(self) -> bool:
        return self.signum is not None

    def stopped(self, out: str | Path, step: int) -> TrainingStopped:
        """The exception to raise once the checkpoint of `out` is saved at `step`."""
        name = signal.Signals(self.signum or signal.SIGINT).name
        return TrainingStopped(
            f"stopped by {name} at step {step}; checkpoint saved in {out}: "
            "rerun the same command with --resume to continue",
            self.signum or signal.SIGINT,
        )
