"""P2 elements with rigid obstacles and several contact pairs (issue 11 x issue 10, items of the p2pairs brief).

Cross-checks, each independent of the code under test:
* a body pressed onto a rigid plane equals one half of the mirror-image two-body problem with the gap
  split (the two-body P2 solve, which has its own closed-form patch tests in test_p2.py/test_p2_pairs.py);
* the conic condition against a rigid circle, sampled densely along the body's own P2 edges against the
  exact (not interpolated) gap, with the interpolation error of g_h measured separately;
* a stack of three blocks (two pairs, nodal conditions) against a dense active-set solve of the mixed
  system (26) whose rows are built here from each body's own quadratic edges;
* the same stack with the middle body clamped: the pairs decouple, so each equals its single-pair solve.
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.geometry.quadratic import P2Nodes

from conftest import rel
from reference_problems import active_set_solve
from stack_scenes import A, MAT, YOUNG, dense_stack, three_blocks
from stack_scenes import part_abscissae as _part_x

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def mirrored(m):
    """The mesh reflected through the line x2 = 0 (triangles reordered to stay counter-clockwise)."""
    return cc.Mesh(m.points * np.array([1.0, -1.0]), m.triangles[:, ::-1], {t: m.boundary(t) for t in m.tags})


def upper(force=-1e7):
    m = cc.rectangle(x=(0, 1), y=(0, A), nx=5, ny=3)
    return m, cc.Body(m, MAT, clamped=["top"], contact="bottom", body_force=(0.0, force))


GAP = lambda s: -1e-4 + 2e-2 * (s - 0.45) ** 2          # noqa: E731  quadratic in s: g_h = g exactly


@pytest.mark.parametrize("condition, bound", [("sigma1", 1e-12), ("gamma3", 1e-6)])   # measured 3e-15, 1.4e-7
def test_rigid_plane_equals_the_mirror_two_body_problem(condition, bound):
    """Body on the plane x2 = 0 with gap g == the body and its mirror image pressed onto each other with
    the pair gap 2 g: by symmetry the line stays at x2 = 0 and each body sees g. Fields to ``bound``
    (nodal: exact finish; conic: interior point), both backends, lambda_h and the plane's force too."""
    m, body = upper()
    plane = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
    rigid = cc.Scene(body, contacts=[cc.Contact(body, "bottom", plane, gap=GAP)])
    mirror = cc.Body(mirrored(m), MAT, clamped=["top"], contact="bottom", body_force=(0.0, 1e7))
    two = cc.Scene(body, mirror, contacts=[cc.Contact(body, "bottom", mirror, "bottom", gap=lambda s: 2 * GAP(s))])
    # gamma3: interior points, complementarity measured 4.8e-7 .. 2.3e-6 (clarabel 0.10.0, 0.11.1), tol 2e-5
    ref = cc.solve(two, condition, degree=2, method="full", tol=2e-5)
    assert ref.ok, ref.report()
    flip = np.array([1.0, -1.0])
    assert rel(ref.u[1], ref.u[0] * flip) < bound                       # the reference is symmetric itself
    for method in ("full", "condensed"):
        sol = cc.solve(rigid, condition, degree=2, method=method, tol=2e-5)
        assert sol.ok and sol.degree == 2, sol.report()
        assert rel(sol.u[0], ref.u[0]) < bound
        c, r = sol.contact, ref.contact
        assert np.allclose(c.x, r.x, atol=1e-15) and np.allclose(c.gap, GAP(c.x), rtol=0, atol=1e-15)
        assert rel(c.jump, r.jump / 2) < bound and rel(c.lam, r.lam) < bound    # gamma3: 2.1e-8, 1.4e-7
        zone = sol.in_contact()   # a real contact zone (the cones touch inside segments: no node closes to tol)
        assert zone.any() and not zone.all()
        # the plane's reaction: the resultant of the nodal forces, = the integral of lambda_h
        assert rel(sol.obstacles[0].force, np.array([0.0, c.force.sum()])) < 1e-14
        assert abs(c.force.sum() - np.sum(c.lam * _simpson(c.x))) < 1e-12 * np.abs(c.force).sum()
        if condition == "sigma1":
            assert sol.polished


def _simpson(x):
    """Row sums of the P2 mass matrix: integral of each nodal basis function of the interleaved P2 mesh."""
    h = x[2::2] - x[:-1:2]
    w = np.zeros_like(x)
    w[:-1:2] += h / 6
    w[2::2] += h / 6
    w[1::2] = 2 * h / 3
    return w


