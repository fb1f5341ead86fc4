"""cc.adapt on tensor grids of quadrilaterals and hexahedra (geometry/grid.py): the grid found from the mesh alone,
the refined grid checked against the coarse one (sizes, tags, marked cells split, a full marking against the
uniform grid built directly), the refusals, a patch test solved on adapted non-matching grids against the
closed form, and the loop on a rigid cylinder pressed into a Q1 block against uniform refinement."""

import warnings
from itertools import pairwise

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.adapt import LOOPS, mark_bisections
from cvxcontact.fem.space import space
from cvxcontact.geometry.generators import graded_block
from cvxcontact.geometry.grid import refine_grid, tensor_grid
from cvxcontact.geometry.refine import local_refusal, refine_local

ALU = cc.materials.isotropic(E=70e9, nu=0.33)
STEEL = cc.materials.isotropic(E=210e9, nu=0.3)


def quietly(f, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        return f(*args, **kw)


def meshes():
    """Tensor grids of both kinds, uniform and graded, with named segments and patches."""
    return {
        "rectangle": cc.rectangle(x=(-1.0, 1.0), y=(0.0, 1.0), nx=4, ny=3, cell="quad",
                                  segments={"foot": ("top", -0.5, 0.5)}),
        "graded": graded_block((0.0, 1.0), (0.0, 0.5), 6, 4, beta=2.0, gamma=1.0, center=0.4, cell="quad"),
        "box": cc.box(x=(0.0, 1.0), y=(0.0, 2.0), z=(0.0, 0.5), nx=4, ny=4, nz=2, cell="hex",
                      patches={"punch": ("top", (0.25, 0.75), (0.4, 1.2))}, grade=((0.5, 1.0, 0.5), 3.0)),
    }


def measures(mesh, tag):
    """(k,) lengths (2D) or areas (3D) of the facets carrying ``tag``, computed from the points."""
    f = mesh.points[mesh.boundary(tag)]
    if mesh.dim == 2:
        return np.linalg.norm(f[:, 1] - f[:, 0], axis=1)
    return 0.5 * np.linalg.norm(np.cross(f[:, 2] - f[:, 0], f[:, 3] - f[:, 1]), axis=1)   # planar quadrilaterals


def sizes(mesh):
    return mesh.areas if mesh.dim == 2 else mesh.volumes


def test_tensor_grids_are_found_and_other_meshes_are_not():
    for name, mesh in meshes().items():
        grid = tensor_grid(mesh)
        assert grid is not None, name
        assert all(np.all(np.diff(a) > 0) for a in grid.axes)
        # the grid's boxes are the cells: their sizes from the axes alone equal the mesh's
        box = np.prod([np.diff(a)[grid.lower[:, d]] for d, a in enumerate(grid.axes)], axis=0)
        assert np.allclose(box, sizes(mesh), rtol=1e-12)
    rect = meshes()["rectangle"]
    warped = rect.with_points(rect.points + 0.01 * np.sin(7 * rect.points[:, ::-1]))
    turn = np.array([[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]])
    two = cc.QuadMesh(np.vstack([rect.points, rect.points + [3.0, 0.0]]),
                      np.vstack([rect.cells, rect.cells + len(rect.points)]))          # two grids side by side
    for other in (warped, rect.with_points(rect.points @ turn.T), two, cc.rectangle(nx=3, ny=2)):
        assert tensor_grid(other) is None
    noisy = rect.with_points(rect.points + 1e-13 * np.random.default_rng(0).standard_normal(rect.points.shape))
    grid = tensor_grid(noisy)                               # within GRID_TOL of the size: the same grid lines
    assert grid is not None and np.abs(grid.axes[0] - np.linspace(-1, 1, 5)).max() < 1e-12
    assert "tensor grid" in local_refusal(warped) and "triangles" in local_refusal(warped)
    assert local_refusal(rect) == "" and "curves=" in local_refusal(rect, curved=True)


@pytest.mark.parametrize("name", ["rectangle", "graded", "box"])
@pytest.mark.parametrize("seed", [0, 1])
def test_refine_grid_is_a_valid_graded_grid(name, seed):
    """A random marking (one or two halvings): the fine mesh is again a tensor grid covering the same body, each tag
    keeps its length or area, every marked cell splits into at least 2^(dim k) children of at most 2^-(dim k) its
    size, the children of every cell fill it."""
    mesh = meshes()[name]
    rng = np.random.default_rng(seed)
    times = rng.integers(0, 3, len(mesh.cells)) * (rng.random(len(mesh.cells)) < 0.2)
    times[rng.integers(len(mesh.cells))] = 1
    fine, parent = refine_grid(mesh, times)
    assert type(fine) is type(mesh) and tensor_grid(fine) is not None
    assert sizes(fine).sum() == pytest.approx(sizes(mesh).sum(), rel=1e-12)
    assert fine.tags == mesh.tags
    for tag in mesh.tags:
        assert measures(fine, tag).sum() == pytest.approx(measures(mesh, tag).sum(), rel=1e-12), tag
        assert set(map(tuple, np.round(fine.outward_normals(tag), 12))) == \
            set(map(tuple, np.round(mesh.outward_normals(tag), 12)))
    filled = np.bincount(parent, weights=sizes(fine), minlength=len(mesh.cells))
    assert np.allclose(filled, sizes(mesh), rtol=1e-12)
    count = np.bincount(parent, minlength=len(mesh.cells))
    marked = times > 0
    assert (count[marked] >= 2 ** (mesh.dim * times[marked])).all()
    largest = np.zeros(len(mesh.cells))
    np.maximum.at(largest, parent, sizes(fine))
    assert (largest[marked] <= sizes(mesh)[marked] * 2.0 ** (-mesh.dim * times[marked]) * (1 + 1e-12)).all()
    lo, hi = mesh.points[mesh.cells].min(axis=1), mesh.points[mesh.cells].max(axis=1)
    centre = fine.points[fine.cells].mean(axis=1)
    assert ((centre > lo[parent]) & (centre < hi[parent])).all()


def test_every_cell_marked_is_the_uniform_grid():
    """Marking every cell once gives the grid of twice the cells along each axis, built directly by the
    generators: the same nodes, the same cells' sizes, the same tags."""
    for coarse, fine in ((cc.rectangle(x=(0, 2), y=(0, 1), nx=3, ny=2, cell="quad", segments={"s": ("top", 0, 4 / 3)}),
                          cc.rectangle(x=(0, 2), y=(0, 1), nx=6, ny=4, cell="quad", segments={"s": ("top", 0, 4 / 3)})),
                         (cc.box(nx=2, ny=1, nz=3, cell="hex"), cc.box(nx=4, ny=2, nz=6, cell="hex"))):
        out, parent = refine_grid(coarse, np.ones(len(coarse.cells), dtype=bool))
        assert np.bincount(parent).tolist() == [2 ** coarse.dim] * len(coarse.cells)
        order = np.lexsort(out.points.T)
        assert np.allclose(out.points[order], fine.points[np.lexsort(fine.points.T)], atol=1e-15)
        assert np.allclose(np.sort(sizes(out)), np.sort(sizes(fine)), rtol=1e-12)
        for tag in fine.tags:
            key = np.sort(np.round(out.points[out.boundary(tag)].mean(axis=1), 12), axis=0)
            assert np.array_equal(key, np.sort(np.round(fine.points[fine.boundary(tag)].mean(axis=1), 12), axis=0))


def test_refine_local_counts_bisections():
    """refine_local takes bisections per cell (a halving of the size each) and halves a grid's intervals at most
    once a call (GRID_HALVINGS): in one row of three cells asking 1, 2, 3 the row and the three columns are halved
    once (4 children each); a hexahedron asking 3 splits into 8, its neighbour on top of it, in its column, into 4."""
    rect = cc.rectangle(nx=3, ny=1, cell="quad")
    _, parent = refine_local(rect, np.array([1, 2, 3]))
    assert np.bincount(parent).tolist() == [4, 4, 4]
    assert np.bincount(refine_local(rect, np.array([0, 0, 2]))[1]).tolist() == [2, 2, 4]
    box = cc.box(nx=1, ny=1, nz=2, cell="hex")
    assert np.bincount(refine_local(box, np.array([3, 0]))[1]).tolist() == [8, 4]
    with pytest.raises(cc.MeshError, match="non-negative integers"):
        refine_local(rect, np.array([1.0, 0.0, 0.0]))
    with pytest.raises(cc.MeshError, match="tensor grid"):
        refine_grid(rect.with_points(rect.points + 0.01 * np.sin(5 * rect.points[:, ::-1])), [1, 0, 0])


def indentation(nx=8, ny=4, cell="quad"):
    """A rigid circle (R = 0.6 m) pressed 3 mm into an aluminium block 1 m x 0.5 m of quadrilaterals
    (tests/obstacle_scenes.py's ``indented_block`` on Q1 cells)."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny, cell=cell), ALU, clamped="bottom",
                    contact="top", name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((0.47, 0.5 + 0.6 - 3e-3), 0.6))])


def test_adapt_refuses_quadrilaterals_that_are_not_a_grid():
    rect = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2, cell="quad")
    inner = (rect.points[:, 1] > 0) & (rect.points[:, 1] < 0.5) & (rect.points[:, 0] > 0) & (rect.points[:, 0] < 1)
    warped = rect.with_points(rect.points + np.where(inner, 0.02, 0.0)[:, None] * [1.0, 0.0])   # sides straight
    block = cc.Body(warped, ALU, clamped="bottom", contact="top")
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((0.47, 1.097), 0.6))])
    with pytest.raises(cc.UnsupportedError, match="not a tensor grid.*triangles"):
        cc.adapt(scene)
    with pytest.raises(cc.UnsupportedError, match="curves="):
        cc.adapt(indentation(), curves={"block": {"top": lambda x: x}})


def two_blocks(lower, upper):
    """Aluminium under steel, 1 m wide, 0.5 m each, on rollers at the left and the bottom, pressed by 10 MPa on the
    top: a uniform compression in plane strain (both blocks' stress -p e_y e_y)."""
    a = cc.Body(lower, ALU, roller=["left", "bottom"], contact="top", name="lower")
    b = cc.Body(upper, STEEL, roller=["left"], contact="bottom", traction={"top": (0.0, -1e7)}, name="upper")
    return cc.Scene(a, b, contacts=[cc.Contact(a, "top", b, "bottom")])


def uniform_compression(x, material, p=1e7, base=None):
    """The closed form of :func:`two_blocks`: plane strain, sigma_yy = -p, sigma_xx = 0: eps_yy = -p (1 - nu^2)/E,
    eps_xx = p nu (1 + nu) / E; u_x = eps_xx x, u_y = eps_yy (y - y0) + u_y(y0) (continuous across the contact)."""
    E, nu = material
    exx, eyy = p * nu * (1 + nu) / E, -p * (1 - nu ** 2) / E
    y0, u0 = base if base is not None else (0.0, 0.0)
    return np.column_stack([exx * x[:, 0], u0 + eyy * (x[:, 1] - y0)])


@pytest.mark.numerics
@pytest.mark.parametrize("degree", [1, 2])
def test_patch_test_on_adapted_grids(degree):
    """Uniform compression of two blocks on non-matching grids, one refined by refine_grid towards a corner, and the
    grids cc.adapt leaves: the solution is the closed form to rounding (u within 1e-9 of its largest value;
    measured <= 6.1e-14, Q2)."""
    lower = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=3, ny=2, cell="quad")
    upper = cc.rectangle(x=(0.0, 1.0), y=(0.5, 1.0), nx=4, ny=2, cell="quad")
    marked = np.zeros(len(upper.cells), dtype=np.int64)
    marked[0] = 2
    graded = refine_grid(upper, marked)[0]
    result = quietly(cc.adapt, two_blocks(lower, upper), "gamma3", degree=degree, max_steps=2, theta=0.5)
    assert [s.step for s in result.history] == [0, 1, 2] and all(s.ok for s in result.history)
    for sol in (quietly(cc.solve, two_blocks(lower, graded), "gamma3", degree=degree), result.solution):
        bodies = sol.scene.bodies
        for k, (body, mat) in enumerate(zip(bodies, [(70e9, 0.33), (210e9, 0.3)])):
            x = space(degree, body.mesh.cell).node_set(body.mesh).points
            base = None if k == 0 else (0.5, -1e7 * (1 - 0.33 ** 2) / 70e9 * 0.5)
            exact = uniform_compression(x, mat, base=base)
            assert np.abs(sol.u[k] - exact).max() < 1e-9 * np.abs(exact).max(), (k, np.abs(sol.u[k] - exact).max())


@pytest.mark.numerics
def test_adapt_on_q1_beats_uniform_refinement():
    """The rigid circle pressed into a Q1 block, 8 x 4 cells: 5 steps of theta = 0.5 (strips halved through the
    marked cells) reach an estimate below that of the uniform 64 x 32 grid with fewer unknowns (measured: 2160
    unknowns, 243.1 sqrt(J) against 4290 unknowns, 363.0: 0.67 of it), the estimate falling at every step
    (measured: by 0.88 at most, 1512 -> 243); the history as on triangles."""
    result = quietly(cc.adapt, indentation(), max_steps=5, theta=0.5)
    uniform = quietly(cc.solve, indentation(64, 32))
    h = result.history
    assert result.stopped == "max_steps" and [s.step for s in h] == list(range(6))
    assert all(b.cells > a.cells for a, b in pairwise(h)) and all(s.ok for s in h)
    assert h[-1].marked == 0 and all(s.marked > 0 for s in h[:-1])
    assert all(b.estimate < a.estimate for a, b in pairwise(h))
    mesh = result.scene.bodies[0].mesh
    assert tensor_grid(mesh) is not None and h[-1].cells == len(mesh.cells)
    assert h[-1].unknowns == 2 * len(mesh.points) == sum(u.size for u in result.solution.u)
    assert result.solution.estimate.absolute == h[-1].estimate
    assert h[-1].unknowns < sum(u.size for u in uniform.u)
    assert h[-1].estimate < uniform.estimate.absolute
    # the grading sits under the circle: the smallest top edges are near x = 0.47
    top = mesh.points[mesh.boundary("top")]
    length = np.abs(top[:, 1, 0] - top[:, 0, 0])
    assert abs(top[np.argmin(length)].mean(axis=0)[0] - 0.47) < 0.1


@pytest.mark.numerics
def test_adapt_on_hexahedra():
    """A rigid sphere pressed into a Q1 hexahedral block (4 x 4 x 2 cells): two steps keep a valid grid with the
    same volume and face areas, and lower the estimate (measured 8928 -> 3970 sqrt(J), 225 -> 1215 unknowns;
    "sigma1": "gamma3" on Q1 hexahedra takes plane obstacles only)."""
    block = cc.Body(cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=4, ny=4, nz=2, cell="hex"), ALU,
                    clamped="bottom", contact="top", name="block")
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.sphere((0.47, 0.5, 0.5 + 0.5 - 0.02), 0.5))])
    result = quietly(cc.adapt, scene, "sigma1", max_steps=2)
    h = result.history
    assert [s.step for s in h] == [0, 1, 2] and all(s.ok for s in h)
    assert all(b.cells > a.cells for a, b in pairwise(h))
    mesh = result.scene.bodies[0].mesh
    assert tensor_grid(mesh) is not None and h[-1].unknowns == 3 * len(mesh.points)
    assert mesh.volumes.sum() == pytest.approx(0.5, rel=1e-12)
    for tag in block.mesh.tags:
        assert mesh.face_areas(tag).sum() == pytest.approx(block.mesh.face_areas(tag).sum(), rel=1e-12)
    assert h[-1].estimate < h[0].estimate


