"""3D bodies: tetrahedral P1 (and P2) assembly of Kuu, Kup, Kpp and the loads, the supports' prolongation and
the rigid motions, checked without contact by solving the bonded linear system directly: patch tests (uniaxial
strain, the open-circuit PZT-5A stiffening), the plane-strain limit of a y-uniform block, the invariance under a
generic rotation, exact linear and quadratic fields (P2)."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import cvxcontact as cc
from cvxcontact.errors import SceneError, SolverError
from cvxcontact.fem import p2
from cvxcontact.fem.assembly import assemble
from cvxcontact.fem.fields import body_fields
from cvxcontact.fem.space import space
from cvxcontact.geometry.quadratic import P2Nodes, P2TetNodes as TetNodes

box = cc.box

PZT = cc.materials.PZT5A
TRANSVERSE = cc.materials.Elastic(PZT.c3, name="PZT-5A elastic part")      # transversely isotropic, no coupling
SIDES = ["left", "right", "front", "back"]


def solve(system, dim=3):
    """(u (n, dim), phi (n,)) of the bonded system: the reduced equations (module docstring of fem/assembly.py)
    T_u^T (Kuu u + Kup phi - f) = 0, T_p^T (Kup^T u - Kpp phi + q) + ... = 0, by a sparse LU, the potential
    unknowns scaled to the displacements' magnitude."""
    Tu, fz = system.Tu, system.reduced_loads()[0]
    K = (Tu.T @ system.Kuu @ Tu).tocsc()
    if not system.piezoelectric:
        z = spla.spsolve(K, fz)
        return (Tu @ z + system.u_fixed).reshape(-1, dim), None
    Tp, qz = system.Tp, system.reduced_loads()[1]
    C, P = Tu.T @ system.Kup @ Tp, Tp.T @ system.Kpp @ Tp
    s = np.sqrt(abs(K.diagonal()).mean() / abs(P.diagonal()).mean())            # phi = s * w
    A = sp.bmat([[K, s * C], [s * C.T, -s * s * P]], format="csc")
    z = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,           # quasi-definite: no pivoting
                  options=dict(SymmetricMode=True)).solve(np.concatenate([fz, -s * qz]))
    u = Tu @ z[:K.shape[0]] + system.u_fixed
    phi = Tp @ (s * z[K.shape[0]:]) + system.phi_fixed
    return u.reshape(-1, dim), phi


def rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


# ------------------------------------------------------------------ operators


def test_free_body_stiffness_has_exactly_the_six_rigid_motions():
    m = box(x=(0, 1), y=(0, 0.6), z=(0, 0.8), nx=2, ny=2, nz=2)
    body = cc.Body(m, PZT.rotated(np.pi / 5), grounded=["bottom"])
    assert len(body.held_by_contact) == 6
    s = assemble(body)
    K = s.Kuu.toarray()
    assert np.abs(K - K.T).max() <= 1e-15 * np.abs(K).max()                    # measured 3e-17
    ev = np.linalg.eigvalsh(K) / np.abs(K).max()
    assert (np.abs(ev[:6]) <= 1e-13).all() and ev[6] >= 1e-4               # measured |ev[:6]| <= 6e-17, ev[6] 1.1e-2
    # the six zero modes are the rigid motions: K R = 0 for the nodal fields of held_modes
    R = body.held_modes()
    assert R.shape == (6, 3 * len(m.points))
    assert np.abs(K @ R.T).max() <= 1e-12 * np.abs(K).max() * np.abs(R).max()   # measured 2.5e-16
    # Kpp: one constant null mode before grounding, SPD after (the grounded bottom removed by T_p)
    P = s.Kpp.toarray()
    assert np.abs(P @ np.ones(len(P))).max() <= 1e-14 * np.abs(P).max()
    Pr = (s.Tp.T @ s.Kpp @ s.Tp).toarray()
    assert np.abs(Pr - Pr.T).max() <= 1e-15 * np.abs(Pr).max()                  # measured 1.5e-17
    assert np.linalg.eigvalsh(Pr).min() > 1e-3 * np.abs(Pr).max()                # measured 0.017