def _edge_values(sol, k, part, xs, comp=1):
    """Component ``comp`` of body k's displacement at abscissae xs of its horizontal ``part``, from its own
    P2 edges (Lagrange on start, end, mid): independent of the interface operators."""
    e = P2Nodes(sol.scene.bodies[k].mesh).boundary(part)
    pts = sol.points[k]
    xa, xb = pts[e[:, 0], 0], pts[e[:, 1], 0]
    lo, hi = np.minimum(xa, xb), np.maximum(xa, xb)
    j = np.array([np.flatnonzero((lo <= x + 1e-15) & (x <= hi + 1e-15))[0] for x in xs])
    t = (xs - xa[j]) / (xb[j] - xa[j])
    v = sol.u[k][:, comp]
    return v[e[j, 0]] * (1 - t) * (1 - 2 * t) + v[e[j, 1]] * t * (2 * t - 1) + v[e[j, 2]] * 4 * t * (1 - t)


def test_conic_condition_against_a_curved_rigid_obstacle():
    """A block pressed onto a rigid cylinder (radius 10 m) with "gamma3": u.nu - g sampled at 4001 points of
    the body's own P2 edges. Against g_h (what is imposed) no violation above rounding; against the exact
    gap, no violation beyond the interpolation error max |g - g_h|, which is measured separately (O(h^3)
    times the gap's third derivative: 8e-8 m on these 0.2 m edges). The nodal condition penetrates g_h
    between its nodes (2e-6 m here)."""
    _, body = upper()
    R, c = 10.0, np.array([0.5, -10.0])
    disc = cc.Rigid.circle(center=c, radius=R, distance="ray")       # the vertical gap, rows along nu = (0, -1)
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", disc)])
    xs = np.linspace(0.0, 1.0, 4001)
    exact = lambda x: -(np.sqrt(R ** 2 - (x - c[0]) ** 2) + c[1])    # noqa: E731  distance down to the circle
    g = exact(xs)
    sol = cc.solve(scene, "gamma3", degree=2, tol=1e-5)
    assert sol.ok, sol.report()
    cres = sol.contact
    from cvxcontact.contact.quadratic import p2_interpolation        # the P2 interpolant of the exact gap
    gh = p2_interpolation(cres.x[0::2], xs) @ exact(cres.x)
    interp = np.abs(g - gh).max()
    assert 1e-8 < interp < 1e-6                                      # O(h^3): measured, not zero
    assert np.allclose(cres.gap, exact(cres.x), rtol=0, atol=1e-15)
    q = -_edge_values(sol, 0, "bottom", xs)                          # u . nu with nu = (0, -1)
    scale = np.abs(g).max()
    assert (q - gh).max() < 1e-9 * scale                             # the condition everywhere, to rounding
    assert (q - g).max() < interp + 1e-9 * scale                     # against the exact gap: within g - g_h
    assert (q - gh).min() < -1e-6 and (q - gh).max() > -1e-9 * scale   # an open part and a touching part
    assert cres.active.any() and not cres.active.all()
    nodal = cc.solve(scene, "sigma1", degree=2)
    assert nodal.ok and nodal.polished
    qn = -_edge_values(nodal, 0, "bottom", xs)
    assert (qn - gh).max() > 1e-8                                    # between the nodes it penetrates g_h
    assert rel(nodal.u[0], sol.u[0]) < 5e-2                          # the same problem up to that (0.9 % here)


# ---------------------------------------------------------------- several pairs


def test_stack_of_three_blocks_against_a_dense_active_set_solve():
    """Two pairs, nodal conditions (sigma1: the top body's P2 nodes; sigma2: the bottom body's), non-matching
    meshes (4 : 3 : 5 edges): the stacked P2 solve equals the dense primal-dual active-set solution of (26)
    with rows built from each body's own quadratic edges, for both backends; each pair has open and closed
    rows; sol.contacts[i] is pair i's line."""
    bodies, pairs, gaps = three_blocks()
    scene = cc.Scene(*bodies, contacts=pairs)
    systems, off, K, f, rows, gs, xs_all = dense_stack(bodies, gaps)
    G, g = np.vstack(rows), np.concatenate(gs)
    u, y = active_set_solve(K, f, G, g)
    split = np.cumsum([len(x) for x in xs_all])[:-1]
    for yi in np.split(y, split):
        assert (yi > 1e-9 * y.max()).any() and (yi < 1e-12 * y.max()).any()      # each pair: open and closed rows
    for method in ("full", "condensed"):
        sol = cc.solve(scene, "gamma3", degree=2, method=method)
        assert sol.ok and sol.polished and len(sol.contacts) == 2, sol.report()
        for k, (s, a, b) in enumerate(zip(systems, off[:-1], off[1:])):
            assert rel(sol.u[k].ravel()[s.u_free], u[a:b]) < 1e-12           # measured 8e-15
        for i, (c, xs) in enumerate(zip(sol.contacts, xs_all)):
            assert c.degree == 2 and np.allclose(c.gap, gaps[i](c.x), rtol=0, atol=1e-15)
            # the row forces of the reference, as nodal forces on X_h: their sum, and lambda_h's integral
            yi = np.split(y, split)[i]
            assert abs(c.force.sum() - yi.sum()) < 1e-9 * y.sum()
            assert abs(np.sum(c.lam * _simpson(c.x)) - yi.sum()) < 1e-9 * y.sum()
            for k in (0, 1):                                              # each pair's own traces
                x, p = sol.traction(k, pair=i)
                part = pairs[i].part_a if k == 0 else pairs[i].part_b
                assert len(x) == 2 * len(bodies[i + k].mesh.boundary(part)) + 1
                assert abs(np.sum(p * _simpson(x)) - yi.sum()) < 1e-9 * y.sum()   # the force it receives


