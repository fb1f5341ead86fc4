"""The GetFEM half of benchmarks/compare_getfem_hertz3d.py: the quarter Hertz block pressed by a fixed rigid
sphere, solved by GetFEM on the mesh cvxcontact wrote.

NOT part of CI and not importable from the project's venv: it needs Debian's GetFEM
(``apt-get install python3-getfem``, GetFEM 5.4) and runs under the system interpreter, which the
comparison script calls:

    /usr/bin/python3 benchmarks/getfem_hertz3d_side.py scene.npz answer.npz

Input (npz, plain arrays, no pickle): ``points`` (N, 3) m, ``tets`` (T, 4), ``zone`` (F, 3) the contact faces,
``bottom``/``left``/``front`` (., 3) the clamped bottom and the roller faces x = 0, y = 0 (their triangles),
``E`` (Pa), ``nu``, ``center`` (3,) m and ``radius`` m of the sphere (further keys, cvxcontact's answers, are
read only as ``u_in_<name>``).

GetFEM builds its own P1 tetrahedral mesh_fem from those points and cells (its dof numbering, mapped back to
the points by coordinates), the isotropic linearised elasticity brick (Lame constants from E, nu), the supports
as explicit dof constraints with multipliers (every component on the bottom's nodes, u_x on x = 0, u_y on
y = 0) and the sphere four ways, each solved by GetFEM's Newton on the Alart-Curnier augmented Lagrangian:

``obstacle``  GetFEM's nodal contact with a rigid obstacle given by its signed distance expression
              sqrt(x^2 + y^2 + (z - zc)^2) - R (``add_nodal_contact_with_rigid_obstacle_brick``): one row per
              node of the contact region, gap d(x), direction minus the gradient of d by a forward difference
              with step 1e-3 of the node's first cell's radius estimate (GetFEM's own normal).
``radial``    GetFEM's basic contact brick with the same rows but the gradient in closed form (the unit vector
              from the centre): the closest-point posing, like for like with cvxcontact's ``distance="closest"``.
``vertical``  the basic contact brick with rows along +z and the vertical distance to the sphere's lower surface:
              like for like with ``distance="ray"``.
``given``     the basic contact brick with the ``obstacle`` brick's own rows (read from GetFEM's tangent matrix,
              whose (u, lambda) block is -B_N^T) and the gap d(x): it isolates the forward-difference normal.

Output (npz): ``rows_obstacle`` (rows, 3) the obstacle brick's row directions, ``normal_error`` their largest
distance from the exact radial ones; per variant ``u_<variant>`` (N, 3) m at the input's points,
``lam_<variant>`` the nodal contact multipliers (GetFEM's sign: <= 0), ``fz_<variant>`` the vertical force (N, on
the quarter) that the block feels at its contact nodes, the z-sum of K u over them (K GetFEM's stiffness
assembled alone, so the roller reactions, along x or y, do not enter); and ``fz_of_<name>``, the same sum on
each displacement given as ``u_in_<name>`` (cvxcontact's answers: an independent read of their force).
"""

import sys

import getfem as gf
import numpy as np
from scipy.sparse import csc_matrix
from scipy.spatial import cKDTree

MAX_RES = 1e-8
"""N: the Newton residual GetFEM is asked for (absolute; the nodal forces are 1e2-1e3 N, and its Newton stalls at
roundoff, ~3e-11, measured at n = 4)."""


def build(data):
    P, T = data["points"], data["tets"]
    mesh = gf.Mesh("empty", 3)
    mesh.add_convex(gf.GeoTrans("GT_PK(3,1)"), np.transpose(P[T], (2, 1, 0)).copy())   # (3, 4, T)
    mf = gf.MeshFem(mesh, 3)
    mf.set_classical_fem(1)
    mim = gf.MeshIm(mesh, gf.Integ("IM_TETRAHEDRON(2)"))
    dof_points = mf.basic_dof_nodes().T                                              # (ndof, 3)
    dist, node = cKDTree(P).query(dof_points)
    assert dist.max() <= 1e-12 * np.abs(P).max(), "GetFEM's dofs do not sit on the input's points"
    assert mf.nbdof() == 3 * len(P)
    comp = np.arange(mf.nbdof()) % 3                                 # GetFEM: a node's 3 dofs consecutive
    assert np.all(node[0::3] == node[1::3]) and np.all(node[0::3] == node[2::3])
    # the contact region: the outer faces whose vertices are a triangle of the zone
    faces = mesh.outer_faces()                                                        # (2, nf): cv, face
    pid_points = mesh.pts().T
    _, pid_node = cKDTree(P).query(pid_points)
    zone = {tuple(sorted(t)) for t in data["zone"].tolist()}
    keep = []
    for cv, f in faces.T:
        pids = mesh.pid_in_faces(np.array([[cv], [f]]))
        if tuple(sorted(pid_node[pids].tolist())) in zone:
            keep.append((cv, f))
    assert len(keep) == len(zone), f"found {len(keep)} of the {len(zone)} contact faces"
    mesh.set_region(1, np.array(keep).T)
    return mesh, mf, mim, node, comp


