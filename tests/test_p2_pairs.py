"""P2 elements with the contact pairs of main (issue 11 items 1-3 x issue 10): the quadratic patch test in
any orientation and through a cc.Contact in either body order (closed form at every P2 node), partial
overlap with the "everywhere" condition (dense sampling of each body's own trace), and the typed
refusals of what P2 does not support yet (a compliance limit under gamma3 on several pairs)."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.geometry.quadratic import P2Nodes

from conftest import rel

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

A, YOUNG, F, GAP = 0.5, 1e9, 4e9, -1e-3        # half-height (m), Young (Pa), body force (N/m^3), gap (m)
PRESSURE = F * A / 4 - GAP * YOUNG / (2 * A)    # closed form of the patch (tests/test_p2.py)
MAT = cc.materials.isotropic(E=YOUNG, nu=0.0)


def rotation(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def turned(m, R):
    return cc.Mesh(m.points @ R.T, m.triangles, {t: m.boundary(t) for t in m.tags})


def exact(k, y):
    """u_y of the patch in its own frame: quadratic in the upper block (k = 0), linear in the lower one."""
    if k == 0:
        return F / (2 * YOUNG) * (y ** 2 - A ** 2) - PRESSURE / YOUNG * (y - A)
    return -PRESSURE / YOUNG * (y + A)


def patch_bodies(R):
    m1 = cc.rectangle(x=(0, 1), y=(0, A), nx=5, ny=3, diagonal="alternate")
    m2 = cc.rectangle(x=(0, 1), y=(-A, 0), nx=3, ny=2, diagonal="alternate")
    b1 = cc.Body(turned(m1, R), MAT, clamped=["top"], contact="bottom", body_force=R @ np.array([0.0, -F]))
    b2 = cc.Body(turned(m2, R), MAT, clamped=["bottom"], contact="top")
    return b1, b2


@pytest.mark.parametrize("degrees, pair", [(30.0, False), (-135.0, True), (90.0, True)])
def test_turned_p2_patch_is_exact_at_every_node(degrees, pair):
    """The patch test turned by ``degrees`` (loads turned too): u = R (0, v(y')) with y' the ordinate in
    the block's own frame, at every P2 node, and lambda_h = the closed-form pressure; ``pair``: posed as
    cc.Contact with the lower block first (the opposite normal, the scene's bodies in the other order)."""
    R = rotation(np.radians(degrees))
    b1, b2 = patch_bodies(R)
    scene = (cc.Scene(b1, b2, contacts=[cc.Contact(b2, "top", b1, "bottom", gap=GAP)]) if pair
             else cc.Scene(b1, b2, gap=GAP))
    for method in ("full", "condensed"):       # interior points: complementarity measured 1.2e-7 .. 9.3e-7
        sol = cc.solve(scene, "gamma3", degree=2, method=method, tol=1e-5)
        assert sol.ok and sol.degree == 2, sol.report()
        for k in (0, 1):
            local = sol.points[k] @ R                                  # R^T p, row-wise
            want = np.column_stack([np.zeros(len(local)), exact(k, local[:, 1])]) @ R.T
            assert np.abs(sol.u[k] - want).max() < 1e-9 * abs(exact(1, 0.0))   # measured <= 2.3e-11 of it
        assert np.abs(sol.contact.lam / PRESSURE - 1).max() < 1e-7                # measured <= 1.24e-8
        assert np.abs(sol.contact.pressure / PRESSURE - 1).max() < 1e-7           # measured <= 8.2e-9
        assert sol.contact.points is not None and len(sol.contact.points) == len(sol.contact.x)
        # the contact line's points lie on the turned line y' = 0, at the tangential coordinates x
        assert np.abs((sol.contact.points @ R)[:, 1]).max() < 1e-12
        for k in (0, 1):
            x, p = sol.traction(k)
            assert np.abs(p / PRESSURE - 1).max() < 1e-7


def punch(width=(0.3, 0.7)):
    steel, alu = cc.materials.isotropic(E=200e9, nu=0.3), cc.materials.isotropic(E=70e9, nu=0.33)
    top = cc.Body(cc.rectangle(x=width, y=(0.0, 0.2), nx=5, ny=2), steel, clamped="top", contact="bottom",
                  body_force=(0.0, -1e9), name="punch")
    base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=8, ny=4), alu, clamped="bottom", contact="top",
                   name="substrate")
    gap = lambda s: -2e-4 + 5e-3 * (s - 0.52) ** 2                       # noqa: E731  (quadratic: g_h = g)
    return cc.Scene(top, base, contacts=[cc.Contact(top, "bottom", base, "top", gap=gap)]), gap


def sampled_jump(sol, xs):
    """[u_nu] at abscissae xs of the horizontal line, from each body's own P2 boundary edges (quadratic
    Lagrange on (start, end, mid)): independent of the merged mesh and of the interface operators."""
    out = np.zeros_like(xs)
    for k, (body, part, normal) in enumerate(((sol.scene.bodies[0], "bottom", -1.0),
                                              (sol.scene.bodies[1], "top", 1.0))):
        e = P2Nodes(body.mesh).boundary(part)
        pts = sol.points[k]
        xa, xb = pts[e[:, 0], 0], pts[e[:, 1], 0]
        lo, hi = np.minimum(xa, xb), np.maximum(xa, xb)
        j = np.array([np.flatnonzero((lo <= x + 1e-15) & (x <= hi + 1e-15))[0] for x in xs])
        t = (xs - xa[j]) / (xb[j] - xa[j])
        uy = sol.u[k][:, 1]
        out += normal * (uy[e[j, 0]] * (1 - t) * (1 - 2 * t) + uy[e[j, 1]] * t * (2 * t - 1)
                         + uy[e[j, 2]] * 4 * t * (1 - t))
    return out


def test_p2_partial_overlap_everywhere_holds_and_nodal_rows_stay_inside():
    scene, gap = punch()
    xs = np.linspace(0.3, 0.7, 2001)
    # no exact finish for the cone: the interior point reaches complementarity 1.6e-6 .. 2.7e-6 here (clarabel
    # 0.10.0, 0.11.1; 6.5e-6 with clarabel 0.9.0), formulation.md §8
    sols = {m: cc.solve(scene, "gamma3", degree=2, method=m, tol=3e-5) for m in ("full", "condensed")}
    for sol in sols.values():
        assert sol.ok, sol.report()
        assert sol.residuals()["equilibrium"] < 1e-12 and sol.residuals()["feasibility"] < 1e-9
        c = sol.contact
        assert c.x[0] == pytest.approx(0.3, abs=1e-15) and c.x[-1] == pytest.approx(0.7, abs=1e-15)
        q = sampled_jump(sol, xs) - gap(xs)
        assert q.max() < 1e-9 * np.abs(gap(xs)).max()                 # no penetration anywhere on the overlap
        assert q.min() < -1e-6                                         # ... and an open part: a real contact zone
        assert c.active.any() and not c.active.all()
    for k in (0, 1):
        assert rel(sols["condensed"].u[k], sols["full"].u[k]) < 1e-6
    # the nodal condition: rows at body l's P2 trace nodes inside the overlap only
    for cond, n_inside in (("sigma1", 2 * 5 + 1), ("sigma2", 2 * 3 + 1)):     # punch: 5 edges; substrate: 3 inside
        solver = cc.ContactSolver(scene, cond, degree=2)
        assert solver.problem.E.shape[0] == n_inside
        sol = solver.solve()
        assert sol.ok and sol.polished


def test_p2_scene_with_the_pair_equals_the_two_body_scene():
    """Scene(b1, b2) and the same pair given as cc.Contact (either body first) pose one problem."""
    b1, b2 = patch_bodies(np.eye(2))
    ref = cc.solve(cc.Scene(b1, b2, gap=GAP), "sigma2", degree=2)
    for c in (cc.Contact(b1, "bottom", b2, "top", gap=GAP, condition="sigma2"),
              cc.Contact(b2, "top", b1, "bottom", gap=GAP, condition="sigma1")):   # sigma of the same body
        sol = cc.solve(cc.Scene(b1, b2, contacts=[c]), "gamma3", degree=2)
        assert sol.ok and sol.polished
        for k in (0, 1):
            assert rel(sol.u[k], ref.u[k]) < 1e-9


# ---------------------------------------------------------------- what P2 refuses, typed

def _refusals():
    b1, b2 = patch_bodies(np.eye(2))
    top = cc.Body(cc.rectangle(x=(0, 1), y=(A, 2 * A), nx=3, ny=2), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -F))
    mid = cc.Body(cc.rectangle(x=(0, 1), y=(0, A), nx=3, ny=2), MAT, clamped=["left"], contact="bottom")
    two = cc.Scene(top, mid, b2, contacts=[cc.Contact(top, "bottom", mid, "top"), cc.Contact(mid, "bottom", b2, "top")])
    plane = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
    rigid = cc.Scene(b1, contacts=[cc.Contact(b1, "bottom", plane, gap=-1e-4)])
    # several pairs and rigid obstacles are solved with P2 by solve/ContactSolver (tests/test_p2_stack.py) and
    # cc.Model (tests/test_model_stack.py); the conic limit of a compliance law is solved (test_p2_model_compliance)
    # the conic solves' complementarity: measured 2.4e-7 (two), 7.4e-7 (rigid)
    return [(two, {"tol": 1e-5}, None, ()), (rigid, {"tol": 1e-4}, None, ())]