@pytest.mark.parametrize("conditions, law", [(("sigma1", "sigma2"), None), (("gamma3", "gamma3"), None),
                                             (("gamma3", "sigma1"), cc.NormalCompliance(stiffness=1e11, exponent=1))])
def test_decoupled_pairs_equal_the_separate_single_pair_solves(conditions, law):
    """Two pairs that share no body (the top block on the middle one; a third block on a rigid plane): the
    stacked solve equals the two single-pair solves body by body and pair by pair, for both backends; each
    pair keeps its own condition (given on the contacts, the ``condition`` argument of solve differs) and,
    with ``law``, the first pair its own normal-compliance law (nodal rows at every P2 node of X_h under
    gamma3, docs/formulation.md §10) next to a Signorini pair."""
    (top, mid, bot), _, gaps = three_blocks()
    plane = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    low = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(-0.5, -0.4), nx=3, ny=1), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -3e7), name="low")
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=gaps[0], condition=conditions[0], law=law),
             cc.Contact(low, "bottom", plane, gap=lambda s: 5e-3 * (s - 0.45) ** 2 - 2e-5, condition=conditions[1])]
    scene = cc.Scene(top, mid, low, contacts=pairs)
    singles = [cc.Scene(top, mid, contacts=[pairs[0]]), cc.Scene(low, contacts=[pairs[1]])]
    conic = conditions[0] == "gamma3" and law is None
    # conic: both finished exactly (accumulated cuts) at the default tol; u measured 8.8e-9 .. 2.0e-8 (the cuts
    # stop at a violation of 1e-15 .. 1.5e-14, which leaves u determined to about its square root: the
    # certified bound reads 1.8e-8 .. 9.4e-8; 3.0e-8 before, both interior points); lambda_h of the cones is
    # not unique where the inf-sup condition fails (§9)
    tol, bound = 1e-6, (1e-7 if conic else 1e-9)
    lam_bound = 5e-5 if conic else 1e-9
    refs = [cc.solve(sc, "sigma2", degree=2, method="full", tol=tol) for sc in singles]
    assert all(r.ok for r in refs)
    for method in ("full", "condensed"):
        sol = cc.solve(scene, "sigma2", degree=2, method=method, tol=tol)
        assert sol.ok and sol.polished and len(sol.contacts) == 2, sol.report()
        for u, r in zip(sol.u, [refs[0].u[0], refs[0].u[1], refs[1].u[0]]):
            assert rel(u, r) < bound
        for i, (c, r) in enumerate(zip(sol.contacts, refs)):
            assert np.array_equal(c.x, r.contact.x) and rel(c.lam, r.contact.lam) < lam_bound
            assert getattr(c.law, "compliant", False) == getattr(r.contact.law, "compliant", False)
            zone = sol.in_contact(i)      # the contact zone (the cones' active nodes: only those closed to tol)
            assert zone.any() and not zone.all()
        assert rel(sol.obstacles[0].force, refs[1].obstacles[0].force) < lam_bound


def test_p2_stack_refusals_are_typed():
    """The conic condition on some pairs next to a normal-compliance law on others is solved (it was refused;
    tests/test_p2_mixed_laws.py checks it); a bad per-pair condition is still a SceneError."""
    bodies, pairs, gaps = three_blocks(conditions=("gamma3", "sigma2"))
    pairs[1] = cc.Contact(bodies[1], "bottom", bodies[2], "top", gap=gaps[1], condition="sigma2",
                          law=cc.NormalCompliance(stiffness=1e11))
    scene = cc.Scene(*bodies, contacts=pairs)
    assert cc.solve(scene, "gamma3", degree=2, tol=1e-5).ok
    assert cc.solve(scene, "gamma3").ok                                # P1 takes it (both conditions nodal)
    bodies, pairs, _ = three_blocks(conditions=(None, "sigma2"))
    with pytest.raises(cc.SceneError, match="condition must be one of"):
        cc.ContactSolver(cc.Scene(*bodies, contacts=pairs), "sigma3", degree=2)


