"""Q2 (27-node) hexahedra whose contact faces do not match (fem/q2faces.BiquadraticRows): the nodal rows at the
constrained side's 9-node face nodes, each reading the other side's biquadratic trace on its faces.

Independent reference: the jump at every row computed here by hand, the constrained side's nodal displacement
minus the other side's trace by the 1D quadratic Lagrange functions written here (tensor product on the other
side's face holding the node), against the gap; the biquadratic part of that trace (its departure from the
bilinear interpolant of its corners) is 7.5 % to 8.9 % of the displacement at the rows, so a row reading another
function of the other side's nodes is seen. The closed form with a nearly rigid other side: tests/test_refusals.py
(row 40).
"""

import numpy as np
import pytest
from hex_scenes import DELTA, SIDES, STEEL, block, pair

import cvxcontact as cc
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics

Q2 = space(2, "hex")


def _lagrange(t):
    """(3,): the 1D quadratic Lagrange functions of the nodes -1, 0, 1 at ``t``."""
    return np.array([t * (t - 1) / 2, 1 - t ** 2, t * (t + 1) / 2])


def _top(sol, k, z=0.5):
    """(in-plane points (m, 2), u_z (m,)) of body k's Q2 nodes on the contact plane z."""
    p = Q2.node_set(sol.scene.bodies[k].mesh).points
    on = np.flatnonzero(np.isclose(p[:, 2], z))
    return p[on, :2], sol.u[k][on, 2]


def _trace(points, uz, n, x):
    """The biquadratic trace at ``x`` (2,) of a side of n x n faces on the unit square whose nodes (at multiples of
    1 / (2 n)) are ``points`` with values ``uz``."""
    grid = {tuple(np.rint(p * 2 * n).astype(int)): u for p, u in zip(points, uz)}
    i, j = min(int(x[0] * n), n - 1), min(int(x[1] * n), n - 1)
    s, t = 2 * (x[0] * n - i) - 1, 2 * (x[1] * n - j) - 1
    vals = np.array([[grid[(2 * i + a, 2 * j + b)] for b in range(3)] for a in range(3)])
    return _lagrange(s) @ vals @ _lagrange(t)


@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_every_row_reads_the_other_sides_biquadratic_trace(condition):
    """Two steel blocks of 2 x 2 (lower) and 3 x 3 (upper) Q2 cells pushed together (no gap): every row closes,
    and at every node of the constrained side the jump by hand, u_z(lower) - u_z(upper), is 0."""
    scene = pair(block(2, (0.0, 0.5)), block(3, (0.5, 1.0)))
    sol = cc.solve(scene, condition, degree=2)
    assert sol.ok and sol.polished
    side, cells = int(condition[-1]) - 1, (2, 3)
    xy, own = _top(sol, side)
    points, uz = _top(sol, 1 - side)
    other = np.array([_trace(points, uz, cells[1 - side], x) for x in xy])
    jump = (own - other) if side == 0 else (other - own)
    scale = max(np.abs(u).max() for u in sol.u)
    assert len(sol.contacts[0].lam) == len(xy) and sol.contacts[0].active.all()
    assert np.abs(jump).max() <= 1e-12 * scale                                 # measured <= 2.5e-16
    assert np.ptp(own) >= 0.05 * scale                                         # the trace is not flat: 0.11


def test_a_compliance_law_on_faces_that_do_not_match_weighs_the_constrained_sides_simpson_weights():
    """The 3 x 3 upper block constrained ("sigma2") on a nearly rigid 2 x 2 lower one (1e6 times stiffer), pushed
    by DELTA through p = k r: the upper is in uniaxial strain, p = k DELTA / (1 + k H / M_steel), and each row's
    force is p times its Simpson weight (1D: h/6, 4h/6, 2h/6, ... with h = 1/3), computed here."""
    stiff = cc.materials.isotropic(E=STEEL.E * 1e6, nu=STEEL.nu)
    scene = pair(block(2, (0.0, 0.5)), block(3, (0.5, 1.0)), materials=(stiff, STEEL))
    k, H = 2e11, 0.5
    sol = cc.solve(scene, "sigma2", degree=2, law=cc.NormalCompliance(k))
    assert sol.ok and sol.polished
    M = float(STEEL.tensors(3)[0][2, 2])
    p = k * DELTA / (1.0 + k * H / M)
    s = np.array([1, 4, 2, 4, 2, 4, 1]) / 18                                    # Simpson on faces 1/3 wide
    c = sol.contacts[0]
    ij = np.rint(c.points[:, :2] * 6).astype(int)
    w = s[ij[:, 0]] * s[ij[:, 1]]
    assert np.abs(c.force - p * w).max() <= 1e-4 * p * w.max()                   # measured 4.1e-7
    assert np.abs(c.lam - p).max() <= 1e-4 * p                                    # measured 4.1e-7


