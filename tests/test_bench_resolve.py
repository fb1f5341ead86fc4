"""The re-solve benchmark's part (benchmarks/bench_resolve.py): plumbing and the answer check only.

No timing is asserted here: the times of a shared machine are not a pass/fail criterion.
"""

from pathlib import Path

import numpy as np
from conftest import benchmark

import cvxcontact

PACKAGE_ROOT = Path(cvxcontact.__file__).resolve().parents[1]
"""The folder the suite's package is imported from (the source tree, or site-packages when installed: the part
checks it imports the package from the folder it is given, and the suite's is already imported)."""


def test_a_resolve_part_checks_its_answer_against_a_from_scratch_solve(tmp_path):
    """One part at nx = 6: the re-solve's answer saved, its agreement with cc.solve of the new scene reported
    (measured 0.0), the package imported from the tree asked for."""
    out = tmp_path / "after.npz"
    r = benchmark("bench_resolve").resolve_part(str(PACKAGE_ROOT), 6, str(out))
    assert r["ok"] and Path(r["package"]) == PACKAGE_ROOT / "cvxcontact"
    assert set(r["direct"]) == {"u", "phi", "force"} and max(r["direct"].values()) < 1e-9
    saved = np.load(out)
    assert saved["u"].size + saved["phi"].size == r["dofs"] and np.abs(saved["force"]).max() > 0
    assert r["resolve_cpu"] > 0 and r["first_cpu"] > 0 and "estimate" in r["timings"]