def test_cone_rows_of_a_nodal_pair_are_its_rows_three_times():
    """QuadraticStack.cone_rows: a gamma3 pair gets its Bernstein rows, a nodal pair each evaluation row as
    the Bernstein coefficients (e q, e q, e q) of a constant (the cone then holds e q <= 0 exactly), its
    'segment' the nodes that row reads; checked on random nodal values against the evaluation and the
    Bernstein form computed here (b1 = 2 q(1/2) - (q(0) + q(1)) / 2)."""
    from cvxcontact.contact.quadratic import quadratic_stack

    bodies, pairs, _ = three_blocks(conditions=("gamma3", "sigma2"))
    scene = cc.Scene(*bodies, contacts=pairs)
    stack = quadratic_stack(scene, [P2Nodes(b.mesh) for b in bodies])
    B, seg = stack.cone_rows("gamma3", scene.conditions)
    q = np.random.default_rng(0).normal(size=stack.size)
    b = (B @ q).reshape(-1, 3)
    first, second = stack.interfaces
    S = len(first.segments)
    q0 = q[:first.size]
    assert np.allclose(b[:S], np.column_stack([q0[0:-1:2], 2 * q0[1::2] - (q0[0:-1:2] + q0[2::2]) / 2, q0[2::2]]),
                       rtol=0, atol=1e-14)
    Eq = second.evaluation("sigma2") @ q[first.size:]
    assert len(b) - S == len(Eq) and np.allclose(b[S:], Eq[:, None], rtol=0, atol=1e-14)
    assert (seg[S:] >= first.size).all() and (seg[:S] < first.size).all()


def test_conic_and_nodal_pairs_in_one_scene():
    """gamma3 on the first pair and sigma1 on the second: (1) pairs that share no body equal their single-
    pair solves (the conic one by the interior point, the nodal one with its exact finish) to 1e-6; (2) on
    the coupled stack of three blocks ("gamma3", "sigma2") the first pair holds everywhere (4001 samples
    along each body's own P2 edges) and the second at the bottom body's P2 trace nodes, with open and
    closed parts; both backends agree to 1e-6."""
    (top, mid, bot), _, gaps = three_blocks()
    plane = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    low = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(-0.5, -0.4), nx=3, ny=1), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -3e7), name="low")
    pairs = [cc.Contact(top, "bottom", mid, "top", gap=gaps[0], condition="gamma3"),
             cc.Contact(low, "bottom", plane, gap=lambda s: 5e-3 * (s - 0.45) ** 2 - 2e-5, condition="sigma1")]
    refs = [cc.solve(cc.Scene(top, mid, contacts=[pairs[0]]), degree=2, method="full", tol=1e-5),
            cc.solve(cc.Scene(low, contacts=[pairs[1]]), degree=2)]
    assert refs[1].polished
    for method in ("full", "condensed"):
        sol = cc.solve(cc.Scene(top, mid, low, contacts=pairs), degree=2, method=method, tol=1e-5)
        assert sol.ok, sol.report()
        for u, r in zip(sol.u, [refs[0].u[0], refs[0].u[1], refs[1].u[0]]):
            assert rel(u, r) < 1e-6                                    # measured 3.0e-8 .. 3.4e-8
        for c, r in zip(sol.contacts, refs):     # lambda_h: two interior points' cone duals, measured <= 9.0e-6
            assert rel(c.lam, r.contact.lam) < 5e-5 and np.array_equal(c.constrained, r.contact.constrained)
    bodies, pairs, gaps = three_blocks(conditions=("gamma3", "sigma2"))
    scene = cc.Scene(*bodies, contacts=pairs)
    sols = [cc.solve(scene, degree=2, method=m, tol=1e-5) for m in ("full", "condensed")]
    for sol in sols:
        assert sol.ok, sol.report()
        xs = np.linspace(0.0, 1.0, 4001)
        q = _edge_values(sol, 1, "top", xs) - _edge_values(sol, 0, "bottom", xs) - gaps[0](xs)
        assert q.max() < 1e-9 * np.abs(gaps[0](xs)).max() and q.min() < -1e-6
        c = sol.contacts[1]                                            # nodal rows at the bottom body's trace nodes
        xb = _part_x(P2Nodes(bodies[2].mesh), "top")
        assert c.constrained.sum() >= len(xb) and c.active.any() and not c.active.all()
        qb = _edge_values(sol, 2, "top", xb) - _edge_values(sol, 1, "bottom", xb) - gaps[1](xb)
        assert qb.max() < 1e-9 * np.abs(gaps[1](xb)).max()
    for a, b in zip(*(s.u for s in sols)):
        assert rel(a, b) < 1e-6


