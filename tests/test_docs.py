"""The README and docs/: the site builds with warnings as errors, every relative link resolves (files and
#anchors), the blocks marked runnable run as typed, and the README stays short.

A block is runnable when the line before its opening fence is `<!-- runnable -->`: a `sh` block runs in bash
(`set -e`) in a fresh folder, a `python` block in the test's interpreter there; both with this checkout's `src`
first on PYTHONPATH and this interpreter's `bin` first on PATH, as a user's activated venv has it.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
PAGES = [README, *sorted(DOCS.rglob("*.md"))]
RUNNABLE = "<!-- runnable -->"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```\n", re.S | re.M)
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
README_MAX_LINES = 250


def _name(page: Path) -> str:
    return str(page.relative_to(ROOT))


def _prose(text: str) -> str:
    """The page without its fenced blocks and inline code, where a `[x](y)` is not a link."""
    text = FENCE.sub("", text)
    return re.sub(r"`[^`\n]*`", "", text)


def _slugs(text: str) -> set[str]:
    """The #anchors of a page's headings: Python-Markdown's toc slugs (the site) and GitHub's (the README)."""
    slugs = set()
    for title in re.findall(r"^#{1,6} (.+)$", FENCE.sub("", text), re.M):
        title = re.sub(r"`([^`]*)`", r"\1", title).strip()
        ascii_title = unicodedata.normalize("NFKD", title).encode("ascii", "ignore").decode()
        slugs.add(re.sub(r"[-\s]+", "-", re.sub(r"[^\w\s-]", "", ascii_title).strip().lower()))
        slugs.add(re.sub(r"[^\w\- ]", "", title.lower()).replace(" ", "-"))
    return slugs


def _runnable_blocks() -> list[tuple[str, str, str]]:
    blocks = []
    for page in PAGES:
        text = page.read_text()
        for match in FENCE.finditer(text):
            before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1]
            if before.strip() == RUNNABLE:
                line = text[: match.start()].count("\n") + 1
                blocks.append((f"{_name(page)}:{line}", match.group(1), match.group(2)))
    return blocks


def test_the_readme_stays_short() -> None:
    lines = README.read_text().count("\n")
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines (at most {README_MAX_LINES}): move detail to docs/"


def test_every_relative_link_resolves() -> None:
    broken = []
    for page in PAGES:
        for target in LINK.findall(_prose(page.read_text())):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto: ...
                continue
            path, _, anchor = target.partition("#")
            file = (page.parent / path).resolve() if path else page
            if not file.exists():
                broken.append(f"{_name(page)}: {target} (no file {path})")
            elif anchor and file.suffix == ".md" and anchor not in _slugs(file.read_text()):
                broken.append(f"{_name(page)}: {target} (no heading #{anchor} in {_name(file)})")
    assert not broken, "\n".join(broken)


def test_the_link_checker_sees_a_broken_link_and_anchor() -> None:
    text = "[a](docs/run.md#no-such-heading) [b](docs/nowhere.md) [c](run.md#a-fleet)"
    assert LINK.findall(_prose(text)) == [
        "docs/run.md#no-such-heading",
        "docs/nowhere.md",
        "run.md#a-fleet",
    ]
    assert "a-fleet" in _slugs((DOCS / "run.md").read_text())
    assert "no-such-heading" not in _slugs((DOCS / "run.md").read_text())


def test_there_are_runnable_blocks_in_the_readme_and_the_docs() -> None:
    where = {name.split(":")[0] for name, _, _ in _runnable_blocks()}
    assert "README.md" in where and len(where) >= 4, where
    assert {lang for _, lang, _ in _runnable_blocks()} == {"sh", "python"}


@pytest.mark.parametrize(("where", "lang", "code"), _runnable_blocks(), ids=[b[0] for b in _runnable_blocks()])
def test_runnable_block_runs(where: str, lang: str, code: str, tmp_path: Path) -> None:
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(ROOT / "src"), env.get("PYTHONPATH"))))
    env["PATH"] = os.pathsep.join((str(Path(sys.executable).parent), env["PATH"]))
    command = ["bash", "-e", "-o", "pipefail", "-c", code] if lang == "sh" else [sys.executable, "-c", code]
    assert lang in ("sh", "python"), f"{where}: a runnable block must be sh or python, not {lang!r}"
    (tmp_path / "examples").symlink_to(ROOT / "examples")  # commands name examples/ as from the clone's root
    result = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, f"{where} failed ({result.returncode}):\n{code}\n{result.stdout}\n{result.stderr}"


@pytest.mark.skipif(
    not all(importlib.util.find_spec(m) for m in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers")),
    reason='the docs tools are not installed (pip install -e ".[docs]")',
)
def test_the_docs_site_builds_with_warnings_as_errors(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        env=dict(os.environ, NO_MKDOCS_2_WARNING="1"),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert "WARNING" not in result.stderr, result.stderr
    for page in ("index.html", "ros2/index.html", "api/simulator/index.html"):
        assert (tmp_path / "site" / page).exists(), page
    api = (tmp_path / "site" / "api" / "simulator" / "index.html").read_text()
    assert "run_until" in api  # the API pages come from the docstrings