def test_a_grid_listed_from_other_corners_is_the_same_grid():
    """A cell listed from another corner (a gmsh grid, a clockwise mesh reoriented by QuadMesh) is the same box:
    the rotated grid is found and refined as the grid of the generator (the same fine points, parents and tags);
    corners out of order around the box stay refused (HexMesh accepts a hexahedron whose corners are the box's in
    another order only if it is a rotation of the reference cell)."""
    rng = np.random.default_rng(4)
    rect = cc.rectangle(x=(0.0, 2.0), y=(0.0, 1.0), nx=4, ny=3, cell="quad", segments={"s": ("top", 0.5, 1.5)})
    box = cc.box(nx=2, ny=3, nz=2, cell="hex", patches={"p": ("top", (0.0, 0.5), (1 / 3, 1.0))})
    # per cell a different start corner (quads), a different rotation of the cube (hexes: about z, about x)
    about_z = np.array([[0, 1, 2, 3, 4, 5, 6, 7], [1, 2, 3, 0, 5, 6, 7, 4], [2, 3, 0, 1, 6, 7, 4, 5]])
    about_x = np.array([3, 2, 6, 7, 0, 1, 5, 4])                      # bottom face -> the face y = 1
    shuffled = []
    for mesh, orders in ((rect, np.array([np.roll(np.arange(4), -k) for k in range(4)])),
                         (box, np.vstack([about_z, about_z[:, about_x]]))):
        pick = orders[rng.integers(len(orders), size=len(mesh.cells))]
        cells = np.take_along_axis(mesh.cells, pick, axis=1)
        other = type(mesh)(mesh.points, cells, {t: mesh.boundary(t) for t in mesh.tags})
        assert not np.array_equal(other.cells, mesh.cells)
        shuffled.append(other)
        assert tensor_grid(other) is not None and local_refusal(other) == ""
        times = (rng.random(len(mesh.cells)) < 0.3).astype(np.int64)
        (a, pa), (b, pb) = refine_grid(mesh, times), refine_grid(other, times)
        assert np.array_equal(a.points, b.points) and np.array_equal(a.cells, b.cells) and np.array_equal(pa, pb)
        assert all(np.array_equal(a.boundary(t), b.boundary(t)) for t in mesh.tags)
    crossed = rect.cells[:, [0, 2, 1, 3]]                   # not around the box: QuadMesh refuses it already
    with pytest.raises(cc.MeshError):
        cc.QuadMesh(rect.points, crossed)


