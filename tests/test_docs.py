"""Every code block of the documentation runs (the docs convention).

- ```` ```python ```` blocks of a page run in order as one script sharing one namespace, in a
  fresh temporary folder;
- ```` ```bash ```` blocks run line by line in that folder (``\\`` continues a line), with the
  ``odorloc`` and ``python`` of this test's environment first on the ``PATH``;
- a block right after the line ``<!-- docs-test: skip (REASON) -->`` is not run: it is reported
  as skipped with its reason (only for commands that take minutes);
- ```` ```text ````, ```` ```yaml ```` and ```` ```console ```` blocks (shown output) are not run;
  a block without a language, or of another one, is an error (it would never be checked).

A page's blocks run in document order in one subprocess, so a bash line may write a file the
next python block reads. A line ``--8<-- "path"`` in a block includes that file (a path from the
root of the source, as the site's snippets extension does), and the page's own folder is on the
``PYTHONPATH``: a guide shows a module kept beside it (``docs/how-to/my_searchers.py``) and
imports it. Relative links and images between pages must exist.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
RUN = ("python", "bash")
SHOWN = ("text", "yaml", "console")
SKIP = re.compile(r"^<!-- docs-test: skip \((?P<reason>[^)]*)\) -->$")
FENCE = re.compile(r"^(?P<indent>\s*)(?P<ticks>```+)(?P<lang>[\w+-]*)\s*$")
SNIPPET = re.compile(r'^--8<-- "(?P<path>[^"]+)"$', re.M)
#: A hang guard for one page (its blocks should take seconds; the machine may be loaded).
TIMEOUT = 900


@dataclass
class Block:
    page: str
    line: int
    lang: str
    code: str
    skip: str | None


def pages() -> list[Path]:
    return sorted(DOCS.rglob("*.md"))


def blocks(path: Path) -> list[Block]:
    """The fenced code blocks of a page, with the skip marker on the line before each."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out: list[Block] = []
    i = 0
    rel = str(path.relative_to(DOCS))
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, ticks = m.group("indent"), m.group("ticks")
        prev = next((x.strip() for x in reversed(lines[:i]) if x.strip()), "")
        skip = SKIP.match(prev)
        start = i + 1
        j = start
        while j < len(lines) and lines[j].strip() != ticks:
            j += 1
        body = "\n".join(x[len(indent) :] if x.startswith(indent) else x for x in lines[start:j])
        body = SNIPPET.sub(lambda s: (ROOT / s.group("path")).read_text(encoding="utf-8"), body)
        out.append(Block(rel, i + 1, m.group("lang"), body, skip.group("reason") if skip else None))
        i = j + 1
    return out


ALL = [b for p in pages() for b in blocks(p)]
RUNNABLE_PAGES = sorted({b.page for b in ALL if b.lang in RUN and b.skip is None})
SKIPPED = [b for b in ALL if b.skip is not None]


def test_the_docs_have_runnable_blocks() -> None:
    assert len(pages()) >= 20
    assert len(RUNNABLE_PAGES) >= 10


@pytest.mark.parametrize("block", ALL, ids=[f"{b.page}:{b.line}" for b in ALL])
def test_every_block_has_a_known_language(block: Block) -> None:
    assert block.lang in RUN + SHOWN, (
        f"{block.page}:{block.line}: a ```{block.lang or '(none)'} block is neither run nor "
        f"shown output; use one of {', '.join(RUN + SHOWN)}"
    )
    if block.skip is not None:
        assert block.skip.strip(), f"{block.page}:{block.line}: a skip needs its REASON"
        assert block.lang in RUN, f"{block.page}:{block.line}: only runnable blocks are skipped"


def test_skip_markers_are_well_formed() -> None:
    for path in pages():
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "docs-test:" in line:
                assert SKIP.match(line.strip()), f"{path.relative_to(DOCS)}:{k}: {line.strip()}"


@pytest.mark.parametrize("block", SKIPPED, ids=[f"{b.page}:{b.line}" for b in SKIPPED])
def test_skipped_block(block: Block) -> None:
    pytest.skip(f"{block.page}:{block.line} not run: {block.skip}")


_DRIVER = textwrap.dedent(
    """
    import json, os, subprocess, sys, traceback, types
    steps = json.load(open(sys.argv[1]))
    # one module for the page's blocks, so that classes defined there resolve their names
    # (pydantic reads a class's annotations in the module the class names)
    page = types.ModuleType("docs_page")
    sys.modules["docs_page"] = page
    namespace = page.__dict__
    for step in steps:
        where = f"{step['page']}:{step['line']}"
        if step["lang"] == "python":
            try:
                exec(compile(step["code"], where, "exec"), namespace)
            except BaseException:
                print(f"python block at {where} failed:", file=sys.stderr)
                traceback.print_exc()
                sys.exit(1)
            continue
        for cmd in step["commands"]:
            r = subprocess.run(["bash", "-euo", "pipefail", "-c", cmd])
            if r.returncode != 0:
                print(f"bash line at {where} failed ({r.returncode}): {cmd}", file=sys.stderr)
                sys.exit(1)
    """
)


def bash_commands(code: str) -> list[str]:
    """A bash block's commands: one per line, ``\\`` joining lines, comments left out."""
    out, cur = [], ""
    for raw in code.splitlines():
        line = raw.rstrip()
        if not cur and (not line.strip() or line.lstrip().startswith("#")):
            continue
        if line.endswith("\\"):
            cur += line[:-1] + " "
            continue
        out.append(cur + line)
        cur = ""
    if cur.strip():
        out.append(cur)
    return out


@pytest.mark.parametrize("page", RUNNABLE_PAGES)
def test_page_blocks_run(page: str, tmp_path: Path) -> None:
    steps = []
    for b in blocks(DOCS / page):
        if b.lang not in RUN or b.skip is not None:
            continue
        step = {"page": b.page, "line": b.line, "lang": b.lang, "code": b.code}
        if b.lang == "bash":
            step["commands"] = bash_commands(b.code)
        steps.append(step)
    (tmp_path / ".steps.json").write_text(json.dumps(steps))
    (tmp_path / ".driver.py").write_text(_DRIVER)
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    folder = str((DOCS / page).parent)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (folder, env.get("PYTHONPATH")) if p)
    env.update(MPLBACKEND="Agg", COLUMNS="80", PYTHONHASHSEED="0")
    r = subprocess.run(
        [sys.executable, ".driver.py", ".steps.json"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert r.returncode == 0, f"{page}:\n{r.stderr[-4000:]}\n{r.stdout[-2000:]}"


_LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


@pytest.mark.parametrize("path", pages(), ids=lambda p: str(p.relative_to(DOCS)))
def test_relative_links_and_images_exist(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    # code blocks and spans hold no links
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    text = re.sub(r"`[^`\n]*`", "", text)
    for target in _LINK.findall(text):
        if re.match(r"^[a-z]+:", target) or target.startswith("#"):
            continue
        file = target.split("#", 1)[0]
        assert (path.parent / file).resolve().exists(), f"{path.relative_to(DOCS)}: {target}"
        if file.endswith(".md"):
            assert (path.parent / file).resolve().is_relative_to(DOCS), target
