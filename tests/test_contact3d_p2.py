"""P2 (10-node) tetrahedra in contact under the nodal conditions (docs/formulation.md §15): the P2 mass matrix of
a triangle against exact integration, patch tests to rounding (uniform pressure through matching and nested
faces, a layer on a rigid plane), and every scene against an independent dense solve of the mixed system (26)
whose rows are rebuilt here by brute force (the P2 shape functions re-derived, every face tried)."""

from itertools import product
from math import factorial

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.contact.quadratic3d import P2_TRIANGLE_MASS
from cvxcontact.fem import p2
from cvxcontact.geometry.quadratic import P2TetNodes

from reference3d import Dense, obstacle_distance, plane_frame
from scenes3d import P, bumped_blocks, bumped_gap, layer_on_plane, stacked_blocks, uniaxial_modulus

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def uniaxial_error(sol) -> float:
    c = uniaxial_modulus()
    uz = max(float(np.abs(u[:, 2] + P * x[:, 2] / c).max()) for u, x in zip(sol.u, sol.points))
    uxy = max(float(np.abs(u[:, :2]).max()) for u in sol.u)
    return max(uz, uxy) / (P / c)


def test_the_p2_triangle_mass_matrix_is_the_exact_integral():
    """Each triangle6 shape function as a quadratic form in the barycentric coordinates (L_i (2 L_i - sum L),
    4 L_i L_j), integrated exactly by int L^a = 2 A a! / (|a| + 2)!."""
    S = np.zeros((6, 3, 3))
    for i in range(3):
        S[i] = -np.outer(np.eye(3)[i], np.ones(3))
        S[i, i, i] += 2.0
    for n, (i, j) in enumerate([(0, 1), (1, 2), (2, 0)]):
        S[3 + n, i, j] = 4.0

    def integral(idx):          # int over a triangle of area 1/2 of prod L_idx
        a = np.bincount(idx, minlength=3)
        return 2 * 0.5 * np.prod([factorial(k) for k in a]) / factorial(a.sum() + 2)

    M = np.zeros((6, 6))
    for a, b, c, d in product(range(3), repeat=4):
        M += np.outer(S[:, a, b], S[:, c, d]) * integral(np.array([a, b, c, d]))
    np.testing.assert_allclose(P2_TRIANGLE_MASS, 2 * M, rtol=0, atol=1e-15)   # unit area


# ---------------------------------------------------------------------------------------------------------
# patch tests (rounding)

def test_a_layer_on_a_rigid_plane_is_in_uniaxial_strain_with_p2():
    sol = cc.solve(layer_on_plane(n=(2, 2, 1)), "sigma1", degree=2)
    assert sol.ok and sol.polished and sol.degree == 2
    assert sol.u[0].shape == (75, 3) and sol.contact.points.shape == (25, 3)   # 5 x 5 P2 face nodes
    assert uniaxial_error(sol) < 1e-13                                          # measured 1.1e-15
    np.testing.assert_allclose(sol.obstacles[0].force, [0, 0, P], rtol=0, atol=1e-12 * P)   # measured 7e-16 P
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-13                        # measured 3.3e-15
    assert np.abs(sol.traction(0)[1] / P - 1).max() < 1e-13                     # measured 3.3e-15


@pytest.mark.parametrize("counts, condition", [(((3, 3), (3, 3)), "sigma1"), (((3, 3), (3, 3)), "sigma2"),
                                               (((2, 2), (4, 4)), "sigma2"), (((4, 4), (2, 2)), "sigma1")],
                         ids=["matching, sigma1", "matching, sigma2", "fine upper", "fine lower"])
