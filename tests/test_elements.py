"""Every element through the same checks (issue 31, the element seam): P1, P2 (triangles), Q1, Q2 (quadrilaterals).

Independent references: the partition of unity and the reproduction of x by the gradients at the cells' centres;
rigid motions (and, with a piezoelectric body, constant potentials) in the kernels, and no other zero-energy
mode (dense eigenvalues); Irons' patch test on distorted meshes (a field of the space's polynomial degree whose
stress and electric displacement are divergence-free, chosen from the null space of the divergence computed by
central differences, which are exact on the linear stresses: the rows of the interior nodes vanish); a layer
squeezed through contact onto a rigid floor in uniaxial strain (closed form, every condition); the observed
energy-norm rates on a smooth manufactured solution (a(u, u) by an independent 40 x 40 Gauss rule); VTU cells
VTK_QUAD (9) and VTK_BIQUADRATIC_QUAD (28) in the file's own types array; a gmsh quad9 file read back.
"""

import re

import meshio
import numpy as np
import pytest
import scipy.sparse.linalg as spla
from scipy.linalg import null_space

import cvxcontact as cc
from cvxcontact.errors import MeshError, SceneError, UnsupportedError
from cvxcontact.fem.quad import Q1_ELEMENT, Q2_ELEMENT
from cvxcontact.fem.space import space
from cvxcontact.io.output import body_mesh

pytestmark = pytest.mark.numerics   # every element through the contact finishes (every kernel set)

ELEMENTS = [("triangle", 1), ("triangle", 2), ("quad", 1), ("quad", 2), ("hex", 1), ("hex", 2)]
IDS = ["P1", "P2", "Q1", "Q2", "Q1hex", "Q2hex"]
STEEL = cc.materials.isotropic(E=200e9, nu=0.3)
ALU = cc.materials.isotropic(E=70e9, nu=0.33)
PZT = cc.materials.PZT5A


def distorted(cell, nx=3, ny=3, amount=0.25, seed=0, x=(0.0, 1.0), y=(0.0, 1.0), nz=None, z=(0.0, 1.0)):
    """A rectangle mesh (a unit box of hexahedra or tetrahedra for ``cell="hex"``/``"tetra"``, ``nz`` = ``ny`` cells
    high unless given)
    whose interior nodes are moved at random by up to ``amount`` of a cell (the sides stay straight or planar:
    one tag, one normal)."""
    if cell in ("hex", "tetra"):
        nz = ny if nz is None else nz
        mesh = cc.box(x=x, y=y, z=z, nx=nx, ny=ny, nz=nz, cell=cell)
        h = np.array([(x[1] - x[0]) / nx, (y[1] - y[0]) / ny, (z[1] - z[0]) / nz])
    else:
        mesh = cc.rectangle(x=x, y=y, nx=nx, ny=ny, cell=cell)
        h = np.array([(x[1] - x[0]) / nx, (y[1] - y[0]) / ny])
    p = mesh.points.copy()
    inside = np.ones(len(p), dtype=bool)
    inside[mesh.boundary_nodes(mesh.tags)] = False
    p[inside] += amount * h * np.random.default_rng(seed).uniform(-1, 1, (int(inside.sum()), len(h)))
    return mesh.with_points(p)


def system(body, cell, degree):
    """(space, nodes, node points, matrices with loads) of ``body``."""
    S = space(degree, cell)
    nodes = S.nodes(body)
    held = body.mesh if nodes is None else nodes
    return S, nodes, held, S.assemble_loads(body, S.assemble_matrices(body, nodes), nodes)


@pytest.mark.parametrize("cell,degree", ELEMENTS, ids=IDS)
def test_partition_of_unity_and_reproduction_of_x(cell, degree):
    """At each cell's centre the shape gradients sum to zero and map the nodes' x to the identity; the consistent
    loads of constant densities sum to density x measure (the basis integrates to the cell's area and to the
    side's length): a body force and a volume charge over the body, a traction on "top", a surface charge on
    "right" (which enters q with a minus sign: D nu = q2 is the charge leaving the body)."""
    b, t, qv, q2 = (3.0, -5.0, 19.0), (7.0, 11.0, -23.0), 13.0, 17.0
    mesh = distorted(cell)
    d = mesh.dim
    body = cc.Body(mesh, PZT, clamped=["bottom"], grounded=["bottom"], body_force=b[:d], traction={"top": t[:d]},
                   volume_charge=qv, surface_charge={"right": q2})
    S, nodes, held, sys_ = system(body, cell, degree)
    el, G = S.centre_gradients(body, nodes)
    assert np.abs(G.sum(axis=2)).max() <= 1e-12 * np.abs(G).max()                 # measured <= 2.4e-16
    X = held.points[el]                                                            # (m, k, d)
    assert np.abs(np.einsum("mdk,mke->mde", G, X) - np.eye(d)).max() <= 1e-12      # measured <= 2.2e-15
    area = (mesh.areas if d == 2 else mesh.volumes).sum()     # 1 m^2 (m^3); each side 1 m long (face 1 m^2)
    assert abs(area - 1) <= 1e-12                                                  # hex: measured 2.2e-16
    force = np.array(b[:d]) * area + np.array(t[:d]) * 1.0
    assert np.abs(sys_.f.reshape(-1, d).sum(axis=0) / force - 1).max() <= 1e-12    # measured <= 8.9e-16
    assert abs(sys_.q.sum() / (qv * area - q2 * 1.0) - 1) <= 1e-12                # measured <= 3.6e-15


@pytest.mark.parametrize("element", [Q1_ELEMENT, Q2_ELEMENT], ids=["Q1", "Q2"])
def test_quadrilateral_shape_functions_are_a_lagrange_basis(element):
    """Kronecker at the reference nodes, a partition of unity with gradients summing to zero at random points."""
    N = element.shape(element.reference)
    assert np.abs(N - np.eye(len(element.reference))).max() <= 1e-14
    xi = np.random.default_rng(1).uniform(-1, 1, (50, 2))
    N, dN = element.shape_derivatives(xi)
    assert np.abs(N.sum(axis=1) - 1).max() <= 1e-14 and np.abs(dN.sum(axis=2)).max() <= 1e-13


