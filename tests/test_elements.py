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

ELEMENTS = [("triangle", 1), ("triangle", 2), ("quad", 1), ("quad", 2)]
IDS = ["P1", "P2", "Q1", "Q2"]
STEEL = cc.materials.isotropic(E=200e9, nu=0.3)
ALU = cc.materials.isotropic(E=70e9, nu=0.33)
PZT = cc.materials.PZT5A


def distorted(cell, nx=3, ny=3, amount=0.25, seed=0, x=(0.0, 1.0), y=(0.0, 1.0)):
    """A rectangle mesh whose interior nodes are moved at random by up to ``amount`` of a cell (the sides stay
    straight: one tag, one normal)."""
    mesh = cc.rectangle(x=x, y=y, nx=nx, ny=ny, cell=cell)
    p = mesh.points.copy()
    inside = np.ones(len(p), dtype=bool)
    inside[mesh.boundary_nodes(mesh.tags)] = False
    h = np.array([(x[1] - x[0]) / nx, (y[1] - y[0]) / ny])
    p[inside] += amount * h * np.random.default_rng(seed).uniform(-1, 1, (int(inside.sum()), 2))
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
    b, t, qv, q2 = (3.0, -5.0), (7.0, 11.0), 13.0, 17.0
    body = cc.Body(distorted(cell), PZT, clamped=["bottom"], grounded=["bottom"], body_force=b, traction={"top": t},
                   volume_charge=qv, surface_charge={"right": q2})
    S, nodes, held, sys_ = system(body, cell, degree)
    el, G = S.centre_gradients(body, nodes)
    assert np.abs(G.sum(axis=2)).max() <= 1e-12 * np.abs(G).max()                 # measured <= 2.4e-16
    X = held.points[el]                                                            # (m, k, 2)
    assert np.abs(np.einsum("mdk,mke->mde", G, X) - np.eye(2)).max() <= 1e-12      # measured <= 2.2e-15
    area = body.mesh.areas.sum()                                                   # 1 m^2; each side 1 m long
    force = np.array(b) * area + np.array(t) * 1.0
    assert np.abs(sys_.f.reshape(-1, 2).sum(axis=0) / force - 1).max() <= 1e-12    # measured <= 8.9e-16
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
    """K r = 0 for the two translations and the rotation; K has exactly three zero eigenvalues (full
    integration: no hourglass or other spurious mode); Kpp has the constants alone and Kup^T r = 0."""
    body = cc.Body(distorted(cell, 2, 2), PZT, clamped=["bottom"], grounded=["bottom"])
    _, _, held, s = system(body, cell, degree)
    x = held.points
    n = len(x)
    modes = np.stack([np.tile([1.0, 0.0], n), np.tile([0.0, 1.0], n), np.column_stack([-x[:, 1], x[:, 0]]).ravel()])
    K = s.Kuu.toarray()
    scale = np.abs(K).max()
    assert np.abs(K @ modes.T).max() <= 1e-12 * scale                               # measured <= 2.5e-16
    assert np.abs(s.Kup.T @ modes.T).max() <= 1e-12 * np.abs(s.Kup).max()          # measured <= 2.3e-16
    ev = np.linalg.eigvalsh(K) / scale
    assert (ev < 1e-10).sum() == 3 and ev[3] > 1e-6                                 # measured ev[3] >= 0.018
    P = s.Kpp.toarray()
    ep = np.linalg.eigvalsh(P) / np.abs(P).max()
    assert np.abs(P @ np.ones(n)).max() <= 1e-12 * np.abs(P).max()
    assert (ep < 1e-10).sum() == 1 and ep[1] > 1e-6                                 # measured ep[1] >= 0.047