def test_uniform_pressure_through_matching_and_nested_faces_is_exact(counts, condition):
    """With the nodes of the finer (or either matching) side the P2 nodal rows pass the patch test: the
    uniaxial solution, lambda_h = p on the overlay, the pressure p felt by both bodies."""
    sol = cc.solve(stacked_blocks(*counts, nz=1), condition, degree=2)
    assert sol.ok and sol.polished
    assert uniaxial_error(sol) < 1e-13                                          # measured <= 3.5e-15
    assert np.abs(sol.contact.lam / P - 1).max() < 1e-12                        # measured <= 2.3e-14
    assert abs(sol.contact.force.sum() / P - 1) < 1e-13                         # area 1 m^2
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] / P - 1).max() < 1e-12                 # measured <= 2.3e-14


def test_the_coarser_sides_p2_nodes_on_nested_faces_fail_the_patch_test():
    """As with P1 (docs/formulation.md §13): node-to-face rows at the coarser side's nodes let the finer side's
    midpoints between them penetrate, and the pressure is not transmitted uniformly."""
    sol = cc.solve(stacked_blocks((2, 2), (4, 4), nz=1), "sigma1", degree=2)
    assert sol.ok and sol.polished
    assert uniaxial_error(sol) > 0.1                                            # measured 0.44
    assert abs(sol.contact.force.sum() / P - 1) < 1e-13                         # the resultant still balances


# ---------------------------------------------------------------------------------------------------------
# against an independent dense solve of (26)

def _shape(L):
    """The triangle6 shape functions (v0, v1, v2, m01, m12, m20) at barycentric rows L."""
    return np.column_stack([L[:, 0] * (2 * L[:, 0] - 1), L[:, 1] * (2 * L[:, 1] - 1), L[:, 2] * (2 * L[:, 2] - 1),
                            4 * L[:, 0] * L[:, 1], 4 * L[:, 1] * L[:, 2], 4 * L[:, 2] * L[:, 0]])


def _faces(scene, k, part):
    nodes = P2TetNodes(scene.bodies[k].mesh)
    f6 = np.asarray(nodes.boundary(part))
    normal = np.asarray(scene.bodies[k].mesh.outward_normals(part)).mean(axis=0)
    return nodes, f6, normal / np.linalg.norm(normal)


def _values(s, X, f6, n_dofs, normal, tol=1e-9):
    """(len(s), n_dofs): nu . u at the in-plane points s from the P2 displacements, each point in the first
    face (every face tried) whose barycentric coordinates are all >= -tol; a row of NaN outside."""
    out = np.full((len(s), n_dofs), np.nan)
    for p, x in enumerate(s):
        for f in f6:
            A, B, C = X[f[:3]]
            L12 = np.linalg.solve(np.column_stack([B - A, C - A]), x - A)
            L = np.array([[1 - L12.sum(), *L12]])
            if L.min() >= -tol:
                out[p] = 0.0
                for a in range(3):
                    out[p, 3 * f + a] = normal[a] * _shape(L)[0]
                break
    return out


