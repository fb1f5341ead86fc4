"""cc.ResolutionWarning in 3D (cells across the contact zone) and the aspect-ratio rule of the contact cells
(2D and 3D); the aspect ratio against closed forms. The 2D count is tested in tests/test_estimate.py."""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import estimate as study
from cvxcontact.solution.resolution import MAX_ASPECT, aspect_ratios

ALU = cc.materials.isotropic(E=70e9, nu=0.33)


def _resolution_messages(scene, **options):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = cc.solve(scene, **options)
    return sol, [str(w.message) for w in caught if w.category is cc.ResolutionWarning]


def test_a_coarse_3d_sphere_warns_and_a_refined_one_does_not():
    """The sphere of the effectivity study refined once (faces of 0.125 m): its zone has 2 loaded nodes, 2 faces
    across; refined twice (0.0625 m): 10 loaded nodes, 4 faces across, and no warning (measured)."""
    coarse, _ = study.refined(study.sphere_scene(), 1)
    sol, messages = _resolution_messages(coarse)
    assert sol.ok and len(messages) == 1
    assert "block/top" in messages[0] and "spanned by 2 faces of block" in messages[0]
    assert "Refine the contact face there: faces of at most" in messages[0]
    fine, _ = study.refined(study.sphere_scene(), 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResolutionWarning)
        assert cc.solve(fine).ok


def test_p2_in_3d_counts_the_zone_of_the_nodal_forces():
    """P2 on the sphere at level 0: the P2 Riesz pressure of the small zone has lobes of either sign over the
    whole face (its minimum -0.40 of its maximum at level 1, measured), the nodal forces are local: one zone,
    10 loaded P2 nodes spanning 2 node spacings, 4 spacings across with the ones either side, no warning;
    the same mesh in P1 (1 loaded node) warns."""
    scene = study.sphere_scene()
    sol, messages = _resolution_messages(scene, degree=2)
    assert sol.ok and messages == []
    _, messages = _resolution_messages(scene)
    assert len(messages) == 1 and "1 loaded node" in messages[0]


def test_the_aspect_ratio_of_simplices_against_closed_forms():
    """Longest edge over the inscribed diameter, over sqrt(3) (sqrt(6)): 1 for the regular simplices; the right
    isosceles triangle with legs 1: sqrt(2) / (2 - sqrt(2)) / sqrt(3); a flat triangle (base b, height t):
    b / (2 r) / sqrt(3) with its inradius r = area / semi-perimeter computed here."""
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]])
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    right = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    assert aspect_ratios(tri, [[0, 1, 2]])[0] == pytest.approx(1.0, rel=1e-14)
    assert aspect_ratios(tet, [[0, 1, 2, 3]])[0] == pytest.approx(1.0, rel=1e-14)
    assert aspect_ratios(right, [[0, 1, 2]])[0] == pytest.approx(np.sqrt(2) / (2 - np.sqrt(2)) / np.sqrt(3), rel=1e-14)
    b, t = 1.0, 0.01
    flat = np.array([[0.0, 0.0], [b, 0.0], [0.3, t]])
    sides = np.linalg.norm(flat - np.roll(flat, 1, axis=0), axis=1)
    r = 0.5 * b * t / (0.5 * sides.sum())
    assert aspect_ratios(flat, [[0, 1, 2]])[0] == pytest.approx(b / (2 * r) / np.sqrt(3), rel=1e-14)
    # the orientation does not matter
    assert aspect_ratios(flat, [[0, 2, 1]])[0] == aspect_ratios(flat, [[0, 1, 2]])[0]


def test_thin_contact_cells_warn_in_2d_and_3d():
    """Cells 1/192 m along the face and 1/4 m deep (aspect ratio 28.0) under the study's circle; tetrahedra
    1/32 m along the face and 1 m deep (up to 22.5 at the zone, 26.2 in the mesh) under its sphere: each zone is
    resolved (no 'spanned by') but its cells are too thin, and the message names the body, the part, the ratio
    and the fix."""
    mesh = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=192, ny=2)
    block = cc.Body(mesh, ALU, clamped="bottom", contact="top", name="block")
    scene = cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((0.47, 0.5 + 0.6 - 3e-3), 0.6))])
    mesh3 = cc.box(x=(0, 1), y=(0, 1), z=(0, 1.0), nx=32, ny=32, nz=1)
    block3 = cc.Body(mesh3, ALU, clamped="bottom", contact="top", name="block")
    scene3 = cc.Scene(block3, contacts=[cc.Contact(block3, "top", cc.Rigid.sphere((0.47, 0.5, 1.48), 0.5))])
    for s, shape in ((scene, "equilateral triangle"), (scene3, "regular tetrahedron")):
        sol, messages = _resolution_messages(s)
        assert sol.ok and len(messages) == 1, messages
        (m,) = messages
        assert "block/top" in m and "aspect ratio up to" in m and shape in m and "spanned by" not in m
        assert f"Remesh the cells along 'top' there with aspect ratio at most {MAX_ASPECT:g}" in m
        ratio = float(m.split("aspect ratio up to ")[1].split(" ")[0])
        assert MAX_ASPECT < ratio <= aspect_ratios(s.bodies[0].mesh.points, s.bodies[0].mesh.cells).max() * (1 + 1e-3)