@pytest.mark.parametrize("condition", ["sigma1", "gamma3"])
def test_force_controlled_plane_with_p2_closed_form(condition):
    """A nu = 0 block clamped at its top, pushed up by a rigid plane under the prescribed force F (N/m)
    over its width 1 m, starting 1 mm below it: uniform pressure p = F, u = (0, p (H - y) / E) exactly (P2
    holds it), the plane's translation 1 mm + p H / E, lambda_h = p at every node of X_h and the
    obstacle balance at rounding; both conditions (the conic one through the full model's cone)."""
    H, force = 0.5, 2e6
    mat = cc.materials.isotropic(E=YOUNG, nu=0.0)
    body = cc.Body(cc.rectangle(x=(0, 1), y=(0, H), nx=5, ny=3), mat, clamped=["top"], contact="bottom")
    plane = cc.Rigid.plane(point=(0.0, -1e-3), normal=(0.0, 1.0), force=(0.0, force))
    sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", plane)]), condition, degree=2, tol=1e-5)
    assert sol.ok and sol.method == "condensed", sol.report()      # the translation borders the interface
    want = np.column_stack([np.zeros(len(sol.points[0])), force / YOUNG * (H - sol.points[0][:, 1])])
    assert np.abs(sol.u[0] - want).max() < 1e-9 * force * H / YOUNG
    ob = sol.obstacles[0]
    assert np.abs(ob.translation - [0.0, 1e-3 + force * H / YOUNG]).max() < 1e-12
    assert np.abs(sol.contact.lam / force - 1).max() < 1e-9
    assert sol.residuals()["obstacle balance"] < 1e-12 and rel(ob.force, np.array([0.0, force])) < 1e-12


def test_p2_stack_outputs_per_pair(tmp_path):
    """VTU/JSON output and figures of a P2 solution with a two-body pair and a rigid pair: one contact line
    per pair with that pair's P2 nodes (line3 cells), the bodies of each pair, the obstacle's force."""
    import json

    import matplotlib
    matplotlib.use("Agg")
    from cvxcontact.io.output import pair_bodies, write_all
    from cvxcontact.io.plot import plot_contact, plot_deformed

    (top, mid, _), _, gaps = three_blocks()
    plane = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    low = cc.Body(cc.rectangle(x=(0.2, 0.8), y=(-0.5, -0.4), nx=3, ny=1), MAT, clamped=["top"], contact="bottom",
                  body_force=(0.0, -3e7), name="low")
    scene = cc.Scene(top, mid, low, contacts=[cc.Contact(top, "bottom", mid, "top", gap=gaps[0]),
                                              cc.Contact(low, "bottom", plane, gap=lambda s: 5e-3 * (s - 0.45) ** 2)])
    sol = cc.solve(scene, "sigma1", degree=2)
    assert sol.ok and [pair_bodies(sol, i) for i in (0, 1)] == [[0, 1], [2]]
    paths = write_all(sol, tmp_path)
    data = json.loads((tmp_path / "solution.json").read_text())
    assert len(data["contacts"]) == 2 and data["degree"] == 2
    assert rel(np.array(data["obstacles"][0]["contact_force_N_per_m"]), sol.obstacles[0].force) < 1e-12
    assert [c["bodies"] for c in data["contacts"]] == [["top", "mid"], ["low"]]
    for c, res in zip(data["contacts"], sol.contacts):       # the total force: the sum of the nodal forces
        assert c["merged_nodes"] == len(res.x)
        assert abs(c["total_force_N_per_m"] - res.force.sum()) < 1e-9 * abs(res.force).sum()
    import meshio
    lines = [meshio.read(tmp_path / n) for n in ("solution_contact.vtu", "solution_contact2.vtu")]
    assert [len(m.points) for m in lines] == [len(c.x) for c in sol.contacts]
    assert all(m.cells[0].type == "line3" for m in lines)
    traces = {n: meshio.read(tmp_path / f"{n}.vtu") for n in ("solution_contact_body1", "solution_contact_body2",
                                                              "solution_contact2_body3")}
    assert {p.name for p in paths} >= {f"{n}.vtu" for n in traces}
    assert len(traces["solution_contact2_body3"].points) == 2 * 3 + 1      # low's 3 bottom edges, P2
    plot_contact(sol)
    plot_deformed(sol)


def test_p2_stack_contact_solver_resolves_a_new_load_case():
    """ContactSolver with a P2 stack: a second load case (other gaps, a stronger body force) re-solved by the
    prepared solver (warm start from the previous active set) equals a fresh solve of that scene."""
    def scene(shift, force):
        (top, mid, bot), pairs, gaps = three_blocks()
        top = cc.Body(top.mesh, MAT, clamped=["top"], contact="bottom", body_force=(0.0, force), name="top")
        return cc.Scene(top, mid, bot, contacts=[
            cc.Contact(top, "bottom", mid, "top", gap=lambda s: gaps[0](s) + shift, condition="sigma1"),
            cc.Contact(mid, "bottom", bot, "top", gap=gaps[1], condition="sigma2")])
    solver = cc.ContactSolver(scene(0.0, -2e7), degree=2)
    first = solver.solve()
    assert first.ok and first.polished
    again = solver.solve(scene(-1e-5, -3e7))
    fresh = cc.solve(scene(-1e-5, -3e7), degree=2)
    assert again.ok and again.polished and fresh.ok
    assert rel(again.u[0], first.u[0]) > 1e-3                           # a different answer ...
    for a, b in zip(again.u, fresh.u):
        assert rel(a, b) < 1e-9                                          # ... equal to the fresh solve
    for a, b in zip(again.contacts, fresh.contacts):
        assert rel(a.lam, b.lam) < 1e-9