@pytest.mark.parametrize("case", range(2))
def test_p2_refuses_what_it_does_not_support(case):
    scene, kw, match, refused = _refusals()[case]
    for name, make in (("solve", lambda: cc.solve(scene, "gamma3", degree=2, **kw)),
                       ("solver", lambda: cc.ContactSolver(scene, "sigma1", degree=2, **kw)),
                       ("model", lambda: cc.Model(scene, "sigma1", degree=2, **kw))):
        if name not in refused:
            make()
            continue
        with pytest.raises(cc.UnsupportedError, match=match) as info:
            make()
        assert "degree=2" in str(info.value)
    assert cc.solve(scene, "gamma3", **kw).ok                          # the same scene is solved with P1


def _supported(kind):
    """Two blocks, the upper one pressed down by its weight, with one support of the prolongation."""
    low = cc.rectangle(x=(0, 1), y=(-A, 0), nx=3, ny=2)
    up = cc.rectangle(x=(0, 1), y=(0, A), nx=3, ny=2)
    lower = dict(clamped=["bottom"], contact="top")
    upper = dict(clamped=["top"], contact="bottom", body_force=(0.0, -F))
    mat_low = MAT
    if kind == "roller":
        lower = dict(lower, roller=["left"])
    elif kind == "displacement":
        upper = dict(upper, displacement={"left": (0.0, None)})
    elif kind == "floating":
        mat_low = cc.materials.PZT5A
        lower = dict(lower, grounded=["right"], floating={"left": 0.0})
    elif kind == "held by the contact only":
        upper = dict(contact="bottom", body_force=(0.0, -F), roller=["left", "right"])
    return cc.Scene(cc.Body(up, MAT, **upper), cc.Body(low, mat_low, **lower), gap=GAP)