@pytest.mark.parametrize("cell,degree", ELEMENTS, ids=IDS)
def test_rigid_motions_span_the_kernel_and_nothing_else(cell, degree):
    """K r = 0 for the translations and the rotations (3 in 2D, 6 in 3D); K has exactly that many zero
    eigenvalues (full integration: no hourglass or other spurious mode); Kpp has the constants alone and
    Kup^T r = 0."""
    body = cc.Body(distorted(cell, 2, 2), PZT, clamped=["bottom"], grounded=["bottom"])
    _, _, held, s = system(body, cell, degree)
    x = held.points
    n, d = x.shape
    if d == 2:
        modes = np.stack([np.tile([1.0, 0.0], n), np.tile([0.0, 1.0], n), np.column_stack([-x[:, 1], x[:, 0]]).ravel()])
    else:
        modes = np.stack([np.tile(e, n) for e in np.eye(3)] + [np.cross(w, x).ravel() for w in np.eye(3)])
    rigid = len(modes)
    K = s.Kuu.toarray()
    scale = np.abs(K).max()
    assert np.abs(K @ modes.T).max() <= 1e-12 * scale                               # measured <= 2.5e-16
    assert np.abs(s.Kup.T @ modes.T).max() <= 1e-12 * np.abs(s.Kup).max()          # measured <= 2.3e-16
    ev = np.linalg.eigvalsh(K) / scale
    assert (ev < 1e-10).sum() == rigid and ev[rigid] > 1e-6  # measured ev[rigid] >= 0.018 (2D), 0.0048 (Q2 hex)
    P = s.Kpp.toarray()
    ep = np.linalg.eigvalsh(P) / np.abs(P).max()
    assert np.abs(P @ np.ones(n)).max() <= 1e-12 * np.abs(P).max()
    assert (ep < 1e-10).sum() == 1 and ep[1] > 1e-6                                 # measured ep[1] >= 0.047


