"""Progress bars that stay readable in log files: tqdm refreshes every second on a
terminal and at most once a minute when stderr is redirected (nohup, CI)."""

from __future__ import annotations

import sys
from typing import Any

from tqdm.auto import tqdm


def progress_bar(**kwargs: Any) -> tqdm:
    """`tqdm(**kwargs)` with `mininterval` chosen by where stderr goes (unless given)."""
    kwargs.setdefault("mininterval", 1.0 if sys.stderr.isatty() else 60.0)
    return tqdm(**kwargs)
