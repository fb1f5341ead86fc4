"""Friction on a curved 3D contact part against a planar one, certified by the optimality conditions of the
nodal law posed from the geometry alone (contact/surface.py CurvedSurfaceInterface.tangential_jump).

The reference here shares nothing with the package's contact code: each curved node x over the planar part is
projected along the plane's normal n_p (from the planar faces' cross products) onto X, located by barycentric
coordinates on every planar face; the rows are the slip u^a - u^b (a the pair's first body: the planar body's P1
interpolant at X, the curved body's displacement at x) in an orthonormal basis of the plane of our own (an SVD of
I - n_p n_p^T), the normal jump along n_p and the capacities g times a third of each curved face's true area
(Tresca) or mu times the row's normal force (Coulomb). At the package's displacements the stationarity of the
mixed system K v - f + A^T [y; q] = 0 (the bodies' reduced stiffness, with a piezoelectric body's K_up phi term)
gives the multipliers y (normal) and q (friction, pushing the slip back) by least squares; the answer is the
solution of the law when the residual is rounding and y >= 0, gap - [u_nu] >= 0, y (gap - [u_nu]) = 0,
|q_a| <= c_a, q_a = c_a s_a / |s_a| where s_a != 0 (the optimality conditions of a strictly convex program, so
they certify it). The package's normal and shear forces must be y and -q (the shear on the first body opposes
the slip u^a - u^b) whatever body is first, however the scene is turned (the plane's normal along no axis),
numbered or scaled; nodes whose projection misses the planar part have no row (the reference poses none there, so
a friction force posed on them would break the stationarity).
Scenes: tests/friction_scenes.py (capped_pair, two_caps)."""

import numpy as np
import pytest
import scipy.linalg as sla
from friction_scenes import capped_pair, two_caps
from scenes3d import rotation

import cvxcontact as cc
from cvxcontact.fem.space import P1Tet

pytestmark = pytest.mark.numerics

S = 1e-4                                                  # m, the upper block's top moved along x
TRESCA, COULOMB = cc.Tresca(threshold=8e6), cc.Coulomb(coefficient=0.15)
LAWS = {"tresca": TRESCA, "coulomb": COULOMB}
TOL = 1e-10        # every measure of every certificate below: measured at most 4.8e-13 (the floor's Tresca cone)


def _systems(scene):
    return [P1Tet().assemble_loads(b, P1Tet().assemble_matrices(b)) for b in scene.bodies]