def test_roller_columns_and_rigid_motions_named_in_3d():
    m = box(nx=2, ny=2, nz=2)
    body = cc.Body(m, TRANSVERSE, roller=["bottom", "left", "front"])
    free, directions, _ = body.node_supports()
    p = m.points
    on = {f: np.isin(np.arange(len(p)), m.boundary_nodes([f])) for f in ("bottom", "left", "front")}
    count = sum(on.values())
    assert np.array_equal(free, 3 - count)                                   # 1 face: 2 columns, 2: 1, 3: none
    edge = np.flatnonzero(on["bottom"] & on["left"] & ~on["front"])
    assert np.allclose(np.abs(directions[edge, 0]), [0, 1, 0])                # the bottom-left edge slides along y
    # three orthogonal roller faces hold translations and rotations alike: nothing is free
    assert body.held_by_contact == ()
    # on the bottom alone: two in-plane translations and the rotation about z are free
    names = cc.Body(m, TRANSVERSE, roller=["bottom"]).free_motions()
    assert sorted(names) == sorted(["translation along x", "translation along y",
                                    "rotation about z through (0.5, 0.5, 0.5) m"]), names
    s = assemble(cc.Body(m, TRANSVERSE, roller=["bottom", "left", "front"]))
    assert s.Tu.shape == (3 * len(p), int(free.sum()))
    T = s.Tu.toarray()
    assert np.abs(T.T @ T - np.eye(T.shape[1])).max() <= 1e-15             # orthonormal columns


def test_refusals_in_3d():
    m = box(nx=1, ny=1, nz=1)
    plane_only = cc.materials.Piezoelectric(c11=1e11, c13=7e10, c33=1e11, c44=2e10, e31=-5, e33=15, e15=12,
                                            eps11=1e-8, eps33=1e-8)
    with pytest.raises(cc.errors.MaterialError, match="no 3D constants"):
        cc.Body(m, plane_only, grounded=["bottom"])
    with pytest.raises(SceneError, match=r"3 components"):
        cc.Body(m, TRANSVERSE, clamped=["bottom"], body_force=(0.0, 1.0))
    with pytest.raises(SceneError, match=r"triple \(ux, uy, uz\)"):
        cc.Body(m, TRANSVERSE, displacement={"bottom": (0.0, 0.0)})
    with pytest.raises(SceneError, match="all components are None"):
        cc.Body(m, TRANSVERSE, displacement={"bottom": (None, None, None)})
    lower = cc.Body(box(nx=1, ny=1, nz=1), TRANSVERSE, clamped=["bottom"], contact="top", name="lower")
    upper = cc.Body(box(nx=1, ny=1, nz=1, z=(1, 2)), TRANSVERSE, clamped=["top"], contact="bottom", name="upper")
    lines = space(2, "tetra").contact(cc.Scene(lower, upper), "gamma3", cc.Signorini())     # the copositive condition
    assert lines.cone is not None and lines.cone[1].shape[1] == 6
    with pytest.raises(SolverError, match="tetra cells in the space P1"):
        space(1).assemble_matrices(cc.Body(m, TRANSVERSE, clamped=["bottom"]))
    assert space(2, "tetra").dim == 3 and space(1).dim == 2


# ------------------------------------------------------------------ patch tests (exact to rounding)


def test_uniaxial_strain_block_under_pressure():
    """Rollers on the four sides and the bottom, pressure p on top: u_z = -p z / c33, u_x = u_y = 0,
    sigma_zz = -p and sigma_xx = sigma_yy = -p c13 / c33 in every tetrahedron."""
    p = 2e6
    m = box(x=(0, 0.3), y=(0, 0.2), z=(0, 0.25), nx=3, ny=2, nz=3)
    body = cc.Body(m, TRANSVERSE, roller=SIDES + ["bottom"], traction={"top": (0.0, 0.0, -p)})
    u, _ = solve(assemble(body))
    c13, c33 = PZT.c3[0, 2], PZT.c3[2, 2]
    z = m.points[:, 2]
    assert rel(u[:, 2], -p * z / c33) <= 1e-12                                 # measured 1.5e-15
    assert np.abs(u[:, :2]).max() <= 1e-12 * np.abs(u[:, 2]).max()
    f = body_fields(body, u, None)
    assert rel(f.stress[:, 2], np.full(len(m.tets), -p)) <= 1e-12                 # measured 2.9e-15
    assert rel(f.stress[:, :2], np.full((len(m.tets), 2), -p * c13 / c33)) <= 1e-12  # measured 2.9e-15
    assert np.abs(f.stress[:, 3:]).max() <= 1e-12 * p                             # measured 6.4e-16


