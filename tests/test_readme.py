"""The README is the front door: its examples must run and its paths must exist.

Every ```python block of README.md (and of the pages in docs/) runs in a subprocess, with
its working directory a temporary copy of the repository's files (what a fresh clone
has), so an example that needs an uncommitted file, or an API that changed, fails here
with the block's text. The README must stay within 250 lines and name only files and folders that
are in the repository; markdown links in README.md and docs/ must point at existing files
and headings.

"In the repository" means known to git and not ignored: tracked files plus new files not
yet committed (`git ls-files --cached --others --exclude-standard`), so that outputs of
local runs (datasets/, runs/, both gitignored) never count.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_LINES = 250
TEST_COMMAND = 'pip install -e ".[dev]" && ruff check . && ruff format --check . && mypy && pytest'
DEMO_COMMAND = "pip install -e . && fbil demo"
# Paths mentioned anywhere in the README (prose, inline code, code blocks) with these
# leading folders must exist; datasets/ and runs/ are what the commands write.
PATH_PREFIXES = ("artifacts", "docs", "scripts", "benchmarks", "tests", "src", ".ci")
PATH_RE = re.compile(
    r"(?<![\w./-])(?:" + "|".join(re.escape(p) for p in PATH_PREFIXES) + r")/[^\s`'\"(),;|\[\]]*"
)
LINK_RE = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
FENCE_RE = re.compile(r"^```.*?^```[ \t]*$", re.M | re.S)
PYTHON_BLOCK_RE = re.compile(r"^```python[ \t]*\n(.*?)^```[ \t]*$", re.M | re.S)


def _repo_files() -> list[str]:
    try:
        out = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: the README checks need `git ls-files`")
    return [line for line in out.splitlines() if line and (ROOT / line).is_file()]


@pytest.fixture(scope="module")
def repo_files() -> list[str]:
    return _repo_files()


@pytest.fixture(scope="module")
def repo_paths(repo_files: list[str]) -> set[str]:
    """Every file and every folder above one."""
    paths = set(repo_files)
    for f in repo_files:
        parts = f.split("/")
        paths.update("/".join(parts[:i]) for i in range(1, len(parts)))
    return paths


@pytest.fixture(scope="module")
def fresh_copy(repo_files: list[str], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the repository's files, as a fresh clone would have them."""
    root = tmp_path_factory.mktemp("clone")
    for f in repo_files:
        dest = root / f
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / f, dest)
    return root


def _readme() -> str:
    return README.read_text(encoding="utf-8")


def _python_blocks() -> list[tuple[str, str]]:
    """(where, code) of every python block: README.md first, then docs/*.md."""
    pages = [README, *sorted((ROOT / "docs").glob("*.md"))]
    blocks = []
    for page in pages:
        found = PYTHON_BLOCK_RE.findall(page.read_text(encoding="utf-8"))
        name = page.relative_to(ROOT).as_posix()
        blocks += [(f"{name}, block {i + 1}", code) for i, code in enumerate(found)]
    return blocks


def _exists(path: str, repo_paths: set[str]) -> bool:
    """A file or folder of the repository; <placeholder> and * match one path part."""
    path = path.rstrip("/")
    if "<" not in path and "*" not in path:
        return path in repo_paths
    pattern = re.escape(path).replace(r"\*", "[^/]+")
    pattern = re.sub(r"<[^>]*>", "[^/]+", pattern.replace(r"\<", "<").replace(r"\>", ">"))
    return any(re.fullmatch(pattern, p) for p in repo_paths)


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _anchors(markdown: str) -> set[str]:
    body = FENCE_RE.sub("", markdown)
    return {_slug(m) for m in re.findall(r"^#{1,6}[ \t]+(.+?)[ \t]*#*[ \t]*$", body, re.M)}


def test_readme_is_short() -> None:
    lines = len(_readme().splitlines())
    assert lines <= MAX_LINES, f"README.md has {lines} lines; keep it within {MAX_LINES}"


def test_readme_keeps_the_set_up_commands() -> None:
    lines = _readme().splitlines()
    assert TEST_COMMAND in lines, "README.md lost the test command that .ci/run greps for"
    assert DEMO_COMMAND in lines, "README.md lost the demo command"


def test_readme_paths_exist(repo_paths: set[str]) -> None:
    text = _readme()
    mentioned = {m.group(0).rstrip(".:") for m in PATH_RE.finditer(text)}
    mentioned |= {
        target for target in LINK_RE.findall(text) if not re.match(r"[a-z][a-z+.-]*:", target)
    }
    missing = []
    for raw in sorted(mentioned):
        path = raw.split("#", 1)[0]
        if path and not _exists(os.path.normpath(path), repo_paths):
            missing.append(raw)
    assert not missing, "README.md names paths that are not in the repository: " + ", ".join(
        missing
    )


@pytest.mark.parametrize("doc", ["README.md", "docs"])
def test_markdown_links_resolve(doc: str, repo_paths: set[str]) -> None:
    pages = [ROOT / doc] if doc.endswith(".md") else sorted((ROOT / doc).glob("*.md"))
    broken = []
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for target in LINK_RE.findall(FENCE_RE.sub("", text)):
            if re.match(r"[a-z][a-z+.-]*:", target):  # http:, https:, mailto:
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            try:
                rel = dest.relative_to(ROOT).as_posix()
            except ValueError:
                broken.append(f"{page.name}: {target} (outside the repository)")
                continue
            if path and not _exists(rel, repo_paths):
                broken.append(f"{page.name}: {target} (no such file)")
            elif (
                anchor
                and dest.suffix == ".md"
                and anchor not in _anchors(dest.read_text(encoding="utf-8"))
            ):
                broken.append(f"{page.name}: {target} (no such heading)")
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_readme_has_python_examples() -> None:
    assert PYTHON_BLOCK_RE.findall(_readme()), "README.md has no ```python block to run"


BLOCKS = _python_blocks()


@pytest.mark.parametrize("where,block", BLOCKS, ids=[where for where, _ in BLOCKS])
def test_python_block_runs(where: str, block: str, fresh_copy: Path) -> None:
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    env.setdefault("OMP_NUM_THREADS", "1")
    result = subprocess.run(
        [sys.executable, "-c", block],
        cwd=fresh_copy,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, (
        f"{where} failed (exit {result.returncode}):\n"
        f"{block}\n--- stderr ---\n{result.stderr[-4000:]}"
    )
