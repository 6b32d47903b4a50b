"""Optional torch.compile of a training step's loss functions, with a fallback to eager.

At CPU sizes an update is bound by many small kernels (layer norms, tanh, elementwise
chains, Python), not by its matmuls; inductor fuses them. Compilation changes no saved
state: models and checkpoints are the same either way, and a run trained compiled resumes
eagerly (and back). Where compilation is unavailable or fails (no C++ compiler, an
unsupported op), the step says so in one line on stderr and runs eagerly from then on.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Callable
from typing import Any, Literal, TypeVar

from fbil.errors import FbilError

F = TypeVar("F", bound=Callable[..., Any])
CompileMode = Literal["auto", "on", "off"]
COMPILE_MODES = ("auto", "on", "off")
# Compiling costs ~0.5-1.5 min on 2 cores; "auto" compiles runs long enough to repay it.
AUTO_MIN_STEPS = 5_000


def use_compile(mode: str, steps: int) -> bool:
    """Whether a run of `steps` updates compiles: on, off, or auto (>= AUTO_MIN_STEPS)."""
    if mode not in COMPILE_MODES:
        raise FbilError(f"unknown compile mode {mode!r}; valid: {', '.join(COMPILE_MODES)}")
    return mode == "on" or (mode == "auto" and steps >= AUTO_MIN_STEPS)


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