def _rows(scene):
    """Per pair: (D (m, 3, total dofs): u^a - u^b at each curved node over the planar part, n_p, gap (m,),
    points (m, 3), shares (m,) m^2) from the meshes alone (module docstring). A rigid pair is the floor of
    :func:`capped_pair` (the plane z = -0.5 L, normal +z): its rows the body's nodes on it, u^a - u^b = u^a."""
    bodies = list(scene.bodies)
    offsets = np.concatenate([[0], np.cumsum([3 * len(b.mesh.points) for b in bodies])])
    out = []
    for pair, itf in zip(scene.contacts, scene.interfaces):
        if itf.rigid:
            kc, pc, kp = bodies.index(pair.body_a), pair.part_a, None
            n_p = np.array([0.0, 0.0, 1.0])
            level, curved = float(np.asarray(bodies[kc].mesh.points)[:, 2].min()), 0
        else:
            sides = [(bodies.index(pair.body_a), pair.part_a), (bodies.index(pair.other), pair.part_b)]
            curved = itf.curved
            (kp, pp), (kc, pc) = sides[1 - curved], sides[curved]
            plane = bodies[kp].mesh.triangulation
            faces = np.asarray(plane.boundary(pp))
            P = np.asarray(plane.points, dtype=float)[faces]
            n_p = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]).sum(axis=0)
            n_p /= np.linalg.norm(n_p)
            if (P.mean(axis=(0, 1)) - np.asarray(plane.points).mean(axis=0)) @ n_p < 0:     # outward
                n_p = -n_p
            level = float((P.reshape(-1, 3) @ n_p).mean())
            # each face's least-squares map to its (lambda_1, lambda_2) (the pseudo-inverse of its edge vectors)
            pinv = np.linalg.pinv(np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]], axis=2))       # (faces, 2, 3)
        cmesh = bodies[kc].mesh.triangulation
        cf = np.asarray(cmesh.boundary(pc))
        cpts = np.asarray(cmesh.points, dtype=float)
        Q = cpts[cf]
        share = np.zeros(len(cpts))
        np.add.at(share, cf.ravel(), np.repeat(0.5 * np.linalg.norm(np.cross(Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0]),
                                                                    axis=1) / 3, 3))
        sign = 1.0 if curved == 1 else -1.0               # planar body first: u^a - u^b = u^p(X) - u^c(x)
        D, gap, pts, w = [], [], [], []
        for a in np.unique(cf):
            row = np.zeros((3, offsets[-1]))
            if kp is not None:
                X = cpts[a] - (cpts[a] @ n_p - level) * n_p
                lam = np.einsum("fij,fj->fi", pinv, X - P[:, 0])                # on every face at once
                bary = np.column_stack([1.0 - lam.sum(axis=1), lam])
                inside = bary.min(axis=1) >= -1e-10
                if not inside.any():
                    continue                              # misses the planar part: free, no row
                j = int(np.argmax(inside))                        # the first face that holds it
                f, bary = faces[j], bary[j]
                for i in range(3):
                    row[i, offsets[kp] + 3 * f + i] += sign * bary
            for i in range(3):
                row[i, offsets[kc] + 3 * a + i] -= sign
            D.append(row)
            gap.append(cpts[a] @ n_p - level)
            pts.append(cpts[a])
            w.append(share[a])
        out.append((np.array(D), n_p, np.array(gap), np.array(pts), np.array(w), sign))
    return out


