"""A normal-compliance law on Q1 hexahedra between faces that do not match (fem/hexfaces.law_weights): nested
faces (under "gamma3" or the finer side's own nodal condition: the finer side's rows, its hats' integrals on
the overlap), aligned parallelogram grids that cross ("gamma3": the pieces' corners, a quarter of each
piece's area) and any faces under a nodal condition (the constrained side's hats over the overlap).

Independent references: the series closed form of a column squeezed through the law (two blocks in uniaxial
strain and the law between them, linear and quadratic, solved here by hand); the Signorini answer the law tends
to as k grows (at the rate 1/k); the same geometry meshed with matching faces (the energies agree to the
discretisation's order, h^2). Nodal rows where the jump is not bilinear on the constrained side's faces (crossing
grids, the coarser side of nested ones, faces the overlap's edge cuts): the constrained side's hats over the
overlap, written here by hand, against a nearly rigid other side.
"""

import numpy as np
import pytest
from hex_scenes import (
    ALU,
    CROSSING,
    DELTA,
    M_A,
    M_S,
    NESTED,
    PUSH,
    SIDES,
    SOFT,
    STEEL,
    TILTED,
    H,
    block,
    check_column,
    nested,
    pair,
    series,
)

import cvxcontact as cc

pytestmark = pytest.mark.numerics

STIFF_SIDE = 1e6              # how much stiffer than steel a nearly flat other side is



def _column(case, condition, m):
    """The solution of the column of :func:`series` through the faces of ``case`` (NESTED or CROSSING), rollers
    on the sides, under ``condition`` ("fine": the finer side's nodal condition)."""
    if case in NESTED:
        scene, fine = nested(case, materials=(STEEL, ALU))
    else:
        (n1, m1), (n2, m2) = CROSSING[case]
        scene, fine = pair(block(n1, (0.0, H), m=m1), block(n2, (H, 2 * H), m=m2), materials=(STEEL, ALU)), None
    if condition == "fine":
        condition = f"sigma{fine + 1}"
    return cc.solve(scene, condition, law=cc.NormalCompliance(SOFT[m], exponent=m))


COLUMNS = [(case, "gamma3") for case in NESTED] + [(case, "fine") for case in ("4 on 2", "skewed 2 on 4")] + \
    [(case, "gamma3") for case in CROSSING]


@pytest.mark.parametrize("m", [1, 2])
@pytest.mark.parametrize("case,condition", COLUMNS)
def test_a_column_squeezed_through_the_law_is_the_series_closed_form(case, condition, m):
    """Uniaxial strain through nested faces ("gamma3" and the finer side's rows) and aligned crossings
    ("gamma3"): the penetration r is uniform, so the total force is k r^m times the overlap's area (1 m^2), the
    displacements are piecewise linear with the jump r at the faces, and every row reads p = k r^m (weights
    summing to the overlap's area, positive)."""
    sol = _column(case, condition, m)
    assert sol.ok and sol.polished
    p, r = series(SOFT[m], m)
    assert 0.1 * DELTA < r < 0.9 * DELTA                                      # the law takes part in the answer
    check_column(sol, p, r)                     # measured: u <= 6.8e-16 DELTA, forces 5.4e-16 p, lam 1.8e-15 p
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] - p).max() <= 1e-12 * p              # measured <= 2.0e-15 p


@pytest.mark.parametrize("condition", ["gamma3", "sigma1"])
@pytest.mark.parametrize("faces", [(1, 2), (2, 4)], ids=["nested", "matching"])
def test_the_law_on_a_partial_overlap_is_integrated_over_the_overlap_only(faces, condition):
    """An aluminium column on [0, 0.5] x [0, 1] (1 x 2 faces: nested; 2 x 4: matching) pushed by DELTA onto the
    held top of a block of 4 x 4 faces (the constrained side; its faces beyond x = 0.5 off the overlap): the
    penetration is uniform, r = DELTA / (1 + k H / M_alu), so the total force is k r times the overlap's area,
    0.5 m^2 (the rows at x = 0.5 weigh half their hats: the whole hats, which matching faces took before, gave
    0.625 m^2, the force 8.8 % high and the pressure the column felt 39 %), and the column is in uniaxial
    strain."""
    lower = cc.Body(cc.box(z=(0.0, H), nx=4, ny=4, nz=1, cell="hex"), STEEL, clamped=["bottom", "top"],
                    contact="left", name="lower")
    upper = cc.Body(cc.box(x=(0.0, 0.5), z=(H, 2 * H), nx=faces[0], ny=faces[1], nz=1, cell="hex"), ALU,
                    roller=SIDES, contact="bottom", name="upper", displacement={"top": (None, None, -DELTA)})
    scene = cc.Scene(lower, upper, contacts=[cc.Contact(lower, "top", upper, "bottom")])
    k = SOFT[1]
    r = DELTA / (1.0 + k * H / M_A)
    sol = cc.solve(scene, condition, law=cc.NormalCompliance(k))
    assert sol.ok and sol.polished
    assert abs(sol.contacts[0].force.sum() - k * r * 0.5) <= 1e-12 * k * r           # measured 1.1e-16 k r
    z = sol.points[1][:, 2]
    assert np.abs(sol.u[1][:, 2] + r + k * r * (z - H) / M_A).max() <= 1e-12 * DELTA  # measured 4.2e-16 DELTA
    assert np.abs(sol.traction(1)[1] - k * r).max() <= 1e-12 * k * r                  # measured 3.4e-16 k r