@pytest.mark.parametrize("condition", ["sigma1", "gamma3"])
def test_model_with_p2_against_a_rigid_obstacle_is_the_full_solve(condition):
    """cc.Model(degree=2) takes one pair against a rigid obstacle (its one pair, as before): the same program
    as solve(..., method="full"), so the same answer (to the interior point's rounding for the cone)."""
    _, body = upper()
    plane = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", plane, gap=GAP)])
    ref = cc.solve(scene, condition, degree=2, method="full", tol=2e-5)       # gamma3: complementarity measured
    sol = cc.Model(scene, condition, degree=2, tol=2e-5).solve()               # 4.8e-7 .. 2.1e-6
    assert sol.ok and ref.ok, sol.report()
    assert rel(sol.u[0], ref.u[0]) < (1e-9 if condition == "sigma1" else 1e-6)
    assert np.array_equal(sol.contact.x, ref.contact.x) and rel(sol.contact.lam, ref.contact.lam) < 1e-5


def _punch_on_base_on_floor(gap=0.0):
    """The README's P2 scene: a punch pressed onto a base whose clamped corner sits on a rigid floor."""
    steel = cc.materials.isotropic(E=200e9, nu=0.3)
    punch = cc.Body(cc.rectangle(x=(0.3, 0.7), y=(0.0, 0.2), nx=4, ny=2), steel, clamped="top", contact="bottom",
                    body_force=(0.0, -1e9))
    base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=8, ny=4), steel, clamped="left", contact="top")
    floor = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    return cc.Scene(punch, base, contacts=[cc.Contact(punch, "bottom", base, "top"),
                                           cc.Contact(base, "bottom", floor, gap=gap)])


def test_conic_checks_at_a_clamped_corner_on_the_floor():
    """With g = 0 the base's clamped corner node is held at u.nu = g by its supports: its force acts on no
    unknown, (26)-(27) do not determine it, and the interior point returned 8e8 N/m there (under a 1.4e7 N/m
    punch load), which inflated lambda_h and the checks' force scale (ok read True). It is now set to the least
    admissible value; the nodal condition's exact finish (declined as singular before) takes it too. Checked:
    the floor's reaction of the conic and the nodal conditions agree (different conditions: 0.4 %), neither
    exceeds the punch's force, the held node carries no nodal force under sigma1, full == condensed; the conic
    answer reports its interior-point complementarity honestly (1.2e-6, tol 1e-5 here), and a solve stopped
    early is still seen."""
    scene = _punch_on_base_on_floor()
    full, cond = (cc.solve(scene, "gamma3", degree=2, method=m, tol=1e-5) for m in ("full", "condensed"))
    nodal = cc.solve(scene, "sigma1", degree=2)
    assert full.ok and cond.ok and nodal.ok and nodal.polished
    assert abs(full.energy - cond.energy) <= 1e-10 * abs(full.energy)          # two programs, one minimum
    assert rel(full.u[1], cond.u[1]) < 1e-6
    punch = nodal.contacts[0].force.sum()
    floor = [s.obstacles[0].force[1] for s in (full, cond, nodal)]
    assert all(0 < f < punch for f in floor)
    # conic vs nodal: 0.36 % (two conditions); full vs condensed: two interior points, measured 3.8e-8 .. 3.0e-7
    assert abs(floor[0] - floor[2]) < 1e-2 * floor[2] and abs(floor[0] - floor[1]) < 2e-6 * floor[0]
    corner = int(np.argmin(np.hypot(*(nodal.contacts[1].points - [0.0, -0.5]).T)))
    assert nodal.contacts[1].force[corner] == 0.0
    assert np.abs(full.contacts[1].lam).max() < 10 * np.abs(nodal.contacts[1].lam).max()   # was 1e5 times
    with pytest.warns(cc.ResidualWarning):
        loose = cc.solve(scene, "gamma3", degree=2, tol=1e-5, polish=False,
                         solver_options=dict(tol_gap_abs=1e-6, tol_gap_rel=1e-6, tol_ktratio=1e-6))
    assert not loose.ok and loose.residuals()["complementarity"] > 1e-4