def _certificate(sol):
    """The optimality conditions of the law posed by :func:`_rows` at the answer's displacements (module
    docstring), and the package's read-back against the multipliers: a dict of dimensionless measures."""
    scene = sol.scene
    systems = _systems(scene)
    Tu = sla.block_diag(*[s.Tu.toarray() for s in systems])
    U = np.concatenate([np.asarray(u).ravel() for u in sol.u])
    u0 = np.concatenate([s.u_fixed for s in systems])
    v = np.linalg.lstsq(Tu, U - u0, rcond=None)[0]
    Kv = Tu.T @ np.concatenate([s.Kuu @ (Tu_k @ vk) for s, Tu_k, vk in
                                zip(systems, [s.Tu.toarray() for s in systems],
                                    np.split(v, np.cumsum([s.Tu.shape[1] for s in systems])[:-1]))])
    coupled = [s.Kup @ (np.asarray(p).ravel() - s.phi_fixed) if s.Kup is not None and p is not None
               else np.zeros(s.Kuu.shape[0]) for s, p in zip(systems, sol.phi)]
    residual_force = Kv + Tu.T @ np.concatenate(coupled) - Tu.T @ np.concatenate([s.f for s in systems])
    rows = _rows(scene)
    cols, frames = [], []
    for D, n_p, gap, pts, w, sign in rows:
        B = np.linalg.svd(np.eye(3) - np.outer(n_p, n_p))[0][:, :2].T           # our own basis of the plane
        frames.append(B)
        cols.append((sign * np.einsum("k,akd->ad", n_p, D), np.einsum("jk,akd->ajd", B, D)))
    A = np.vstack([N for N, _ in cols] + [T[:, j] for _, T in cols for j in range(2)]).T
    A = Tu.T @ A
    mult = np.linalg.lstsq(A, -residual_force, rcond=None)[0]
    F = max(float(np.abs(Tu.T @ np.concatenate([s.f for s in systems])).max()), float(np.abs(Kv).max()))
    out = {"stationarity": float(np.abs(A @ mult + residual_force).max()) / F}
    m = [len(r[0]) for r in rows]
    y_all, q_all = np.split(mult[:sum(m)], np.cumsum(m)[:-1]), mult[sum(m):]
    scale_u = max(float(np.abs(u).max()) for u in sol.u)
    q_at, worst = 0, {k: 0.0 for k in ("tension", "penetration", "complementarity", "cone", "direction",
                                        "normal force", "shear force")}
    for i, ((D, n_p, gap, pts, w, sign), (N, T), B, y) in enumerate(zip(rows, cols, frames, y_all)):
        q = np.column_stack([q_all[q_at:q_at + m[i]], q_all[q_at + m[i]:q_at + 2 * m[i]]])
        q_at += 2 * m[i]
        law = scene.contacts[i].law
        cap = (law.coefficient * y if isinstance(law, cc.Coulomb) else
               law.threshold * w if isinstance(law, cc.Tresca) else np.zeros(len(y)))
        s = np.einsum("jk,akd,d->aj", B, D, U)
        open_ = gap - N @ U
        C = max(float(np.abs(y).max()), float(cap.max(initial=0.0)), np.finfo(float).tiny)
        sn, qn = np.linalg.norm(s, axis=1), np.linalg.norm(q, axis=1)
        slides = (sn > 1e-8 * scale_u) & (cap > 0)
        c = sol.contacts[i]
        at = [int(np.argmin(np.linalg.norm(np.asarray(c.points) - p, axis=1))) for p in pts]
        assert np.abs(np.asarray(c.points)[at] - pts).max() <= 1e-12 * np.abs(pts).max()
        assert len(c.force) == len(pts), "a row at a node whose projection misses the planar part"
        shear = (np.zeros((len(y), 3)) if c.shear_force is None
                 else np.asarray(c.shear_force)[at] @ np.asarray(sol.scene.interfaces[i].frame))
        for key, value in (("tension", float(np.maximum(-y, 0).max()) / C),
                           ("penetration", float(np.maximum(-open_, 0).max()) / scale_u),
                           ("complementarity", float(np.abs(y * open_).max()) / (C * scale_u)),
                           ("cone", float(np.maximum(qn - cap, 0).max()) / C),
                           ("direction", float(np.abs(q[slides] - cap[slides, None] * s[slides]
                                                      / sn[slides, None]).max(initial=0.0)) / C),
                           ("normal force", float(np.abs(np.asarray(c.force)[at] - y).max()) / C),
                           ("shear force", float(np.abs(shear + q @ B).max()) / C)):
            worst[key] = max(worst[key], value)
        worst.setdefault("sliding", 0)
        worst["sliding"] += int(slides.sum())
    out.update(worst)
    return out


def _certified(sol, sliding=True):
    assert sol.ok
    cert = _certificate(sol)
    for key, value in cert.items():
        if key != "sliding":
            assert value <= TOL, (key, cert)
    if sliding:
        assert cert["sliding"] >= 1, cert
    return cert


def _capped(once, law, swap=False, turned=False):
    """``cc.solve(capped_pair(law, s=S, swap=swap, turn=rotation() if turned else None))`` once per module: several
    tests read the same answer."""
    return once(("capped", law, swap, turned),
                lambda: cc.solve(capped_pair(law, s=S, swap=swap, turn=rotation() if turned else None)))


OFF_CENTRE = {"radius": 3.0, "centre": (0.3, 0.65), "d": 6e-3, "s": 5e-4, "n": (6, 6)}
"""The cap of radius 3 m whose lowest point is no node, pressed 6 mm, slid 0.5 mm (6 x 6 cells each)."""


def _off_centre(once, law):
    """``cc.solve(capped_pair(law, **OFF_CENTRE))`` once per module (two tests read it)."""
    return once(("off-centre", law), lambda: cc.solve(capped_pair(law, **OFF_CENTRE)))