def _divergence_free_field(degree, rng, dim=2):
    """(u(x) (k, dim), phi(x) (k,)): a random field of total degree ``degree`` with div sigma = 0 and div D = 0
    for PZT (sigma = c eps + e^T grad phi, D = e eps - kappa grad phi; linear fields: any). Its quadratic part
    spans the null space of the divergences, found by central differences (exact on the linear stresses)."""
    c, e, kappa = PZT.tensors(dim)
    voigt = [(0, 0), (1, 1), (0, 1)] if dim == 2 else [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
    pairs = [(i, j) for i in range(dim) for j in range(i, dim)]          # the quadratic monomials x_i x_j
    nq = len(pairs)
    U, V = 1e-6, 1e2                        # the scales of u (m) and phi (V)

    def monomials(x):
        return np.stack([x[..., i] * x[..., j] for i, j in pairs], -1)

    def gradient(A, Q, x):
        """(r, dim) the gradient at x (dim,) of x -> A x + Q monomials(x) (A (r, dim), Q (r, nq))."""
        out = np.array(A, dtype=float)
        for m, (i, j) in enumerate(pairs):
            out[:, i] += Q[:, m] * x[j]
            out[:, j] += Q[:, m] * x[i]
        return out

    def fields(coef):
        A, b, Q, q = coef                   # u = A x + Q monomials, phi = b.x + q.monomials

        def flux(x):
            du = gradient(A, Q, x)                                         # (dim, dim) du_a/dx_j
            dphi = gradient(b[None], q[None], x)[0]
            eps = np.array([du[a, a] if a == k else du[a, k] + du[k, a] for a, k in voigt])
            return eps @ c.T + dphi @ e, eps @ e.T - dphi @ kappa.T        # Voigt sigma, D

        def div(x):
            h = 0.5
            out = np.zeros(dim + 1)
            for j in range(dim):
                step = np.zeros(dim)
                step[j] = h
                (sp, Dp), (sm, Dm) = flux(x + step), flux(x - step)
                ds, dD = (sp - sm) / (2 * h), (Dp - Dm) / (2 * h)
                for v, (a, k) in enumerate(voigt):                        # sigma_ak = sigma_ka
                    if k == j:
                        out[a] += ds[v]
                    if a == j and a != k:
                        out[k] += ds[v]
                out[dim] += dD[j]
            return out

        return div

    A, b = U * rng.standard_normal((dim, dim)), V * rng.standard_normal(dim)
    Q, q = np.zeros((dim, nq)), np.zeros(nq)
    if degree == 2:
        size_k = dim * nq + nq
        M = np.column_stack([fields((np.zeros((dim, dim)), np.zeros(dim), (U * k[:dim * nq]).reshape(dim, nq),
                                     V * k[dim * nq:]))(np.zeros(dim)) for k in np.eye(size_k)])
        size = np.abs(M).max(axis=1)                         # the divergences of unit coefficients, per row
        Z = null_space(M / size[:, None])                    # (size_k, size_k - dim - 1)
        k = Z @ rng.standard_normal(Z.shape[1])
        Q, q = (U * k[:dim * nq]).reshape(dim, nq), V * k[dim * nq:]
        assert (np.abs(fields((A, b, Q, q))(np.full(dim, 0.3))) <= 1e-12 * size * np.abs(k).max()).all()

    def u(x):
        return x @ A.T + monomials(x) @ Q.T

    def phi(x):
        return x @ b + monomials(x) @ q

    return u, phi


@pytest.mark.parametrize("cell,degree", ELEMENTS, ids=IDS)
def test_patch_test_on_distorted_cells(cell, degree):
    """Irons' patch test: a field of the element's degree with divergence-free stress and electric displacement
    (linear for P1/Q1, quadratic for P2/Q2; quadrilaterals moved off parallelograms) makes the rows of every
    interior node of [Kuu Kup; Kup^T -Kpp] vanish: the element represents it exactly and integrates its weak
    form exactly (2 x 2 and 3 x 3 Gauss on the bilinear map; 2 x 2 x 2 and 3 x 3 x 3 on the trilinear map of
    hexahedra whose interior nodes moved, so their faces are warped)."""
    body = cc.Body(distorted(cell, 4, 3, seed=degree), PZT, clamped=["bottom"], grounded=["bottom"])
    _, _, held, s = system(body, cell, degree)
    d = body.dim
    u, phi = _divergence_free_field(degree, np.random.default_rng(7), d)
    x = held.points
    U, P = u(x).ravel(), phi(x)
    inside = np.ones(len(x), dtype=bool)
    inside[held.boundary_nodes(body.mesh.tags)] = False
    assert inside.sum() >= 4
    rows = np.flatnonzero(np.repeat(inside, d))
    Kuu, Kup, Kpp = s.Kuu, s.Kup, s.Kpp
    r_u = (Kuu @ U + Kup @ P)[rows]
    r_p = (Kup.T @ U - Kpp @ P)[inside]
    size_u = (abs(Kuu) @ np.abs(U) + abs(Kup) @ np.abs(P))[rows]
    size_p = (abs(Kup).T @ np.abs(U) + abs(Kpp) @ np.abs(P))[inside]
    assert np.abs(r_u).max() <= 1e-11 * size_u.max()                                # measured <= 1.2e-16
    assert np.abs(r_p).max() <= 1e-11 * size_p.max()                                # measured <= 1.3e-16


H1, H2, DELTA = 0.4, 0.2, 1e-4


def exact_solution_estimate(sol):
    """The residual estimate of a solution the space reproduces (piecewise affine u_h, a uniform stress in each
    body) vanishes: its residual terms to rounding (relative 1e-12 in eta: parts <= 1e-24 norm^2; measured below
    1e-28), and the two formed as differences to their own rounding (relative 1e-6 in eta: parts <= 1e-12 norm^2):
    the complementarity, which enters eta^2 unsquared (measured <= 2.8e-17 norm^2), and in 3D the contact
    traction, int_F |sigma_h n|^2 + int_S (2 lambda_h sigma_nn + lambda_h^2) (measured <= 3.4e-15 norm^2)."""
    est = sol.estimate
    assert est is not None and sol.estimate_reason == ""
    norm2 = est.norm ** 2
    differences = ("complementarity",) + (("contact traction",) if sol.scene.dim == 3 else ())
    for name, value in est.parts.items():
        assert abs(value) <= (1e-12 if name in differences else 1e-24) * norm2, (name, value / norm2)


@pytest.mark.parametrize("degree,condition,law", [(1, "sigma1", None), (1, "gamma3", None), (2, "sigma1", None),
                                                  (2, "sigma2", None), (2, "gamma3", None), (1, "sigma1", 2e12),
                                                  (2, "sigma1", 2e12)])
def test_quadrilateral_layers_squeezed_through_contact_are_in_uniaxial_strain(degree, condition, law):
    """A steel layer on a rigid floor under an aluminium block driven down by DELTA, both between side rollers,
    meshed with distorted quadrilaterals (non-matching under "gamma3"): springs in series, sigma_yy = -p,
    p = DELTA / (H1/M_steel + H2/M_alu [+ 2/k through a linear normal-compliance law of stiffness k on both
    pairs, each then penetrated by p/k]), u_y piecewise linear, u_x = 0, each pair carries p (N/m). The contact
    rows are P1's and P2's on the segments of the traces, unchanged."""
    M_s, M_a = float(STEEL.c[1, 1]), float(ALU.c[1, 1])
    layer = cc.Body(distorted("quad", 4, 3, x=(0.0, 1.0), y=(0.0, H1)), STEEL, roller=["left", "right"],
                    contact="bottom", name="layer")
    punch = cc.Body(distorted("quad", 3 if condition == "gamma3" else 4, 2, x=(0.0, 1.0), y=(H1, H1 + H2), seed=1),
                    ALU, roller=["left", "right"], displacement={"top": (None, -DELTA)}, contact="bottom", name="punch")
    floor = cc.Rigid.plane((0.0, 0.0), (0.0, 1.0))
    scene = cc.Scene(layer, punch, contacts=[cc.Contact(layer, "bottom", floor),
                                             cc.Contact(punch, "bottom", layer, "top")])
    sol = cc.solve(scene, condition, degree=degree, law=None if law is None else cc.NormalCompliance(law))
    assert sol.ok and sol.polished
    exact_solution_estimate(sol)
    gap = 0.0 if law is None else 1.0 / law                      # m per Pa: each pair's penetration p / k
    p = DELTA / (H1 / M_s + H2 / M_a + 2 * gap)
    for k, exact in enumerate((lambda y: -p * gap - p * y / M_s,
                               lambda y: -2 * p * gap - p * H1 / M_s - p * (y - H1) / M_a)):
        y = sol.points[k][:, 1]
        assert np.abs(sol.u[k][:, 1] - exact(y)).max() <= 1e-9 * DELTA              # measured <= 2.2e-15 DELTA
        assert np.abs(sol.u[k][:, 0]).max() <= 1e-9 * DELTA
    for c in sol.contacts:
        assert abs(c.force.sum() - p) <= 1e-9 * p                                    # measured <= 8.9e-16 p


def _energy_error(cell, degree, n, amount):
    """sqrt(a(u - u_h, u - u_h) / a(u, u)) on the unit square clamped all round, u = U0 sin(pi x) sin(pi y) (1, 1)
    with its body force b = -div sigma(u) (plane strain steel); a(u - u_h, u - u_h) = a(u, u) - f . u_h
    (Galerkin orthogonality, a(u_h, u_h) = f . u_h), a(u, u) by a 40 x 40 Gauss rule of the exact strain."""
    lam, mu = float(STEEL.c[0, 1]), float(STEEL.c[2, 2])
    U0, pi = 1e-3, np.pi

    def force(x, y):
        ss, cc_ = np.sin(pi * x) * np.sin(pi * y), np.cos(pi * x) * np.cos(pi * y)
        d = -(mu * (-2 * pi ** 2 * ss) + (lam + mu) * pi ** 2 * (cc_ - ss)) * U0
        return d, d

    mesh = distorted(cell, n, n, amount=amount, seed=n)
    body = cc.Body(mesh, STEEL, clamped=["left", "right", "bottom", "top"], body_force=force)
    _, _, _, s = system(body, cell, degree)
    T = s.Tu
    z = spla.spsolve((T.T @ s.Kuu @ T).tocsc(), T.T @ s.f)
    t, w = np.polynomial.legendre.leggauss(40)
    X, Y = np.meshgrid(0.5 + 0.5 * t, 0.5 + 0.5 * t, indexing="ij")
    W = np.outer(w, w) / 4
    sx, sy, cx, cy = np.sin(pi * X), np.sin(pi * Y), np.cos(pi * X), np.cos(pi * Y)
    exx, eyy, gxy = pi * cx * sy * U0, pi * sx * cy * U0, pi * (sx * cy + cx * sy) * U0
    a_uu = float((W * (lam * (exx + eyy) ** 2 + 2 * mu * (exx ** 2 + eyy ** 2) + mu * gxy ** 2)).sum())
    return np.sqrt(max(a_uu - float(s.f @ (T @ z)), 0.0) / a_uu)


@pytest.mark.parametrize("cell,degree", ELEMENTS[:4], ids=IDS[:4])      # the hexahedra: the test below
def test_observed_energy_norm_rates(cell, degree):
    """Energy-norm error ~ h^degree on meshes whose interior nodes are moved at random by 15 % of a cell (the
    quadrilaterals are not parallelograms, even asymptotically: the 9-node Q2 keeps its O(h^2), module
    cvxcontact.fem.quad). Observed rates, h = 1/8 -> 1/16 (degree 1), 1/4 -> 1/8 (degree 2): measured P1 1.01,
    P2 1.99, Q1 0.98, Q2 1.92 (one level finer: 1.02, 1.95, 0.99, 1.94; uniform cells: 1.02, 1.96, 1.00, 1.99)."""
    n0 = 8 if degree == 1 else 4
    e0, e1 = _energy_error(cell, degree, n0, 0.15), _energy_error(cell, degree, 2 * n0, 0.15)
    rate = np.log2(e0 / e1)
    assert degree - 0.25 <= rate <= degree + 0.5, (e0, e1, rate)


@pytest.mark.parametrize("degree,vtk", [(1, 9), (2, 28)])
def test_vtu_writes_vtk_quad_cells_that_meshio_reads_back(tmp_path, degree, vtk):
    """The body's cells in the file's own types array are VTK_QUAD (9) / VTK_BIQUADRATIC_QUAD (28); meshio reads
    them back with the points, the cell connectivity and the affine field's constant strain per cell."""
    mesh = distorted("quad", 3, 2)
    body = cc.Body(mesh, STEEL, clamped=["bottom"])
    S = space(degree, "quad")
    nodes = S.nodes(body)
    x = (mesh if nodes is None else nodes).points
    A = np.array([[1e-4, 2e-5], [-3e-5, 5e-5]])
    m = body_mesh(body, x @ A.T, None, nodes)
    meshio.write(tmp_path / "a.vtu", m, binary=False)         # ASCII: the types array readable here
    meshio.write(tmp_path / "b.vtu", m)
    text = (tmp_path / "a.vtu").read_text()
    types = re.search(r'Name="types"[^>]*>([^<]*)<', text).group(1).split()
    assert set(types) == {str(vtk)} and len(types) == len(mesh.quads)
    back = meshio.read(tmp_path / "b.vtu")
    assert back.cells[0].type == ("quad" if degree == 1 else "quad9")
    assert np.array_equal(back.cells[0].data, (mesh if nodes is None else nodes).cells)
    assert np.allclose(back.points[:, :2], x, rtol=0, atol=1e-15)
    strain = back.cell_data["strain xy [-]"][0]
    assert np.allclose(strain, 0.5 * (A[0, 1] + A[1, 0]), rtol=1e-10, atol=0)


def test_gmsh_quad9_file_reads_as_the_quadrilateral_mesh(tmp_path):
    """A quad9 / line3 gmsh file (the nodes of Q2Nodes on a distorted mesh) reads back as its corner QuadMesh with
    the tags of its physical lines; a centre node off the cell's centre is refused."""
    mesh = distorted("quad", 3, 2)
    nodes = space(2, "quad").nodes(cc.Body(mesh, STEEL, clamped=["bottom"]))
    lines = {t: nodes.boundary(t) for t in mesh.tags}
    cells = [meshio.CellBlock("quad9", nodes.cells)] + [meshio.CellBlock("line3", e) for e in lines.values()]
    physical = [np.full(len(nodes.cells), 10)] + [np.full(len(e), i + 1) for i, e in enumerate(lines.values())]
    field = {"body": np.array([10, 2])} | {t: np.array([i + 1, 1]) for i, t in enumerate(lines)}
    points = np.column_stack([nodes.points, np.zeros(len(nodes.points))])
    path = tmp_path / "q9.msh"
    meshio.write(path, meshio.Mesh(points, cells, cell_data={"gmsh:physical": physical, "gmsh:geometrical": physical},
                                   field_data=field), file_format="gmsh22", binary=False)
    back = cc.read_mesh(path)
    assert type(back).__name__ == "QuadMesh" and back.cell == "quad"
    assert np.array_equal(back.points, mesh.points) and np.array_equal(back.quads, mesh.quads)
    for t in mesh.tags:
        assert np.array_equal(back.boundary(t), mesh.boundary(t))
    points[nodes.cells[0, 8], 0] += 1e-3
    meshio.write(path, meshio.Mesh(points, cells, cell_data={"gmsh:physical": physical, "gmsh:geometrical": physical},
                                   field_data=field), file_format="gmsh22", binary=False)
    with pytest.raises(MeshError, match="centre node"):
        cc.read_mesh(path)


def test_quadrilateral_mesh_refusals_and_what_is_not_covered_yet():
    """Typed refusals naming the fix: a non-convex cell, a scene mixing cells, the estimates, the bound and adapt
    on quadrilaterals (the residual estimate covers them)."""
    with pytest.raises(MeshError, match="not convex"):
        cc.QuadMesh([[0, 0], [1, 0], [0.2, 0.2], [0, 1]], [[0, 1, 2, 3]])
    with pytest.raises(MeshError, match="cell must be"):
        cc.rectangle(cell="hex")
    quad = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=2, ny=2, cell="quad"), STEEL, clamped=["bottom"],
                   contact="top")
    tri = cc.Body(cc.rectangle(x=(0, 1), y=(0.5, 1), nx=2, ny=2), STEEL, clamped=["top"], contact="bottom")
    with pytest.raises(SceneError, match="same cells"):
        cc.Scene(quad, tri)
    other = cc.Body(cc.rectangle(x=(0, 1), y=(0.5, 1), nx=2, ny=2, cell="quad"), STEEL,
                    displacement={"top": (0.0, -1e-5)}, contact="bottom")
    scene = cc.Scene(quad, other)
    with pytest.raises(UnsupportedError, match="bound does not cover quad cells"):
        cc.solve(scene, "sigma1", estimate="equilibrated")
    grid = quad.mesh
    inner = (grid.points[:, 0] == 0.5) & (grid.points[:, 1] == 0.25)          # the interior node: not a grid
    bent = quad.with_changes(mesh=grid.with_points(grid.points + np.where(inner, 0.05, 0.0)[:, None] * [1, 0]))
    with pytest.raises(UnsupportedError, match="not a tensor grid"):
        cc.adapt(cc.Scene(bent, other), "sigma1")
    sol = cc.solve(scene, "sigma1")
    assert sol.ok and sol.estimate is not None and sol.estimate_reason == ""
    with pytest.raises(UnsupportedError, match="quad cells"):
        cc.error_bound(sol)