def test_held_corner_row_p1_backends_agree():
    """P1, the same scene: the corner row no unknown moves was kept by the nodal finish of the full backend
    (singular, declined: floor force 1.9e8 N/m, ok False) while the condensed one returned another
    admissible force there (1.30e7 against 1.19e7): the held row now carries y = 0 in every backend, which
    then agree (sigma2) to rounding."""
    scene = _punch_on_base_on_floor()
    full, cond = (cc.solve(scene, "sigma2", method=m) for m in ("full", "condensed"))
    assert full.ok and cond.ok and full.polished and cond.polished
    assert abs(full.obstacles[0].force[1] - cond.obstacles[0].force[1]) < 1e-9 * abs(cond.obstacles[0].force[1])


def test_p2_obstacle_hole_at_a_midpoint_is_a_scene_error():
    """A profile with no obstacle (+inf) only around a P2 edge midpoint: P1 (vertices only) solves; P2 needs
    the gap at the midpoint too and names the point with a SceneError (it ended in a solver NaN error)."""
    mat = cc.materials.isotropic(E=70e9, nu=0.33)

    def hole(s):
        d = np.zeros_like(s)
        d[np.abs(s - 0.375) < 0.01] = np.inf
        return d

    b = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.3), nx=4, ny=2), mat, contact="bottom", body_force=(0, -1e8),
                clamped=["top"])
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.profile(hole))])
    assert cc.solve(scene, "sigma1").ok
    with pytest.raises(cc.SceneError, match=r"\(0.375, 0\) m"):
        cc.solve(scene, "sigma1", degree=2)


@pytest.mark.parametrize("method", ["full", "condensed"])
def test_held_corner_under_the_conic_compliance_limit(method):
    """A block clamped on its sides, pressed onto a rigid floor through a stiff law whose penetration limit
    l = 0 is posed as the cone at g + l = 0 ("gamma3", P2): the clamped corners sit at the cone's value 0, so
    the cone's force there is not determined; the interior point put 9.8e7 N/m on each (floor force 2.2e8
    against 2.56e7, ok True). Now the least admissible force: the floor's reaction equals the nodal sigma1
    answer (its held rows carry 0) to 1 %."""
    mat = cc.materials.isotropic(E=70e9, nu=0.33)
    b = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.3), nx=6, ny=3), mat, clamped=["left", "right"], contact="bottom",
                body_force=(0, -1e8))
    law = cc.NormalCompliance(stiffness=1e16, exponent=1, penetration_limit=0.0)
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane(point=(0, 0), normal=(0, 1)), law=law)])
    conic = cc.solve(scene, "gamma3", degree=2, method=method, tol=1e-5)
    nodal = cc.solve(scene, "sigma1", degree=2, method="full")
    assert conic.ok and nodal.ok
    f, ref = conic.obstacles[0].force[1], nodal.obstacles[0].force[1]
    assert abs(f - ref) < 2e-2 * abs(ref)           # measured 0.13 % .. 0.27 % (the interior point's held force)


@pytest.mark.parametrize("degree,condition", [(1, "gamma3"), (2, "sigma1"), (2, "gamma3")])
def test_model_releases_held_rows_as_solve_does(degree, condition):
    """cc.Model on the held-corner scene: it kept the interior point's force on the clamped corner (floor force
    1.9e9 / 7.4e8 / 8.2e8 N/m against 1.3e7, ok True); it now sets it as cc.solve does, and the two agree."""
    scene = _punch_on_base_on_floor()
    ref = cc.solve(scene, condition, degree=degree, method="full", tol=1e-5)
    sol = cc.Model(scene, condition, degree=degree, tol=1e-5).solve()
    assert ref.ok and sol.ok
    f, fr = sol.obstacles[0].force[1], ref.obstacles[0].force[1]
    assert abs(f - fr) < 1e-6 * abs(fr)
    assert np.abs(sol.contacts[1].lam).max() < 2 * np.abs(ref.contacts[1].lam).max()


def test_conic_mix_releases_held_nodal_rows():
    """P2, the punch pair compliant with a limit under gamma3 (a cone) and the floor pair nodal with the held
    corner: the linear rows' reaction at the corner was the interior point's (floor 8.4e8 N/m, ok True);
    released, the floor's reaction equals the all-nodal compliance answer's to 1 %."""
    scene = _punch_on_base_on_floor()
    punch, base = scene.bodies
    floor = scene.contacts[1].other
    law = cc.NormalCompliance(stiffness=1e14, exponent=1, penetration_limit=1e-6)
    pairs = lambda c0: [cc.Contact(punch, "bottom", base, "top", condition=c0, law=law),   # noqa: E731
                        cc.Contact(base, "bottom", floor, condition="sigma1")]
    mix = cc.solve(cc.Scene(punch, base, contacts=pairs("gamma3")), degree=2, tol=1e-5)
    nodal = cc.solve(cc.Scene(punch, base, contacts=pairs("sigma1")), degree=2)
    assert mix.ok and nodal.ok
    f, fr = mix.obstacles[0].force[1], nodal.obstacles[0].force[1]
    assert 0 < f < 2 * mix.contacts[0].force.sum() and abs(f - fr) < 1e-2 * fr