@pytest.mark.parametrize("turned", [False, True], ids=["axes", "turned"])
@pytest.mark.parametrize("swap", [False, True], ids=["planar-first", "curved-first"])
@pytest.mark.parametrize("name", LAWS)
def test_the_answer_solves_the_law_posed_from_the_geometry(name, swap, turned, once):
    """Either body first, the plane's normal along z or along no axis (a generic rotation): the answer satisfies
    the optimality conditions of the independently posed law, and the package's frame is an orthonormal basis of
    the plane (measured: stationarity 1.3e-15, penetration 2.1e-13 and complementarity 1.7e-13 turned, shear
    force 2.1e-15; Tresca 10, Coulomb 16 to 19 loaded rows slide)."""
    sol = _capped(once, LAWS[name], swap, turned)
    itf = sol.scene.interfaces[0]
    frame, normal = np.asarray(itf.frame), np.asarray(itf.normal)
    assert np.abs(frame @ frame.T - np.eye(2)).max() <= 1e-14 and np.abs(frame @ normal).max() <= 1e-14
    assert sol.info.method == "full"
    _certified(sol)


@pytest.mark.parametrize("name", LAWS)
def test_nodes_missing_the_planar_part_have_no_row(name):
    """The upper block wider than the lower ((-0.25, 1.25)^2, 6 x 6 cells): 24 of its 49 bottom nodes project
    outside the lower top and are free; the answer solves the law posed on the 25 others only (a friction force
    at a free node, which slides with the block, would break the stationarity; measured 1.1e-15)."""
    sc = capped_pair(LAWS[name], s=S, n=(6, 6), span=(-0.25, 1.25))
    sol = cc.solve(sc)
    nodes = np.unique(np.asarray(sc.bodies[1].mesh.triangulation.boundary("bottom")))
    assert (len(nodes), sc.interfaces[0].size, len(sol.contact.shear_force)) == (49, 25, 25)
    _certified(sol)


def test_coulomb_on_a_dragged_cap_carries_mu_times_the_load():
    """The cap dragged 5 mm along x (every loaded row slides): the friction forces' magnitudes sum to mu times
    the normal forces' sum, and their resultant is at most that (measured ratios 1 - 2.2e-16 and 1 - 1.1e-6;
    certificate at most 2e-14)."""
    sol = cc.solve(capped_pair(COULOMB, s=5e-3))
    c = sol.contact
    loaded = c.force > 1e-9 * c.force.max()
    assert loaded.sum() >= 5 and (np.linalg.norm(c.slip[loaded], axis=1) > 1e-6 * 5e-3).all()
    total = COULOMB.coefficient * float(c.force.sum())
    assert float(np.linalg.norm(c.shear_force, axis=1).sum()) == pytest.approx(total, rel=1e-12)
    assert 0.9 * total < float(np.linalg.norm(c.shear_force.sum(axis=0))) <= total * (1 + 1e-12)
    _certified(sol)


@pytest.mark.parametrize("volts", [0.0, 200.0])
@pytest.mark.parametrize("name", LAWS)
def test_a_piezoelectric_curved_body_with_friction(name, volts):
    """Both blocks PZT-5A, the upper's top at 0 or 200 V: the mechanical stationarity with the coupling
    K_up (phi - phi_fixed) at the answer's potentials (measured 6.7e-16; with the coupling's sign flipped 3e-2),
    and the law's conditions (Coulomb: 10 and 8 loaded rows slide; Tresca 8 MPa: every row sticks)."""
    sol = cc.solve(capped_pair(LAWS[name], s=S, piezo=True, volts=volts))
    assert all(p is not None for p in sol.phi)
    _certified(sol, sliding=name == "coulomb")