def test_open_circuit_pzt_block_is_stiffened_by_e33_squared_over_eps33():
    """PZT-5A poled along z, rollers on the sides and bottom, grounded bottom, an open-circuit floating top
    electrode, pressure p on top: eps_zz = -p / (c33 + e33^2 / eps33), D_z = 0, phi = -E_z z with
    E_z = -e33 eps_zz / eps33, sigma_xx = c13 eps_zz - e31 E_z."""
    p = 5e6
    m = box(x=(0, 0.2), y=(0, 0.3), z=(0, 0.1), nx=2, ny=3, nz=2)
    body = cc.Body(m, PZT, roller=SIDES + ["bottom"], grounded=["bottom"], floating={"top": 0.0},
                   traction={"top": (0.0, 0.0, -p)})
    u, phi = solve(assemble(body))
    c13, c33, e31, e33, k33 = PZT.c3[0, 2], PZT.c3[2, 2], PZT.e3[2, 0], PZT.e3[2, 2], PZT.kappa3[2, 2]
    ezz = -p / (c33 + e33 ** 2 / k33)
    Ez = -e33 * ezz / k33
    z = m.points[:, 2]
    assert rel(u[:, 2], ezz * z) <= 1e-10                                      # measured 7e-16
    assert rel(phi, -Ez * z) <= 1e-10                                          # measured 8.6e-16
    f = body_fields(body, u, phi)
    assert np.abs(f.electric_displacement).max() <= 1e-10 * abs(e33 * ezz)     # D = 0 (open circuit)
    assert rel(f.stress[:, 2], np.full(len(m.tets), -p)) <= 1e-10
    assert rel(f.stress[:, 0], np.full(len(m.tets), c13 * ezz - e31 * Ez)) <= 1e-10
    # stiffer than the short-circuited block (c33 alone) by the closed-form factor
    assert abs(c33 / (c33 + e33 ** 2 / k33) - ezz / (-p / c33)) <= 1e-15


def _random_fields(seed, quadratic):
    """u (x) = a + A x (+ 1/2 x^T H_i x), phi(x) = b + g . x (+ 1/2 x^T P x): coefficients of magnitude 1e-3 m
    and 1e3 V over a unit box."""
    rng = np.random.default_rng(seed)
    a, A, b, g = 1e-3 * rng.normal(size=3), 1e-3 * rng.normal(size=(3, 3)), 1e3 * rng.normal(), 1e3 * rng.normal(size=3)
    H = 1e-3 * rng.normal(size=(3, 3, 3)) * quadratic
    H = H + np.swapaxes(H, 1, 2)
    P = 1e3 * rng.normal(size=(3, 3)) * quadratic
    P = P + P.T
    u = lambda x: a + x @ A.T + 0.5 * np.einsum("ijk,nj,nk->ni", H, x, x)     # noqa: E731
    phi = lambda x: b + x @ g + 0.5 * np.einsum("jk,nj,nk->n", P, x, x)         # noqa: E731
    grad_u = lambda x: A[None] + np.einsum("ijk,nk->nij", H, x)                 # noqa: E731
    grad_phi = lambda x: g + x @ P                                              # noqa: E731
    return u, phi, grad_u, grad_phi


def _sources(mat, grad_u, grad_phi):
    """The constant body force f0 = -div sigma and volume charge q0 = div D of quadratic fields, from the
    constitutive law at the origin and the unit points (sigma and D are affine)."""
    pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]

    def laws(x):
        G = grad_u(x[None])[0]
        eps = np.array([G[i, j] + G[j, i] if i != j else G[i, i] for i, j in pairs])
        E = -grad_phi(x[None])[0]
        s = mat.c3 @ eps - mat.e3.T @ E
        sig = np.zeros((3, 3))
        for k, (i, j) in enumerate(pairs):
            sig[i, j] = sig[j, i] = s[k]
        return sig, mat.e3 @ eps + mat.kappa3 @ E

    s0, d0 = laws(np.zeros(3))
    div_s = sum(laws(np.eye(3)[j])[0][:, j] - s0[:, j] for j in range(3))
    div_d = sum(laws(np.eye(3)[j])[1][j] - d0[j] for j in range(3))
    return -div_s, div_d


