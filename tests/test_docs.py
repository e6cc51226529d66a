"""Every fenced Python block of README.md and docs/*.md runs, so a snippet cannot rot.

Each block runs in a fresh namespace, in a temporary directory holding links to the
repository's ``scenarios`` and ``docs`` (the paths the docs use), with warnings shown but not
errors. A marker on the line before a block (an HTML comment, invisible on the page) changes
that:

* ``<!-- doc-test: continue -->`` runs the block in the namespace of the page's previous block
  (a snippet that goes on from the one above it);
* ``<!-- doc-test: slow -->`` marks it ``slow`` (``pytest -m slow``);
* ``<!-- doc-test: script -->`` runs it as a script of its own (``python block.py`` in the
  directory: ``__name__ == "__main__"``, worker processes that import it);
* ``<!-- doc-test: skip REASON -->`` does not run it (say why: e.g. it needs a Dask cluster);

markers combine (``<!-- doc-test: continue slow -->``). Blocks of other languages (bash, toml,
text) are not run.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_FENCE = re.compile(r"^```(\w*)\s*$")
_MARK = re.compile(r"^<!--\s*doc-test:\s*(.*?)\s*-->\s*$")


def blocks(page: Path) -> list[dict]:
    """The fenced Python blocks of a page: line, code, markers."""
    out = []
    lines = page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m or not m.group(1):
            i += 1
            continue
        lang, start = m.group(1), i
        j = i + 1
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        if lang == "python":
            mark = _MARK.match(lines[start - 1]) if start > 0 else None
            words = mark.group(1).split() if mark else []
            out.append(
                {
                    "line": start + 1,
                    "code": "\n".join(lines[start + 1 : j]) + "\n",
                    "continue": "continue" in words,
                    "slow": "slow" in words,
                    "script": "script" in words,
                    "skip": " ".join(words[words.index("skip") + 1 :]) if "skip" in words else None,
                }
            )
        i = j + 1
    return out


def _cases():
    for page in PAGES:
        for k, b in enumerate(blocks(page)):
            marks = [pytest.mark.slow] if b["slow"] else []
            rel = page.relative_to(ROOT)
            yield pytest.param(page, k, id=f"{rel}:{b['line']}", marks=marks)


@pytest.fixture
def workdir(tmp_path):
    for name in ("scenarios", "docs"):
        (tmp_path / name).symlink_to(ROOT / name)
    old = os.getcwd()
    os.chdir(tmp_path)
    try:
        yield tmp_path
    finally:
        os.chdir(old)


@pytest.mark.parametrize(("page", "index"), list(_cases()))
def test_doc_block_runs(page, index, workdir):
    """The block at that line of the page runs (with the blocks it continues)."""
    import matplotlib

    matplotlib.use("Agg")
    page_blocks = blocks(page)
    b = page_blocks[index]
    if b["skip"] is not None:
        pytest.skip(f"doc-test: skip {b['skip']}")
    if b["continue"]:
        # run the chain of blocks this one continues (each test is independent under xdist)
        first = index
        while first > 0 and page_blocks[first]["continue"]:
            first -= 1
        chain = range(first, index + 1)
    else:
        chain = range(index, index + 1)
    # a real file: numba caches what a snippet compiles next to the file it comes from
    source = workdir / f"doc_{page.stem}_{b['line']}.py"
    source.write_text("".join(page_blocks[k]["code"] for k in chain), encoding="utf-8")
    if b["script"]:
        import subprocess
        import sys

        r = subprocess.run([sys.executable, source.name], cwd=workdir, capture_output=True,
                           text=True, timeout=600)  # fmt: skip
        assert r.returncode == 0, r.stderr[-3000:]
        return
    ns: dict = {"__name__": source.stem, "__file__": str(source)}
    code = compile(source.read_text(encoding="utf-8"), str(source), "exec")
    with warnings.catch_warnings():
        # the paper's printed state (6 digits) is projected onto the constraints, as the pages
        # say; other warnings follow the suite's filters (pyproject.toml)
        warnings.filterwarnings("ignore", "initial state projected", UserWarning)
        exec(code, ns)  # the docs' own examples
    import matplotlib.pyplot as plt

    plt.close("all")


def test_every_python_block_is_collected():
    """The parser finds the blocks a reader sees (a block whose fence is not ``python`` is not
    one), and a continuation marker never starts a page."""
    total = 0
    for page in PAGES:
        bs = blocks(page)
        total += len(bs)
        text = page.read_text(encoding="utf-8")
        assert len(bs) == text.count("```python\n"), page
        if bs:
            assert not bs[0]["continue"], f"{page.name}: the first block cannot continue another"
    assert total >= 20