def _coarse_over_small(lo=0.3, hi=0.45):
    """A block (0, 1) x (0, 0.5) of 2 x 2 cells (its bottom nodes at x = 0, 0.5, 1) clamped on its top, 1e-5 m
    into a block (lo, hi) x (-0.5, 0) clamped on its bottom: no node of the upper block's bottom lies in the
    overlap (lo, hi)."""
    mat = cc.materials.isotropic(E=70e9, nu=0.0)
    up = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=2, ny=2), mat, contact="bottom", clamped=["top"])
    low = cc.Body(cc.rectangle(x=(lo, hi), y=(-0.5, 0), nx=1, ny=2), mat, clamped=["bottom"], contact="top")
    return cc.Scene(up, low, contacts=[cc.Contact(up, "bottom", low, "top", gap=-1e-5)])


@pytest.mark.numerics
@pytest.mark.parametrize("degree", [1, 2])
def test_a_sigma_condition_with_no_row_in_the_overlap_warns_naming_the_other_conditions(degree):
    """Under "sigma1" the rows are body 1's nodes in the overlap; with none there the pair has no row and the
    bodies pass through each other (the discrete problem solved exactly, ok): a ResolutionWarning names the pair,
    the missing rows, the interpenetration (1e-5 m: both blocks clamped, nothing moves) and the fix. Under "sigma2"
    (the small block's two nodes) and "gamma3" the bodies are kept apart, and no such warning is given (before:
    "gamma3" raised a bare ValueError in the resolution check)."""
    scene = _coarse_over_small()
    sol, messages = _resolution_messages(scene, condition="sigma1", degree=degree)
    rowless = [m for m in messages if "there is none" in m]
    assert sol.ok and len(rowless) == 1
    assert "'sigma2'" in rowless[0] and "'gamma3'" in rowless[0] and "1e-05 m" in rowless[0]
    assert np.max(sol.contact.jump - sol.contact.gap) == pytest.approx(1e-5, rel=1e-12)
    for condition in ("sigma2", "gamma3"):
        sol, messages = _resolution_messages(scene, condition=condition, degree=degree)
        assert sol.ok and not [m for m in messages if "there is none" in m]
        assert np.max(sol.contact.jump - sol.contact.gap) <= 1e-12 * 1e-5 * 1e3    # kept apart (rounding)


@pytest.mark.numerics
def test_a_sigma_condition_with_no_row_in_the_overlap_warns_in_3d():
    """The 3D counterpart: a box of 1 x 1 x 1 cells over a block (0.3, 0.45)^2 of the plane: under "sigma1" no
    node of the box's bottom lies in the overlap (warned); under "sigma2" the rows are the small block's nodes."""
    mat = cc.materials.isotropic(E=70e9, nu=0.0)
    up = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=1, ny=1, nz=1), mat, contact="bottom", clamped=["top"])
    low = cc.Body(cc.box(x=(.3, .45), y=(.3, .45), z=(-.5, 0), nx=1, ny=1, nz=1), mat, contact="top",
                  clamped=["bottom"])
    scene = cc.Scene(up, low, contacts=[cc.Contact(up, "bottom", low, "top", gap=-1e-5)])
    sol, messages = _resolution_messages(scene, condition="sigma1")
    assert sol.ok and len([m for m in messages if "there is none" in m]) == 1
    sol, messages = _resolution_messages(scene, condition="sigma2")
    assert sol.ok and not [m for m in messages if "there is none" in m]


def _box_over_small():
    """The 3D counterpart of :func:`_coarse_over_small`: a box of 1 x 1 x 1 cells (its bottom's P1 and Q1/P2 nodes
    at x, y in {0, 0.5, 1}) clamped on its top, 1e-5 m into a block (0.3, 0.45)^2 clamped on its bottom."""
    mat = cc.materials.isotropic(E=70e9, nu=0.0)
    up = cc.Body(cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=1, ny=1, nz=1), mat, contact="bottom", clamped=["top"])
    low = cc.Body(cc.box(x=(.3, .45), y=(.3, .45), z=(-.5, 0), nx=1, ny=1, nz=1), mat, contact="top",
                  clamped=["bottom"])
    return cc.Scene(up, low, contacts=[cc.Contact(up, "bottom", low, "top", gap=-1e-5)])


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.NormalCompliance(stiffness=1e12), cc.Tresca(1e3), cc.Coulomb(0.3)],
                         ids=["compliance", "tresca", "coulomb"])