def test_refined_grid_keeps_the_coarse_coordinates_bit_for_bit():
    """Grid lines given exactly (every node of a line holds the same float) are kept exactly: a contact face at
    z = 0.9 stays at 0.9, not one rounding off it (a mean of equal floats is not always that float: three
    copies of 0.1 sum to 0.30000000000000004); lines given with noise go to their mean, within the noise."""
    rng = np.random.default_rng(5)
    for mesh in (cc.rectangle(x=(0.1, 0.7), y=(0.3, 0.9), nx=7, ny=13, cell="quad"),
                 cc.box(x=(0.1, 0.7), y=(0.3, 1.1), z=(0.2, 0.9), nx=5, ny=6, nz=7, cell="hex")):
        fine, _ = refine_grid(mesh, rng.random(len(mesh.cells)) < 0.2)
        for d in range(mesh.dim):
            assert set(mesh.points[:, d]) <= set(fine.points[:, d]), d                 # exactly, no tolerance
        noise = 1e-11 * rng.standard_normal(mesh.points.shape)
        grid = tensor_grid(mesh.with_points(mesh.points + noise))
        for d, a in enumerate(grid.axes):
            assert np.abs(a - np.unique(mesh.points[:, d])).max() <= np.abs(noise[:, d]).max()


def _loads(mesh, degree, clamped, traction):
    """(total force (dim,), total moment about the origin, the coordinates of the clamped nodes) of a body on
    ``mesh`` (Q``degree``), from its assembled load vector and its free dofs."""
    body = cc.Body(mesh, ALU, clamped=clamped, traction=traction, name="b")
    sp = space(degree, mesh.cell)
    nodes = sp.nodes(body)
    system = sp.assemble_loads(body, sp.assemble_matrices(body, nodes), nodes)
    x, f = sp.node_set(mesh).points, system.f.reshape(-1, mesh.dim)
    moment = (x[:, 0] * f[:, 1] - x[:, 1] * f[:, 0]).sum() if mesh.dim == 2 else np.cross(x, f).sum(axis=0)
    fixed = np.unique(np.setdiff1d(np.arange(system.f.size), system.u_free) // mesh.dim)
    return f.sum(axis=0), moment, x[fixed]


def _covered(mesh, tag):
    """The set a 2D tag covers: {(the axis its edges are normal to, their line): merged intervals along it}."""
    parts = {}
    for e in mesh.points[mesh.boundary(tag)]:
        axis = int(np.argmin(np.abs(e[1] - e[0])))
        parts.setdefault((axis, e[0, axis]), []).append(tuple(np.sort(e[:, 1 - axis])))
    merged = {}
    for key, pieces in parts.items():
        runs = [list(p) for p in sorted(pieces)[:1]]
        for a, b in sorted(pieces)[1:]:
            if a == runs[-1][1]:
                runs[-1][1] = b
            else:
                runs.append([a, b])
        merged[key] = runs
    return merged


@pytest.mark.numerics
@pytest.mark.parametrize("degree", [1, 2])
def test_tags_cover_the_same_set_and_carry_the_same_loads(degree):
    """Segments and patches (a traction on part of a side, a clamp on a sub-segment) after refine_grid: each tag
    covers exactly the same points of the boundary (2D: the same intervals, bit for bit; 3D: every fine face in
    one coarse face of its tag, the same area), the assembled loads of a traction linear in x (exact under every
    quadrature) have the same total force and moment (measured <= 2.5e-16 relative), and the clamped nodes are
    exactly the fine nodes on the clamped part."""
    rng = np.random.default_rng(degree)
    rect = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=5, ny=3, cell="quad",
                        segments={"pad": ("top", 0.2, 0.6), "grip": ("left", 1 / 6, 0.5),
                                  "foot": ("bottom", 0.4, 0.8)})
    box = cc.box(x=(0.0, 1.0), y=(0.0, 2.0), z=(0.0, 0.5), nx=4, ny=4, nz=2, cell="hex",
                 patches={"pad": ("top", (0.25, 0.75), (0.5, 1.5)), "grip": ("left", (0.5, 1.5), (0.0, 0.25))})
    on_grip = {2: lambda x: (x[:, 0] == 0) & (x[:, 1] >= 1 / 6) & (x[:, 1] <= 0.5),
               3: lambda x: (x[:, 0] == 0) & (x[:, 1] >= 0.5) & (x[:, 1] <= 1.5) & (x[:, 2] <= 0.25)}
    traction = {2: {"pad": lambda x, y: (1e6 * (1 + x), -2e6 * x), "right": (3e5, 1e5)},
                3: {"pad": lambda x, y, z: (1e6 * x, 2e6 * y, -3e6 * (1 + x + y))}}
    for mesh in (rect, box):
        fine, _ = refine_grid(mesh, rng.integers(1, 3, len(mesh.cells)) * (rng.random(len(mesh.cells)) < 0.3))
        for tag in mesh.tags:
            if mesh.dim == 2:
                assert _covered(fine, tag) == _covered(mesh, tag), tag
            else:
                coarse, faces = mesh.points[mesh.boundary(tag)], fine.points[fine.boundary(tag)].mean(axis=1)
                lo, hi = coarse.min(axis=1), coarse.max(axis=1)
                inside = ((faces[:, None] >= lo[None]) & (faces[:, None] <= hi[None])).all(axis=2)
                assert (inside.sum(axis=1) == 1).all(), tag
                assert fine.face_areas(tag).sum() == pytest.approx(mesh.face_areas(tag).sum(), rel=1e-14)
        (f0, m0, _), (f1, m1, clamped) = (_loads(m, degree, "grip", traction[mesh.dim]) for m in (mesh, fine))
        assert np.abs(f1 - f0).max() <= 1e-13 * np.abs(f0).max() and np.abs(m1 - m0).max() <= 1e-13 * np.abs(m0).max()
        x = space(degree, mesh.cell).node_set(fine).points
        want = x[on_grip[mesh.dim](x)]
        assert len(clamped) == len(want) and np.array_equal(np.unique(clamped, axis=0), np.unique(want, axis=0))


