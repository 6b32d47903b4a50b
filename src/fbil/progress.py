"""Progress bars that stay readable in log files: tqdm refreshes every second on a
terminal; when stderr is redirected (nohup, CI) it refreshes at most once a minute, each
refresh on its own line (no carriage returns piling up into one endless line), and a
`set_postfix` never forces a refresh of its own."""

from __future__ import annotations

import sys
from typing import Any, TextIO

from tqdm.auto import tqdm


class _Lines:
    """A text stream that turns tqdm's carriage returns into new lines."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream

    def write(self, text: str) -> int:
        text = text.replace("\r", "\n")
        return self.stream.write(text) if text.strip() or text == "\n" else 0

    def flush(self) -> None:
        self.stream.flush()


class Bar(tqdm):
    """tqdm whose postfix waits for the next timed refresh (the interval holds)."""

    def set_postfix(self, ordered_dict: Any = None, refresh: bool = False, **kwargs: Any) -> None:
        super().set_postfix(ordered_dict, refresh=refresh, **kwargs)


def progress_bar(**kwargs: Any) -> Bar:
    """A progress bar with `mininterval` (and, in log files, the stream) chosen by where
    stderr goes, unless given."""
    terminal = sys.stderr.isatty()
    kwargs.setdefault("mininterval", 1.0 if terminal else 60.0)
    if not terminal:
        # tqdm's monitor redraws a bar idle for maxinterval (10 s by default): not in logs.
        kwargs.setdefault("maxinterval", max(kwargs["mininterval"], 10.0))
        kwargs.setdefault("file", _Lines(sys.stderr))
    return Bar(**kwargs)
