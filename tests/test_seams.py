"""The element seam stays closed (docs/architecture.md, "A new space"): above fem/, geometry/ and discrete/ no code
asks "is this P2?" of a node set (``nodes is None``) and no code compares the degree, except the few sites listed
here; a new element then needs no edit there. The patterns are those of the counting greps in the docs."""

import re
from pathlib import Path

import cvxcontact

ROOT = Path(cvxcontact.__file__).parent
INSIDE = ("fem", "geometry", "discrete")
"""Where the element is decided: the spaces, the meshes and their node sets, the discrete problem."""
NODES = re.compile(r"nodes is None|nodes is not None")
DEGREE = re.compile(r"degree *(==|!=|>=|<=|>|<) *[0-9]|[0-9] *(==|!=) *degree|degree in \(")
DEGREE_SITES = {
    "backends/__init__.py": 1,         # the registry: the condensed backend's sparse fallback, P1 only (its entry)
    "apps/studies/stability.py": 1,    # the inf-sup study's own P1 and P2 multiplier machinery
    "apps/studies/hertz3d.py": 2,      # the 3D Hertz study's P1 (force over lumped area) and P2 (Riesz) readings
}
"""The degree comparisons left outside fem/, geometry/ and discrete/ (path: count), docs/architecture.md."""


def sites(pattern, files):
    """{package-relative path: [line numbers]} of the lines of ``files`` ({path: source}) matching ``pattern``,
    outside :data:`INSIDE`."""
    out = {}
    for path, source in files.items():
        if path.split("/")[0] in INSIDE:
            continue
        lines = [i for i, line in enumerate(source.splitlines(), 1) if pattern.search(line)]
        if lines:
            out[path] = lines
    return out


def package():
    return {p.relative_to(ROOT).as_posix(): p.read_text() for p in sorted(ROOT.rglob("*.py"))}


def test_no_node_set_asks_for_the_degree():
    found = sites(NODES, package())
    assert not found, (f"'nodes is None' outside {INSIDE}: {found}; ask the space (space.node_set, space.trace, "
                       "mesh.node_set) instead")


def test_degree_comparisons_only_where_listed():
    found = {path: len(lines) for path, lines in sites(DEGREE, package()).items()}
    extra = {p: (n, DEGREE_SITES.get(p, 0)) for p, n in found.items() if n > DEGREE_SITES.get(p, 0)}
    assert not extra, (f"degree comparisons outside {INSIDE} beyond those listed (path: (found, allowed)): {extra}; "
                       "ask the space (its trace, label, order, node_set, shape_values) instead")
    assert sum(n for p, n in DEGREE_SITES.items() if p != "backends/__init__.py") <= 3    # issue 31, "Done when"


def test_the_checks_see_a_planted_site():
    """A planted "is this P2?" and a planted degree comparison in a module above fem/ are found; the same lines
    inside fem/ are not (the checks run on the package's text, so they fail on these plants)."""
    files = package()
    planted = dict(files)
    planted["io/output.py"] = files["io/output.py"] + "\nP2 = nodes is not None\nstep = 2 if degree == 2 else 1\n"
    planted["fem/space.py"] = files["fem/space.py"] + "\nP2 = nodes is not None\n"
    n = len(planted["io/output.py"].splitlines())
    assert sites(NODES, planted) == {"io/output.py": [n - 1]}
    assert sites(DEGREE, planted)["io/output.py"][-1] == n
    assert "fem/space.py" not in sites(DEGREE, planted)
    for line in ("if sol.degree != 1:", "x = 1 if 2 == degree else 0", "for degree in (1, 2):"):
        assert DEGREE.search(line), line
    assert not DEGREE.search("space(degree, cell).trace")