def spmat(A):
    """A GetFEM sparse matrix holding the dense array A."""
    S = gf.Spmat("empty", *A.shape)
    S.assign(np.arange(A.shape[0]), np.arange(A.shape[1]), A)
    return S


def constraint_matrix(data, node, comp, ndof):
    """The supports as rows of the identity: every component on the bottom, u_x on x = 0, u_y on y = 0."""
    held = set()
    for tag, comps in (("bottom", (0, 1, 2)), ("left", (0,)), ("front", (1,))):
        nodes = np.unique(data[tag])
        held |= {(int(a), c) for a in nodes for c in comps}
    index = {(int(n), int(c)): i for i, (n, c) in enumerate(zip(node, comp))}
    cols = sorted(index[h] for h in held)
    B = np.zeros((len(cols), ndof))
    B[np.arange(len(cols)), cols] = 1.0
    return B


def model(data, mesh, mf, mim, node, comp):
    E, nu = float(data["E"]), float(data["nu"])
    md = gf.Model("real")
    md.add_fem_variable("u", mf)
    md.add_initialized_data("lambda", [E * nu / ((1 + nu) * (1 - 2 * nu))])
    md.add_initialized_data("mu", [E / (2 * (1 + nu))])
    md.add_isotropic_linearized_elasticity_brick(mim, "u", "lambda", "mu")
    B = constraint_matrix(data, node, comp, mf.nbdof())
    md.add_variable("held", B.shape[0])
    md.add_constraint_with_multipliers("u", "held", spmat(B), np.zeros(B.shape[0]))
    md.add_initialized_data("r", [E])
    return md


def contact_dofs(mf):
    """The first (x) dof of each node of the contact region, in GetFEM's order: one row per node."""
    first = np.asarray(mf.basic_dof_on_region(1))
    return first[first % 3 == 0]


def contact_rows(data, mf, node, kind):
    """(BN (rows, ndof), gap (rows,)) of the region's nodes, the condition BN u <= gap: ``kind`` "radial" (the
    closest point: gap |x - c| - R, direction (c - x) / |x - c|) or "vertical" (the ray along +z: gap the height
    of the sphere's lower surface above x, direction e_z)."""
    P, c, R = data["points"], data["center"], float(data["radius"])
    first = contact_dofs(mf)
    x = P[node[first]]
    if kind == "radial":
        w = x - c
        d = np.linalg.norm(w, axis=1)
        gap, direction = d - R, -w / d[:, None]
    else:
        r2 = (x[:, 0] - c[0]) ** 2 + (x[:, 1] - c[1]) ** 2
        gap = c[2] - np.sqrt(R ** 2 - r2) - x[:, 2]
        direction = np.tile([0.0, 0.0, 1.0], (len(x), 1))
    return row_matrix(direction, first, mf.nbdof()), gap


def row_matrix(direction, first, ndof):
    BN = np.zeros((len(first), ndof))
    for k in range(3):
        BN[np.arange(len(first)), first + k] = direction[:, k]
    return BN


def augmentation_weights(data, mf, mim):
    """The rows' weights alpha in the augmented complementarity function, as GetFEM's rigid-obstacle brick sets
    them (the diagonal of the contact region's mass matrix over the mesh's largest extent); they scale the
    Newton path, not the solution."""
    M = scipy_matrix(gf.asm_mass_matrix(mim, mf, mf, 1))
    return M.diagonal()[contact_dofs(mf)] / np.ptp(data["points"], axis=0).max()


def scipy_matrix(S):
    S.to_csc()
    indptr, rows = S.csc_ind()
    return csc_matrix((S.csc_val(), rows, indptr), shape=S.size())