def _grid_by_hand(xs, ys):
    """The QuadMesh of the grid xs x ys built without the generators: nodes y fastest, each cell listed from its
    upper right corner, the four sides tagged by hand."""
    nid = lambda i, j: i * len(ys) + j
    nx, ny = len(xs) - 1, len(ys) - 1
    points = np.column_stack([g.ravel() for g in np.meshgrid(xs, ys, indexing="ij")])
    cells = [[nid(i + 1, j + 1), nid(i, j + 1), nid(i, j), nid(i + 1, j)] for i in range(nx) for j in range(ny)]
    sides = {"bottom": [[nid(i, 0), nid(i + 1, 0)] for i in range(nx)],
             "top": [[nid(i + 1, ny), nid(i, ny)] for i in range(nx)],
             "left": [[nid(0, j + 1), nid(0, j)] for j in range(ny)],
             "right": [[nid(nx, j), nid(nx, j + 1)] for j in range(ny)]}
    return cc.QuadMesh(points, np.array(cells), sides)


@pytest.mark.numerics
@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("condition", ["sigma1", "sigma2", "gamma3"])
def test_refined_pair_is_the_graded_grid_built_by_hand(degree, condition):
    """Two blocks refined each on its own (non-matching at the contact line) and the same grids built by hand: the
    same answer (u within 1e-10 of its largest value; measured <= 2.2e-13). The load, 10 MPa (1 - 1.6 x) down on
    the top, lifts the upper block's right end: the contact is partly open (checked)."""
    lower = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=3, ny=2, cell="quad")
    upper = cc.rectangle(x=(0.0, 1.0), y=(0.5, 1.0), nx=4, ny=2, cell="quad")
    lower = refine_grid(lower, np.isin(np.arange(len(lower.cells)), [0, 4]))[0]
    upper = refine_grid(upper, np.array([0, 0, 2, 0, 0, 1, 0, 0]))[0]
    by_hand = [_grid_by_hand(*tensor_grid(m).axes) for m in (lower, upper)]

    def scene(a, b):
        a = cc.Body(a, ALU, clamped="bottom", contact="top", name="lower")
        b = cc.Body(b, STEEL, roller=["left"], contact="bottom", name="upper",
                    traction={"top": lambda x, y: (0.0 * x, -1e7 * (1 - 1.6 * x))})
        return cc.Scene(a, b, contacts=[cc.Contact(a, "top", b, "bottom")])

    one = quietly(cc.solve, scene(lower, upper), condition, degree=degree)
    two = quietly(cc.solve, scene(*by_hand), condition, degree=degree)
    assert one.ok and two.ok
    for k, (a, b) in enumerate(zip((lower, upper), by_hand)):
        xa, xb = (space(degree, "quad").node_set(m).points for m in (a, b))
        oa, ob = np.lexsort(np.round(xa, 12).T), np.lexsort(np.round(xb, 12).T)
        assert np.abs(xa[oa] - xb[ob]).max() < 1e-15                  # Q2 centres: means in another corner order
        assert np.abs(one.u[k][oa] - two.u[k][ob]).max() < 1e-10 * np.abs(one.u[k]).max()
    x = upper.points
    right = np.flatnonzero((x[:, 1] == 0.5) & (x[:, 0] > 0.9))
    below = np.flatnonzero((lower.points[:, 1] == 0.5) & (lower.points[:, 0] == 1.0))
    assert (one.u[1][right, 1] - one.u[0][below, 1] > 1e-6).all()                # open: measured >= 6.9e-5