@pytest.mark.parametrize("kind", ["roller", "displacement", "floating", "held by the contact only"])
def test_p2_takes_every_support_of_the_prolongation(kind):
    """Rollers, prescribed displacements, floating electrodes and bodies held by the contact only are built
    by the prolongation u = T z + u_D on the P2 nodes (formerly refused with degree=2; their cross-checks are
    in tests/test_p2_supports.py): solved and checked by solve, ContactSolver and cc.Model (which refuses a
    body held by the contact only for P1 too)."""
    scene = _supported(kind)
    # the conic condition on the full model: the condensed SOCP reaches complementarity ~1e-5 only on the PZT
    # scene, floating electrode or not (an interior-point accuracy of the conic backend, not of the supports)
    assert cc.solve(scene, "gamma3", degree=2, method="full", tol=1e-5).ok    # compl. measured 2.1e-8 .. 4.3e-7
    assert cc.ContactSolver(scene, "sigma1", degree=2).solve().ok
    model, ref = cc.Model(scene, "sigma1", degree=2).solve(), cc.solve(scene, "sigma1", degree=2, method="full")
    assert model.ok and rel(model.u[0], ref.u[0]) < 1e-12          # the same route (measured 0)


@pytest.mark.parametrize("degree", [1, 2])
def test_contact_vtu_of_a_pair_given_lower_body_first(degree, tmp_path):
    """cc.Contact(lower, ..., upper, ...) on Scene(upper, lower): the contact line's 'displacement body j'
    (j the scene's 1-based body index) and each trace file's displacement are that body's own (the lower block first), not the
    scene's body k's: equal to that body's solution at its own nodes on the line (read from sol.points,
    sol.u), wherever a point of the file is one of those nodes."""
    import meshio

    from cvxcontact.io.output import write_vtu

    b1, b2 = patch_bodies(np.eye(2))
    scene = cc.Scene(b1, b2, contacts=[cc.Contact(b2, "top", b1, "bottom", gap=GAP)])
    sol = cc.solve(scene, "gamma3", degree=degree)
    paths = write_vtu(sol, tmp_path, stem="s")
    line = meshio.read(paths[2])
    for k, j in enumerate((1, 0)):                  # the pair's order: the lower block (scene body 1) first
        pts, u = sol.points[j], sol.u[j]
        on = np.flatnonzero(np.abs(pts[:, 1]) < 1e-12)
        on = on[np.argsort(pts[on, 0])]             # that body's nodes on the line y = 0, along x
        trace = meshio.read(paths[3 + k]).point_data["displacement [m]"][:, :2]
        assert np.array_equal(trace, u[on])
        hit = np.flatnonzero(np.isin(np.round(line.points[:, 0], 12), np.round(pts[on, 0], 12)))
        assert len(hit) >= 4
        got = line.point_data[f"displacement body {j + 1} [m]"][hit, :2]     # named by the scene's body index
        want = u[on][np.searchsorted(np.round(pts[on, 0], 12), np.round(line.points[hit, 0], 12))]
        assert np.abs(got - want).max() < 1e-12 * np.abs(u).max()