@pytest.mark.parametrize("name", LAWS)
def test_numbering_and_units_do_not_change_the_answer(name, once):
    """Both meshes renumbered at random: the same answer (measured 9e-16 of the displacement scale); every length
    times 1e-3 (d, s too; g and mu unchanged): the displacements times 1e-3 and the forces times 1e-6 (measured
    1.3e-15, 3.3e-15); each certified (at most 7.8e-15)."""
    law = LAWS[name]
    base = _capped(once, law)
    scale = float(np.abs(base.u[1]).max())
    sol = cc.solve(capped_pair(law, s=S, order=7))
    rng = np.random.default_rng(7)
    order = [rng.permutation(len(u)) for u in base.u]
    assert max(float(np.abs(u - v[o]).max()) for u, v, o in zip(sol.u, base.u, order)) <= 1e-12 * scale
    _certified(sol)
    small = cc.solve(capped_pair(law, s=1e-3 * S, d=3e-7, length=1e-3))
    assert max(float(np.abs(1e3 * u - v).max()) for u, v in zip(small.u, base.u)) <= 1e-12 * scale
    F = float(np.abs(base.contact.shear_force).max())
    np.testing.assert_allclose(1e6 * small.contact.shear_force, base.contact.shear_force, rtol=0, atol=1e-12 * F)
    _certified(small)


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")     # 3 loaded nodes: deliberately coarse
@pytest.mark.parametrize("name", LAWS)
def test_a_strongly_curved_off_centre_cap(name, once):
    """A cap of radius 3 m whose lowest point (0.3, 0.65) is no node (its faces tilted up to 16 degrees from the
    plane), pressed 6 mm: certified (measured stationarity 1.2e-15, complementarity 8.6e-15)."""
    _certified(_off_centre(once, LAWS[name]))


@pytest.mark.parametrize("laws", [(TRESCA, COULOMB), (None, TRESCA)], ids=["tresca-coulomb", "none-tresca"])
def test_two_curved_pairs_on_one_plane(laws):
    """Two caps on one block, each its own pair (the slip rows of both stacked component-major), one law each
    (a frictionless pair beside a Tresca one; 7 loaded rows each): certified (measured stationarity 8.6e-16)."""
    _certified(cc.solve(two_caps(laws, radius=200.0)))


def test_the_shear_traction_is_the_force_over_the_curved_areas():
    """ContactResult.shear (Pa) is each row's shear force over a third of the curved faces' true areas at its
    node; Tresca's sliding rows read g, Coulomb's threshold is mu times the pressure read the same way."""
    for law in (TRESCA, COULOMB):
        sc = capped_pair(law, s=S)
        sol = cc.solve(sc)
        c = sol.contact
        (_, _, _, pts, w, _), = _rows(sc)
        at = [int(np.argmin(np.linalg.norm(c.points - p, axis=1))) for p in pts]
        np.testing.assert_allclose(c.shear[at] * w[:, None], c.shear_force[at], rtol=1e-13,
                                   atol=1e-13 * float(np.abs(c.shear_force).max()))
        np.testing.assert_allclose(c.pressure[at] * w, c.force[at], rtol=1e-13, atol=1e-13 * float(c.force.max()))
        slides = np.linalg.norm(c.slip, axis=1) > 1e-8 * S
        if isinstance(law, cc.Tresca):
            np.testing.assert_allclose(np.linalg.norm(c.shear[slides], axis=1), law.threshold, rtol=1e-12)
        else:
            np.testing.assert_allclose(c.threshold, law.coefficient * c.pressure, rtol=1e-14, atol=0)


@pytest.mark.parametrize("method", ["sparse", "condensed", "amg", "newton"])
def test_other_routes_refuse_the_curved_pair_with_friction(method):
    """Only the full program poses a friction law: every other route refuses with a typed error naming the way
    out; ``auto`` takes ``full``."""
    sc = capped_pair(TRESCA, s=S)
    with pytest.raises(cc.SolverError, match="use method='auto' or 'full'"):
        cc.solve(sc, method=method)
    assert cc.solve(sc).info.method == "full"


