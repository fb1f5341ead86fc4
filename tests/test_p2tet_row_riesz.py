"""The Riesz read-back of a 3D P2 (10-node tetrahedra) "sigma1"/"sigma2" pair's rows (QuadraticSurface.row_mass,
row_riesz; docs/formulation.md §15), checked against a P2 face mass assembled here.

References built here: the triangle6 shape functions from barycentric coordinates, their vertices and edge
midpoints told apart by geometry (not by the package's node order), integrated by a collapsed Gauss-Legendre rule
(8 x 8 points, exact to degree 14) on the faces found wholly inside the overlap (a closed-form rectangle).
"""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import cvxcontact as cc
from cvxcontact.fem.space import P2Tet

OVERLAPS = {"same faces": ((0, 1), (0, 1)), "nested": ((0.2, 0.8), (0.1, 0.7)),
            "shifted": ((0.25, 1.25), (-0.1, 0.9))}


def _scene(upper, E=1e9, ratio=1.0, soft=0, gap=-1e-5):
    mats = [cc.materials.isotropic(E=E * (1.0 if k == soft else ratio), nu=0.0) for k in range(2)]
    up = cc.box(x=upper[0], y=upper[1], z=(0.5, 1), nx=3, ny=2, nz=1)
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=2, ny=3, nz=1)
    b1 = cc.Body(up, mats[0], contact="bottom", clamped=["top"])
    b2 = cc.Body(low, mats[1], clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", gap=gap)])


def _rule():
    g, w = np.polynomial.legendre.leggauss(8)
    g, w = (g + 1) / 2, w / 2
    U, V = np.meshgrid(g, g, indexing="ij")
    xi, eta = U.ravel(), (V * (1 - U)).ravel()
    return np.column_stack([1 - xi - eta, xi, eta]), (np.outer(w, w) * (1 - U)).ravel()    # weights sum to 1/2


def _mass(x, faces, rows, n_rows, rect):
    """The P2 mass (m^2) on the rows of the faces whose six nodes lie in ``rect`` (x0, x1, y0, y1)."""
    L, W = _rule()
    M = np.zeros((n_rows, n_rows))
    inside = (x[:, 0] >= rect[0] - 1e-12) & (x[:, 0] <= rect[1] + 1e-12) & (x[:, 1] >= rect[2] - 1e-12) & (
        x[:, 1] <= rect[3] + 1e-12)
    for f in faces:
        if not inside[f].all():
            continue
        P = x[f]
        mid = [any(np.allclose(P[i], (P[j] + P[k]) / 2) for j in range(6) for k in range(j + 1, 6) if i not in (j, k))
               for i in range(6)]
        v = [i for i in range(6) if not mid[i]]
        assert len(v) == 3
        N = np.zeros((len(W), 6))
        for a, i in enumerate(v):
            N[:, i] = L[:, a] * (2 * L[:, a] - 1)
        for a in range(3):
            for b in range(a + 1, 3):
                (m,) = [i for i in range(6) if mid[i] and np.allclose(P[i], (P[v[a]] + P[v[b]]) / 2)]
                N[:, m] = 4 * L[:, a] * L[:, b]
        d1, d2 = P[v[1]] - P[v[0]], P[v[2]] - P[v[0]]
        area = 0.5 * abs(d1[0] * d2[1] - d1[1] * d2[0])
        r = rows[f]
        M[np.ix_(r, r)] += 2 * area * (N.T * W) @ N
    return M


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
@pytest.mark.parametrize("name", list(OVERLAPS))
def test_the_row_mass_is_the_p2_mass_and_a_quadratic_pressure_reads_itself(name, condition):
    """The rows' mass less the cut weights' diagonal is the P2 mass of the faces wholly in the overlap assembled here
    (measured 2.9e-15 relative at most; bound 1e-12), and the row forces of a random quadratic pressure (its
    integrals against the P2 functions on those faces, the cut weights times its values on the others) read it back
    at every row that reads (measured 1.2e-14 relative; bound 1e-11)."""
    upper = OVERLAPS[name]
    rect = (max(upper[0][0], 0), min(upper[0][1], 1), max(upper[1][0], 0), min(upper[1][1], 1))
    itf = P2Tet().contact(_scene(upper), condition, cc.Signorini()).interface
    l = int(condition[-1]) - 1
    t, inside = itf.traces[l], itf.sigma_rows(l)
    rows = np.full(len(t.nodes), -1)
    rows[inside] = np.arange(len(inside))
    M = _mass(np.asarray(t.x), np.asarray(t.faces), rows, len(inside), rect)
    cut = itf._cut_weights(condition)
    theirs = (itf.row_mass(condition) - sp.diags(cut)).toarray()
    assert np.abs(M - theirs).max() <= 1e-12 * np.abs(theirs).max()
    q = np.random.default_rng(len(name) + l).normal(size=6)
    X, Y = np.asarray(t.x)[inside].T
    p = q[0] + q[1] * X + q[2] * Y + q[3] * X ** 2 + q[4] * X * Y + q[5] * Y ** 2
    read = itf.row_riesz(condition, M @ p + cut * p)
    on = (np.abs(M).sum(axis=1) + cut) > 0
    assert on.any() and np.abs(read - p)[on].max() <= 1e-11 * np.abs(p).max()


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_the_nodal_pressure_is_the_constrained_bodys_own_pressure(condition):
    """The contact VTU's "nodal pressure" (the rows' Riesz read-back) and "pressure on body l" (the constrained
    body's own-trace Riesz representer of its nodal forces, computed apart) agree where every face of that body lies
    in the overlap (measured 2.1e-15 of the largest at most; bound 1e-10), here in partial contact (a gap
    tilted along x, open at x = 0)."""
    pytest.importorskip("meshio")
    from cvxcontact.io.output import contact_mesh

    l = int(condition[-1]) - 1
    scene = _scene(((0, 1), (0, 1)), ratio=1e3, soft=l, gap=lambda s1, s2: -1e-5 * (s1 - 0.4))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(scene, condition, degree=2)
    data = contact_mesh(sol).point_data
    nodal, own = data["nodal pressure [Pa]"], data[f"pressure on body {l + 1} [Pa]"]
    assert sol.ok and np.abs(nodal - own).max() <= 1e-10 * np.abs(own).max()


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.Signorini(), cc.Tresca(1e5), cc.Coulomb(0.3)],
                         ids=["signorini", "tresca", "coulomb"])
def test_a_pair_with_no_row_in_its_overlap_reads_no_pressure(law):
    """Under "sigma2" a small block (0.52, 0.7) x (0.52, 0.64) on a block of 2 x 3 cells holds no node of the lower
    one: the pair has no row, a ResolutionWarning says so (as without the read-back), and the pressure, the shear
    and the threshold are 0 (the read-back raised a bare ValueError on the empty rows before)."""
    m = cc.materials.isotropic(E=1e9, nu=0.3)
    up = cc.box(x=(0.52, 0.7), y=(0.52, 0.64), z=(0.5, 1), nx=1, ny=1, nz=1)
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=2, ny=3, nz=1)
    b1 = cc.Body(up, m, contact="bottom", displacement={"top": (1e-5, 0, -1e-5)})
    b2 = cc.Body(low, m, clamped=["bottom"], contact="top")
    scene = cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", law=law)])
    with pytest.warns(cc.ResolutionWarning):
        sol = cc.solve(scene, "sigma2", degree=2)
    c = sol.contact
    assert sol.ok and c.row_pressure is not None and not np.any(c.pressure)
    for field in (c.shear, c.threshold):
        assert field is None or not np.any(field)