def test_scene_file_rectangle_takes_the_cell(tmp_path):
    """``mesh = { rectangle = {..., cell = "quad"} }`` in a scene file gives quadrilateral bodies that solve with
    degree 2 as the same scene built in Python (equal fields to rounding)."""
    from cvxcontact.io.scenefile import load_scene

    path = tmp_path / "q.toml"
    path.write_text('condition = "sigma1"\n\n'
                    '[[body]]\nname = "lower"\nmaterial = { E = 200e9, nu = 0.3 }\n'
                    'mesh = { rectangle = { x = [0.0, 1.0], y = [0.0, 0.5], nx = 3, ny = 2, cell = "quad" } }\n'
                    'clamped = ["bottom"]\ncontact = "top"\n\n'
                    '[[body]]\nname = "upper"\nmaterial = { E = 200e9, nu = 0.3 }\n'
                    'mesh = { rectangle = { x = [0.0, 1.0], y = [0.5, 1.0], nx = 3, ny = 2, cell = "quad" } }\n'
                    'displacement = { top = [0.0, -1e-5] }\ncontact = "bottom"\n')
    scene = load_scene(path).scene
    assert [b.mesh.cell for b in scene.bodies] == ["quad", "quad"] and scene.cell == "quad"
    mat = cc.materials.isotropic(E=200e9, nu=0.3)
    lower = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=3, ny=2, cell="quad"), mat, clamped=["bottom"], contact="top")
    upper = cc.Body(cc.rectangle(x=(0, 1), y=(0.5, 1), nx=3, ny=2, cell="quad"), mat,
                    displacement={"top": (0.0, -1e-5)}, contact="bottom")
    a, b = cc.solve(scene, "sigma1", degree=2), cc.solve(cc.Scene(lower, upper), "sigma1", degree=2)
    assert a.ok and b.ok
    for ua, ub in zip(a.u, b.u):
        assert np.abs(ua - ub).max() <= 1e-12 * 1e-5                              # measured 0 (the same program)