def _dirichlet_solve(system, points, boundary, u_b, phi_b):
    """Interior values of the assembled (unreduced) system with u and phi given on the boundary nodes."""
    n = len(points)
    inner = np.setdiff1d(np.arange(n), boundary)
    ui = (3 * inner[:, None] + np.arange(3)).ravel()
    ub = (3 * boundary[:, None] + np.arange(3)).ravel()
    K, C, P = system.Kuu.tocsr(), system.Kup.tocsr(), system.Kpp.tocsr()
    s = np.sqrt(abs(K.diagonal()).mean() / abs(P.diagonal()).mean())
    A = sp.bmat([[K[ui][:, ui], s * C[ui][:, inner]], [s * C[ui][:, inner].T, -s * s * P[inner][:, inner]]], format="csc")
    rhs = np.concatenate([system.f[ui] - K[ui][:, ub] @ u_b.ravel() - C[ui][:, boundary] @ phi_b,
                          s * (-system.q[inner] - C[ub][:, inner].T @ u_b.ravel() + P[inner][:, boundary] @ phi_b)])
    z = spla.spsolve(A, rhs)
    return inner, z[:len(ui)].reshape(-1, 3), s * z[len(ui):]


@pytest.mark.parametrize("degree,quadratic", [(1, False), (2, False), (2, True)],
                         ids=["P1-linear", "P2-linear", "P2-quadratic"])
def test_polynomial_fields_are_reproduced_exactly(degree, quadratic):
    """Coupled fields given on the boundary of a distorted box, with the body force and volume charge of the
    fields: P1 reproduces affine fields, P2 quadratic ones, at every interior node, to rounding."""
    mat = PZT.rotated(np.array([[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]]))
    mesh = box(nx=3, ny=3, nz=3)
    x = mesh.points
    mesh = mesh.with_points(x + 0.08 * np.sin(3.0 * x[:, [1, 2, 0]]) * (x * (1 - x)))
    u, phi, grad_u, grad_phi = _random_fields(7, quadratic)
    f0, q0 = _sources(mat, grad_u, grad_phi)
    body = cc.Body(mesh, mat, grounded=["bottom"], body_force=tuple(f0), volume_charge=float(q0))
    if degree == 1:
        nodes, system = mesh, assemble(body)
    else:
        nodes = TetNodes(mesh)
        system = p2.assemble(body, nodes)
    pts = nodes.points
    boundary = nodes.boundary_nodes(list(mesh.tags))
    inner, u_in, phi_in = _dirichlet_solve(system, pts, boundary, u(pts[boundary]), phi(pts[boundary]))
    assert len(inner) > 0
    assert rel(u_in, u(pts[inner])) <= 1e-9                      # measured P1 7e-16, P2 1.5e-15 / 1.1e-15
    assert rel(phi_in, phi(pts[inner])) <= 1e-9                  # measured P1 1.8e-12, P2 8.7e-12 / 9.4e-12 (P1 on the
    # quadratic fields: 9e-4 and 2.2)


# ------------------------------------------------------------------ invariance and limits


def _generic_rotation():
    """A rotation about no coordinate axis (QR of a fixed random matrix, det +1)."""
    Q, r = np.linalg.qr(np.random.default_rng(11).normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(r))
    return Q if np.linalg.det(Q) > 0 else -Q


