"""The import contracts of docs/architecture.md hold (import-linter; pyproject.toml)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def test_import_contracts_are_kept():
    exe = shutil.which("lint-imports") or str(Path(sys.executable).parent / "lint-imports")
    if not Path(exe).exists():
        pytest.fail("lint-imports not found: install the test extra (pip install -e '.[test]')")
    out = subprocess.run([exe, "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]
    assert "0 broken" in out.stdout


def test_no_library_module_longer_than_800_lines_unless_it_says_why():
    long = []
    for path in sorted(
        [*ROOT.joinpath("attitude").rglob("*.py"), *ROOT.joinpath("orbit").rglob("*.py")]
    ):
        lines = path.read_text(encoding="utf-8").splitlines()
        if len(lines) > 800 and "One concept" not in "\n".join(lines[:30]):
            long.append(f"{path.relative_to(ROOT)}: {len(lines)} lines")
    assert not long, long