def test_sweep_case_arrays_name_the_quadrilaterals():
    """A sweep case of a quadrilateral scene stores its cells as ``quads<k>`` (m, 4), with their unit, and the
    surface charge of a Q1 body is loaded (it failed before on the 1D segment load)."""
    from cvxcontact.apps.sweep.store import ARRAY_UNITS
    from cvxcontact.apps.sweep.worker import arrays

    lower = cc.Body(cc.rectangle(x=(0, 1e-3), y=(0, 5e-4), nx=3, ny=2, cell="quad"), PZT, clamped=["bottom"],
                    grounded=["bottom"], surface_charge={"left": -0.05}, contact="top")
    upper = cc.Body(cc.rectangle(x=(0, 1e-3), y=(5e-4, 1e-3), nx=3, ny=2, cell="quad"), STEEL,
                    displacement={"top": (0.0, -1e-7)}, contact="bottom")
    out = arrays(cc.solve(cc.Scene(lower, upper), "sigma1"))
    assert out["quads1"].shape == (6, 4) and out["quads2"].shape == (6, 4) and "triangles1" not in out
    assert any(re.fullmatch(pattern, "quads1") and unit == "1" for pattern, unit in ARRAY_UNITS)


def test_graded_block_takes_the_cell():
    """``graded_block(..., cell="quad")``: the graded triangle mesh's nodes and tags on its uncut cells (each
    quadrilateral the union of two of the triangles: the same total area, the same points)."""
    kw = {"x": (0.0, 2.0), "y": (0.0, 1.0), "nx": 6, "ny": 4, "beta": 2.0, "gamma": 1.5, "center": 0.8}
    tri, quad = cc.graded_block(**kw), cc.graded_block(**kw, cell="quad")
    assert type(quad).__name__ == "QuadMesh" and np.array_equal(tri.points, quad.points)
    assert np.isclose(quad.areas.sum(), 2.0, rtol=1e-14) and np.isclose(tri.areas.sum(), quad.areas.sum(), rtol=1e-14)
    for t in tri.tags:
        assert np.array_equal(tri.boundary(t), quad.boundary(t))


def _energy_error_3d(degree, n, amount, cell="hex"):
    """sqrt(a(u - u_h, u - u_h) / a(u, u)) on the unit cube of hexahedra clamped all round, u = U0 sin(pi x)
    sin(pi y) sin(pi z) (1, 1, 1) with its body force b = -div sigma(u) (isotropic steel): as
    :func:`_energy_error` (Galerkin orthogonality), a(u, u) by a 24 x 24 x 24 Gauss rule of the exact strain."""
    lam, mu = float(STEEL.c[0, 1]), float(STEEL.c[2, 2])
    U0, pi = 1e-3, np.pi

    def force(x, y, z):
        s, c = np.sin(pi * np.stack([x, y, z])), np.cos(pi * np.stack([x, y, z]))
        sss = s[0] * s[1] * s[2]
        cross = [c[0] * (c[1] * s[2] + s[1] * c[2]), c[1] * (c[0] * s[2] + s[0] * c[2]),
                 c[2] * (c[0] * s[1] + s[0] * c[1])]                 # sum over j != i of c_i c_j s_k
        return tuple(-U0 * pi ** 2 * (-3 * mu * sss + (lam + mu) * (-sss + cross[i])) for i in range(3))

    mesh = distorted(cell, n, n, amount=amount, seed=n)
    body = cc.Body(mesh, STEEL, clamped=list(mesh.tags), body_force=force)
    _, _, _, s = system(body, cell, degree)
    T = s.Tu
    z = spla.spsolve((T.T @ s.Kuu @ T).tocsc(), T.T @ s.f)
    t, w = np.polynomial.legendre.leggauss(24)
    X = np.stack(np.meshgrid(0.5 + 0.5 * t, 0.5 + 0.5 * t, 0.5 + 0.5 * t, indexing="ij"))
    W = np.einsum("i,j,k->ijk", w, w, w) / 8
    s_, c_ = np.sin(pi * X), np.cos(pi * X)
    grad = np.stack([pi * c_[j] * s_[(j + 1) % 3] * s_[(j + 2) % 3] for j in range(3)]) * U0   # d u_i / dx_j
    div = grad.sum(axis=0)
    sym = 0.5 * (grad[:, None] + grad[None, :])                      # eps_jk = (d_j u_k + d_k u_j) / 2, u_i equal
    a_uu = float((W * (lam * div ** 2 + 2 * mu * (sym ** 2).sum(axis=(0, 1)))).sum())
    return np.sqrt(max(a_uu - float(s.f @ (T @ z)), 0.0) / a_uu)


@pytest.mark.parametrize("degree", [1, 2], ids=["Q1hex", "Q2hex"])
def test_observed_energy_norm_rates_of_hexahedra(degree):
    """Energy-norm error ~ h^degree on hexahedra whose interior nodes are moved at random by 15 % of a cell
    (warped faces, not parallelepipeds: the 27-node Q2 keeps its O(h^2), module cvxcontact.fem.hex). Observed
    rates, h = 1/4 -> 1/8 (Q1), 1/3 -> 1/6 (Q2): measured Q1 0.95, Q2 1.94 (Q1 2 -> 4: 0.96, Q2 2 -> 4: 1.86;
    uniform cubes: Q1 0.96, 0.98, Q2 1.96, 1.98, 1.99 on n = 2, 3, 4, 6)."""
    n0 = 4 if degree == 1 else 3
    e0, e1 = _energy_error_3d(degree, n0, 0.15), _energy_error_3d(degree, 2 * n0, 0.15)
    rate = np.log2(e0 / e1)
    assert degree - 0.25 <= rate <= degree + 0.5, (e0, e1, rate)


