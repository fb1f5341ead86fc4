"""The contact pressure and shear a 3D P2 (10-node tetrahedra) solution reads back under "sigma1"/"sigma2"
(ContactResult.pressure, .shear; docs/formulation.md §15).

The rows sit at the constrained body's P2 face nodes, which are not nodes of X_h (the overlay's). The consistent
loads of a uniform pressure p on 6-node triangles are 0 at the vertices and pA/3 at the edge midpoints, so the
pressure is the Riesz representer of the rows' forces in the P2 functions of that body's own faces (on a face the
overlap's edge cuts, the cut weights on the diagonal), extended to X_h as that body's P2 function. (Before, lambda_h,
the representer in X_h of E^T y, was read: a uniform p read from -4 to 12 times itself here.) The shear is each row's
tangential force over its own weight (the red refinement's, which weighs the friction capacities g w_a), so that
|t| <= g at every row under Tresca.

References built here: the consistent loads of a uniform p from the faces' areas (A/3 per edge midpoint), the
integral of a P2 function on a triangle (A/3 times the sum of its edge-midpoint values), the springs in series'
closed form, the overlap's area in closed form.
"""

import warnings

import numpy as np
import pytest
from friction_scenes import dragged_blocks3d
from scenes3d import P, stacked_blocks, three_blocks

import cvxcontact as cc
from cvxcontact.fem.space import P2Tet
from cvxcontact.fem.trace import TRACES

DELTA = 1e-5                                               # m, the interference


def _blocks(soft, ratio=1e10, E=1e9, h=0.5, upper=((0, 1), (0, 1)), n1=(3, 2), n2=(2, 3), law=None, top=None):
    """A nu = 0 block ``upper`` x (h, 2h) (n1 cells) on a block (0, 1)^2 x (0, h) (n2 cells: non-matching faces),
    each clamped at its far face, interfering by DELTA; body ``soft`` has Young's modulus E, the other E ``ratio``.
    The soft body, its rows' forces read against a rigid one, is in uniaxial strain up to O(1 / ratio) when its
    contact face lies in the other's: p = DELTA / (h / E + h / (E ratio)) (the springs in series). ``top``: the
    upper block's top displaced by it instead of clamped."""
    mats = [cc.materials.isotropic(E=E * (1.0 if k == soft else ratio), nu=0.0) for k in range(2)]
    up = cc.box(x=upper[0], y=upper[1], z=(h, 2 * h), nx=n1[0], ny=n1[1], nz=1)
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, h), nx=n2[0], ny=n2[1], nz=1)
    b1 = cc.Body(up, mats[0], contact="bottom", **({"clamped": ["top"]} if top is None else
                                                   {"displacement": {"top": top}}))
    b2 = cc.Body(low, mats[1], clamped=["bottom"], contact="top")
    scene = cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", gap=-DELTA, law=law)])
    return scene, DELTA / (h / E + h / (E * ratio))


SCENES = {"same faces": {}, "nested": {"upper": ((0.2, 0.8), (0.1, 0.7))}}
CASES = [("same faces", "sigma1"), ("same faces", "sigma2"), ("nested", "sigma1")]
"""(scene, condition): the rows on a body whose contact face lies wholly in the other's."""


def _loads(t):
    """(n,): the consistent loads (m^2, per unit pressure) of a uniform pressure on the 6-node faces of the trace
    ``t``: A/3 at each edge midpoint of a face, 0 at its vertices."""
    corners = t.x[t.faces[:, :3]]
    d1, d2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    return np.bincount(t.faces[:, 3:].ravel(), weights=np.repeat(area / 3, 3), minlength=len(t.nodes))


def _integral(t, values):
    """The integral (m^2 times the values' unit) over the faces of the trace ``t`` of the P2 function of nodal
    ``values`` (at every node of ``t``): A/3 times the sum of its edge-midpoint values on each face."""
    return float(_loads(t) @ values)


