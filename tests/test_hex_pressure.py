"""lambda_h on hexahedral faces (fem/hexfaces.LumpedPressure): a uniform pressure reads uniform at every node of
X_h, Q1 and Q2, against a rigid plane and between two bodies (matching and nested faces). Before, the read-back
solved the representer in the P1/P2 functions of the faces' triangles, whose mass does not weigh the Q1/Q2
rows' forces alike: a uniform 14 MPa read 5.9-30 MPa (Q1) and 1.3-63 MPa (Q2). Under a varying pressure on
matching faces and against a plane, lambda_h is each node's force over its hat's integral, the read the
residual estimate now takes from ``c.lam``. The pressure each Q2 body feels (``sol.traction(k)``,
fem/q2faces.SimpsonSurface.pressure): its nodal forces over its biquadratic hats' integrals, a uniform pressure
read uniform on matching and nested faces and against a plane; on faces that do not match, the side whose nodes
carry no row (fem/q2faces.BiquadraticRows.pressure) reads the rows' pressures interpolated by the constrained side's
split faces: non-negative under non-negative forces, p under a uniform p; on Q1 faces that do not match
(fem/hexfaces.BilinearSurface.pressure) by the constrained side's bilinear faces."""

import numpy as np
import pytest

import cvxcontact as cc
from hex_scenes import ALU, DELTA, STEEL, block, pair

pytestmark = pytest.mark.numerics

P = 14e6
H = 0.5


def _on_plane(degree, condition):
    """A steel block on a rigid plane, rollers on two sides, a uniform traction -P on its top."""
    mesh = cc.box(nx=3, ny=3, nz=2, cell="hex")
    b = cc.Body(mesh, STEEL, roller=["left", "front"], traction={"top": (0.0, 0.0, -P)})
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])
    return cc.solve(scene, condition, degree=degree), P


def _two_blocks(degree, condition, lower_n, upper_n):
    """A steel block under an aluminium one (hex_scenes.pair), pushed by DELTA: uniaxial strain, the closed-form
    pressure p = DELTA / (H / M_steel + H / M_alu)."""
    scene = pair(block(lower_n, (0.0, H)), block(upper_n, (H, 2 * H)), materials=(STEEL, ALU))
    M_s, M_a = float(STEEL.tensors(3)[0][2, 2]), float(ALU.tensors(3)[0][2, 2])
    return cc.solve(scene, condition, degree=degree), DELTA / (H / M_s + H / M_a)