@pytest.mark.parametrize("degree,condition,law", [(1, "sigma1", None), (1, "sigma2", None), (1, "gamma3", None),
                                                  (1, "sigma1", 2e12), (1, "gamma3", 2e12), (2, "sigma1", None),
                                                  (2, "sigma2", None)])
def test_hexahedral_layers_squeezed_through_contact_are_in_uniaxial_strain(degree, condition, law):
    """The 3D counterpart of the quadrilateral layers: a steel layer of hexahedra (interior nodes moved, warped
    cells) on a rigid plane under an aluminium block driven down by DELTA, matching faces between them, rollers
    on the four sides: uniaxial strain, sigma_zz = -p, p = DELTA / (H1/M_steel + H2/M_alu [+ 2/k]), M = c33,
    u_z piecewise linear, u_x = u_y = 0, each pair carries p A (A = 1 m^2). Q1 through the faces' triangles
    (nodal rows at their corners, "gamma3" = those rows on matching faces and a plane; a compliance law weighted
    by the Q1 hats' integrals), Q2 Signorini nodal rows at the 9 nodes of each face."""
    sides = ["left", "right", "front", "back"]
    M_s, M_a = float(STEEL.tensors(3)[0][2, 2]), float(ALU.tensors(3)[0][2, 2])
    layer = cc.Body(distorted("hex", 3, 2, nz=2, z=(0.0, H1)), STEEL, roller=sides, contact="bottom", name="layer")
    punch = cc.Body(distorted("hex", 3, 2, nz=2, z=(H1, H1 + H2), seed=1), ALU, roller=sides,
                    displacement={"top": (None, None, -DELTA)}, contact="bottom", name="punch")
    floor = cc.Rigid.plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    scene = cc.Scene(layer, punch, contacts=[cc.Contact(layer, "bottom", floor),
                                             cc.Contact(punch, "bottom", layer, "top")])
    sol = cc.solve(scene, condition, degree=degree, law=None if law is None else cc.NormalCompliance(law))
    assert sol.ok and sol.polished
    exact_solution_estimate(sol)
    gap = 0.0 if law is None else 1.0 / law
    p = DELTA / (H1 / M_s + H2 / M_a + 2 * gap)
    for k, exact in enumerate((lambda z: -p * gap - p * z / M_s,
                               lambda z: -2 * p * gap - p * H1 / M_s - p * (z - H1) / M_a)):
        z = sol.points[k][:, 2]
        assert np.abs(sol.u[k][:, 2] - exact(z)).max() <= 1e-12 * DELTA * 100      # measured <= 2.1e-15 DELTA
        assert np.abs(sol.u[k][:, :2]).max() <= 1e-12 * DELTA * 100                # measured <= 1.6e-15 DELTA
    for c in sol.contacts:
        assert abs(c.force.sum() - p) <= 1e-12 * p                                   # measured <= 6.7e-16 p
    if degree == 1:              # the pressure read-back: nodal forces over the Q1 hats' areas (mesh.node_areas)
        for pair, k in ((0, 0), (1, 0), (1, 1)):
            assert np.abs(sol.traction(k, pair)[1] - p).max() <= 1e-12 * p          # measured <= 1.5e-15 p


def test_hexahedral_contact_refusals_name_the_alternative():
    """Typed refusals where the hexahedral rows would not be exact: under Q1 "gamma3" between faces that neither
    nest nor are parallelograms along common directions (tests/test_hex_nested.py); Q1 "gamma3" against a curved
    obstacle, Q2 "gamma3", Q2 faces that are not parallelograms; the estimates, the bound and adapt on hexahedra.
    Taken: Q2 nodal rows on faces that do not match, a compliance law under a nodal condition (Q1 on faces that
    neither nest nor align, Q2 on a plane: docs/refusals.md rows 39-41)."""
    lower = cc.Body(cc.box(z=(0.0, 0.5), nx=3, ny=2, nz=1, cell="hex"), STEEL, clamped=["bottom"], contact="top")
    upper = cc.Body(cc.box(z=(0.5, 1.0), nx=2, ny=2, nz=1, cell="hex"), STEEL, displacement={"top": (0, 0, -1e-5)},
                    contact="bottom")
    assert cc.solve(cc.Scene(lower, upper), "sigma1", degree=2).ok          # docs/refusals.md row 40
    mesh = upper.mesh                                      # its bottom's faces no longer parallelograms
    p = mesh.points.copy()
    p[(p[:, 0] == 0.5) & (p[:, 1] == 0.5), :2] += (0.1, 0.05)
    warped = cc.Body(mesh.with_points(p), STEEL, displacement={"top": (0, 0, -1e-5)}, contact="bottom")
    with pytest.raises(UnsupportedError, match="do not match corner to corner.*not nested.*sigma1"):
        cc.solve(cc.Scene(lower, warped), "gamma3")
    assert cc.solve(cc.Scene(lower, upper), "sigma1", law=cc.NormalCompliance(1e12)).ok    # refusals.md row 41
    ball = cc.Rigid.sphere((0.5, 0.5, -1.0), 1.0)
    body = cc.Body(cc.box(z=(0.0, 0.5), nx=2, ny=2, nz=1, cell="hex"), STEEL,
                   displacement={"top": (0.0, 0.0, -1e-5)}, contact="bottom")
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", ball)])
    with pytest.raises(UnsupportedError, match="curved obstacle.*sigma1"):
        cc.solve(scene, "gamma3")
    assert cc.solve(scene, "sigma1").ok
    plane = cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])
    with pytest.raises(UnsupportedError, match="'gamma3' on Q2.*sigma1"):
        cc.solve(plane, "gamma3", degree=2)
    assert cc.solve(plane, "sigma1", degree=2, law=cc.NormalCompliance(1e12)).ok     # docs/refusals.md row 39
    mesh = cc.box(z=(0.0, 0.5), nx=2, ny=2, nz=1, cell="hex")
    p = mesh.points.copy()
    p[(p[:, 0] == 0.5) & (p[:, 1] == 0.5), 0] += 0.1                     # an interior node of the bottom face
    skew = cc.Body(mesh.with_points(p), STEEL, displacement={"top": (0.0, 0.0, -1e-5)}, contact="bottom")
    with pytest.raises(UnsupportedError, match="not parallelograms"):
        cc.solve(cc.Scene(skew, contacts=[cc.Contact(skew, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))]),
                 "sigma1", degree=2)
    with pytest.raises(UnsupportedError, match=r"bound does not cover 3D \(hex cells\)"):
        cc.solve(plane, "sigma1", estimate="equilibrated")
    with pytest.raises(UnsupportedError, match="hex cells are not a tensor grid"):
        cc.adapt(cc.Scene(skew, contacts=[cc.Contact(skew, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))]), "sigma1")
    with pytest.raises(UnsupportedError, match=r"does not cover 3D \(hex cells\)"):
        cc.error_bound(cc.solve(plane, "sigma1"))