def test_least_held_duals_stay_in_the_dual_cone_and_never_rise():
    """least_held_duals on random points of the dual cone: the result is in the cone, no entry rises, and a
    lowered single end sits on the cone's boundary (beta1^2 = 4 beta0 beta2: the least value)."""
    from cvxcontact.backends.conic import least_held_duals

    rng = np.random.default_rng(1)
    b0, b2 = rng.exponential(size=4000), rng.exponential(size=4000)
    beta = np.column_stack([b0, 2 * np.sqrt(b0 * b2) * rng.uniform(size=4000), b2])
    for held in ([1, 0, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1]):
        out = least_held_duals(beta, np.tile(np.array(held, dtype=bool), (len(beta), 1)))
        assert (out >= 0).all() and (out <= beta * (1 + 1e-15)).all()
        assert (out[:, 1] ** 2 <= 4 * out[:, 0] * out[:, 2] * (1 + 1e-12)).all()
        if held in ([1, 0, 0], [0, 0, 1]):
            assert np.allclose(out[:, 1] ** 2, 4 * out[:, 0] * out[:, 2], rtol=1e-12)
    assert not least_held_duals(beta[:5], np.tile([True, True, True], (5, 1))).any()


def _held_punch_on_base_on_floor(floor_gap=0.0, law=None):
    """A punch held by the contact only (side rollers, pressed on top) on a base whose clamped corner sits on
    the rigid floor: both the held body and the held corner row."""
    steel = cc.materials.isotropic(E=200e9, nu=0.3)
    punch = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.2), nx=4, ny=2), steel, roller=["left", "right"],
                    contact="bottom", traction={"top": (0.0, -1e7)}, name="punch")
    base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=8, ny=4), steel, clamped="left", contact="top",
                   name="base")
    floor = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
    return cc.Scene(punch, base, contacts=[cc.Contact(punch, "bottom", base, "top", law=law),
                                           cc.Contact(base, "bottom", floor, gap=floor_gap)])


@pytest.mark.parametrize("law", [None, cc.NormalCompliance(stiffness=1e13)])
@pytest.mark.parametrize("degree,condition", [(1, "sigma2"), (2, "sigma1")])
def test_finishes_on_the_sparse_mixed_system_leave_held_rows_out(degree, condition, law):
    """The finishes on the sparse mixed system (a body held by the contact only: Signorini and compliance)
    put the held corner row in their active set, met a singular system and declined (ok False). They now
    leave it out; the answer at g = 0 equals the one with the floor lowered by 1e-14 m (the corner then
    open, its force 0 by complementarity) to 1e-6, an independent limit."""
    sol = cc.solve(_held_punch_on_base_on_floor(0.0, law), condition, degree=degree)
    ref = cc.solve(_held_punch_on_base_on_floor(1e-14, law), condition, degree=degree)
    assert sol.ok and sol.polished and ref.ok and ref.polished
    f, fr = sol.obstacles[0].force[1], ref.obstacles[0].force[1]
    assert abs(f - fr) < 1e-6 * abs(fr)


@pytest.mark.parametrize("degree,condition", [(1, "sigma2"), (2, "gamma3")])
def test_held_node_beyond_its_limit_is_named_with_compliance_too(degree, condition):
    """A clamped corner the floor already penetrates (g = -1e-6 m) cannot satisfy its row: a SceneError naming
    the point before any solve, also when the scene has a compliance law (the check was skipped there, and the
    solver ended in a vague error), and when the floor's own law allows less (a limit 5e-7 m) than the
    overlap; a limit that allows it (2e-6 m) solves."""
    steel = cc.materials.isotropic(E=200e9, nu=0.3)

    def scene(law=None, floor_law=None):
        punch = cc.Body(cc.rectangle(x=(0.3, 0.7), y=(0.0, 0.2), nx=4, ny=2), steel, clamped="top",
                        contact="bottom", body_force=(0.0, -1e9))
        base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=8, ny=4), steel, clamped="left", contact="top")
        floor = cc.Rigid.plane(point=(0.0, -0.5), normal=(0.0, 1.0))
        return cc.Scene(punch, base, contacts=[cc.Contact(punch, "bottom", base, "top", law=law),
                                               cc.Contact(base, "bottom", floor, gap=-1e-6, law=floor_law)])

    k = 1e13
    for sc in (scene(law=cc.NormalCompliance(stiffness=k)),
               scene(floor_law=cc.NormalCompliance(stiffness=k, penetration_limit=5e-7))):
        with pytest.raises(cc.SceneError, match=r"start in penetration, e.g. at \(0, -0.5\) m"):
            cc.solve(sc, condition, degree=degree, tol=1e-5)
    ok = cc.solve(scene(floor_law=cc.NormalCompliance(stiffness=k, penetration_limit=2e-6)), condition,
                  degree=degree, tol=1e-5)
    assert ok.ok
