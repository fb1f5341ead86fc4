"""The README's quickstart, and the P2 tutorial's example of several pairs, run as written
(every other snippet of the pages: tests/test_docs_snippets.py)."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"
P2_TUTORIAL = README.parent / "docs" / "tutorials" / "p2.md"


def test_quickstart_runs(capsys):
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    ns = {}
    exec(compile(code, str(README), "exec"), ns)  # our own documentation, not user input
    sol = ns["sol"]
    assert sol.ok and sol.u[0].shape == (17 * 9, 2) and "equilibrium" in capsys.readouterr().out


def test_p2_pairs_example_runs():
    """The P2 example of several pairs (a punch, a base, a rigid floor) runs as written and passes its checks."""
    import numpy as np

    import cvxcontact as cc

    blocks = re.findall(r"```python\n(.*?)```", P2_TUTORIAL.read_text(), re.S)
    code = next(b for b in blocks if "cc.Rigid.plane" in b and "degree=2" in b)
    ns = {"cc": cc}
    exec(compile(code, str(P2_TUTORIAL), "exec"), ns)  # our own documentation, not user input
    sol = ns["sol"]
    # the snippet passes tol=1e-5: complementarity measured 2.5e-7 .. 8.3e-7 (clarabel 0.9.0, 0.10.0, 0.11.1), 1.18e-6
    # on another machine, against the default tol 1e-6
    assert sol.ok and sol.degree == 2 and len(sol.contacts) == 2
    assert np.all(np.isfinite(sol.contacts[1].lam)) and sol.obstacles[0].force is not None


def test_3d_example_runs():
    """The README's 3D snippet runs as written: the sphere's force is balanced by the contact (force control),
    the open-circuit electrode reads a negative potential under compression, and the checks pass."""
    import numpy as np

    code = next(b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "cc.cylinder" in b)
    ns = {}
    exec(compile(code, str(README), "exec"), ns)  # our own documentation, not user input
    sol = ns["sol3"]
    assert sol.ok and sol.u[0].shape[1] == 3
    # the contact force on the sphere balances its prescribed 400 N (measured to 3e-14 relative)
    assert np.allclose(sol.obstacles[0].force, (0.0, 0.0, -400.0), rtol=0, atol=1e-9 * 400)
    V = [e.potential for e in sol.electrodes if e.kind == "floating"][0]
    assert V < 0            # direct effect under compression (measured -178 V at n_r = 6)


def _table_after(text, header_start):
    """The body rows (lists of cell strings) of the Markdown table whose header line starts with
    ``header_start``."""
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[i + 2:]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split("|")])
    return rows


def _percent(cell):
    """(value, half a unit of its last digit) of a cell such as "+7.5 %", "-20 %*"."""
    number = cell.replace("%", "").replace("*", "").strip()
    decimals = len(number.split(".")[1]) if "." in number else 0
    return float(number), 0.5 * 10.0 ** -decimals


def test_3d_hertz_table_is_the_studys_csv():
    """Every row of the README's 3D Hertz table is a row of docs/studies/hertz3d/hertz3d.csv (unknowns, and
    the radius, peak pressure and approach errors to the printed digits), and the errors shrink with h in
    each kind of row."""
    import csv

    with open(README.parent / "docs" / "studies" / "hertz3d" / "hertz3d.csv") as fh:
        study = [r for r in csv.DictReader(fh) if r["size_a"] == "10"]
    kinds = {"P1": ("1", "gamma3"), "P2, nodal": ("2", "sigma1"), 'P2, `"gamma3"`': ("2", "gamma3")}
    table = _table_after(README.read_text(), "| elements, condition |")
    assert len(table) == 9
    errors = {}
    for label, n, dofs, a, p0, delta in table:
        kind = next(k for k in sorted(kinds, key=len, reverse=True) if label.startswith(k))
        row = next(r for r in study if (r["degree"], r["condition"]) == kinds[kind] and r["n"] == n)
        assert int(dofs.replace(",", "")) == int(row["dofs"]), label
        for cell, key in ((a, "a_rel_error"), (p0, "p0_rel_error"), (delta, "delta_rel_error")):
            value, half = _percent(cell)
            assert abs(value - 100 * float(row[key])) <= half + 1e-9, (label, n, key)
        errors.setdefault(kind, []).append(abs(float(row["p0_rel_error"])))
    for kind, p0 in errors.items():
        assert p0 == sorted(p0, reverse=True), kind                     # the peak pressure converges with h


def test_3d_benchmark_table_is_the_benchmarks_csv():
    """The README's 3D benchmark rows are rows of benchmarks/results/bench3d.csv: unknowns, default and
    AMG-CG wall seconds, their ratio and the peak memory, to the printed digits."""
    import csv

    with open(README.parent / "benchmarks" / "results" / "bench3d.csv") as fh:
        bench = list(csv.DictReader(fh))
    table = _table_after(README.read_text(), "| scene | unknowns | default |")
    assert len(table) == 4
    names = {"rigid sphere on a block": "sphere", "two elastic boxes": "two_boxes"}
    for scene, unknowns, default, amg, pardiso, ratio, peak in table:
        row = next(r for r in bench if r["scene"] == names[scene]
                   and abs(int(r["unknowns"]) / float(unknowns) - 1) < 0.05)
        cells = [(default, "default_s"), (amg, "amg_s"), (ratio, "ratio_amg"), (peak, "default_peak_gb")]
        if pardiso.strip() != "-":
            cells.append((pardiso, "pardiso_s"))
        else:
            assert row["pardiso_s"] in ("", "nan"), (scene, unknowns)
        for cell, key in cells:
            value, half = _percent(cell.split("(")[0].replace("s", "").replace("GB", ""))
            assert abs(value - float(row[key])) <= half + 1e-9, (scene, unknowns, key)
