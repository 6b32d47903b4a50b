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


def test_a_log_file_gets_whole_lines_and_postfixes_wait_for_the_interval(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Redirected stderr: no carriage returns, and 100 updates with a postfix inside one
    interval render only the opening and closing lines (a postfix used to force a render
    every time, filling nohup logs with one endless line)."""
    log = io.StringIO()
    monkeypatch.setattr(sys, "stderr", log)
    bar = progress_bar(total=100, desc="pretrain")
    for i in range(100):
        bar.set_postfix(loss=f"{i}")
        bar.update(1)
    bar.close()
    assert bar.maxinterval == 60.0  # tqdm's monitor thread would redraw every 10 s
    text = log.getvalue()
    assert "\r" not in text
    lines = [line for line in text.splitlines() if line.strip()]
    assert len(lines) == 2, lines
    assert lines[0].startswith("pretrain:   0%") and "100/100" in lines[1] and "loss=99" in lines[1]