def test_grids_with_holes_are_refused():
    """Meshes whose nodes or cells are almost a grid's: an L-shape (a quadrant of cells and its corner node
    missing), a square ring (the centre cell missing, every node kept): neither is a tensor grid, adapt refuses
    them by name rather than filling the hole. (A cell spanning two columns leaves a hanging node, which QuadMesh
    refuses already.)"""
    square = cc.rectangle(nx=3, ny=3, cell="quad")
    centre = square.points[square.cells].mean(axis=1)
    ring = cc.QuadMesh(square.points, square.cells[~((np.abs(centre - 0.5) < 0.2).all(axis=1))],
                       {t: square.boundary(t) for t in ("bottom", "left")})
    rect = cc.rectangle(x=(0.0, 2.0), y=(0.0, 1.0), nx=4, ny=2, cell="quad")
    c = rect.points[rect.cells].mean(axis=1)
    kept = ~((c[:, 0] > 1) & (c[:, 1] > 0.5))
    used = np.unique(rect.cells[kept])
    number = np.full(len(rect.points), -1)
    number[used] = np.arange(len(used))
    ell = cc.QuadMesh(rect.points[used], number[rect.cells[kept]],
                      {t: number[rect.boundary(t)] for t in ("bottom", "left")})
    for mesh in (ell, ring):
        assert tensor_grid(mesh) is None and "not a tensor grid" in local_refusal(mesh)
        body = cc.Body(mesh, ALU, clamped="left", contact="bottom", name="b")
        scene = cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.circle((0.5, -1.0), 0.9))])
        with pytest.raises(cc.UnsupportedError, match="not a tensor grid"):
            cc.adapt(scene)


