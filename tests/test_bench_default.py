"""The before/after harness of benchmarks/bench_default.py (``--baseline``): plumbing and the answer check only.

No timing is asserted here: the times of a shared machine are not a pass/fail criterion.
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import benchmark

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "benchmarks" / "bench_default.py"


def bench():
    return benchmark("bench_default")


def test_sizes_are_nx_or_unknowns():
    """A size >= 1e4 is a count of unknowns; the issue's sizes map to the scenes of the benchmark table
    (two_blocks(280) P1: 156,632 unknowns, two_blocks(560): 625,296; benchmarks/results/default.csv)."""
    size = bench().size
    assert [size(t) for t in ("40", "280", "1.6e5", "6.3e5", "2.5e6", "4e4", "1e4")] == [40, 280, 280, 560, 1120,
                                                                                          140, 70]
    with pytest.raises(Exception):
        size("1")


@pytest.mark.skipif(shutil.which("git") is None or not (REPO / ".git").exists(), reason="needs a git checkout")
def test_a_revision_is_extracted_as_committed(tmp_path):
    b = bench()
    root, label, commit = b.materialise("HEAD", REPO, tmp_path)
    committed = subprocess.run(["git", "-C", str(REPO), "show", "HEAD:cvxcontact/__init__.py"], capture_output=True,
                               text=True, check=True).stdout
    assert (root / "cvxcontact" / "__init__.py").read_text() == committed
    assert commit and label.startswith(commit[:7])
    with pytest.raises(SystemExit, match="neither a git revision"):
        b.materialise("no-such-revision-xyz", REPO, tmp_path)


def test_a_different_answer_is_caught(tmp_path):
    """A baseline whose scene carries a 10 % larger body force solves a different problem: the run compares
    the answers, says DIFFERENT and exits with status 1 (and writes its report)."""
    base = tmp_path / "base"
    shutil.copytree(REPO / "cvxcontact", base / "cvxcontact", ignore=shutil.ignore_patterns("__pycache__"))
    demo = base / "cvxcontact" / "apps" / "demo.py"
    text = demo.read_text()
    assert "body_force=(0.0, -2e9 * s)" in text
    demo.write_text(text.replace("body_force=(0.0, -2e9 * s)", "body_force=(0.0, -2.2e9 * s)"))
    report = tmp_path / "report.md"
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    out = subprocess.run([sys.executable, str(SCRIPT), "--baseline", str(base), "--sizes", "6", "--repeats", "1",
                          "--report", str(report)], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 1, out.stdout + out.stderr
    assert "DIFFERENT" in out.stdout
    assert str(base / "cvxcontact") in out.stdout                 # each side imported its own package
    assert str(REPO / "cvxcontact") in out.stdout
    table = report.read_text()
    assert "| two_blocks(6) P1 |" in table and "| no |" in table
    row = next(line for line in table.splitlines() if line.startswith("| two_blocks(6) P1 | ") and "e" in line
               and "| no |" in line)
    u_diff = float(row.split("|")[2])
    assert 1e-3 < u_diff < 1.0                          # measured 0.09 (u is not the body force's alone)
