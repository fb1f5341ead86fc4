"""The element seam stays closed (docs/architecture.md, "A new space"): above fem/, geometry/ and discrete/ no code
asks "is this P2?" of a node set (``nodes is None``) and no code compares the degree, except the few sites listed
here; a new element then needs no edit there. The patterns are those of the counting greps in the docs."""

import re
from pathlib import Path

import numpy as np
import pytest

import cvxcontact
import cvxcontact as cc

ROOT = Path(cvxcontact.__file__).parent
INSIDE = ("fem", "geometry", "discrete")
"""Where the element is decided: the spaces, the meshes and their node sets, the discrete problem."""
NODES = re.compile(r"nodes is None|nodes is not None")
DEGREE = re.compile(r"degree *(==|!=|>=|<=|>|<) *[0-9]|[0-9] *(==|!=) *degree|degree in \(")
DEGREE_SITES = {
    "backends/__init__.py": 1,         # the registry: the condensed backend's sparse fallback, P1 only (its entry)
    "apps/studies/stability.py": 1,    # the inf-sup study's own P1 and P2 multiplier machinery
    "apps/studies/hertz3d.py": 1,      # the 3D Hertz study's P1 (force over lumped area) and P2 (Riesz) readings
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


KIND = re.compile(r"term\.(kind|compliant|cones|tangential|finishes|always_finished|estimated|takes_user_terms|"
                  r"zeroes_held_forces|active_from_forces|rows_may_depend|hands_on_state|takes_active_start)\b")
"""A line asking the contact term for its kind or a flag (docs/architecture.md, "A new contact law": the grep)."""


def test_kind_tests_outside_the_discrete_problem_are_at_most_eight():
    """Issue 31, "Done when": at most 8 lines outside fem/, geometry/ and discrete/ ask the term for its kind or a
    flag (the counting grep of docs/architecture.md, which also reads fem/ and geometry/: 8 now, the public
    description's fields and the route's key among them); a planted one is found."""
    files = {p: s for p, s in package().items() if not p.startswith("discrete/")}
    found = {path: len(lines) for path, lines in sites(KIND, files).items()}
    assert sum(found.values()) <= 8, f"kind tests outside {INSIDE} (path: count): {found}"
    planted = {"io/output.py": files["io/output.py"] + "\nif problem.term.compliant:\n    pass\n"}
    assert sites(KIND, planted) == {"io/output.py": [len(planted["io/output.py"].splitlines()) - 1]}


COMBINED = re.compile(r"(problem|lines|p)\.(compliant|friction|mixed|conic)\b|rows\.(compliant|friction)\b")
"""A line asking the problem, its lines or its rows which laws they combine (docs/architecture.md, "A new contact
law": the grep), counted outside the terms, the friction data, contact/ and fem/."""
SPACE_BRANCH = re.compile(r"^\s+(el)?if .*(conic_only|\.mixed|friction|compliant)")
"""A branch of fem/space.py on the laws of the rows (docs/architecture.md: the space's branches on which laws a scene
combines moved to the terms, ``own_lines``; those left pose a compliance law's weights and rows, and the cones of
"gamma3" where no compliance law is posed)."""


def test_which_laws_are_combined_is_asked_at_most_where_listed():
    """The lines outside the terms that ask which laws are combined: at most 8 (docs/architecture.md: the problem's
    four properties, the registry's four policies); fem/space.py's branches on the rows' laws: at most 6 (10 before
    the terms asked the elements for their rows, ``own_lines``); a planted one of each is found."""
    files = package()
    skip = ("discrete/terms.py", "discrete/slip.py", "contact/", "fem/")
    outside = {p: s for p, s in files.items() if not p.startswith(skip)}
    found = {p: n for p, s in outside.items() if (n := sum(1 for line in s.splitlines() if COMBINED.search(line)))}
    assert sum(found.values()) <= 8, f"lines asking which laws are combined (path: count): {found}"
    space_branches = [line for line in files["fem/space.py"].splitlines() if SPACE_BRANCH.search(line)]
    assert len(space_branches) <= 6, space_branches
    assert COMBINED.search("    if problem.friction and lines.rows.compliant:")
    assert SPACE_BRANCH.search("        elif pairs.conic_only and rows.friction:")
    assert not SPACE_BRANCH.search("    rows = RowLaws(laws, counts)")


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


# --- what the layers above now ask of the space and its trace, checked against independent constructions


def test_quadratic_trace_lumped_lengths_and_values():
    """The P2 lumped lengths are the integrals of the Lagrange basis on each segment (built here by numpy's
    polyfit through the three nodes, integrated exactly); the values between the nodes reproduce a quadratic."""
    from cvxcontact.fem.trace import TRACES

    rng = np.random.default_rng(3)
    xv = np.cumsum(rng.uniform(0.2, 1.0, 6))
    x = np.empty(2 * len(xv) - 1)
    x[::2], x[1::2] = xv, 0.5 * (xv[:-1] + xv[1:])
    expected = np.zeros_like(x)
    for s in range(len(xv) - 1):
        nodes = x[2 * s:2 * s + 3]
        for j in range(3):
            p = np.polyint(np.polyfit(nodes, np.eye(3)[j], 2))
            expected[2 * s + j] += np.polyval(p, nodes[2]) - np.polyval(p, nodes[0])
    trace = TRACES[2]
    assert np.abs(trace.lumped(x) - expected).max() < 1e-11 * x[-1]          # measured 4.3e-14 (x[-1] ~ 3)
    s = np.linspace(x[0], x[-1], 41)
    assert np.abs(trace.values(x, x ** 2 - 3 * x, s) - (s ** 2 - 3 * s)).max() < 1e-12    # measured 1.3e-15
    assert np.array_equal(trace.vertices(x), xv)
    assert np.abs(TRACES[1].values(xv, 2 * xv + 1, s) - (2 * s + 1)).max() < 1e-13                # measured 0
    assert np.allclose(TRACES[1].lumped(xv).sum(), xv[-1] - xv[0])


@pytest.mark.parametrize("degree", [1, 2])
def test_corner_gradients_are_the_gradients_of_a_field_of_the_degree(degree):
    """At every vertex of every cell, the shape gradients applied to the nodal values of a polynomial of the
    space's degree give its gradient (closed form)."""
    from cvxcontact.fem.space import space

    body = cc.Body(cc.rectangle(nx=3, ny=2), cc.materials.isotropic(1e9, 0.3), contact="bottom", clamped=["top"])
    element = space(degree, body.mesh.cell)
    cells, G = element.corner_gradients(body)
    pts = element.node_set(body.mesh).points
    f = pts[:, 0] + 2 * pts[:, 1] + (degree - 1) * pts[:, 0] * pts[:, 1]
    grad = np.einsum("mvdk,mk->mvd", G, f[cells])
    corners = body.mesh.points[body.mesh.cells]                                     # (m, 3, 2)
    exact = np.stack([1 + (degree - 1) * corners[..., 1], 2 + (degree - 1) * corners[..., 0]], axis=-1)
    assert np.abs(grad - exact).max() < 1e-12                                      # measured 7.1e-15 (P2)


def test_node_sets_answer_their_components():
    """A quadratic node set gives each node its cells' mesh component; at the vertices, the mesh's own."""
    from cvxcontact.geometry.quadratic import P2Nodes

    a = cc.rectangle(nx=2, ny=1)
    b = a.with_points(a.points + [3.0, 0.0])
    mesh = cc.Mesh(np.vstack([a.points, b.points]), np.vstack([a.cells, b.cells + len(a.points)]))
    nodes = P2Nodes(mesh)
    comp = nodes.node_components
    assert np.array_equal(comp[:len(mesh.points)], mesh.node_components)
    assert set(comp[nodes.points[:, 0] > 2.0]) == {mesh.node_components[-1]} != {mesh.node_components[0]}
    assert mesh.node_set() is mesh and mesh.node_set(nodes) is nodes