def dense_p2(scene, condition, gap=None, plane=None):
    """Dense (tests/reference3d.py) with P2 systems and brute-force P2 rows: two bodies, rows at body l's P2
    face nodes inside the other's faces ("sigma_l"); a rigid plane ``plane`` = (point, normal), rows at every
    P2 face node. Returns (reference, R per body on the full nodal dofs, g)."""
    systems = []
    for b in scene.bodies:
        nodes = P2TetNodes(b.mesh)
        systems.append(p2.assemble_loads(b, p2.assemble_matrices(b, nodes), nodes))
    c = scene.contacts[0]
    n = [3 * len(P2TetNodes(b.mesh).points) for b in scene.bodies]
    if plane is not None:
        nodes, f6, nu = _faces(scene, 0, c.part_a)
        at = np.unique(f6)
        x = np.asarray(nodes.points)[at]
        d = obstacle_distance(("plane", *plane), x, nu)[0]
        R = {0: np.zeros((len(at), n[0]))}
        for a in range(3):
            R[0][np.arange(len(at)), 3 * at + a] = nu[a]
        g = d
    else:
        l = int(condition[-1]) - 1
        sides = [_faces(scene, k, part) for k, part in ((0, c.part_a), (1, c.part_b))]
        T = plane_frame(sides[0][2])
        own_nodes, own_f6, own_nu = sides[l]
        at = np.unique(own_f6)
        s = np.asarray(own_nodes.points)[at] @ T.T
        other_nodes, other_f6, other_nu = sides[1 - l]
        other = _values(s, np.asarray(other_nodes.points) @ T.T, other_f6, n[1 - l], other_nu)
        keep = ~np.isnan(other[:, 0])
        own = np.zeros((keep.sum(), n[l]))
        for a in range(3):
            own[np.arange(keep.sum()), 3 * at[keep] + a] = own_nu[a]
        R = {l: own, 1 - l: other[keep]}
        g = np.zeros(keep.sum()) if gap is None else gap(s[keep, 0], s[keep, 1])
    ref = Dense.__new__(Dense)
    sizes = []
    for s_ in systems:
        sizes += [s_.Tu.shape[1], 0 if s_.Tp is None else s_.Tp.shape[1]]
    ref.systems, ref.off = systems, np.concatenate([[0], np.cumsum(sizes + [0])])
    N = ref.off[-1]
    K, b, G, gg = np.zeros((N, N)), np.zeros(N), np.zeros((len(g), N)), np.array(g, dtype=float)
    for k, s_ in enumerate(systems):
        z = slice(ref.off[2 * k], ref.off[2 * k + 1])
        Tu = s_.Tu.toarray()
        K[z, z] = Tu.T @ s_.Kuu.toarray() @ Tu
        b[z] = s_.reduced_loads()[0]
        G[:, z] = R[k] @ Tu
        gg -= R[k] @ s_.u_fixed
    ref.K, ref.b, ref.G, ref.g = K, b, G, gg
    return ref, R, np.asarray(g, dtype=float)


DENSE = {
    "layer on a plane": (lambda: layer_on_plane(n=(2, 2, 1)), "sigma1", dict(plane=((0, 0, 0), (0, 0, 1)))),
    "stacked 3x3 on 2x2, sigma1": (lambda: stacked_blocks((3, 3), (2, 2), nz=1), "sigma1", {}),
    "stacked 3x3 on 2x2, sigma2": (lambda: stacked_blocks((3, 3), (2, 2), nz=1), "sigma2", {}),
    "bumped, sigma1": (lambda: bumped_blocks((3, 3), (2, 3)), "sigma1", dict(gap=bumped_gap)),
    "bumped, sigma2": (lambda: bumped_blocks((3, 3), (2, 3)), "sigma2", dict(gap=bumped_gap)),
}


@pytest.mark.parametrize("name", list(DENSE))
def test_p2_nodal_conditions_against_a_dense_solve_of_the_mixed_system(name):
    """The reference's rows at the package's answer give the active set (rows within rounding of the gap);
    (26) solved densely on it is certified (every row feasible, non-negative forces balance the momentum
    rows) and equals the package's exact finish to rounding."""
    make, condition, extra = DENSE[name]
    scene = make()
    sol = cc.solve(scene, condition, degree=2)
    assert sol.ok and sol.polished
    ref, R, g = dense_p2(scene, condition, **extra)
    jump = sum(R[k] @ sol.u[k].ravel() for k in R)
    scale = max(float(np.abs(u).max()) for u in sol.u)
    assert (jump - g).max() < 1e-12 * scale                                     # feasible at the ref's rows
    active = jump - g > -1e-10 * scale
    assert active.any() and (name.startswith("bumped") <= (~active).any())     # bumped: a contact edge inside
    ans = ref.solve_on(active)
    _, unbalanced, _ = ref.certify(ans, active)
    penetration = float((ref.G @ ans.x - ref.g).max()) / scale     # (the layer's contact face does not move)
    assert penetration < 1e-12 and unbalanced < 1e-12                           # measured <= 5.4e-16, 1.5e-14
    err = max(float(np.abs(a - b).max()) for a, b in zip(sol.u, ans.u)) / scale
    assert err < 1e-12                                                          # measured <= 6.5e-15
