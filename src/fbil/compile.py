"""Optional torch.compile of a training step's loss functions, with a fallback to eager.

Inductor fuses the elementwise chains (layer norms, tanh) between the matmuls. Measured on
this project's 2-core CPU machines it does not pay at the `cpu` preset sizes (the same CPU
time per FB update, 34 ms at the maze size, with it and without it: docs/speed.md), so it
is off by default; it is kept for larger models and other hardware. Compilation changes no saved
state: models and checkpoints are the same either way, and a run trained compiled resumes
eagerly (and back). Where compilation is unavailable or fails (no C++ compiler, an
unsupported op), the step says so in one line on stderr and runs eagerly from then on.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

F = TypeVar("F", bound=Callable[..., Any])


class _Compiled:
    def __init__(self, fn: Callable[..., Any]) -> None:
        import torch  # here, so that the CLI reads this module's constants without torch

        self.eager = fn
        self.fast: Callable[..., Any] | None = torch.compile(fn, dynamic=False)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        if self.fast is None:
            return self.eager(*args, **kwargs)
        try:
            with warnings.catch_warnings():  # inductor's own deprecation notices
                warnings.simplefilter("ignore", FutureWarning)
                return self.fast(*args, **kwargs)
        except Exception as exc:  # any compiler failure falls back to eager
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:200]
            name = getattr(self.eager, "__name__", "step")
            print(
                f"note: torch.compile of {name} failed ({first}); running it eagerly "
                "(same results, slower)",
                file=sys.stderr,
            )
            self.fast = None
            return self.eager(*args, **kwargs)


def compiled(fn: F) -> F:
    """`fn` compiled by torch.compile, falling back to `fn` itself on any failure."""
    return _Compiled(fn)  # type: ignore[return-value]
