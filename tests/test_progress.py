"""Progress bars refresh at most once a minute when stderr is not a terminal (log files),
every second on a terminal, and keep an explicit choice."""

import io
import sys

import pytest

from fbil.progress import progress_bar


def _interval(**kwargs: float) -> float:
    bar = progress_bar(total=3, file=io.StringIO(), **kwargs)
    bar.close()
    return float(bar.mininterval)


def test_sparse_in_log_files_and_live_on_terminals(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert _interval() == 60.0
    assert _interval(mininterval=5.0) == 5.0

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr(sys, "stderr", Terminal())
    assert _interval() == 1.0