@pytest.mark.numerics
def test_adapt_history_on_a_piezoelectric_q2_grid():
    """A PZT-5A block on Q2 cells (an electrode on part of the bottom, the top floating) under a rigid circle, the
    loop bounded by max_unknowns: every step's kept solution is solved on a tensor grid of the step's cells, its
    unknowns (u and phi) and estimate are the history's, none above max_unknowns, the electrode keeps its length,
    and the loop stops by max_unknowns before max_steps (measured: 459, 759, 1131 unknowns)."""
    mesh = cc.rectangle(x=(0.0, 1e-2), y=(0.0, 5e-3), nx=8, ny=4, cell="quad",
                        segments={"el": ("bottom", 2.5e-3, 7.5e-3)})
    block = cc.Body(mesh, cc.materials.PZT5A, clamped="bottom", contact="top", grounded="el",
                    floating={"top": 0.0}, name="pzt")
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((4.7e-3, 1.1e-2 - 3e-5), 6e-3))])
    result = quietly(cc.adapt, scene, degree=2, max_steps=8, max_unknowns=1500, keep=True)
    h = result.history
    assert result.stopped == "max_unknowns" and len(h) == len(result.solutions) and h[-1].step < 8
    assert h[-1].ok and h[-1].marked == 0 and all(s.marked > 0 for s in h[:-1])
    for row, sol in zip(h, result.solutions):
        fine = sol.scene.bodies[0].mesh
        assert tensor_grid(fine) is not None and len(fine.cells) == row.cells
        assert row.unknowns == sum(u.size + p.size for u, p in zip(sol.u, sol.phi)) <= 1500
        assert sol.estimate.absolute == row.estimate
        edges = fine.points[fine.boundary("el")]
        assert np.linalg.norm(edges[:, 1] - edges[:, 0], axis=1).sum() == pytest.approx(5e-3, rel=1e-13)
    assert result.solution is result.solutions[-1] and result.scene is result.solutions[-1].scene
    assert all(b.unknowns > a.unknowns for a, b in pairwise(h))


@pytest.mark.numerics
def test_marked_counts_cells_not_bisections():
    """AdaptStep.marked is the number of cells marked (its docstring), also where the loop asks several bisections
    of a cell (2D Q2: rate 1, h-prediction; a grid halves each strip once a step whatever is asked): on the Q1
    indentation block on Q2 cells the first step asks more bisections than it marks cells (measured: 5 cells,
    15 bisections)."""
    result = quietly(cc.adapt, indentation(), degree=2, max_steps=1, keep=True)
    loop = LOOPS[(2, 2)]
    asked = mark_bisections(result.solutions[0].estimate.indicators, loop.theta, loop.rate, 2)
    assert sum(int(k.sum()) for k in asked) > sum(np.count_nonzero(k) for k in asked)      # the case in point
    assert result.history[0].marked == sum(np.count_nonzero(k) for k in asked)


def _hexes_by_hand(xs, ys, zs):
    """The HexMesh of the grid xs x ys x zs built without the generators: nodes z fastest, each hexahedron listed
    from another corner (its reference cell turned about z), the faces tagged by their centres."""
    from cvxcontact.geometry.hexmesh import HEX_FACES

    shape = (len(xs), len(ys), len(zs))
    points = np.column_stack([g.ravel() for g in np.meshgrid(xs, ys, zs, indexing="ij")])
    turned = np.array([[1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 0], [1, 0, 1], [1, 1, 1], [0, 1, 1], [0, 0, 1]])
    low = np.stack(np.meshgrid(*(np.arange(n - 1) for n in shape), indexing="ij"), axis=-1).reshape(-1, 3)
    cells = np.ravel_multi_index(tuple(np.moveaxis(low[:, None] + turned, -1, 0)), shape)
    faces = cells[:, HEX_FACES].reshape(-1, 4)
    centre = points[faces].mean(axis=1)
    sides = {"bottom": (2, zs[0]), "top": (2, zs[-1]), "left": (0, xs[0]), "front": (1, ys[0])}
    return cc.HexMesh(points, cells, {t: faces[centre[:, d] == v] for t, (d, v) in sides.items()})


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2", "gamma3"])
def test_refined_hexahedral_pair_is_the_grid_built_by_hand(condition):
    """Two Q1 boxes refined each on its own (non-matching, aligned faces) and the same grids built by hand: the
    same answer (u within 1e-10 of its largest value; measured <= 8.1e-15). (Q2 hexahedra need matching contact
    faces, which refining two bodies each on its own does not keep: fem/hexfaces.py refuses them; cc.adapt refines
    them together, test_q2_hexahedral_pairs_are_refined_with_their_faces_alike.)"""
    lower = cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=2, ny=2, nz=1, cell="hex")
    upper = cc.box(x=(0, 1), y=(0, 1), z=(0.5, 1.0), nx=3, ny=3, nz=1, cell="hex")
    lower = refine_grid(lower, np.arange(len(lower.cells)) == 0)[0]
    upper = refine_grid(upper, np.arange(len(upper.cells)) == 4)[0]
    by_hand = [_hexes_by_hand(*tensor_grid(m).axes) for m in (lower, upper)]

    def scene(a, b):
        a = cc.Body(a, ALU, clamped="bottom", contact="top", name="lower")
        b = cc.Body(b, STEEL, roller=["left", "front"], contact="bottom", name="upper",
                    traction={"top": lambda x, y, z: (0 * x, 0 * x, -1e7 * (1 - 1.6 * x))})
        return cc.Scene(a, b, contacts=[cc.Contact(a, "top", b, "bottom")])

    one, two = (quietly(cc.solve, scene(*pair), condition) for pair in ((lower, upper), by_hand))
    assert one.ok and two.ok
    for k, (a, b) in enumerate(zip((lower, upper), by_hand)):
        oa, ob = np.lexsort(a.points.T), np.lexsort(b.points.T)
        assert np.array_equal(a.points[oa], b.points[ob])
        assert np.abs(one.u[k][oa] - two.u[k][ob]).max() < 1e-10 * np.abs(one.u[k]).max()