@pytest.mark.parametrize("name, condition", CASES)
def test_the_consistent_loads_of_a_uniform_pressure_read_it_at_every_node(name, condition):
    """The consistent loads of a uniform p on the constrained body's faces (built here) as the rows' forces read p at
    every node of X_h (measured 1.2e-15 relative at most; bound 1e-12); lambda_h, the representer in X_h the
    pressure was before, reads them off by more than p (measured -5.0 to 18.4 times p)."""
    l = int(condition[-1]) - 1
    scene, _ = _blocks(l, **SCENES[name])
    itf = P2Tet().contact(scene, condition, cc.Signorini()).interface
    t, rows = itf.traces[l], itf.sigma_rows(l)
    assert len(rows) == len(t.nodes)                                     # every face of the body in the overlap
    p = 3.7e6
    y = p * _loads(t)[rows]
    E = itf.evaluation(condition)
    read = TRACES[2].row_pressure(itf, condition, E, y)
    assert read.shape == (itf.size,) and np.abs(read - p).max() <= 1e-12 * p
    assert np.abs(itf.multiplier(E.T @ y) - p).max() > p                  # the former read-back


@pytest.mark.numerics
@pytest.mark.parametrize("name, condition", CASES)
def test_a_soft_block_on_a_stiff_one_reads_the_closed_form_pressure(name, condition):
    """The rows on the soft block's nodes (the other 1e10 times stiffer), its face inside the other's: the state is
    uniform to O(1e-10) and the pressure is the closed form at every node of X_h (measured 3.3e-10 relative at most,
    the state's own O(1 / ratio): 3.6e-8 at ratio 1e8; bound 1e-7), also at the rows (the P2 function evaluated
    there). lambda_h, read before, is off by more than p (measured -5.0 to 18.4 times p)."""
    l = int(condition[-1]) - 1
    scene, p = _blocks(l, **SCENES[name])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(scene, condition, degree=2)
    c = sol.contact
    assert sol.ok and c.row_pressure is not None
    assert np.abs(c.pressure / p - 1).max() <= 1e-7
    assert np.abs(sol.interface.evaluation(condition) @ c.pressure / p - 1).max() <= 1e-7
    assert np.abs(c.lam / p - 1).max() > 1.0


CUT = {"sigma1 nested": ("sigma1", {"upper": ((0.2, 0.8), (0.1, 0.7))}, 0.6 * 0.6),
       "sigma2 nested": ("sigma2", {"upper": ((0.2, 0.8), (0.1, 0.7))}, 0.6 * 0.6),
       "sigma2 shifted": ("sigma2", {"upper": ((0.3, 1.3), (0, 1))}, 0.7),
       "sigma1 shifted": ("sigma1", {"upper": ((0.3, 1.3), (0, 1))}, 0.7)}