@pytest.mark.parametrize("dim, degree", [(2, 1), (2, 2), (3, 1), (3, 2)])
def test_a_law_under_a_sigma_condition_with_no_row_in_the_overlap_warns_as_signorini(dim, degree, law):
    """A law on the rows (normal compliance, friction) under "sigma1" with no node of body 1's part in the overlap
    has no row, as Signorini's condition: the same ResolutionWarning (the pair, the other conditions, the
    interpenetration: 1e-5 m, both blocks clamped, nothing moves) on every dimension and degree (before, the 2D P2
    compliance law raised UnsupportedError). Under "sigma2" the small block's nodes carry the law: no warning,
    and the blocks are kept apart by a compressive force."""
    scene = _coarse_over_small() if dim == 2 else _box_over_small()
    sol, messages = _resolution_messages(scene, condition="sigma1", degree=degree, law=law)
    rowless = [m for m in messages if "there is none" in m]
    assert sol.ok and len(rowless) == 1
    assert "'sigma2'" in rowless[0] and "'gamma3'" in rowless[0] and "1e-05 m" in rowless[0]
    assert np.max(sol.contact.jump - sol.contact.gap) == pytest.approx(1e-5, rel=1e-12)
    assert not np.asarray(sol.contact.force).any() and not np.asarray(sol.contact.lam).any()
    sol, messages = _resolution_messages(scene, condition="sigma2", degree=degree, law=law)
    assert sol.ok and not [m for m in messages if "there is none" in m]
    assert np.asarray(sol.contact.force).sum() > 0


@pytest.mark.numerics
def test_a_pair_with_no_row_leaves_the_other_pairs_answer_unchanged():
    """A P2 compliance or Tresca law with one pair rowless under "sigma1" (warned) beside a block pressed on a rigid
    plane: the pressed block's answer equals that of the scene without the rowless pair, by cc.solve and cc.Model
    (measured: 1.7e-16 relative, forces equal to rounding)."""
    mat = cc.materials.isotropic(E=70e9, nu=0.0)
    pressed = cc.Body(cc.rectangle(x=(2, 3), y=(0, 0.5), nx=2, ny=2), mat, displacement={"top": (0, -1e-5)},
                      contact="bottom")
    plane = cc.Contact(pressed, "bottom", cc.Rigid.plane((0, 0), (0, 1)))
    pair = _coarse_over_small()
    both = cc.Scene(*pair.bodies, pressed, contacts=[*pair.contacts, plane])
    alone = cc.Scene(pressed, contacts=[plane])
    for law in (cc.NormalCompliance(stiffness=1e12), cc.Tresca(1e3)):
        ref = cc.solve(alone, "sigma1", degree=2, law=law)
        with pytest.warns(cc.ResolutionWarning, match="there is none"):
            sol = cc.solve(both, "sigma1", degree=2, law=law)
        model = cc.Model(both, "sigma1", degree=2, law=law).solve()
        assert ref.ok and sol.ok and model.ok and ref.contact.force.sum() > 0
        for other in (sol, model):
            assert np.abs(other.u[2] - ref.u[0]).max() <= 1e-12 * np.abs(ref.u[0]).max()      # measured 1.7e-16
            assert other.contacts[1].force.sum() == pytest.approx(ref.contact.force.sum(), rel=1e-12)


@pytest.mark.parametrize("mesh", [cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=12, ny=5),
                                  cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=6, ny=3, cell="quad"),
                                  cc.box(x=(0, 1), y=(0, 1), z=(0, 0.5), nx=4, ny=3, nz=2)],
                         ids=["triangles", "quads", "tetrahedra"])
def test_the_owners_of_a_part_s_facets_are_found_among_the_cells_kept_at_the_part(mesh):
    """The cells at a boundary part (CellMesh.cells_at, kept: the same array when asked again) hold the owner of
    each of its facets: the search among them finds the owners of a search among all cells, and each owner has
    the facet's vertices among its own (the oracle: the cells' vertex lists)."""
    from cvxcontact.solution.resolution import _owners

    simplices = getattr(mesh, "split", mesh)
    for part in ("top", "left"):
        facets = simplices.boundary(part)[::2]                           # some of the part's facets
        near = simplices.cells_at(part)
        assert simplices.cells_at(part) is near and len(near) < len(simplices.cells)
        owners = _owners(simplices.cells, facets, near)
        assert np.array_equal(owners, _owners(simplices.cells, facets))
        assert all(set(f) <= set(simplices.cells[c]) for f, c in zip(facets, owners))
