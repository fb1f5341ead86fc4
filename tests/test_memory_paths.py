"""The memory-saving code paths of the 3D pipeline give what the straightforward construction gives, on small
meshes: the free rigid motions from an SVD without its left factor (`physics/supports.py` `free_basis`), the
estimate's strain fields formed without per-cell strain matrices (`solution/estimate.py` `_strains`,
`fem.assembly.voigt_strains`) and its diameters by blocks of cells (`simplex_diameters`, blocks of
`solution/contactestimate.py` `CELLS`), the tetrahedra's barycentric gradients by
blocks (`fem/assembly.py`, blocks of `TETS`) and the P1 corner gradients as a view of them (`corner_gradients`),
the AMG route's coupling block taken columns first (`backends/amg.py` `_precondition`) and what it releases after
a solve (`release`), and the sparse route's backward-error sizes by rows (`backends/sparse.py`). The references
are computed here the plain way."""

import numpy as np
import pytest
import scipy.sparse as sp
from scenes3d import two_boxes

import cvxcontact as cc
from cvxcontact.fem.assembly import strain_matrix
from cvxcontact.physics import supports
from cvxcontact.solution import contactestimate as cest
from cvxcontact.solution import estimate as est

ALU = cc.materials.isotropic(E=70e9, nu=0.3)


def _projector(V):
    """The orthogonal projector onto the row space of V (k, 6): independent of the basis chosen."""
    return V.T @ V if len(V) else np.zeros((6, 6))


@pytest.mark.parametrize("kw, free", [({"contact": "bottom"}, 3),                     # the normal holds tz, wx, wy
                                      ({"roller": ["left"], "contact": "bottom"}, 1),  # the roller tx, wy, wz
                                      ({"clamped": ["bottom"]}, 0)])
def test_free_basis_without_the_left_factor_matches_the_full_svd(monkeypatch, kw, free):
    """free_basis with ``full_matrices=False`` spans the same free motions as the full SVD (whose U is a
    square of the support rows), to 1e-14 in the projector; their number is the one the supports leave."""
    body = cc.Body(cc.box(nx=3, ny=2, nz=2), ALU, name="block", **kw)
    saving = supports.free_basis(body, True)
    plain_svd = np.linalg.svd
    monkeypatch.setattr(np.linalg, "svd", lambda a, full_matrices=True, **k: plain_svd(a, full_matrices=True, **k))
    plain = supports.free_basis(body, True)
    assert [c for c, *_ in saving] == [c for c, *_ in plain]
    assert sum(len(V) for _, V, _, _ in saving) == free
    for (_, V, centre, size), (_, W, c2, s2) in zip(saving, plain):
        assert np.array_equal(centre, c2) and size == s2
        assert np.abs(_projector(V) - _projector(W)).max() <= 1e-14


@pytest.mark.numerics
@pytest.mark.parametrize("degree", [1, 2])
def test_estimate_strains_by_blocks_equal_the_stored_strain_matrices(monkeypatch, degree):
    """The strains without strain matrices (`voigt_strains`) are those of the strain matrices of every cell, to
    rounding (the same products summed in another order: measured <= 2.2e-16 of the largest); the diameters by
    blocks of 7 cells (a ragged last block) exactly; and the estimate the same with blocks of 7 cells as with one."""
    monkeypatch.setattr(cest, "CELLS", 7)
    scene = two_boxes(3)                                       # a loaded PZT-5A box on an aluminium box
    body = scene.bodies[0]
    m = body.mesh
    g = est.Geometry(body, degree)
    rng = np.random.default_rng(3)
    u = rng.standard_normal(int(g.el.max() + 1) * 3)
    ue = u.reshape(-1, 3)[g.el].reshape(len(g.el), -1)
    plain = np.stack([np.einsum("mij,mj->mi", strain_matrix(g.G[:, i]), ue) for i in range(g.G.shape[1])], axis=1)
    assert len(m.cells) % 7 and np.abs(est._strains(g.G, ue) - plain).max() <= 1e-13 * np.abs(plain).max()
    p = m.points[m.cells]
    i, j = np.triu_indices(4, 1)
    edge = p[:, i] - p[:, j]                                   # every cell at once
    assert np.array_equal(est.simplex_diameters(m.points, m.cells),
                          np.sqrt(np.einsum("med,med->me", edge, edge).max(axis=1)))
    sol = cc.solve(scene, "sigma1", degree=degree)
    small = sol.estimate
    monkeypatch.setattr(cest, "CELLS", 1 << 15)
    whole = est.estimate(sol)[0]
    assert abs(small.absolute - whole.absolute) <= 1e-14 * whole.absolute
    assert all(np.abs(a - b).max() <= 1e-14 * b.max() for a, b in zip(small.indicators, whole.indicators))