@pytest.mark.parametrize("case", ["skewed 2 on 4", "3 on 2"])
def test_a_penetration_limit_holds_the_column_at_the_limit(case):
    """The column of :func:`series` with a penetration limit l at half the free penetration (nested faces whose
    overlay has more vertices than the finer side's nodes; aligned crossings): the rows stop at r = l, so the
    pressure is the elastic column's, p = (DELTA - l) / (H / M_steel + H / M_alu), the total force p times 1 m^2
    and lambda_h = p at every node of X_h (the limit reactions read at the rows, then extended)."""
    k = SOFT[1]
    c = H / M_S + H / M_A
    limit = 0.5 * series(k, 1)[1]
    p = (DELTA - limit) / c
    if case in NESTED:
        scene, _ = nested(case, materials=(STEEL, ALU))
    else:
        (n1, m1), (n2, m2) = CROSSING[case]
        scene = pair(block(n1, (0.0, H), m=m1), block(n2, (H, 2 * H), m=m2), materials=(STEEL, ALU))
    sol = cc.solve(scene, "gamma3", law=cc.NormalCompliance(k, penetration_limit=limit))
    assert sol.ok and sol.polished
    cr = sol.contacts[0]
    assert abs(cr.force.sum() - p) <= 1e-12 * p                                 # measured <= 2.0e-16 p
    assert np.abs(cr.lam - p).max() <= 1e-12 * p                                # measured <= 2.0e-15 p
    z = sol.points[1][:, 2]
    assert np.abs(sol.u[1][:, 2] + p * H / M_S + limit + p * (z - H) / M_A).max() <= 1e-12 * DELTA  # 4.7e-16


@pytest.mark.parametrize("case", ["4 on 2", "skewed 2 on 4", "3 on 2"])
def test_a_stiff_law_tends_to_the_signorini_answer_at_the_rate_one_over_k(case):
    """Under the tilted gap (part of the faces open), the law's answer departs from Signorini's "gamma3" (the
    rows of tests/test_hex_nested.py) by C / k: from k = 1e15 to 1e17 Pa/m the departure falls at the order 1 in
    1/k, and at k = 1e17 it is about 1e-6 of the displacement."""
    if case in NESTED:
        scene, _ = nested(case, gap=TILTED, rollers=False, push=PUSH)
    else:
        (n1, m1), (n2, m2) = CROSSING[case]
        scene = pair(block(n1, (0.0, 0.5), m=m1), block(n2, (0.5, 1.0), m=m2), gap=TILTED, rollers=False, push=PUSH)
    signorini = cc.solve(scene, "gamma3")
    assert signorini.ok
    scale = max(np.abs(u).max() for u in signorini.u)
    departure = {}
    for k in (1e15, 1e16, 1e17):
        sol = cc.solve(scene, "gamma3", law=cc.NormalCompliance(k))
        assert sol.ok and sol.polished
        departure[k] = max(np.abs(sol.u[i] - signorini.u[i]).max() for i in (0, 1)) / scale
    # k d(k) (1e10 m Pa/m): 9.1249, 9.1274, 9.1276 (4 on 2); 9.2014, 9.2040, 9.2043 (skewed 2 on 4); 17.509, 17.620,
    # 17.631 (3 on 2): the observed order over the two decades 0.9985 to 0.99999
    order = np.log10(departure[1e15] / departure[1e17]) / 2
    assert abs(order - 1) <= 0.05, departure
    assert departure[1e17] <= 2e-4                                                  # measured <= 1.8e-6


@pytest.mark.parametrize("skewed", [False, True], ids=["rectangles", "skewed"])
def test_nested_and_matching_meshes_of_one_geometry_agree_to_the_discretisation_order(skewed):
    """The tilted gap, k = 1e14 Pa/m: the upper block of 2n x 2n faces on a lower one of n x n (nested) or 2n x 2n
    (matching), n = 2, 4, 8. Only the lower block's mesh differs; the energies approach each other as h^2 (the
    observed order over the three levels at least 1.5)."""
    gaps = []
    for n in (2, 4, 8):
        energy = []
        for lower in (n, 2 * n):
            scene = pair(block(lower, (0.0, 0.5), skewed), block(2 * n, (0.5, 1.0), skewed), gap=TILTED,
                         rollers=False, push=PUSH)
            sol = cc.solve(scene, "gamma3", law=cc.NormalCompliance(1e14))
            assert sol.ok and sol.polished
            energy.append(sol.energy)
        gaps.append(abs(energy[0] - energy[1]) / abs(energy[1]))
    # measured 8.2e-4, 1.9e-4, 5.1e-5 (rectangles), 1.0e-3, 2.0e-4, 5.5e-5 (skewed): order 2.0, 2.1
    order = np.log2(gaps[0] / gaps[2]) / 2
    assert order >= 1.5, gaps