@pytest.mark.parametrize("degree,vtk", [(1, 12), (2, 29)])
def test_vtu_writes_vtk_hexahedra_that_meshio_reads_back(tmp_path, degree, vtk):
    """The body's cells in the file's own types array are VTK_HEXAHEDRON (12) / VTK_TRIQUADRATIC_HEXAHEDRON (29);
    meshio reads them back with the points, the connectivity and the affine field's constant strain per cell."""
    mesh = distorted("hex", 2, 2)
    body = cc.Body(mesh, STEEL, clamped=["bottom"])
    S = space(degree, "hex")
    nodes = S.nodes(body)
    x = (mesh if nodes is None else nodes).points
    A = np.array([[1e-4, 2e-5, -7e-5], [-3e-5, 5e-5, 4e-5], [6e-5, -1e-5, 3e-5]])
    m = body_mesh(body, x @ A.T, None, nodes)
    meshio.write(tmp_path / "a.vtu", m, binary=False)
    meshio.write(tmp_path / "b.vtu", m)
    text = (tmp_path / "a.vtu").read_text()
    types = re.search(r'Name="types"[^>]*>([^<]*)<', text).group(1).split()
    assert set(types) == {str(vtk)} and len(types) == len(mesh.hexes)
    back = meshio.read(tmp_path / "b.vtu")
    assert back.cells[0].type == ("hexahedron" if degree == 1 else "hexahedron27")
    assert np.array_equal(back.cells[0].data, (mesh if nodes is None else nodes).cells)
    assert np.allclose(back.points, x, rtol=0, atol=1e-15)
    for label, (i, j) in (("xx", (0, 0)), ("yz", (1, 2)), ("xy", (0, 1))):
        strain = back.cell_data[f"strain {label} [-]"][0]
        assert np.allclose(strain, 0.5 * (A[i, j] + A[j, i]), rtol=1e-10, atol=0)


@pytest.mark.parametrize("kind", ["hexahedron", "hexahedron27"])
def test_gmsh_hexahedra_read_as_the_hexahedral_mesh(tmp_path, kind):
    """A gmsh hexahedron / hexahedron27 file with quad / quad9 physical faces (meshio converts gmsh's hex27 order)
    reads back as its corner HexMesh with the tags of its physical surfaces; a hex27 face node off its face's
    centre is refused."""
    mesh = distorted("hex", 2, 2)
    body = cc.Body(mesh, STEEL, clamped=["bottom"])
    nodes = space(2, "hex").nodes(body) if kind == "hexahedron27" else None
    held = mesh if nodes is None else nodes
    faces = {t: held.boundary(t) for t in mesh.tags}
    face_kind = "quad" if nodes is None else "quad9"
    cells = [meshio.CellBlock(kind, held.cells)] + [meshio.CellBlock(face_kind, f) for f in faces.values()]
    physical = [np.full(len(held.cells), 10)] + [np.full(len(f), i + 1) for i, f in enumerate(faces.values())]
    field = {"body": np.array([10, 3])} | {t: np.array([i + 1, 2]) for i, t in enumerate(faces)}
    points = np.array(held.points)
    path = tmp_path / "h.msh"

    def write():
        meshio.write(path, meshio.Mesh(points, cells, cell_data={"gmsh:physical": physical,
                                                                 "gmsh:geometrical": physical},
                                       field_data=field), file_format="gmsh22", binary=False)
    write()
    back = cc.read_mesh(path)
    assert type(back).__name__ == "HexMesh" and back.cell == "hex"
    assert np.array_equal(back.points, mesh.points) and np.array_equal(back.hexes, mesh.hexes)
    for t in mesh.tags:
        assert np.array_equal(back.boundary(t), mesh.boundary(t))
    if nodes is not None:
        points[nodes.cells[0, 20], 0] += 1e-3
        write()
        with pytest.raises(MeshError, match="off the mean of its corners"):
            cc.read_mesh(path)


def test_hexahedral_mesh_checks_and_the_scene_file_box_cell(tmp_path):
    """HexMesh refuses a cell folded at a corner and a tagged face off the boundary; cc.box(cell="hex") has the
    tetrahedral box's points and tags (each hexahedral face the union of two of its triangles: the same areas);
    ``box = {..., cell = "hex"}`` in a scene file gives the same solution as the scene built in Python."""
    from cvxcontact.io.scenefile import load_scene

    cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    with pytest.raises(MeshError, match="inverted at some corners"):
        cc.HexMesh(cube, [[0, 1, 3, 2, 4, 5, 6, 7]])
    with pytest.raises(MeshError, match="not on the boundary"):
        cc.HexMesh(np.concatenate([cube, cube[4:] + [0, 0, 1]]), [list(range(8)), [4, 5, 6, 7, 8, 9, 10, 11]],
                   {"mid": [[4, 5, 6, 7]]})
    kw = {"x": (0.0, 2.0), "y": (0.0, 1.0), "z": (0.0, 0.5), "nx": 4, "ny": 3, "nz": 2,
          "patches": {"punch": ("top", (0.5, 1.5), (0.0, 1.0 / 3.0))}}
    tet, hexa = cc.box(**kw), cc.box(**kw, cell="hex")
    assert type(hexa).__name__ == "HexMesh" and np.array_equal(tet.points, hexa.points) and tet.tags == hexa.tags
    assert np.isclose(hexa.volumes.sum(), 1.0, rtol=1e-14)
    for t in tet.tags:
        assert np.isclose(tet.face_areas(t).sum(), hexa.face_areas(t).sum(), rtol=1e-14)
        assert np.array_equal(tet.boundary_nodes([t]), hexa.boundary_nodes([t]))
    path = tmp_path / "h.toml"
    path.write_text('condition = "sigma1"\n\n'
                    '[[body]]\nname = "lower"\nmaterial = { E = 200e9, nu = 0.3 }\n'
                    'mesh = { box = { z = [0.0, 0.5], nx = 2, ny = 2, nz = 1, cell = "hex" } }\n'
                    'clamped = ["bottom"]\ncontact = "top"\n\n'
                    '[[body]]\nname = "upper"\nmaterial = { E = 200e9, nu = 0.3 }\n'
                    'mesh = { box = { z = [0.5, 1.0], nx = 2, ny = 2, nz = 1, cell = "hex" } }\n'
                    'displacement = { top = [0.0, 0.0, -1e-5] }\ncontact = "bottom"\n')
    scene = load_scene(path).scene
    assert scene.cell == "hex"
    mat = cc.materials.isotropic(E=200e9, nu=0.3)
    lower = cc.Body(cc.box(z=(0.0, 0.5), nx=2, ny=2, nz=1, cell="hex"), mat, clamped=["bottom"], contact="top")
    upper = cc.Body(cc.box(z=(0.5, 1.0), nx=2, ny=2, nz=1, cell="hex"), mat, displacement={"top": (0.0, 0.0, -1e-5)},
                    contact="bottom")
    a, b = cc.solve(scene, "sigma1", degree=2), cc.solve(cc.Scene(lower, upper), "sigma1", degree=2)
    assert a.ok and b.ok
    for ua, ub in zip(a.u, b.u):
        assert np.abs(ua - ub).max() <= 1e-12 * 1e-5                              # measured 0 (the same program)