@pytest.mark.parametrize("degree", [1, 2])
def test_turned_body_gives_the_turned_solution(degree):
    """Mesh, material, supports and loads turned by a generic rotation R: u'(R x) = R u(x), phi'(R x) = phi(x)."""
    R = _generic_rotation()
    assert min(abs(R[i, i]) for i in range(3)) < 0.99 and np.abs(R @ R.T - np.eye(3)).max() < 1e-15

    def body(turn):
        Rt = R if turn else np.eye(3)
        mesh = box(x=(0, 0.4), y=(0, 0.3), z=(0, 0.2), nx=3, ny=2, nz=2)
        mesh = mesh.with_points(mesh.points @ Rt.T)
        back = lambda x, y, z: np.stack([x, y, z], axis=-1) @ Rt                      # noqa: E731 (R^T x')
        turned = lambda v: tuple(np.moveaxis(v @ Rt.T, -1, 0))                         # noqa: E731 (R v)

        def traction(x, y, z):
            X = back(x, y, z)
            return turned(np.stack([1e6 * X[..., 1], -2e6 + 1e6 * X[..., 0], 5e5 * np.ones_like(x)], axis=-1))

        return cc.Body(mesh, PZT.rotated(Rt), clamped=["bottom"], roller=["left"], grounded=["bottom"],
                       potential={"top": lambda x, y, z: 40.0 + 100.0 * back(x, y, z)[..., 0]},
                       traction={"right": traction}, body_force=tuple(Rt @ np.array([1e7, -3e7, 2e7])),
                       surface_charge={"front": lambda x, y, z: 1e-3 * back(x, y, z)[..., 2]})

    results = []
    for turn in (False, True):
        b = body(turn)
        system = assemble(b) if degree == 1 else p2.assemble(b, TetNodes(b.mesh))
        results.append(solve(system))
    (u0, phi0), (u1, phi1) = results
    assert np.abs(u0).max() > 0 and np.abs(phi0).max() > 0
    assert rel(u1, u0 @ R.T) <= 1e-9                                          # measured P1 2.5e-15, P2 9.7e-15
    assert rel(phi1, phi0) <= 1e-9                                            # measured P1 1.7e-15, P2 6.9e-15


def test_y_uniform_block_converges_to_the_plane_strain_section():
    """A PZT-5A block one layer thick in y with rollers on its front and back (u_y = 0), clamped and grounded at
    the bottom, a driven top electrode and a body force along -z, against the 2D plane-strain solution of its
    (x, z) section (2D y = 3D z; P2 on a fine mesh): the top-centre displacement and the centre potential of
    the 3D P2 solution converge to it. (The rollers hold u_y = 0 on both faces; the midpoints of the edges
    crossing the layer are free in y.)"""
    def section(n):
        m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=n, ny=n // 2)
        b = cc.Body(m, PZT, clamped=["bottom"], grounded=["bottom"], potential={"top": 100.0}, body_force=(0.0, -1e9))
        nodes = P2Nodes(m)
        u, phi = solve(p2.assemble(b, nodes), dim=2)
        at = lambda x: np.flatnonzero(np.linalg.norm(nodes.points - x, axis=1) < 1e-12)   # noqa: E731
        return u[at([0.5, 0.5])][0], phi[at([0.5, 0.25])][0]

    def block(n):
        m = box(x=(0, 1), y=(0, 0.1), z=(0, 0.5), nx=n, ny=1, nz=n // 2)
        b = cc.Body(m, PZT, clamped=["bottom"], roller=["front", "back"], grounded=["bottom"],
                    potential={"top": 100.0}, body_force=(0.0, 0.0, -1e9))
        nodes = TetNodes(m)
        u, phi = solve(p2.assemble(b, nodes))
        at = lambda x: np.flatnonzero(np.linalg.norm(nodes.points[:, [0, 2]] - x, axis=1) < 1e-12)  # noqa: E731
        return u[at([0.5, 0.5])][:, [0, 2]].mean(axis=0), phi[at([0.5, 0.25])].mean()

    u2, phi2 = section(64)
    errors = []
    for n in (4, 8, 16):
        u3, phi3 = block(n)
        errors.append((np.abs(u3 - u2).max() / np.abs(u2).max(), abs(phi3 - phi2) / abs(phi2)))
    eu = [e[0] for e in errors]
    assert eu[1] <= 0.6 * eu[0] and eu[2] <= 0.6 * eu[1]                  # measured 0.010, 0.0045, 0.0017
    assert eu[2] <= 0.01 and max(e[1] for e in errors[1:]) <= 0.003       # measured phi: 6.5e-4, 3.2e-4, 3.2e-4


def test_tet10_and_tet4_converge_to_one_solution():
    """A PZT-5A bar clamped and grounded at x = 0, driven at x = 1, under a body force and a shear traction:
    P1 on meshes refined twice approaches the P2 solution (tip displacement, mid potential), and P2 is closer
    to it than P1 on the mesh with as many nodes."""
    def run(n, degree):
        m = box(x=(0, 1), y=(0, 0.5), z=(0, 0.5), nx=2 * n, ny=n, nz=n)
        b = cc.Body(m, PZT, clamped=["left"], grounded=["left"], potential={"right": 50.0},
                    body_force=(0.0, 0.0, -1e8), traction={"top": lambda x, y, z: (0 * x, 1e6 * x, 0 * x)})
        nodes = m if degree == 1 else TetNodes(m)
        u, phi = solve(assemble(b) if degree == 1 else p2.assemble(b, nodes))
        at = lambda x: np.flatnonzero(np.linalg.norm(nodes.points - x, axis=1) < 1e-12)[0]   # noqa: E731
        return u[at([1, 0.25, 0.25])], phi[at([0.5, 0.25, 0.25])]

    u_ref, phi_ref = run(4, 2)

    def error(n, degree):
        u, phi = run(n, degree)
        return np.abs(u - u_ref).max() / np.abs(u_ref).max(), abs(phi - phi_ref) / abs(phi_ref)

    p1 = [error(n, 1) for n in (2, 4, 8)]
    assert p1[1][0] <= 0.6 * p1[0][0] and p1[2][0] <= 0.6 * p1[1][0]      # measured 0.32, 0.13, 0.038
    assert p1[2][1] <= 0.02                                                 # measured phi 0.021, 0.045, 0.011
    assert error(2, 2)[0] <= 0.5 * p1[1][0]     # P2 against P1 on as many nodes: measured 0.025 against 0.13


def test_fingerprint_of_a_3d_body_covers_its_tensors_not_its_loads():
    from cvxcontact.physics.fingerprint import geometry_fingerprint as fingerprint
    body = cc.Body(box(nx=1, ny=1, nz=1), PZT, clamped=["bottom"], grounded=["bottom"])
    assert fingerprint(body) == fingerprint(body.with_loads(body_force=(0.0, 0.0, 1e3)))
    turned = PZT.rotated(np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]))   # about y: 2D c differs
    about_z = PZT.rotated(np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))  # 6mm: same tensors
    assert fingerprint(body) != fingerprint(body.with_changes(material=turned))
    assert fingerprint(body) != fingerprint(body.with_changes(material=cc.materials.PZT4))
    assert np.abs(about_z.c3 - PZT.c3).max() <= 1e-15 * np.abs(PZT.c3).max()