def _q2_pair(lower_mesh, upper_mesh):
    """A Q2 block pressed by a load varying along x onto another, the two contact faces meshed alike."""
    lower = cc.Body(lower_mesh, ALU, clamped="bottom", contact="top", name="lower")
    upper = cc.Body(upper_mesh, STEEL, roller=["left", "front"], contact="bottom", name="upper",
                    traction={"top": lambda x, y, z: (0 * x, 0 * x, -1e7 * (1 - 0.8 * x))})
    return cc.Scene(lower, upper, contacts=[cc.Contact(lower, "top", upper, "bottom")])


def _blocks(n):
    """(lower, upper) hexahedral boxes, n x n x n/2 and n x n x n cells: faces on z = 0.5 meshed alike."""
    return (cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=n, ny=n, nz=n // 2, cell="hex"),
            cc.box(x=(0, 1), y=(0, 1), z=(0.5, 1.0), nx=n, ny=n, nz=n, cell="hex"))


@pytest.mark.numerics
def test_q2_hexahedral_pairs_are_refined_with_their_faces_alike():
    """Q2 hexahedra pose contact on matching faces only (fem/hexfaces.py): cc.adapt refines the partners' strips
    across a pair's faces together (geometry/refine.refine_together), so two Q2 blocks take two steps (before:
    UnsupportedError at step 1, "do not match corner to corner"). The faces stay alike (the same grid lines on
    z = 0.5), every step is exact and the estimate falls (measured 30.6 -> 19.4 -> 14.3). Marking every cell
    (theta = 1) halves every strip: the answer is that of the uniform grids built directly (measured 0 apart)."""
    scene = _q2_pair(*_blocks(2))
    result = quietly(cc.adapt, scene, "sigma1", degree=2, max_steps=2)
    h = result.history
    assert [s.step for s in h] == [0, 1, 2] and all(s.ok for s in h)
    assert h[2].estimate < h[1].estimate < h[0].estimate
    lower, upper = (b.mesh for b in result.scene.bodies)
    assert len(lower.cells) > 4
    for d in (0, 1):
        assert np.array_equal(tensor_grid(lower).axes[d], tensor_grid(upper).axes[d])
    full = quietly(cc.adapt, scene, "sigma1", degree=2, max_steps=1, theta=1.0, keep=True)
    direct = quietly(cc.solve, _q2_pair(*_blocks(4)), "sigma1", degree=2)
    assert [len(b.mesh.cells) for b in full.scene.bodies] == [32, 64] and direct.ok
    for k, (a, b) in enumerate(zip(full.scene.bodies, direct.scene.bodies)):
        pa, pb = (space(2, "hex").node_set(m.mesh).points for m in (a, b))
        oa, ob = np.lexsort(np.round(pa, 12).T), np.lexsort(np.round(pb, 12).T)
        assert np.abs(pa[oa] - pb[ob]).max() < 1e-14              # the same nodes (midpoints: rounding)
        assert np.abs(full.solution.u[k][oa] - direct.u[k][ob]).max() < 1e-10 * np.abs(direct.u[k]).max()


def test_refine_together_passes_a_partner_s_lines_and_refuses_faces_not_alike():
    """refine_together: a face's partner refined in one strip passes its line (x = 0.25) to the other side, which
    was not marked; a chain of three boxes passes it on; lines that no halving makes (faces 3 and 2 cells across)
    are refused by name (MeshError)."""
    from cvxcontact.geometry.grid import face_lines
    from cvxcontact.geometry.refine import refine_together

    boxes = [cc.box(x=(0, 1), y=(0, 1), z=(z, z + 1), nx=2, ny=2, nz=1, cell="hex") for z in (0, 1, 2)]
    times = [np.zeros(4, dtype=np.int64), np.zeros(4, dtype=np.int64), np.arange(4) == 0]
    faces = [((0, "top"), (1, "bottom")), ((1, "top"), (2, "bottom"))]
    fine = refine_together(boxes, [np.asarray(t, dtype=np.int64) * 3 for t in times], faces)
    for m in fine:
        assert np.array_equal(tensor_grid(m).axes[0], [0, 0.25, 0.5, 1]), tensor_grid(m).axes[0]
        assert np.array_equal(tensor_grid(m).axes[1], [0, 0.25, 0.5, 1])
    assert np.array_equal(face_lines(fine[0], "top")[0], [0, 0.25, 0.5, 1]) and len(face_lines(fine[0], "top")[2]) == 0
    alone = refine_together(boxes, [np.asarray(t, dtype=np.int64) * 3 for t in times], [])
    assert len(alone[0].cells) == 4 and len(alone[2].cells) > 4
    three = cc.box(x=(0, 1), y=(0, 1), z=(1, 2), nx=3, ny=3, nz=1, cell="hex")
    with pytest.raises(cc.MeshError, match="not meshed alike"):
        refine_together([boxes[0], three], [np.zeros(4, dtype=np.int64), np.zeros(9, dtype=np.int64)],
                        [((0, "top"), (1, "bottom"))])


class _Outside:
    """A space registered from outside the package the way docs/architecture.md ("A new space") lists it: the
    built-in ``inner``'s answers, without the optional ``matching_faces``."""

    def __init__(self, inner):
        self._inner = inner

    def __getattr__(self, name):
        if name == "matching_faces":
            raise AttributeError(name)
        return getattr(self._inner, name)