def test_p2_with_a_per_pair_compliance_law_is_solved_by_solve_and_model():
    import cvxcontact as cc
    steel = cc.materials.isotropic(E=200e9, nu=0.3)
    a = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=3, ny=2), steel, clamped="top", contact="bottom")
    b = cc.Body(cc.rectangle(x=(0, 1), y=(-0.5, 0), nx=2, ny=2), steel, clamped="bottom", contact="top")
    scene = cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=cc.NormalCompliance(stiffness=1e13))])
    sol = cc.solve(scene, "sigma1", degree=2)            # solve/ContactSolver take it (test_p2_compliance.py)
    assert sol.ok and sol.degree == 2 and sol.contact.law == cc.NormalCompliance(stiffness=1e13)
    other = cc.Model(scene, "sigma1", degree=2).solve()  # and cc.Model (test_p2_model_compliance.py)
    assert other.ok and other.contact.law == sol.contact.law
    assert np.abs(other.u[0] - sol.u[0]).max() <= 1e-9 * np.abs(sol.u[0]).max()     # (no load here: u = 0)


def test_p2_conic_limit_on_several_pairs_is_solved():
    """The conic penetration limit of a compliance law (one pair: tests/test_p2_model_compliance.py) on a stack
    of pairs is solved (it was refused; tests/test_p2_mixed_laws.py checks it); so is a nodal limit (its limit
    rows at the clamped corner checked with their reactions' local displacement, docs/checks.md)."""
    two = _refusals()[0][0]
    law = cc.NormalCompliance(stiffness=1e12, exponent=1, penetration_limit=1e-6)
    assert cc.solve(two, "gamma3", degree=2, law=law, tol=1e-5).ok
    assert cc.solve(two, "sigma1", degree=2, law=law).ok and cc.solve(two, "sigma1", law=law).ok