def test_p2_free_body_stiffness_vanishes_exactly_on_the_held_modes():
    m = box(x=(0, 1), y=(0, 0.6), z=(0, 0.8), nx=1, ny=1, nz=2)
    body = cc.Body(m, TRANSVERSE.rotated(_generic_rotation()))
    nodes = TetNodes(m)
    K = p2.assemble(body, nodes).Kuu.toarray()
    R = body.held_modes(nodes)
    assert R.shape == (6, 3 * len(nodes))
    assert np.abs(K @ R.T).max() <= 1e-12 * np.abs(K).max() * np.abs(R).max()   # measured 3.6e-16
    ev = np.linalg.eigvalsh(K) / np.abs(K).max()
    assert np.abs(ev[:6]).max() <= 1e-13 and ev[6] >= 1e-4                     # measured 1.2e-16, 3.1e-3


@pytest.mark.parametrize("degree", [1, 2])
def test_consistent_loads_integrate_the_densities_exactly(degree):
    """sum_i F_i p(x_i) = int f p for every p in the element space (P1: affine, P2: quadratic), because
    sum_i N_i p(x_i) = p: with an affine (P1) or quadratic (P2) density the quadrature must be exact.
    Checked against the closed-form integrals of monomials over the box and its top face."""
    a, b, c = 0.3, 0.5, 0.4
    mesh = box(x=(0, a), y=(0, b), z=(0, c), nx=2, ny=3, nz=2)
    k = degree                                           # the density's degree
    f = lambda x, y, z: 2.0 + x - 3.0 * y + 0.5 * z + (k - 1) * (x * y - 2.0 * z * z + y * y)   # noqa: E731
    g = lambda x, y, z: 1.0 - 2.0 * x + y + (k - 1) * (3.0 * x * x - x * y)                     # noqa: E731
    body = cc.Body(mesh, PZT, grounded=["bottom"], body_force=lambda x, y, z: (f(x, y, z), 0 * x, g(x, y, z)),
                   traction={"top": lambda x, y, z: (0 * x, g(x, y, z), 0 * x)}, volume_charge=f,
                   surface_charge={"top": g})
    nodes = mesh if degree == 1 else TetNodes(mesh)
    system = assemble(body) if degree == 1 else p2.assemble(body, nodes)
    F, q = system.f.reshape(-1, 3), system.q
    x, y, z = nodes.points.T
    top = np.zeros(len(x), dtype=bool)
    top[nodes.boundary_nodes(["top"])] = True

    def box_integral(poly):                             # poly: {(i, j, l): coefficient} of x^i y^j z^l
        return sum(v * a ** (i + 1) / (i + 1) * b ** (j + 1) / (j + 1) * c ** (l + 1) / (l + 1)
                   for (i, j, l), v in poly.items())

    def top_integral(poly):                             # over z = c
        return sum(v * a ** (i + 1) / (i + 1) * b ** (j + 1) / (j + 1) * c ** l for (i, j, l), v in poly.items())

    def times(poly, p):                                  # a density times a test monomial p = (i, j, l)
        return {(i + p[0], j + p[1], l + p[2]): v for (i, j, l), v in poly.items()}

    fp = {(0, 0, 0): 2.0, (1, 0, 0): 1.0, (0, 1, 0): -3.0, (0, 0, 1): 0.5}
    gp = {(0, 0, 0): 1.0, (1, 0, 0): -2.0, (0, 1, 0): 1.0}
    if k == 2:
        fp.update({(1, 1, 0): 1.0, (0, 0, 2): -2.0, (0, 2, 0): 1.0})
        gp.update({(2, 0, 0): 3.0, (1, 1, 0): -1.0})
    tests = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)] + ([(2, 0, 0), (1, 1, 0), (0, 1, 1), (0, 0, 2)] if k == 2 else [])
    worst = 0.0
    for p in tests:
        mono = x ** p[0] * y ** p[1] * z ** p[2]
        # F_x: the body force f; F_z: the body force g; F_y: the traction g on top; q = volume f - surface g
        expect = [box_integral(times(fp, p)), top_integral(times(gp, p)), box_integral(times(gp, p)),
                  box_integral(times(fp, p)) - top_integral(times(gp, p))]
        got = [F[:, 0] @ mono, F[top, 1] @ mono[top], F[:, 2] @ mono, q @ mono]
        worst = max(worst, max(abs(u - v) / max(abs(v), 1e-3) for u, v in zip(got, expect)))
    assert worst <= 1e-13       # measured P1 5e-16, P2 1e-15 (P2 with a degree-2 volume rule: 7.6e-5)


def test_prescribed_displacement_component_lifts_the_uniaxial_solution():
    """The top moved down by d (only u_z prescribed, None = free), rollers on the sides and bottom: u_z = -d z/c,
    sigma_zz = -c33 d/c; the top's edges on a roller side keep one free column, its corners none."""
    d, c = 1e-4, 0.25
    m = box(x=(0, 0.3), y=(0, 0.2), z=(0, c), nx=2, ny=2, nz=3)
    body = cc.Body(m, TRANSVERSE, roller=SIDES + ["bottom"], displacement={"top": (None, None, -d)})
    free = body.node_supports()[0]
    top = m.boundary_nodes(["top"])
    sides = [np.isin(top, m.boundary_nodes([s])) for s in SIDES]
    assert np.array_equal(free[top], 2 - np.sum(sides, axis=0))
    u, _ = solve(assemble(body))
    assert rel(u[:, 2], -d * m.points[:, 2] / c) <= 1e-12                 # measured 4e-16
    assert np.abs(u[:, :2]).max() <= 1e-12 * d                            # measured 2.3e-16 d
    s = body_fields(body, u, None).stress
    assert rel(s[:, 2], np.full(len(s), -PZT.c3[2, 2] * d / c)) <= 1e-12   # measured 1.3e-15