def test_a_space_without_matching_faces_adapts_as_one_that_says_false(monkeypatch):
    """``matching_faces`` is optional on the Space protocol: a space registered in SPACES without it (an extender's,
    written before the attribute existed) adapts a Q1 hexahedral pair as the built-in Q1 space does, bit for bit
    (before: AttributeError in cc.adapt)."""
    from cvxcontact.fem.space import SPACES, Q1Hex, needs_matching_faces

    lower = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=2, ny=2, nz=1, cell="hex"), ALU, clamped="bottom",
                    contact="top", name="lower")
    upper = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=3, ny=3, nz=1, cell="hex"), STEEL,
                    roller=["left", "front"], contact="bottom", name="upper",
                    traction={"top": lambda x, y, z: (0 * x, 0 * x, -1e7 * (1 - 0.4 * x))})
    scene = cc.Scene(lower, upper, contacts=[cc.Contact(lower, "top", upper, "bottom")])
    builtin = quietly(cc.adapt, scene, "sigma1", degree=1, max_steps=1)
    monkeypatch.setitem(SPACES, ("hex", 1), lambda: _Outside(Q1Hex()))
    outside = space(1, "hex")
    assert not hasattr(outside, "matching_faces") and not needs_matching_faces(outside)
    assert needs_matching_faces(space(2, "hex")) and not needs_matching_faces(space(2, "quad"))
    other = quietly(cc.adapt, scene, "sigma1", degree=1, max_steps=1)
    assert [len(b.mesh.cells) for b in other.scene.bodies] == [len(b.mesh.cells) for b in builtin.scene.bodies]
    for a, b in zip(other.solution.u, builtin.solution.u):
        assert np.array_equal(a, b)


def _hex_box(x, y, z, n):
    return cc.box(x=x, y=y, z=z, nx=n[0], ny=n[1], nz=n[2], cell="hex")


def _q2_stack3():
    """Three Q2 blocks stacked (2 x 2 x 1 cells each), the middle one between two pairs: a chain of faces."""
    load = {"top": lambda x, y, z: (0 * x, 0 * x, -1e7 * (1 - 0.4 * x))}
    b0 = cc.Body(_hex_box((0, 1), (0, 1), (0, .5), (2, 2, 1)), ALU, clamped="bottom", contact="top", name="b0")
    b1 = cc.Body(_hex_box((0, 1), (0, 1), (.5, 1), (2, 2, 1)), STEEL, roller=["left", "front"], name="b1")
    b2 = cc.Body(_hex_box((0, 1), (0, 1), (1, 1.5), (2, 2, 1)), ALU, roller=["left", "front"], contact="bottom",
                 name="b2", traction=load)
    return cc.Scene(b0, b1, b2, contacts=[cc.Contact(b0, "top", b1, "bottom"), cc.Contact(b1, "top", b2, "bottom")])


def _q2_two_on_one():
    """Two Q2 blocks side by side (x in (0, 0.5) and (0.5, 1)) on one: a body with two partners on one face."""
    load = {"top": lambda x, y, z: (0 * x, 0 * x, -1e7 * (1 - 0.4 * x))}
    lo = cc.Body(_hex_box((0, 1), (0, 1), (0, .5), (2, 2, 1)), ALU, clamped="bottom", contact="top", name="lo")
    u1 = cc.Body(_hex_box((0, .5), (0, 1), (.5, 1), (1, 2, 1)), STEEL, roller=["left", "front"], contact="bottom",
                 name="u1", traction=load)
    u2 = cc.Body(_hex_box((.5, 1), (0, 1), (.5, 1), (1, 2, 1)), STEEL, roller=["right", "front"], contact="bottom",
                 name="u2", traction=load)
    return cc.Scene(lo, u1, u2, contacts=[cc.Contact(lo, "top", u1, "bottom"), cc.Contact(lo, "top", u2, "bottom")])


def _alike_on_overlap(a, b):
    """True if the grid lines of the tensor grids ``a`` and ``b`` along x and y agree where their ranges overlap."""
    for d in (0, 1):
        la, lb = tensor_grid(a).axes[d], tensor_grid(b).axes[d]
        lo, hi = max(la[0], lb[0]) - 1e-12, min(la[-1], lb[-1]) + 1e-12
        sa, sb = la[(la >= lo) & (la <= hi)], lb[(lb >= lo) & (lb <= hi)]
        if len(sa) != len(sb) or np.abs(sa - sb).max() > 1e-12:
            return False
    return True


@pytest.mark.numerics
@pytest.mark.parametrize("build, pairs", [(_q2_stack3, [(0, 1), (1, 2)]), (_q2_two_on_one, [(0, 1), (0, 2)])],
                         ids=["three-stacked", "two-on-one"])
def test_q2_hexahedral_chains_and_shared_faces_adapt_alike(build, pairs):
    """cc.adapt on Q2 hexahedra beyond one pair: three stacked blocks (a line passed along a chain) and two blocks
    on one face of a third. Every step solves (the faces stay alike on each pair's overlap) and the estimate falls
    (measured 29.8 -> 20.7 -> 14.8 and 44.4 -> 31.8 -> 22.9); marking every cell is the uniform refinement built
    directly (measured 0 apart)."""
    scene = build()
    result = quietly(cc.adapt, scene, "sigma1", degree=2, max_steps=2)
    h = result.history
    assert [s.step for s in h] == [0, 1, 2] and all(s.ok for s in h)
    assert h[2].estimate < h[1].estimate < h[0].estimate
    meshes = [b.mesh for b in result.scene.bodies]
    assert sum(len(m.cells) for m in meshes) > sum(len(b.mesh.cells) for b in scene.bodies)
    assert all(_alike_on_overlap(meshes[a], meshes[b]) for a, b in pairs)
    full = quietly(cc.adapt, scene, "sigma1", degree=2, max_steps=1, theta=1.0, keep=True)
    direct = quietly(cc.solve, scene.with_bodies(*(b.with_changes(mesh=refine_grid(b.mesh, np.ones(len(b.mesh.cells),
                                                                                                    dtype=np.int64))[0])
                                                   for b in scene.bodies)), "sigma1", degree=2)
    assert direct.ok
    for k, (a, b) in enumerate(zip(full.scene.bodies, direct.scene.bodies)):
        pa, pb = (space(2, "hex").node_set(m.mesh).points for m in (a, b))
        oa, ob = np.lexsort(np.round(pa, 12).T), np.lexsort(np.round(pb, 12).T)
        assert np.abs(pa[oa] - pb[ob]).max() < 1e-14
        assert np.abs(full.solution.u[k][oa] - direct.u[k][ob]).max() < 1e-10 * np.abs(direct.u[k]).max()