def _skewed_box(n, z, seed, amount):
    """A hexahedral box of n x n x 1 cells whose interior vertical grid lines are moved in x and y by up to
    ``amount`` of a cell (the contact faces top and bottom are then quadrilaterals that are not rectangles)."""
    mesh = cc.box(z=z, nx=n, ny=n, nz=1, cell="hex")
    p = mesh.points.copy()
    inner = (p[:, 0] > 0) & (p[:, 0] < 1) & (p[:, 1] > 0) & (p[:, 1] < 1)
    _, column = np.unique(np.round(p[:, :2], 9), axis=0, return_inverse=True)
    shift = np.random.default_rng(seed).uniform(-amount, amount, (column.max() + 1, 2)) / n
    p[inner, :2] += shift[column.ravel()][inner]
    return mesh.with_points(p)


@pytest.mark.parametrize("amount", [0.0, 0.2], ids=["rectangles", "skewed"])
@pytest.mark.parametrize("n1,n2", [(4, 2), (3, 2)], ids=["nested", "crossing"])
def test_q1_nodal_rows_on_faces_that_do_not_match_evaluate_the_bilinear_trace(amount, n1, n2):
    """Q1 "sigma1"/"sigma2" on two bodies whose contact faces do not match (nested grids 4 on 2, crossing grids 3
    on 2): the row at a node of one body evaluates the other body's bilinear trace there (its face located, its
    reference point found by Newton): a field in the Q1 trace space (x y + 0.3 x - 0.1 on rectangles, an affine
    field on skewed faces) comes out exact, where the faces' triangles' P1 functions were up to 0.0625 off on the
    rectangles (measured). The two solve; the uniaxial squeeze's force is exact on nested rectangles only: nodal
    rows on one side of non-matching faces are a collocation, not a patch-test-passing mortar (measured force
    errors 6.9e-4 nested skewed, 1.0e-2 crossing rectangles, 1.1e-2 crossing skewed; as with P1 "sigma1")."""
    lower = cc.Body(_skewed_box(n1, (0.0, 0.5), 1, amount), STEEL, roller=["left", "right", "front", "back"],
                    clamped=["bottom"], contact="top", name="lower")
    upper = cc.Body(_skewed_box(n2, (0.5, 1.0), 2, amount), STEEL, roller=["left", "right", "front", "back"],
                    displacement={"top": (None, None, -1e-5)}, contact="bottom", name="upper")
    scene = cc.Scene(lower, upper)
    field = (lambda x: x[:, 0] * x[:, 1] + 0.3 * x[:, 0] - 0.1) if amount == 0 else \
        (lambda x: 0.7 * x[:, 0] - 0.4 * x[:, 1] + 0.2)
    for condition, other, sign in (("sigma1", 1, -1.0), ("sigma2", 0, 1.0)):     # the other body's outward normal
        lines = space(1, "hex").contact(scene, condition, None)
        x = scene.bodies[other].mesh.points
        u = np.zeros((len(x), 3))
        u[:, 2] = field(x)
        rows = lines.E @ (lines.interface.jump(other, len(x)) @ u.ravel())
        at = lines.E @ np.asarray(lines.interface.x)                        # the rows' points (x, y) on z = 0.5
        assert lines.E.shape[0] == len(scene.bodies[1 - other].mesh.boundary_nodes(["top" if other else "bottom"]))
        assert np.abs(rows - sign * field(at)).max() <= 1e-13                       # measured <= 3.3e-16
    sol = cc.solve(scene, "sigma1")
    M = float(STEEL.tensors(3)[0][2, 2])
    p = 1e-5 / (1.0 / M)                                                    # uniaxial strain of the unit column
    assert sol.ok
    if amount == 0 and n1 % n2 == 0:     # nested rectangles: the fine nodes integrate the coarse hats exactly
        assert abs(sol.contacts[0].force.sum() - p) <= 1e-12 * p                 # measured 0


@pytest.mark.parametrize("degree", [1, 2])
def test_sweep_case_arrays_name_the_hexahedra(degree):
    """A sweep case of a hexahedral scene stores its cells as ``hexahedra<k>`` (m, 8), with their unit, and the
    export reads them back as meshio hexahedra over the body's vertices (a plain KeyError before)."""
    from cvxcontact.apps.sweep.export import _body_meshes
    from cvxcontact.apps.sweep.store import ARRAY_UNITS
    from cvxcontact.apps.sweep.worker import arrays

    mesh = cc.box(z=(0.0, 0.5), nx=2, ny=2, nz=1, cell="hex")
    body = cc.Body(mesh, STEEL, displacement={"top": (0.0, 0.0, -1e-5)}, contact="bottom")
    scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])
    out = arrays(cc.solve(scene, "sigma1", degree=degree))
    assert out["hexahedra1"].shape == (4, 8) and "tetrahedra1" not in out
    assert any(re.fullmatch(pattern, "hexahedra1") and unit == "1" for pattern, unit in ARRAY_UNITS)
    (name, exported), = _body_meshes(out)
    assert name == "body1" and exported.cells[0].type == "hexahedron"
    assert np.array_equal(exported.cells[0].data, mesh.cells) and len(exported.points) == len(mesh.points)


@pytest.mark.parametrize("cls,corners,name", [(cc.Mesh, 3, "triangles"), (cc.QuadMesh, 4, "quads"),
                                              (cc.HexMesh, 8, "hexes")])
def test_every_mesh_refuses_bad_cells_by_name(cls, corners, name):
    """Cells of the wrong shape, not integer, or naming a node that does not exist: a MeshError naming the array
    (one check for every mesh, geometry.base.cell_corners)."""
    dim = 3 if cls is cc.HexMesh else 2
    points = np.zeros((corners, dim))
    good = np.arange(corners)[None, :]
    for cells, match in ((good[:, :-1], rf"{name} must be a non-empty \(m, {corners}\) array"),
                         (np.zeros((0, corners), dtype=int), rf"{name} must be a non-empty"),
                         (good.astype(float), f"{name} must hold integer node indices"),
                         (good + 1, rf"{name} refer to nodes outside 0..{corners - 1}")):
        with pytest.raises(MeshError, match=match):
            cls(points, cells)
