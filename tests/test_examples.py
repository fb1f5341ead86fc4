"""The examples run (at a small size) and print what their docstrings promise."""

import runpy
from pathlib import Path

import numpy as np

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_two_blocks_example(capsys):
    ns = runpy.run_path(str(EXAMPLES / "two_blocks.py"))
    results = ns["main"](8)
    out = capsys.readouterr().out
    for condition in ("gamma3", "sigma1", "sigma2"):
        assert f"condition {condition}" in out
    assert out.count("active set:") == 3 and "FAILED" not in out
    # the total contact force agrees between the three conditions to within a few per cent
    totals = np.array([r.contact.force.sum() for r in results.values()])
    assert np.ptp(totals) < 0.05 * totals.mean()