@pytest.mark.numerics
@pytest.mark.parametrize("name", list(CUT))
def test_the_pressure_integrates_to_the_total_contact_force(name):
    """Whatever the state (here nu = 0 blocks of equal stiffness, the contact faces cut by the overlap's edge on the
    constrained side in the nested and shifted cases), the pressure at the rows (the P2 function of X_h evaluated at
    them) integrated over the constrained body's faces wholly in the overlap (A/3 per edge midpoint, built here),
    plus its values at the rows of the faces the overlap's edge cuts times their weights (the red hats' integrals
    over the overlap; with the whole faces' areas they sum to the overlap's area, checked here in closed form),
    is the total contact force (measured 2.1e-16 relative at most; bound 1e-12; lambda_h, read before, 3.1 to 8.9
    times the total off)."""
    condition, kw, area = CUT[name]
    l = int(condition[-1]) - 1
    scene, _ = _blocks(l, ratio=1.0, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(scene, condition, degree=2)
    c, itf = sol.contact, sol.interface
    t, rows = itf.traces[l], itf.sigma_rows(l)
    at_rows = itf.evaluation(condition) @ c.pressure
    whole = np.zeros(len(t.nodes), dtype=bool)
    whole[rows] = True
    faces = whole[t.faces].all(axis=1)
    inner = type("Faces", (), {"x": t.x, "faces": t.faces[faces], "nodes": t.nodes})
    values = np.zeros(len(t.nodes))
    values[rows] = at_rows
    cut = itf._cut_weights(condition)
    assert abs(_integral(inner, np.ones(len(t.nodes))) + cut.sum() - area) <= 1e-12
    total = float(np.sum(c.force))
    assert total > 0 and abs(_integral(inner, values) + cut @ at_rows - total) <= 1e-12 * total


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2", "gamma3"])
def test_a_compliance_law_reads_what_it_read(condition):
    """A normal-compliance pair reads lambda from its own law (the rows are its quadrature points, not the
    condition's nodes): no row pressure, the pressure is lambda bit for bit; on a soft block (the condition's
    body; "gamma3" the upper one) on a stiff one the state is uniform and reads the springs in series'
    delta / (h / E + h / (E ratio) + 1 / k) (measured 1.1e-11 relative at most, "gamma3" 2.3e-15;
    bound 1e-8). (Bit for bit as before this read-back: compared on these and cut scenes.)"""
    k = 1e9
    soft = 0 if condition == "gamma3" else int(condition[-1]) - 1
    scene, p = _blocks(soft, law=cc.NormalCompliance(stiffness=k))
    sol = cc.solve(scene, condition, degree=2)
    c = sol.contact
    p = DELTA / (DELTA / p + 1 / k)
    assert c.row_pressure is None and np.array_equal(c.pressure, c.lam)
    assert np.abs(c.pressure / p - 1).max() <= 1e-8


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_the_tresca_shear_is_at_most_g_at_the_rows(condition):
    """Tresca between non-matching blocks (nu = 0.3), the upper one's top dragged along x and y
    and pressed: the rows slip somewhere. The shear at the rows (the P2 function of X_h evaluated there) is at most
    g (measured (1 + 1.0e-15) g; the former read-back, the nodal forces over E^T w, 1.125 g there), and weighted by
    the rows' own weights (the capacities' areas) sums to the total tangential force (measured 1.5e-16 g m^2; bound
    1e-12 g m^2)."""
    g = 1e5
    scene = dragged_blocks3d(cc.Tresca(g), press=1e-5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(scene, condition, degree=2)
    c, itf = sol.contact, sol.interface
    E = itf.evaluation(condition)
    at_rows = np.column_stack([E @ c.shear[:, j] for j in range(2)])
    assert np.abs(c.slip).max() > 0 and c.row_shear is not None
    assert np.linalg.norm(at_rows, axis=1).max() <= g * (1 + 1e-12)
    w = itf.weights(condition)
    assert np.abs(w @ at_rows - np.sum(c.shear_force, axis=0)).max() <= 1e-12 * g


LOADED = {"two blocks sigma1": (lambda: stacked_blocks(nz=1), "sigma1"),
          "two blocks sigma2": (lambda: stacked_blocks(nz=1), "sigma2"),
          "three blocks": (lambda: three_blocks(conditions=("sigma1", "sigma2")), None)}


@pytest.mark.numerics
@pytest.mark.parametrize("name", list(LOADED))
def test_the_pressure_integrates_to_the_load(name):
    """Non-matching blocks on (0, 1)^2 (7 x 3 on 5 x 5 cells; a stack of three, one pair under each condition)
    pressed by P on the top, rollers on the sides: every pair carries P times the unit area (equilibrium, a closed
    form). The pressure each pair reports, evaluated at its rows and integrated over the constrained body's faces
    (A/3 per edge midpoint, built here), is P (measured 1.4e-15 relative at most; bound 1e-12; lambda_h, read before, 2.1 to
    3.1 times P off). (The discrete state is not uniform under a nodal condition on non-matching faces: the
    pressure reads 0.24 P to 3.9 P here.)"""
    build, condition = LOADED[name]
    scene = build()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResidualWarning)
        sol = cc.solve(scene, condition or "gamma3", degree=2)
    pairs = getattr(sol.interface, "interfaces", None) or [sol.interface]
    assert len(pairs) == len(sol.contacts) == len(scene.contacts)
    for itf, c, cond in zip(pairs, sol.contacts, scene.conditions):
        cond = cond or condition
        l = int(cond[-1]) - 1
        t, rows = itf.traces[l], itf.sigma_rows(l)
        assert len(rows) == len(t.nodes) and c.row_pressure is not None
        values = np.zeros(len(t.nodes))
        values[rows] = itf.evaluation(cond) @ c.pressure
        assert abs(_integral(t, values) - P) <= 1e-12 * P