def _divergence_free_field(degree, rng):
    """(u(x) (k, 2), phi(x) (k,)): a random field of total degree ``degree`` with div sigma = 0 and div D = 0
    for PZT (sigma = c eps + e^T grad phi, D = e eps - kappa grad phi; linear fields: any). Its quadratic part
    spans the null space of the divergences, found by central differences (exact on the linear stresses)."""
    c, e, kappa = PZT.tensors(2)
    U, V = 1e-6, 1e2                        # the scales of u (m) and phi (V)

    def fields(coef):
        A, b, Q, q = coef                   # u = A x + Q.(x^2, xy, y^2), phi = b.x + q.(x^2, xy, y^2)

        def flux(x):
            X, Y = x[..., 0], x[..., 1]
            du = A + np.stack([np.stack([2 * Q[a, 0] * X + Q[a, 1] * Y, Q[a, 1] * X + 2 * Q[a, 2] * Y], -1)
                                     for a in range(2)], -2)                          # (k, 2, 2) du_a/dx_j
            dphi = b + np.stack([2 * q[0] * X + q[1] * Y, q[1] * X + 2 * q[2] * Y], -1)
            eps = np.stack([du[..., 0, 0], du[..., 1, 1], du[..., 0, 1] + du[..., 1, 0]], -1)
            return eps @ c.T + dphi @ e, eps @ e.T - dphi @ kappa.T                 # Voigt sigma, D

        def div(x):
            h = 0.5
            out = np.zeros(3)
            for j in range(2):
                step = np.zeros(2)
                step[j] = h
                (sp, Dp), (sm, Dm) = flux(x + step), flux(x - step)
                ds, dD = (sp - sm) / (2 * h), (Dp - Dm) / (2 * h)
                out[0] += ds[[0, 2][j]]            # d sxx/dx + d sxy/dy
                out[1] += ds[[2, 1][j]]            # d sxy/dx + d syy/dy
                out[2] += dD[j]
            return out

        return div

    A, b = U * rng.standard_normal((2, 2)), V * rng.standard_normal(2)
    Q, q = np.zeros((2, 3)), np.zeros(3)
    if degree == 2:
        basis = np.eye(9)
        M = np.column_stack([fields((np.zeros((2, 2)), np.zeros(2), (U * k[:6]).reshape(2, 3), V * k[6:]))(np.zeros(2))
                             for k in basis])
        size = np.abs(M).max(axis=1)                         # the divergences of unit coefficients, per row
        Z = null_space(M / size[:, None])                    # (9, 6)
        k = Z @ rng.standard_normal(Z.shape[1])
        Q, q = (U * k[:6]).reshape(2, 3), V * k[6:]
        assert (np.abs(fields((A, b, Q, q))(np.array([0.3, 0.7]))) <= 1e-12 * size * np.abs(k).max()).all()

    def u(x):
        m = np.column_stack([x[:, 0] ** 2, x[:, 0] * x[:, 1], x[:, 1] ** 2])
        return x @ A.T + m @ Q.T

    def phi(x):
        m = np.column_stack([x[:, 0] ** 2, x[:, 0] * x[:, 1], x[:, 1] ** 2])
        return x @ b + m @ q

    return u, phi


@pytest.mark.parametrize("cell,degree", ELEMENTS, ids=IDS)
def test_patch_test_on_distorted_cells(cell, degree):
    """Irons' patch test: a field of the element's degree with divergence-free stress and electric displacement
    (linear for P1/Q1, quadratic for P2/Q2; quadrilaterals moved off parallelograms) makes the rows of every
    interior node of [Kuu Kup; Kup^T -Kpp] vanish: the element represents it exactly and integrates its weak
    form exactly (2 x 2 and 3 x 3 Gauss on the bilinear map)."""
    body = cc.Body(distorted(cell, 4, 3, seed=degree), PZT, clamped=["bottom"], grounded=["bottom"])
    _, _, held, s = system(body, cell, degree)
    u, phi = _divergence_free_field(degree, np.random.default_rng(7))
    x = held.points
    U, P = u(x).ravel(), phi(x)
    inside = np.ones(len(x), dtype=bool)
    inside[held.boundary_nodes(body.mesh.tags)] = False
    assert inside.sum() >= 4
    rows = np.flatnonzero(np.repeat(inside, 2))
    Kuu, Kup, Kpp = s.Kuu, s.Kup, s.Kpp
    r_u = (Kuu @ U + Kup @ P)[rows]
    r_p = (Kup.T @ U - Kpp @ P)[inside]
    size_u = (abs(Kuu) @ np.abs(U) + abs(Kup) @ np.abs(P))[rows]
    size_p = (abs(Kup).T @ np.abs(U) + abs(Kpp) @ np.abs(P))[inside]
    assert np.abs(r_u).max() <= 1e-11 * size_u.max()                                # measured <= 1.2e-16
    assert np.abs(r_p).max() <= 1e-11 * size_p.max()                                # measured <= 1.3e-16


H1, H2, DELTA = 0.4, 0.2, 1e-4


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
    assert sol.estimate is None and "quad" in sol.estimate_reason
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


@pytest.mark.parametrize("cell,degree", ELEMENTS, ids=IDS)
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
    on quadrilaterals."""
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
    for kind in ("residual", "equilibrated"):
        with pytest.raises(UnsupportedError, match="estimate=False, or triangles"):
            cc.solve(scene, "sigma1", estimate=kind)
    with pytest.raises(UnsupportedError, match="triangle and tetrahedron meshes only"):
        cc.adapt(scene, "sigma1")
    sol = cc.solve(scene, "sigma1")
    assert sol.ok and sol.estimate is None
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