CASES = {
    "Q1 plane gamma3": lambda: _on_plane(1, "gamma3"),
    "Q1 plane sigma1": lambda: _on_plane(1, "sigma1"),
    "Q2 plane sigma1": lambda: _on_plane(2, "sigma1"),
    "Q1 matching gamma3": lambda: _two_blocks(1, "gamma3", 3, 3),
    "Q1 matching sigma2": lambda: _two_blocks(1, "sigma2", 3, 3),
    "Q1 nested gamma3 (fine upper)": lambda: _two_blocks(1, "gamma3", 2, 4),
    "Q1 nested gamma3 (fine lower)": lambda: _two_blocks(1, "gamma3", 4, 2),
    "Q1 nested sigma2 (the fine side's rows)": lambda: _two_blocks(1, "sigma2", 2, 4),
    "Q2 matching sigma1": lambda: _two_blocks(2, "sigma1", 2, 2),
    "Q2 matching sigma2": lambda: _two_blocks(2, "sigma2", 2, 2),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_uniform_pressure_reads_uniform_on_hexahedral_faces(case):
    sol, p = CASES[case]()
    assert sol.ok
    c = sol.contacts[0]
    assert abs(c.force.sum() - p) <= 1e-10 * p                    # the closed form's total (A = 1 m^2)
    assert np.abs(c.lam - p).max() <= 1e-10 * p                   # measured <= 1e-14 p; before: 0.42 p .. 4.5 p
    assert (c.lam >= 0).all()


def _hats(mesh, part, degree):
    """{rounded (x, y, z): the integral of that node's face shape function over the faces of ``part``} of a box's
    rectangular faces, written here: a quarter of each face's area at its corners (Q1); A/36 at a corner, A/9 at
    an edge midpoint, 4A/9 at the centre (Q2, the 1D Simpson weights 1/6, 2/3, 1/6 squared)."""
    out = {}
    for X in mesh.points[mesh.boundary(part)]:                   # (4, 3) corners in order around the face
        area = np.linalg.norm(np.cross(X[1] - X[0], X[3] - X[0]))
        points = [(x, area / 4) for x in X] if degree == 1 else \
            [(x, area / 36) for x in X] + [(0.5 * (X[i] + X[(i + 1) % 4]), area / 9) for i in range(4)] + \
            [(X.mean(axis=0), 4 * area / 9)]
        for x, w in points:
            key = tuple(np.round(x, 9))
            out[key] = out.get(key, 0.0) + w
    return out


def _tilted_blocks(degree, condition):
    """Two steel blocks of 3 x 3 matching faces, the upper pushed 6 um down against an affine gap (1 to 12 um):
    the pressure varies and part of the faces stays open; the constrained side's faces."""
    scene = pair(block(3, (0.0, H)), block(3, (H, 2 * H)), gap=lambda s1, s2: 1e-6 + 8e-6 * s1 + 3e-6 * s2,
                 push=6e-6, rollers=False)
    side = 1 if condition == "sigma2" else 0
    return cc.solve(scene, condition, degree=degree), scene.bodies[side].mesh, ("top", "bottom")[side]


def _tilted_plane(degree, condition):
    """A steel block pushed 10 um down onto a plane tilted by 2e-5 rad about y: the pressure varies along x."""
    body = cc.Body(cc.box(nx=3, ny=3, nz=2, cell="hex"), STEEL, roller=["front"],
                   displacement={"top": (0.0, 0.0, -1e-5)}, contact="bottom")
    plane = cc.Rigid.plane((0.0, 0.0, 0.0), (2e-5, 0.0, 1.0))
    return cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", plane)]), condition, degree=degree), \
        body.mesh, "bottom"


VARYING = {"Q1 matching gamma3": lambda: _tilted_blocks(1, "gamma3"),
           "Q1 matching sigma1": lambda: _tilted_blocks(1, "sigma1"),
           "Q1 matching sigma2": lambda: _tilted_blocks(1, "sigma2"),
           "Q2 matching sigma1": lambda: _tilted_blocks(2, "sigma1"),
           "Q2 matching sigma2": lambda: _tilted_blocks(2, "sigma2"),
           "Q1 plane gamma3": lambda: _tilted_plane(1, "gamma3"),
           "Q1 plane sigma1": lambda: _tilted_plane(1, "sigma1"),
           "Q2 plane sigma1": lambda: _tilted_plane(2, "sigma1")}


@pytest.mark.parametrize("case", list(VARYING))
def test_lambda_on_matching_and_rigid_hexahedral_pairs_is_each_nodes_force_over_its_hats_integral(case):
    """On matching faces and against a rigid plane every node of X_h is a node of the faces, and lambda_h
    (``c.lam``) is each node's force over the integral of its Q1/Q2 hat on the constrained side's faces (the
    integrals written here): the lumped pressure the residual estimate read on its own before
    (solution/tensorestimate.py reads ``c.lam``), under a varying pressure with part of the faces open."""
    sol, mesh, part = VARYING[case]()
    assert sol.ok
    c = sol.contacts[0]
    hats = _hats(mesh, part, 2 if case.startswith("Q2") else 1)
    w = np.array([hats[tuple(np.round(x, 9))] for x in np.asarray(c.points)])
    force, lam = np.asarray(c.force), np.asarray(c.lam)
    assert force.max() > 0 and (force <= 1e-9 * force.max()).any()          # loaded, partly open
    assert np.ptp(lam) >= 0.1 * lam.max()                                   # not uniform
    assert np.abs(lam - force / w).max() <= 1e-12 * lam.max()               # measured <= 9.3e-16 max lam


@pytest.mark.parametrize("degree", [1, 2])
def test_the_hexahedral_spaces_set_lambda_h_through_the_pairs_public_hook(degree):
    """The Q1/Q2 spaces give their pairs the lumped pressure through ``with_representer`` (contact/riesz.py): the
    pairs they pose read lambda_h by it, the scene's own pairs are left as they were (no representer: the Riesz
    representer in X_h), and a pair's multiplier is its representer's solve."""
    from cvxcontact.fem.hexfaces import LumpedPressure
    from cvxcontact.fem.space import space

    scene = pair(block(2, (0.0, H)), block(2, (H, 2 * H)))
    lines = space(degree, "hex").contact(scene, "sigma1", cc.Signorini())
    posed = getattr(lines.interface, "interfaces", (lines.interface,))[0]
    own = scene.interfaces[0]
    assert isinstance(posed.representer, LumpedPressure) and own.representer is None and posed is not own
    r = np.linspace(1.0, 2.0, posed.size)
    assert np.array_equal(posed.multiplier(r), posed.representer.solve(r))


FELT = {"Q2 plane sigma1": lambda: _on_plane(2, "sigma1"),
        "Q2 matching sigma1": lambda: _two_blocks(2, "sigma1", 2, 2),
        "Q2 matching sigma2": lambda: _two_blocks(2, "sigma2", 2, 2),
        "Q2 nested sigma1 (the fine lower's rows)": lambda: _two_blocks(2, "sigma1", 4, 2),
        "Q2 nested sigma2 (the fine upper's rows)": lambda: _two_blocks(2, "sigma2", 2, 4)}


def _on_faces(sol, x):
    """(k, 3): the points of the contact plane at the in-plane coordinates ``x`` (k, 2) of ``sol``'s pair 0, by the
    affine map of its nodes of X_h (``c.x`` to ``c.points``, least squares: exact for a plane)."""
    c = sol.contacts[0]
    A = np.linalg.lstsq(np.column_stack([c.x, np.ones(len(c.x))]), c.points, rcond=None)[0]
    return np.column_stack([x, np.ones(len(x))]) @ A


@pytest.mark.parametrize("case", list(FELT))
def test_the_pressure_each_q2_body_feels_is_a_uniform_pressure(case):
    """``sol.traction(k)`` on Q2 faces in uniaxial strain (matching faces, nested faces under the fine side's nodal
    condition, a rigid plane): p at every node of each body's face trace (the closed form; the forces moved to a
    body's nodes over its biquadratic hats' integrals, docs/checks.md "The pressure views"). Nested faces: the
    coarse side reads the rows' forces p w_a by its biquadratic functions, which Simpson's rule on the fine faces
    inside one coarse face integrates exactly. Before, the Riesz representer in the P2 functions of the faces'
    triangles was off by up to 3.47 p."""
    sol, p = FELT[case]()
    assert sol.ok
    for k in range(len(sol.scene.bodies)):
        felt = sol.traction(k)[1]
        assert np.abs(felt - p).max() <= 1e-10 * p                              # measured <= 7.5e-15 p


def _interpolated(x, rows, q, step):
    """(k,): at the points ``x`` (k, 2) (the other side's nodes on the unit square) the row pressures ``q`` (at the
    points ``rows`` (m, 2)) interpolated by the constrained side's faces split 2 x 2 (tensor products of 1D tents of
    half-width ``step``, the constrained side's node spacing), normalised over the rows: written here."""
    tent = lambda c, r: np.clip(1.0 - np.abs(c[:, None] - r[None]) / step, 0.0, None)
    tau = tent(x[:, 0], rows[:, 0]) * tent(x[:, 1], rows[:, 1])
    return (tau @ q) / tau.sum(axis=1)


# the sides' 1D Simpson weights on faces 1/2 and 1/3 wide (nodes every 1/4, 1/6)
SIMPSON = {2: np.array([1, 4, 2, 4, 1]) / 12, 3: np.array([1, 4, 2, 4, 2, 4, 1]) / 18}


def _crossing(condition, gap=0.0, push=DELTA, cells=(2, 3), degree=2):
    """Q2 (``degree`` 2) or Q1 faces that do not match: a steel block under an aluminium one, ``cells`` x ``cells``
    per side (lower first; (2, 3) neither match nor nest), solved under ``condition``."""
    scene = pair(block(cells[0], (0.0, H)), block(cells[1], (H, 2 * H)), gap=gap, push=push,
                 materials=(STEEL, ALU), rollers=gap == 0.0)
    return scene, cc.solve(scene, condition, degree=degree)


def _simpson_rows(c, n):
    """(rows,) m^2: the Simpson weights of ``c``'s rows (``c.points`` on the constrained side's n x n faces of the
    unit square), written here."""
    i = np.rint(np.asarray(c.points)[:, :2] * 2 * n).astype(int)
    return SIMPSON[n][i[:, 0]] * SIMPSON[n][i[:, 1]]


@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
def test_the_pressure_q2_bodies_feel_on_crossing_faces(condition):
    """Q2 faces that neither match nor nest (3 x 3 over 2 x 2 cells), a uniform push: the constrained side's felt
    pressure times its biquadratic hats' integrals (Simpson's weights, written here: :func:`_hats`) sums to the
    total contact force; the other side (its nodes carry no row) reads the rows' pressures (force over Simpson
    weight) interpolated by the constrained side's split faces (1D tents, written here: :func:`_interpolated`),
    non-negative. Before, the Riesz representer in the P2 functions of the faces' triangles missed the total by
    50 % to 57 %, and read negative at some nodes."""
    scene, sol = _crossing(condition)
    assert sol.ok
    c = sol.contacts[0]
    total = c.force.sum()
    side, cells = int(condition[-1]) - 1, (2, 3)
    for k, part in ((0, "top"), (1, "bottom")):
        x, felt = sol.traction(k)
        assert felt.min() >= 0
        if k == side:
            hats = _hats(scene.bodies[k].mesh, part, 2)
            w = np.array([hats[tuple(np.round(y, 9))] for y in _on_faces(sol, x)])
            assert abs(felt @ w - total) <= 1e-10 * total                      # measured <= 4.7e-16 total
        else:
            q = c.force / _simpson_rows(c, cells[side])
            by_hand = _interpolated(_on_faces(sol, x)[:, :2], np.asarray(c.points)[:, :2], q, 1 / (2 * cells[side]))
            assert np.abs(felt - by_hand).max() <= 1e-10 * q.max()             # measured 1.2e-15 of the max


@pytest.mark.parametrize("condition, cells", [("sigma1", (2, 3)), ("sigma2", (2, 3)), ("sigma1", (2, 4))])
def test_the_pressure_the_other_q2_side_feels_follows_the_forces_sign_and_reads_a_uniform_pressure(condition, cells):
    """The side of a Q2 pair on faces that do not match whose nodes carry no row (:meth:`BiquadraticRows.pressure
    <cvxcontact.fem.q2faces.BiquadraticRows.pressure>`): under a partial contact (the affine gap of
    :func:`_tilted_blocks`, every force >= 0 and some 0) it reads no negative pressure and none above the largest
    row pressure; under the forces of a uniform p on the rows (p times the constrained side's Simpson weights,
    written here) p at every node, a side twice finer than the rows' included (2 x 2 rows under 4 x 4 faces).
    Before, the biquadratic functions moved the forces: -7.6 % and -7.9 % of the peak under the partial contact
    (all forces >= 0), up to 1.12 times the largest row pressure, a uniform p read 0.56 p to 1.27 p ("sigma1") and
    0.79 p to 1.78 p ("sigma2"); then the forces moved by that side's split hats over their areas by the rows'
    rule read a uniform p as 0 at 56 of the 81 nodes of the 4 x 4 side (their hats hold no row)."""
    from cvxcontact.fem.space import space

    scene, sol = _crossing(condition, gap=lambda s1, s2: 1e-6 + 8e-6 * s1 + 3e-6 * s2, push=6e-6, cells=cells)
    assert sol.ok
    c = sol.contacts[0]
    side = int(condition[-1]) - 1
    force = np.asarray(c.force)
    assert force.min() >= 0 and (force == 0).any() and force.max() > 0          # partial contact
    w = _simpson_rows(c, cells[side])
    felt = sol.traction(1 - side)[1]
    assert felt.min() >= 0 and felt.max() > 0                                    # before: -0.079 of the max
    assert felt.max() <= (force / w).max() * (1 + 1e-12)                         # a weighted mean of them
    posed = space(2, "hex").contact(scene, condition, cc.Signorini()).interface
    uniform = posed.pressure(1 - side, P * w)
    assert np.abs(uniform - P).max() <= 1e-12 * P                                # measured 9.3e-16 P


def _trapezoid_rows(points, n):
    """(rows,) m^2: the Q1 hats' integrals at the rows at ``points`` (rows, >= 2) on the constrained side's n x n
    faces of the unit square (the 1D trapezoid weights 1/(2 n), 1/n squared), written here."""
    i = np.rint(np.asarray(points)[:, :2] * n).astype(int)
    t = np.where((i == 0) | (i == n), 0.5, 1.0) / n
    return t[:, 0] * t[:, 1]


@pytest.mark.parametrize("condition, cells", [("sigma1", (2, 3)), ("sigma2", (2, 3)), ("sigma1", (2, 4))])
def test_the_pressure_q1_bodies_feel_on_crossing_faces(condition, cells):
    """Q1 faces that do not match (2 x 2 under 3 x 3 cells: neither match nor nest; under 4 x 4: nested, the
    coarse side's rows), a uniform push: the side whose nodes carry no row reads the rows' pressures (force over
    the Q1 hats' integral, the trapezoid weights written here: :func:`_trapezoid_rows`) interpolated by the
    constrained side's bilinear faces (1D tents as wide as its cells, written here: :func:`_interpolated`),
    non-negative; the constrained side reads its force over its hats' integral, as before."""
    _, sol = _crossing(condition, cells=cells, degree=1)
    assert sol.ok
    c = sol.contacts[0]
    side = int(condition[-1]) - 1
    rows = np.flatnonzero(c.constrained)
    points = np.asarray(c.points)[rows]
    q = np.asarray(c.force)[rows] / _trapezoid_rows(points, cells[side])
    for k in range(2):
        x, felt = sol.traction(k)
        assert felt.min() >= 0
        y = _on_faces(sol, x)[:, :2]
        if k == side:
            by_hand = q[np.argmin(np.linalg.norm(y[:, None] - points[None, :, :2], axis=2), axis=1)]
        else:
            by_hand = _interpolated(y, points[:, :2], q, 1 / cells[side])
        assert np.abs(felt - by_hand).max() <= 1e-10 * q.max()                 # measured <= 9.1e-16 of the max


@pytest.mark.parametrize("condition, cells", [("sigma1", (2, 4)), ("sigma2", (4, 2)), ("sigma1", (2, 5))])
def test_a_uniform_pressure_on_q1_rows_reads_uniform_on_the_side_without_rows(condition, cells):
    """The forces of a uniform p on the rows of a Q1 pair on faces that do not match (p times the rows' Q1 hats'
    integrals, written here): the side without rows reads p at every node, a finer side included (2 x 2 rows
    under 4 x 4 faces, nested; over them; under 5 x 5 faces, crossing). Before, its work-equivalent forces over
    its hats' integrals read 0 at the 16 of 25 nodes (4 x 4) and 20 of 36 (5 x 5) whose hats hold no row."""
    from cvxcontact.fem.space import space

    scene = pair(block(cells[0], (0.0, H)), block(cells[1], (H, 2 * H)), materials=(STEEL, ALU))
    posed = space(1, "hex").contact(scene, condition, cc.Signorini()).interface
    posed = getattr(posed, "interfaces", [posed])[0]
    side = int(condition[-1]) - 1
    rows = posed.evaluation(condition).indices
    r = np.zeros(posed.size)
    r[rows] = P * _trapezoid_rows(np.asarray(posed.points)[rows], cells[side])
    assert np.abs(posed.pressure(side, r) - P).max() <= 1e-12 * P              # measured 2.7e-16 P
    assert np.abs(posed.pressure(1 - side, r) - P).max() <= 1e-12 * P          # measured <= 1.2e-15 P