def test_coupling_block_columns_first_equals_rows_first():
    """K[:, p][u] (the AMG preconditioner's K_up, no copy of K's u rows) holds the same CSR arrays as K[u][:, p]."""
    rng = np.random.default_rng(0)
    K = sp.random(400, 400, density=0.05, random_state=1, format="csr")
    K = (K + K.T).tocsr()
    u = np.sort(rng.choice(400, 300, replace=False))
    p = np.setdiff1d(np.arange(400), u)
    a, b = K[u][:, p].tocsr(), K[:, p][u].tocsr()
    assert all(np.array_equal(x, y) for x, y in ((a.indptr, b.indptr), (a.indices, b.indices), (a.data, b.data)))


@pytest.mark.numerics
def test_amg_route_rebuilds_its_stacked_blocks_after_a_solve_as_first_built():
    """The AMG route drops S (the bodies' quasi-definite blocks stacked, a copy of the stiffness) after a solve and
    stacks it again on the next: the same CSR arrays as a fresh KrylovContact's; a re-solve (warm, from the first
    one's active set) agrees with the first solve to the Krylov tolerance."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends.amg import KrylovContact

    solver = cc.ContactSolver(two_boxes(4), method="amg")
    np.random.seed(5)
    first = solver.solve()
    np.random.seed(5)
    again = solver.solve()                                                   # S stacked again, warm start
    assert first.ok and again.ok and first.info.route != again.info.route
    assert np.abs(again.u[0] - first.u[0]).max() <= 1e-9 * np.abs(first.u[0]).max()   # measured 0.0
    kc = solver.cache.amg
    assert kc is not None and kc.S is None                                   # dropped after the solve
    fresh = KrylovContact(solver.problem).S
    n, m = kc.n, kc.m
    assert kc.solve(np.zeros(n), np.zeros(m), np.zeros(m, dtype=bool)) is not None
    S = kc._stacked()                                      # (dropped again after that solve)
    assert all(np.array_equal(a, b) for a, b in ((S.indptr, fresh.indptr), (S.indices, fresh.indices),
                                                 (S.data, fresh.data)))


def test_abs_product_by_row_blocks_equals_abs_of_the_matrix(monkeypatch):
    """|K| |z| by blocks of 7 rows (a ragged last block) is abs(K) @ |z| exactly, on a canonical CSR matrix; a
    non-canonical one (duplicate entries) takes abs(K) itself; a CSC one goes by blocks of 7 columns (the same
    terms, all non-negative, summed in another order: within the row's term count times eps)."""
    from cvxcontact.discrete import energy

    monkeypatch.setattr(energy, "ROWS", 7)
    K = sp.random(60, 45, density=0.2, random_state=2, format="csr") - 0.5 * sp.random(60, 45, density=0.2,
                                                                                       random_state=3, format="csr")
    z = np.random.default_rng(4).standard_normal(45)
    assert K.has_canonical_format and np.array_equal(energy.abs_product(K, z), abs(K) @ np.abs(z))
    dup = sp.csr_matrix((np.array([1.0, -2.0, 3.0]), np.array([1, 1, 0]), np.array([0, 2, 3])), shape=(2, 2))
    assert np.array_equal(energy.abs_product(dup, [1.0, 1.0]), abs(dup) @ np.ones(2))      # |1 - 2| = 1, not 3
    plain, terms = abs(K.tocsc()) @ np.abs(z), np.diff(K.indptr)
    assert np.all(np.abs(energy.abs_product(K.tocsc(), z) - plain) <= terms * np.finfo(float).eps * plain)


def _tet_gradients_at_once(points, tets):
    """The barycentric gradients of every tetrahedron at once (the plain construction, no blocks)."""
    p = points[tets]
    e1, e2, e3 = (p[:, k] - p[:, 0] for k in (1, 2, 3))
    c = np.stack([np.cross(e2, e3), np.cross(e3, e1), np.cross(e1, e2)], axis=2)
    det = np.einsum("md,md->m", e1, c[:, :, 0])
    g = c / det[:, None, None]
    return det / 6.0, np.concatenate([-g.sum(axis=2, keepdims=True), g], axis=2)


def test_tet_gradients_by_blocks_equal_every_cell_at_once(monkeypatch):
    """Blocks of 7 tetrahedra (a ragged last block) give the volumes and gradients of every cell at once, exactly;
    and they are the barycentric gradients: sum_i grad L_i = 0 and grad L_i . (p_j - p_0) = delta_ij - delta_i0
    (to rounding), the volumes those of the determinant of the edge vectors."""
    from cvxcontact.fem import assembly

    mesh = cc.box(x=(0.0, 1.0), y=(0.0, 2.0), z=(0.0, 0.5), nx=3, ny=2, nz=2)
    rng = np.random.default_rng(6)
    points = mesh.points + 0.05 * rng.standard_normal(mesh.points.shape)     # skewed cells, still positive
    monkeypatch.setattr(assembly, "TETS", 7)
    vol, grad = assembly.gradients(points, mesh.cells)
    plain_vol, plain_grad = _tet_gradients_at_once(points, mesh.cells)
    assert len(mesh.cells) % 7 and np.array_equal(vol, plain_vol) and np.array_equal(grad, plain_grad)
    p = points[mesh.cells]
    edges = p[:, 1:] - p[:, :1]                                              # (m, 3, 3): rows p_j - p_0
    assert np.allclose(vol, np.linalg.det(edges) / 6.0, rtol=1e-12, atol=0.0) and (vol > 0).all()
    target = np.broadcast_to(np.vstack([-np.ones(3), np.eye(3)]), (len(vol), 4, 3))
    assert np.abs(np.einsum("mdi,mjd->mij", grad, edges) - target).max() <= 1e-12


@pytest.mark.parametrize("degree", [1, 2])
def test_corner_gradients_from_given_barycentric_gradients(degree):
    """A space's corner gradients from the mesh's barycentric gradients handed in equal those it forms itself,
    exactly; P1's are then a view of them (the estimate's Geometry keeps one copy of the gradients)."""
    from cvxcontact.fem.assembly import gradients
    from cvxcontact.fem.space import space

    body = two_boxes(3).bodies[0]
    element = space(degree, body.mesh.cell)
    gradL = gradients(body.mesh.points, body.mesh.cells)[1]
    cells, G = element.corner_gradients(body, gradL)
    plain_cells, plain_G = element.corner_gradients(body)
    assert np.array_equal(cells, plain_cells) and np.array_equal(G, plain_G)
    assert np.shares_memory(G, gradL) == (degree == 1)
    g = est.Geometry(body, degree)
    assert np.array_equal(g.G, plain_G) and np.shares_memory(g.G, g.gradL) == (degree == 1)


@pytest.mark.numerics
def test_amg_route_releases_its_preconditioner_and_modes_and_resolves_alike():
    """After a solve the AMG route keeps neither its last preconditioner (the contact rows' factor and a copy of
    the coupling block) nor the rigid-body modes (used by the one set-up), only the hierarchy; a second solver
    that keeps them (``release`` a no-op) gives the same answers, first and warm re-solve, to the Krylov
    tolerance (measured: equal), with the same steps and Krylov iterations."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends.amg import KrylovContact

    scene = two_boxes(4)
    np.random.seed(5)
    saving = cc.ContactSolver(scene, method="amg")
    runs = [saving.solve(), saving.solve()]
    kc = saving.cache.amg
    assert kc.S is None and kc._preconditioner is None and kc.modes is None and kc.ml_u is not None
    keep = KrylovContact.release
    try:
        KrylovContact.release = lambda self: None                       # the plain route: nothing dropped
        np.random.seed(5)
        plain = cc.ContactSolver(scene, method="amg")
        again = [plain.solve(), plain.solve()]
        assert plain.cache.amg._preconditioner is not None
    finally:
        KrylovContact.release = keep
    for a, b in zip(runs, again):
        assert a.ok and b.ok and a.info.route == b.info.route and a.info.iterations == b.info.iterations
        for k in range(2):
            assert np.abs(a.u[k] - b.u[k]).max() <= 1e-9 * np.abs(b.u[k]).max()
    assert saving.cache.amg.iterations == plain.cache.amg.iterations


def test_sparse_route_backward_error_sizes_without_abs_of_the_matrix(monkeypatch):
    """The sparse route's refinement sizes |K| |z| of K(A) (CSC) by ``abs_product``: with one block of columns
    exactly abs(K) @ |z|, by blocks of 7 columns the same non-negative terms summed in another order (each row
    within its term count times eps, the bound of the two orders)."""
    from cvxcontact.backends.sparse import SparseContact
    from cvxcontact.discrete import energy

    solver = cc.ContactSolver(two_boxes(3), method="sparse")
    solver.solve()
    sc = SparseContact(list(solver.problem.blocks), solver.problem.E)
    rng = np.random.default_rng(8)
    for _ in range(3):
        K = sc.matrix(rng.random(sc.m) < 0.5)
        z = rng.standard_normal(K.shape[0])
        plain = abs(K) @ np.abs(z)
        assert K.format == "csc" and np.array_equal(energy.abs_product(K, z), plain)
        monkeypatch.setattr(energy, "ROWS", 7)
        terms = np.diff(K.tocsr().indptr)
        assert np.all(np.abs(energy.abs_product(K, z) - plain) <= terms * np.finfo(float).eps * plain)
        monkeypatch.setattr(energy, "ROWS", 1 << 16)


def _same_csr(A, B) -> bool:
    return all(np.array_equal(a, b) and a.dtype == b.dtype for a, b in ((A.indptr, B.indptr),
                                                                        (A.indices, B.indices), (A.data, B.data)))


@pytest.mark.parametrize("rows", [1, 7, 1 << 16])
def test_congruence_by_row_blocks_holds_the_arrays_of_the_whole_expression(monkeypatch, rows):
    """``congruence(Tt, S, T, D)`` by blocks of ``rows`` rows holds the arrays of (Tt @ S @ T + D).tocsr(), entry
    order included: with a product whose rows come unsorted (scipy's sum then reverses them), with a canonical
    product (a diagonal S and T: the merged, sorted sum), and with D on a row the product fills (the whole
    expression, the fallback)."""
    from cvxcontact.backends import amg

    monkeypatch.setattr(amg, "ROWS", rows)
    rng = np.random.default_rng(9)
    n = 60
    T = (sp.identity(n, format="csr") + sp.random(n, n, density=0.05, random_state=10, format="csr")).tocsr()
    held = np.array([3, 17, 40])                                   # T's columns there zero: Tt's rows empty
    keep = np.setdiff1d(np.arange(n), held)
    T = (T @ sp.diags(np.isin(np.arange(n), keep).astype(float))).tocsr()
    T.eliminate_zeros()
    S = sp.random(n, n, density=0.1, random_state=11, format="csr")
    S = (S + S.T + sp.identity(n)).tocsr()
    D = sp.csr_matrix((rng.random(len(held)) + 1.0, (held, held)), shape=(n, n))
    Tt = T.T.tocsr()
    for A, B, C in ((Tt, S, T), (sp.identity(n, format="csr") - sp.csr_matrix((np.ones(3), (held, held)),
                                                                              shape=(n, n)),
                                 sp.diags(rng.random(n) + 1.0, format="csr"), sp.identity(n, format="csr"))):
        A.eliminate_zeros()
        whole = (A @ B @ C + D).tocsr()
        assert _same_csr(amg.congruence(A, B, C, D), whole)
    full = sp.csr_matrix((np.ones(1), ([5], [5])), shape=(n, n))   # row 5 of the product is not empty
    assert _same_csr(amg.congruence(Tt, S, T, full), (Tt @ S @ T + full).tocsr())


@pytest.mark.numerics
def test_amg_reduced_matrix_by_row_blocks_equals_the_whole_product(monkeypatch):
    """The reduced K = T^T S T + D the AMG route forms (``congruence``: the set-up's, once per geometry; the steps
    apply K unformed, ``amg.Reduced``) by blocks of 7 rows holds the arrays of the whole expression, and the answer
    is the one of the whole expression's K, bit for bit."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    scene = two_boxes(4)
    blocked, same = amg.congruence, []

    def checked(Tt, S, T, D):
        K = blocked(Tt, S, T, D)
        same.append(_same_csr(K, (Tt @ S @ T + D).tocsr()))
        return K

    monkeypatch.setattr(amg, "ROWS", 7)
    monkeypatch.setattr(amg, "congruence", checked)
    sol = cc.ContactSolver(scene, method="amg").solve()
    assert sol.ok and len(same) == 1 and all(same)
    monkeypatch.setattr(amg, "congruence", lambda Tt, S, T, D: (Tt @ S @ T + D).tocsr())
    plain = cc.ContactSolver(scene, method="amg").solve()
    assert plain.ok and plain.info.iterations == sol.info.iterations
    assert all(np.array_equal(a, b) for a, b in zip(plain.u, sol.u)) and np.array_equal(plain.phi[0], sol.phi[0])


@pytest.mark.numerics
def test_amg_route_solves_every_set_without_forming_its_matrix(monkeypatch):
    """No set's K = T^T S T + D is formed beside S: every Krylov solve of the AMG route, first solve and warm
    re-solve, is handed the operator ``amg.Reduced`` over the solver's own S (no arrays of K), and S holds no
    entry stored as 0.0 (the assembled blocks' cancelled entries, which its products would read)."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    plain_gmres, seen = amg.gmres, []

    def spy(K, b, x0, M, rtol, *args, **kw):
        kc = solver.cache.amg
        seen.append(isinstance(K, amg.Reduced) and K.S is kc.S and np.all(kc.S.data != 0.0))
        return plain_gmres(K, b, x0, M, rtol, *args, **kw)

    monkeypatch.setattr(amg, "gmres", spy)
    solver = cc.ContactSolver(two_boxes(4), method="amg")
    assert solver.solve().ok and solver.solve().ok
    assert len(seen) >= 3 and all(seen)


@pytest.mark.numerics
def test_amg_route_frees_a_sets_preconditioner_before_the_next_sets_one(monkeypatch):
    """A new active set's preconditioner (its contact rows, their factor and its copy of Kup) is formed after the
    last set's is dropped, not beside it; the steps still reuse each set's own preconditioner (built once per
    set) and the answer passes its checks."""
    pytest.importorskip("pyamg")
    from cvxcontact.backends import amg

    plain_system, plain_precondition = amg.KrylovContact._system, amg.KrylovContact._precondition
    held, keys = [], []

    def count(self, K=None):
        held.append(self._preconditioner)
        return plain_precondition(self, K)

    def system(self, active, *args, **kw):
        if not keys or keys[-1] != active.tobytes():
            keys.append(active.tobytes())
        return plain_system(self, active, *args, **kw)

    monkeypatch.setattr(amg.KrylovContact, "_system", system)
    monkeypatch.setattr(amg.KrylovContact, "_precondition", count)
    solver = cc.ContactSolver(two_boxes(6), method="amg")
    sol = solver.solve()
    assert sol.ok and sol.info.iterations >= 2           # several sets: a preconditioner existed before the next
    assert len(held) == len(keys) >= 2 and all(h is None for h in held)


@pytest.mark.numerics
@pytest.mark.parametrize("case", ["3d p1", "3d p2", "2d p1"])
def test_estimate_geometry_int32_indices_give_the_int64_estimate(monkeypatch, case):
    """The estimate's Geometry keeps its facet table and facet positions in int32 (local indices int8): the
    indicators and every part of the estimate are those of the same Geometry with int64 indices, bit for bit
    (indices select the same numbers; nothing is summed differently)."""
    from cvxcontact.apps.demo import two_blocks

    scene, degree = {"3d p1": (two_boxes(4), 1), "3d p2": (two_boxes(2), 2), "2d p1": (two_blocks(8), 1)}[case]
    sol = cc.solve(scene, "sigma1", degree=degree, estimate=False)
    saving, _ = est.estimate(sol)
    g = est.Geometry(scene.bodies[0], degree)
    owners, local, vertices, keys = g.facets
    assert owners.dtype == vertices.dtype == np.int32 and local.dtype == np.int8 and keys.dtype == np.int64
    assert all(a.dtype == np.int32 for a in (g.faces.c0, g.faces.c1, g.faces.ii, g.faces.at0, g.faces.at1))
    monkeypatch.setattr(est.Geometry, "index", property(lambda self: np.int64))
    monkeypatch.setattr(est.Geometry, "facets", property(lambda self: est.facet_table(self._mesh.cells,
                                                                                        len(self._mesh.points))))
    assert est.Geometry(scene.bodies[0], degree).faces.at0.dtype == np.int64
    plain, _ = est.estimate(sol)
    assert saving.absolute == plain.absolute and saving.norm == plain.norm and saving.parts == plain.parts
    assert all(np.array_equal(a, b) for a, b in zip(saving.indicators, plain.indicators))


@pytest.mark.parametrize("cells", [3, 7, 1 << 16])
def test_node_checks_by_blocks_of_cells_find_the_same_duplicate(monkeypatch, cells):
    """The node checks' edge lengths by blocks of cells (`geometry/meshchecks.py` ``CELLS``, ragged last block)
    give every node the same local size as all cells at once: a near-duplicate of a node is refused with the
    same message (the distance and the local size in it), and a box's faces and tags are unchanged."""
    from cvxcontact.geometry import meshchecks

    box = cc.box(nx=3, ny=2, nz=2)
    points, tets = np.array(box.points), np.array(box.tets)
    v = int(tets[-1, 2])                                      # a node of the last cell: in the last block
    points = np.vstack([points, points[v] + 1e-12])
    tets[-1, 2] = len(points) - 1                             # the copy takes its place in one cell
    with pytest.raises(cc.errors.MeshError) as whole:
        cc.TetMesh(points, tets)
    monkeypatch.setattr(meshchecks, "CELLS", cells)
    with pytest.raises(cc.errors.MeshError) as blocks:
        cc.TetMesh(points, tets)
    assert "duplicate nodes" in str(whole.value) and str(blocks.value) == str(whole.value)
    sides = {"left": (0, 0.0), "right": (0, 1.0), "front": (1, 0.0), "back": (1, 1.0), "bottom": (2, 0.0),
             "top": (2, 1.0)}                                # cc.box's default bounds
    for tag, (axis, at) in sides.items():                    # the box's sides: its boundary faces on each plane
        on = (box.points[box.boundary_faces, axis] == at).all(axis=1)
        assert sorted(map(tuple, np.sort(box.boundary(tag), axis=1))) == \
            sorted(map(tuple, np.sort(box.boundary_faces[on], axis=1))) and on.any()


@pytest.mark.numerics
@pytest.mark.parametrize("degree", [1, 2])
def test_estimate_normal_jumps_by_blocks_equal_the_jumps_of_every_facet(monkeypatch, degree):
    """The facets' jumps sigma n and D . n by blocks of 7 facets (`estimate._normal_jumps`, ragged last block; a
    boundary facet's second side 0.0) are those of all facets' jumps at once with a zero row appended, bit for
    bit; the estimate is the same with blocks of 7 as with one."""
    from cvxcontact.solution import contactestimate as contact

    scene = two_boxes(3)
    sol = cc.solve(scene, "sigma1", degree=degree, estimate=False)
    body = scene.bodies[0]
    g = est.Geometry(body, degree)
    fields = est._fields(g, sol.u[0], sol.phi[0])
    f, n = g.faces, g.faces.normal

    def whole(values):                                       # all facets at once, the boundary's zero row
        stacked = np.concatenate([values.reshape((-1,) + values.shape[2:]), np.zeros((1,) + values.shape[2:])])
        return stacked[f.at0] - stacked[f.at1]

    monkeypatch.setattr(contact, "CELLS", 7)
    assert np.array_equal(est._normal_jumps(fields[2], f, n, contact.voigt_traction),
                          contact.voigt_traction(whole(fields[2]), n))
    assert np.array_equal(est._normal_jumps(fields[3], f, n, lambda J, nb: np.einsum("kvd,kd->kv", J, nb)),
                          np.einsum("kvd,kd->kv", whole(fields[3]), n))
    small, _ = est.estimate(sol)
    monkeypatch.setattr(contact, "CELLS", 1 << 30)
    one, _ = est.estimate(sol)
    assert small.parts == one.parts and all(np.array_equal(a, b) for a, b in zip(small.indicators, one.indicators))


@pytest.mark.parametrize("dim, cells, q, wide", [(3, 540_000_000, 1, True),      # 4 m facets > 2^31 - 1
                                                  (3, 530_000_000, 1, False),     # 4 m = 2.12e9: all fit
                                                  (2, 715_000_000, 1, False),     # 3 m = 2.145e9: all fit
                                                  (2, 716_000_000, 1, True),      # 3 m = 2.148e9
                                                  (3, 540_000_000, 4, True)])     # q m rows > 2^31 - 1
def test_estimate_geometry_index_type_bounds_the_facets_too(dim, cells, q, wide):
    """The estimate Geometry's index type is int64 as soon as any index it keeps in it could pass 2^31 - 1:
    the fields' stacked rows (q per cell), the nodes, and the facets (`faces.ii`, at most d + 1 per cell; a
    P1 mesh of m cells has only m + 1 stacked rows but up to (d + 1) m facets, which int32 would wrap to
    negative indices). The sizes alone are read: arrays broadcast from one entry (no memory)."""
    from types import SimpleNamespace

    g = est.Geometry.__new__(est.Geometry)
    g.dim = dim
    g.el = np.broadcast_to(np.zeros(1, dtype=np.int64), (cells, dim + 1))
    g.G = np.broadcast_to(np.zeros(1), (cells, q, dim, dim + 1))
    g._mesh = SimpleNamespace(points=np.broadcast_to(np.zeros(1), (cells // 5, dim)))
    assert g.index == (np.int64 if wide else np.int32)


@pytest.mark.parametrize("elastic", [False, True])
def test_amg_stacked_blocks_equal_block_diag_of_the_quasi_definite_blocks(elastic):
    """The AMG route's S stacked from the CSR blocks (`amg.stacked`) has the arrays of scipy's block_diag of
    each body's quasi-definite block (a PZT-5A box on aluminium, and two aluminium boxes), index types included;
    blocks not in canonical form take block_diag itself (the same arrays again)."""
    from cvxcontact.backends import amg
    from cvxcontact.backends.condensed import quasi_definite

    blocks = cc.ContactSolver(two_boxes(4, elastic=elastic), method="amg").problem.blocks
    plain = sp.block_diag([quasi_definite(b)[0] for b in blocks], format="csr")
    for S in (amg.stacked(blocks), amg.stacked([_uncanonical(b) for b in blocks])):
        assert S.format == "csr" and S.shape == plain.shape and S.dtype == plain.dtype
        for a in ("indptr", "indices", "data"):
            assert getattr(S, a).dtype == getattr(plain, a).dtype
            assert np.array_equal(getattr(S, a), getattr(plain, a))


def _synthetic_block(seed, nu, n_p, empty_rows=(), zeros=False, index=np.int32):
    """A block with a random symmetric Kuu (nu x nu), and for n_p > 0 Kup (nu x n_p) and a symmetric Kpp, in
    canonical CSR with ``index`` indices: rows ``empty_rows`` of Kuu and Kup empty, every third stored entry an
    explicit zero (``zeros``)."""
    from types import SimpleNamespace

    rng = np.random.default_rng(seed)

    def csr(m, n, symmetric):
        A = sp.random(m, n, density=0.4, random_state=rng, format="csr")
        A = (A + A.T + sp.eye(m)).tocsr() if symmetric else A
        if m == nu:                                            # Kuu and Kup
            keep = np.ones(m)
            keep[list(empty_rows)] = 0.0
            A = (sp.diags(keep) @ A).tocsr()
        A.eliminate_zeros()
        A.sort_indices()
        if zeros:
            A.data[::3] = 0.0
        A.indices, A.indptr = A.indices.astype(index), A.indptr.astype(index)
        assert A.has_canonical_format and A.indices.dtype == index
        return A

    if n_p == 0:
        return SimpleNamespace(Kuu=csr(nu, nu, True), Kup=None, Kpp=None, f=np.zeros(nu), q=None)
    return SimpleNamespace(Kuu=csr(nu, nu, True), Kup=csr(nu, n_p, False), Kpp=csr(n_p, n_p, True), f=np.zeros(nu),
                           q=np.zeros(n_p))


@pytest.mark.parametrize("shapes, kw", [([(6, 0)], {}), ([(6, 3)], {}), ([(6, 3), (5, 0), (4, 2)], {}),
                                        ([(6, 3), (5, 0)], {"index": np.int64}),
                                        ([(6, 3), (5, 0)], {"zeros": True}),
                                        ([(7, 3), (5, 0)], {"empty_rows": (0, 4)}),
                                        ([(1, 1), (1, 0), (3, 1)], {})])
def test_amg_stacked_equals_block_diag_on_edge_blocks(shapes, kw):
    """`amg.stacked` has the arrays and index types of scipy's block_diag of the quasi-definite blocks on
    synthetic blocks: one block, elastic and piezoelectric mixed, int64 index inputs, explicit zeros (kept, as
    block_diag keeps them), empty rows, 1 x 1 blocks; and an all-zero coupling block. ``zeros=False`` (the AMG
    route's S): the arrays of that block_diag after ``eliminate_zeros``, index types included."""
    from cvxcontact.backends import amg
    from cvxcontact.backends.condensed import quasi_definite

    blocks = [_synthetic_block(i, nu, n_p, **kw) for i, (nu, n_p) in enumerate(shapes)]
    if blocks[0].Kup is not None and kw == {}:
        blocks[0].Kup = sp.csr_matrix(blocks[0].Kup.shape)                # no coupling at all
    plain = sp.block_diag([quasi_definite(b)[0] for b in blocks], format="csr")
    S = amg.stacked(blocks)
    assert S.shape == plain.shape
    for a in ("indptr", "indices", "data"):
        assert getattr(S, a).dtype == getattr(plain, a).dtype
        assert np.array_equal(getattr(S, a), getattr(plain, a))
    S = amg.stacked(blocks, zeros=False)
    plain.eliminate_zeros()
    assert S.shape == plain.shape and np.all(S.data != 0.0)
    for a in ("indptr", "indices", "data"):
        assert getattr(S, a).dtype == getattr(plain, a).dtype
        assert np.array_equal(getattr(S, a), getattr(plain, a))


def _uncanonical(block):
    """The block with its Kuu's rows' entries in reverse order (the same matrix, not canonical)."""
    from dataclasses import replace

    K = block.Kuu.copy()
    for i in range(K.shape[0]):
        lo, hi = K.indptr[i], K.indptr[i + 1]
        K.indices[lo:hi], K.data[lo:hi] = K.indices[lo:hi][::-1].copy(), K.data[lo:hi][::-1].copy()
    K.has_sorted_indices = False
    assert not K.has_canonical_format
    return replace(block, Kuu=K)


@pytest.mark.numerics
def test_contact_tractions_by_blocks_equal_those_of_every_point(monkeypatch):
    """sigma_h n at points of the contact faces by blocks of 7 points (`contactestimate.SimplexSide.traction`,
    ragged last block; per-point barycentric coordinates, one set for every face, a slice of the faces) is the
    traction of every point at once (the per-point vertex values gathered whole, `_traction`), bit for bit."""
    scene = two_boxes(3)
    sol = cc.solve(scene, "sigma1", estimate=False)
    body = scene.bodies[0]
    g = est.Geometry(body, 1)
    fields = est._fields(g, sol.u[0], sol.phi[0])
    corners = np.broadcast_to(fields[2], (len(fields[2]), 4, 6))
    on = cest.SimplexSides(body.mesh, fields[2], g.facets, ["bottom"]).side("bottom")
    rng = np.random.default_rng(5)
    faces = rng.integers(0, len(on.f), 40)                   # repeated faces, in no order
    L = rng.dirichlet(np.ones(3), 40)

    def whole(e, Lf):
        cell = on.cell[e]
        return cest._traction(corners[cell], cest._bary(body.mesh.cells[cell], on.f[e], Lf), on.normals[e])

    monkeypatch.setattr(cest, "CELLS", 7)
    assert np.array_equal(on.traction(faces, L), whole(faces, L))
    third = np.full(3, 1 / 3)
    assert np.array_equal(on.traction(slice(None), third), whole(np.arange(len(on.f)), third))
    assert on.traction(faces[:0], L[:0]).shape == (0, 3)