def test_the_estimate_counts_the_friction_invariantly(once):
    """sol.estimate with friction on the curved pair: Tresca's g = 0 gives the frictionless estimate; the pair
    posed from the curved body or the scene turned gives the same estimate (measured 4.4e-16, 0 and 3.8e-14
    relative); the friction terms move it (by 3.2 % Tresca 8 MPa, 2.5 % Coulomb 0.15)."""
    def est(law, swap=False, turned=False):
        e = _capped(once, law, swap, turned).estimate
        assert e is not None
        return e.absolute, e.norm

    free, zero = est(law=None), est(law=cc.Tresca(threshold=0.0))
    assert zero == pytest.approx(free, rel=1e-12)
    for law in (TRESCA, COULOMB):
        ref = est(law=law)
        assert ref[0] != pytest.approx(free[0], rel=1e-3)            # the friction terms count
        assert est(law=law, swap=True) == pytest.approx(ref, rel=1e-12)
        assert est(law=law, turned=True) == pytest.approx(ref, rel=1e-10)


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")     # 3 loaded nodes: deliberately coarse
def test_tresca_acts_on_rows_far_above_the_plane(once):
    """Tresca's capacity g w_a acts on every node over the planar part, open or not (docs/howto/friction.md): on
    the off-centre cap of radius 3 m slid 0.5 mm, 42 of the 49 rows lie over 1 cm above the plane (up to 0.156 m),
    every row slides and carries its full capacity (measured: 6.6 of the 8.1 MN of friction on those rows, the
    normal force 154 MN on 3 loaded rows); Coulomb puts none there."""
    sc = capped_pair(TRESCA, **OFF_CENTRE)
    sol = _off_centre(once, TRESCA)
    c = sol.contact
    (_, _, gap, pts, w, _), = _rows(sc)
    at = [int(np.argmin(np.linalg.norm(c.points - p, axis=1))) for p in pts]
    far = gap > 0.01
    assert far.sum() == 42 and float(np.abs(c.force[at][far]).max()) <= 1e-12 * float(c.force.max())   # measured 0
    np.testing.assert_allclose(np.linalg.norm(c.shear_force[at][far], axis=1), TRESCA.threshold * w[far],
                               rtol=1e-12)                                       # measured 4e-16
    coulomb = _off_centre(once, COULOMB).contact
    assert float(np.abs(coulomb.shear_force[at][far]).max()) <= 1e-12 * float(np.abs(coulomb.shear_force).max())  # 0


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")     # coarse on purpose
@pytest.mark.parametrize("swap", [False, True], ids=["lower-first", "upper-first"])
@pytest.mark.parametrize("name", LAWS)
def test_a_curved_lower_body_under_a_planar_one(name, swap):
    """The curved part on the clamped lower block (a dome of radius 500 m, 6 x 6 cells) and the planar part facing
    down (the upper block's flat bottom, 4 x 4 cells, or 2 x 2 cells over an 8 x 8 dome: many curved nodes per
    planar face; 21 to 33 loaded rows), the top moved by (1e-4, 0, -3e-4) m: certified (measured at most 3.1e-15)."""
    for n in ((6, 4), (8, 2)):
        sol = cc.solve(capped_pair(LAWS[name], s=S, dome=500.0, n=n, swap=swap))
        assert sol.scene.interfaces[0].curved == (1 if swap else 0)
        _certified(sol)


@pytest.mark.parametrize("name", LAWS)
def test_a_curved_pair_beside_a_rigid_floor_with_friction(name):
    """The lower block clamped on one side and resting on a rigid floor under Tresca 2 MPa, the curved pair above
    under ``name``: two interfaces of different kinds, their slip rows stacked (component-major) in one program;
    both certified (measured at most 4.8e-13, the floor's Tresca cone; 9 and 42 loaded rows)."""
    sol = cc.solve(capped_pair(LAWS[name], s=S, floor=cc.Tresca(threshold=2e6)))
    assert [type(i).__name__ for i in sol.scene.interfaces] == ["CurvedSurfaceInterface", "SurfaceInterface"]
    _certified(sol)


@pytest.mark.parametrize("name", LAWS)
def test_a_curved_block_held_by_its_friction_alone(name):
    """The upper block loaded on its top by (1e5, 0, -1e7) Pa and held by nothing else (its rigid motions along the
    plane held by the friction): certified (measured at most 3.0e-15); Coulomb mu = 0.3 under a shear load of
    half the normal one cannot hold it: a SceneError naming the slide."""
    _certified(cc.solve(capped_pair(LAWS[name], traction=(1e5, 0.0, -1e7))), sliding=name == "coulomb")
    with pytest.raises(cc.SceneError, match="exceeds the friction capacity"):
        cc.solve(capped_pair(cc.Coulomb(coefficient=0.3), traction=(5e6, 0.0, -1e7)))