def test_a_compliance_law_on_faces_the_overlaps_edge_cuts_weighs_the_whole_overlap():
    """A 3 x 3 steel block on (0.2, 0.8)^2 pushed by DELTA through p = k r onto a nearly rigid 2 x 2 Q2 block, under
    "sigma1" (the rows at the lower's nodes inside the overlap, x, y in {0.25, 0.5, 0.75}): no lower face lies
    wholly in the overlap, so every weight comes from the faces its edge cuts. Each row's force is k r_a times
    s(x) s(y), s written here: the 1D tents of step 1/4 (each face split 2 x 2) integrated over [0.2, 0.8], the
    nodes 0 and 1 outside giving their 0.005 to 0.25 and 0.75: s = 0.175, 0.25, 0.175 (summing to 0.6, the
    overlap's side). Before, those faces weighed nothing: the block went through the law with no force (ok)."""
    stiff = cc.materials.isotropic(E=STEEL.E * 1e6, nu=STEEL.nu)
    H, k = 0.5, 2e11
    lower = cc.Body(block(2, (0.0, H)), stiff, roller=SIDES, clamped=["bottom"], contact="top", name="lower")
    upper = cc.Body(cc.box(x=(0.2, 0.8), y=(0.2, 0.8), z=(H, 2 * H), nx=3, ny=3, nz=1, cell="hex"), STEEL,
                    roller=SIDES, contact="bottom", name="upper", displacement={"top": (None, None, -DELTA)})
    scene = cc.Scene(lower, upper, contacts=[cc.Contact(lower, "top", upper, "bottom")])
    sol = cc.solve(scene, "sigma1", degree=2, law=cc.NormalCompliance(k))
    assert sol.ok and sol.polished
    c = sol.contacts[0]
    s = {1: 0.175, 2: 0.25, 3: 0.175}
    w = np.array([s[i] * s[j] for i, j in np.rint(c.points[:, :2] * 4).astype(int)])
    assert len(w) == 9 and abs(w.sum() - 0.36) <= 1e-15
    p = k * DELTA / (1.0 + k * H / float(STEEL.tensors(3)[0][2, 2]))          # the uniaxial column, for scale
    assert np.abs(c.force - w * c.lam).max() <= 1e-12 * p * w.max()             # measured 5.6e-16
    assert c.force.sum() >= 0.5 * 0.36 * p                                     # 0.92 of it (coarse rows); before 0


@pytest.mark.parametrize("upper", [((0.0, 1.0), (0.0, 1.0)), ((0.2, 0.8), (0.2, 0.8))])
def test_the_contact_map_draws_q2_rows_on_faces_that_do_not_match(upper):
    """``plot_contact_map`` (what `cvxcontact solve` draws) on Q2 faces that do not match (2 x 2 under 3 x 3,
    "sigma1"): the opening is drawn on the nodes of the posed pair's X_h (the lower's nodes in the overlap), not
    on the scene's P1 overlay (whose triangles index other nodes: "triangles are indices into the points ...
    found value 32"); on (0.2, 0.8)^2 no lower face lies wholly in the overlap (no cell of X_h): drawn on their
    Delaunay."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import plot_contact_map

    lower = cc.Body(block(2, (0.0, 0.5)), STEEL, clamped=["bottom"], contact="top", name="lower")
    box = cc.box(x=upper[0], y=upper[1], z=(0.5, 1.0), nx=3, ny=3, nz=1, cell="hex")
    top = cc.Body(box, STEEL, contact="bottom", name="upper", displacement={"top": (0.0, 0.0, -DELTA)})
    sol = cc.solve(cc.Scene(lower, top, contacts=[cc.Contact(lower, "top", top, "bottom")]), "sigma1", degree=2)
    fig = plot_contact_map(sol)
    try:
        panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>" and ax.axison]
        assert len(panels) == 3 and all(ax.collections for ax in panels)
    finally:
        plt.close(fig)