@pytest.mark.parametrize("case, condition, stiff", [((2, 3), "sigma1", "upper"), ((2, 3), "sigma2", "lower"),
                                                    ((4, 2), "sigma2", "lower")],
                         ids=["crossing-sigma1", "crossing-sigma2", "nested-coarse-sigma2"])
def test_a_law_on_nodal_rows_where_the_jump_is_not_bilinear_weighs_the_constrained_sides_hats(case, condition,
                                                                                                 stiff):
    """Nodal rows whose faces the jump is not bilinear on (2 x 2 and 3 x 3 grids; the coarser side's rows on
    nested 4 x 4 / 2 x 2 grids): the law integrated by the constrained side's Q1 hats, the other side's trace
    read at its nodes. The other side STIFF_SIDE times stiffer (nearly flat): the constrained, steel, block is in
    uniaxial strain through the law, p = k r with r + p H / M_steel = DELTA, and each row's force is p times its
    node's hat integral written here (h^2 / 4 at a corner of the n x n grid, h^2 / 2 on its edges, h^2 inside,
    h = 1 / n); 0 at the other nodes of X_h."""
    side = int(condition[-1]) - 1
    mats = [STEEL, STEEL]
    mats[("lower", "upper").index(stiff)] = cc.materials.isotropic(E=STEEL.E * STIFF_SIDE, nu=STEEL.nu)
    scene = pair(block(case[0], (0.0, H)), block(case[1], (H, 2 * H)), materials=tuple(mats))
    k = SOFT[1]
    sol = cc.solve(scene, condition, law=cc.NormalCompliance(k))
    assert sol.ok and sol.polished
    p = k * DELTA / (1.0 + k * H / M_S)
    n = case[side]
    c = sol.contacts[0]
    ij = c.points[:, :2] * n
    on = np.isclose(ij, np.rint(ij), atol=1e-9).all(axis=1)                   # the constrained side's nodes
    ends = np.isclose(ij, 0.0) | np.isclose(ij, n)
    hat = np.where(on, np.prod(np.where(ends, 0.5, 1.0), axis=1), 0.0) / n ** 2
    assert np.abs(c.force - p * hat).max() <= 1e-4 * p / n ** 2                # measured <= 8.0e-7 p / n^2
    assert abs(c.force.sum() - p) <= 1e-4 * p                                  # measured <= 8.0e-7 p


def test_a_law_on_constrained_faces_the_overlap_cuts_weighs_their_hats_over_the_overlap():
    """A column on [0, 0.4] x [0, 1] (1 x 2 faces) pushed by DELTA onto a block of 3 x 3 faces (the constrained
    side, "sigma1"), whose middle column of faces the overlap's edge x = 0.4 cuts; both blocks STIFF_SIDE times
    stiffer than steel (nearly rigid: r = DELTA at every row to their strain). The weights are the hats integrated
    over the overlap, the share of the nodes beyond it (x = 2/3, 1/150 per unit length) given to the nearest rows
    (x = 1/3): along x 1/6 at x = 0 and 1/6 + 1/15 - 1/150 + 1/150 = 7/30 at x = 1/3 (they sum to 0.4, the overlap's
    width; whole hats would give 1/2, the cut hats without the shares 0.393), along y 1/6, 1/3, 1/3, 1/6: each row's
    force k DELTA times its weight, computed here by hand."""
    stiff = cc.materials.isotropic(E=STEEL.E * STIFF_SIDE, nu=STEEL.nu)
    lower = cc.Body(cc.box(z=(0.0, H), nx=3, ny=3, nz=1, cell="hex"), stiff, roller=SIDES, clamped=["bottom"],
                    contact="top", name="lower")
    upper = cc.Body(cc.box(x=(0.0, 0.4), z=(H, 2 * H), nx=1, ny=2, nz=1, cell="hex"), stiff, roller=SIDES,
                    contact="bottom", name="upper", displacement={"top": (None, None, -DELTA)})
    scene = cc.Scene(lower, upper, contacts=[cc.Contact(lower, "top", upper, "bottom")])
    k = SOFT[1]
    sol = cc.solve(scene, "sigma1", law=cc.NormalCompliance(k))
    assert sol.ok and sol.polished
    c = sol.contacts[0]
    i, j = np.rint(c.points[:, 0] * 3).astype(int), np.rint(c.points[:, 1] * 3).astype(int)
    row = np.isclose(c.points[:, 0] * 3, i) & np.isclose(c.points[:, 1] * 3, j)     # the lower's nodes
    wx, wy = np.array([1 / 6, 7 / 30]), np.array([1, 2, 2, 1]) / 6
    weight = np.where(row, wx[np.minimum(i, 1)] * wy[j], 0.0)
    scale = k * DELTA
    assert np.abs(c.force - scale * weight).max() <= 1e-4 * scale / 9          # measured 4.2e-7 k DELTA / 9
    assert abs(c.force.sum() - 0.4 * scale) <= 1e-4 * scale                     # measured 2.7e-7 k DELTA