def solve(data, variant, rows=None):
    """(u (N, 3) m, the multipliers (N, <= 0), the obstacle brick's rows (the direction of each, (rows, 3)) or
    None, (mesh, mf, mim, node, comp)) of one posing: ``variant`` "obstacle" (GetFEM's rigid-obstacle brick),
    "radial", "vertical" (:func:`contact_rows`) or "given" (the directions ``rows`` with the gap d(x))."""
    mesh, mf, mim, node, comp = build(data)
    md = model(data, mesh, mf, mim, node, comp)
    first = contact_dofs(mf)
    md.add_variable("lam", len(first))
    c, R = data["center"], float(data["radius"])
    if variant == "obstacle":
        expr = f"sqrt(x*x + y*y + (z-({c[2]!r}))*(z-({c[2]!r}))) - {R!r}"
        assert c[0] == 0.0 and c[1] == 0.0
        md.add_nodal_contact_with_rigid_obstacle_brick(mim, "u", "lam", "r", 1, expr, 1)
    else:
        if variant == "given":
            BN, gap = row_matrix(rows, first, mf.nbdof()), contact_rows(data, mf, node, "radial")[1]
        else:
            BN, gap = contact_rows(data, mf, node, variant)
        md.add_initialized_data("gap", gap)
        md.add_initialized_data("alpha", augmentation_weights(data, mf, mim))
        md.add_basic_contact_brick("u", "lam", "r", spmat(BN), "gap", "alpha", 1)
    _, converged = md.solve("max_res", MAX_RES, "max_iter", 40)
    assert converged, f"{variant}: GetFEM's Newton did not reach the residual {MAX_RES} N in 40 steps"
    directions = None
    if variant == "obstacle":            # its rows: the tangent's (u, lam) block is -BN^T (unit rows, no alpha)
        md.assembly("build_matrix")
        K = scipy_matrix(md.tangent_matrix())
        iu, il = md.interval_of_variable("u"), md.interval_of_variable("lam")
        BN = -K[iu[0]:iu[0] + iu[1], il[0]:il[0] + il[1]].toarray().T
        directions = np.stack([BN[np.arange(len(first)), first + k] for k in range(3)], axis=1)
        assert np.allclose(np.abs(BN).sum(), np.abs(directions).sum(), rtol=1e-14, atol=0)   # nothing else
    u = np.zeros((len(data["points"]), 3))
    u[node, comp] = md.variable("u")
    return u, md.variable("lam"), directions, (mesh, mf, mim, node, comp)


def vertical_force(data, mf, mim, node, comp, u):
    """N: the z-sum of K u over the contact nodes (K GetFEM's stiffness, no supports, no contact)."""
    E, nu = float(data["E"]), float(data["nu"])
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    mfd = gf.MeshFem(mf.linked_mesh(), 1)
    mfd.set_classical_fem(0)
    n_el = mfd.nbdof()
    K = gf.asm_linear_elasticity(mim, mf, mfd, np.full(n_el, lam), np.full(n_el, mu))
    U = u[node, comp]
    f = np.asarray(K.mult(U))
    first = np.asarray(mf.basic_dof_on_region(1))
    zdofs = first[first % 3 == 2]
    return float(-f[zdofs].sum())                  # the block pushes up on the sphere: K u is -(contact force)


def main(inp, out):
    with np.load(inp, allow_pickle=False) as f:
        data = {k: f[k] for k in f.files}
    result = {}
    for variant in ("obstacle", "radial", "vertical", "given"):
        u, lam, directions, (_, mf, mim, node, comp) = solve(data, variant, result.get("rows_obstacle"))
        result[f"u_{variant}"] = u
        result[f"lam_{variant}"] = lam
        result[f"fz_{variant}"] = np.array(vertical_force(data, mf, mim, node, comp, u))
        if directions is not None:
            result["rows_obstacle"] = directions
            radial = contact_rows(data, mf, node, "radial")[0]
            exact = np.stack([radial[np.arange(len(directions)), contact_dofs(mf) + k] for k in range(3)], axis=1)
            result["normal_error"] = np.array(np.linalg.norm(directions - exact, axis=1).max())
    for key, u in data.items():
        if key.startswith("u_in_"):
            result["fz_of_" + key[5:]] = np.array(vertical_force(data, mf, mim, node, comp, u))
    np.savez(out, **result)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
