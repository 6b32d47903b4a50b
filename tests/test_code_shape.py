"""Code shape (issue #19): every function and method in src/fbil spans at most 60 lines,
from its `def` line to its last line, so that long functions cannot come back."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "fbil"
MAX_LINES = 60


def long_functions(root: Path, limit: int) -> list[str]:
    """`file:line:name (N lines)` for each function or method under `root` longer than
    `limit` lines, nested ones included."""
    found = []
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                span = (node.end_lineno or node.lineno) - node.lineno + 1
                if span > limit:
                    where = path.relative_to(root.parents[1])
                    found.append(f"{where}:{node.lineno}:{node.name} ({span} lines)")
    return found


def test_every_function_in_src_spans_at_most_60_lines() -> None:
    assert SRC.is_dir()
    offenders = long_functions(SRC, MAX_LINES)
    assert not offenders, f"functions over {MAX_LINES} lines (split them): " + ", ".join(offenders)


def test_the_check_reports_file_line_and_name(tmp_path: Path) -> None:
    pkg = tmp_path / "src" / "pkg"
    pkg.mkdir(parents=True)
    body = "\n".join(f"        x{i} = {i}" for i in range(5))
    (pkg / "m.py").write_text(
        f"def short():\n    pass\n\n\nclass C:\n    def long(self):\n{body}\n"
    )
    assert long_functions(pkg, 6) == []
    assert long_functions(pkg, 5) == ["src/pkg/m.py:6:long (6 lines)"]
