"""Q1 hexahedra: "gamma3" between two bodies whose contact faces are nested, or aligned grids that cross (issue
31, item 3; cvxcontact/fem/hexfaces.py).

Independent references: the jump of the answer sampled at 7 x 7 points of every fine face, both traces evaluated
by the Q1 shape functions written in tests/hex_scenes.py (the coarse face's reference point found by its own
Newton iteration), against the gap; the uniaxial closed form of a column squeezed through nested faces (displacements,
stresses, forces, pressures); the reference backend (``method="full"``); the same scene with its pair written
the other way round; the fine side's nodal rows ("sigma1"/"sigma2", the same condition) and the coarse side's
(a weaker one, under which the fine face sinks into the coarse body between the coarse corners).
"""

import numpy as np
import pytest
from hex_scenes import (
    ALU,
    CROSSING,
    DELTA,
    NESTED,
    PUSH,
    STEEL,
    TILTED,
    block,
    nested,
    pair,
    sampled_slack,
)

import cvxcontact as cc
from cvxcontact.errors import UnsupportedError
from cvxcontact.fem.fields import body_fields
from cvxcontact.fem.space import space

pytestmark = pytest.mark.numerics


@pytest.mark.parametrize("case", list(NESTED))
def test_nested_gamma3_holds_everywhere_on_the_fine_faces(case):
    """Under an affine gap that leaves part of the faces open, "gamma3" on nested faces (aligned grids 2:1 in
    both directions or one, 4:1, the finer side below or above; general quadrilaterals refined in their bilinear
    coordinates) is non-penetration at every sampled point of every fine face (7 x 7 per face, the Q1 traces
    written here), the rows are the fine side's nodes only (fewer than the overlay's vertices where the faces'
    diagonals cross), every fine face whose four corners carry force is closed everywhere (a bilinear jump
    vanishing at its corners), the checks hold, and the reference backend gives the same answer."""
    scene, fine = nested(case, gap=TILTED, rollers=False, push=PUSH)
    lines = space(1, "hex").contact(scene, "gamma3", None)
    itf = lines.interface.interfaces[0]
    fine_nodes = scene.bodies[fine].mesh.boundary_nodes(["top" if fine == 0 else "bottom"])
    assert lines.E.shape[0] == len(fine_nodes) <= itf.size
    if case in ("4x2 on 2x2", "2x2 on 2x4"):
        assert len(fine_nodes) < itf.size                        # the coarse diagonals cut the fine faces
    assert np.array_equal(lines.gap, TILTED(itf.x[:, 0], itf.x[:, 1]))      # the gap at the nodes of X_h
    sol = cc.solve(scene, "gamma3")
    assert sol.ok and sol.polished
    slack, scale = sampled_slack(scene, sol, fine, TILTED)
    assert scale > 0.1 * PUSH
    assert slack.min() >= -1e-12 * scale                                   # measured >= -6.9e-16 scale
    assert slack.max() >= 0.1 * scale                                      # partly open: measured 0.91 scale
    c = sol.contacts[0]
    force = np.asarray(c.force)
    carry = force > 1e-9 * force.max()
    node_of = np.full(scene.bodies[fine].mesh.points.shape[0], -1)
    at = np.asarray(itf.overlay.node_a if fine == 0 else itf.overlay.node_b)
    node_of[itf.traces[fine].nodes[at >= 0]] = at[at >= 0]
    faces = scene.bodies[fine].mesh.boundary("top" if fine == 0 else "bottom")
    closed = carry[node_of[faces]].all(axis=1)
    assert 0 < closed.sum() < len(faces)
    assert np.abs(slack[closed]).max() <= 1e-12 * scale                    # measured <= 6.9e-16 scale
    assert (np.abs(c.jump - c.gap)[carry] <= 1e-12 * scale).all()          # at the rows: measured <= 6.9e-16
    full = cc.solve(scene, "gamma3", method="full")
    assert full.ok
    for k in (0, 1):
        assert np.abs(full.u[k] - sol.u[k]).max() <= 1e-10 * scale         # measured <= 1.8e-15 scale


@pytest.mark.parametrize("case", list(NESTED))
def test_uniform_pressure_through_nested_faces_is_the_closed_form(case):
    """A steel block under an aluminium one, rollers on the sides, pushed by DELTA through nested faces: uniaxial
    strain, sigma_zz = -p, p = DELTA / (H/M_steel + H/M_alu), u_z piecewise linear, u_x = u_y = 0, the force p A
    (A = 1 m^2), the pressure each body feels (nodal forces over the Q1 hats' areas) and the rows' pressure
    (forces over the fine hats' integrals) p at every node."""
    scene, _ = nested(case, materials=(STEEL, ALU))
    sol = cc.solve(scene, "gamma3")
    assert sol.ok and sol.polished
    M_s, M_a = float(STEEL.tensors(3)[0][2, 2]), float(ALU.tensors(3)[0][2, 2])
    H = 0.5
    p = DELTA / (H / M_s + H / M_a)
    for k, exact in enumerate((lambda z: -p * z / M_s, lambda z: -p * H / M_s - p * (z - H) / M_a)):
        z = sol.points[k][:, 2]
        assert np.abs(sol.u[k][:, 2] - exact(z)).max() <= 1e-12 * DELTA      # measured <= 6.8e-16 DELTA
        assert np.abs(sol.u[k][:, :2]).max() <= 1e-12 * DELTA                # measured <= 3.6e-16 DELTA
        stress = body_fields(scene.bodies[k], sol.u[k], None).stress
        c = (STEEL, ALU)[k].tensors(3)[0]
        assert np.abs(stress[:, 2] + p).max() <= 1e-12 * p                      # measured <= 9.4e-16 p
        assert np.abs(stress[:, 0] + p * c[0, 2] / c[2, 2]).max() <= 1e-12 * p  # measured <= 3.9e-16 p
        assert np.abs(stress[:, 3:]).max() <= 1e-12 * p                         # measured <= 6.2e-16 p
    c = sol.contacts[0]
    assert abs(c.force.sum() - p) <= 1e-12 * p                                 # measured <= 4.7e-16 p
    assert np.abs(c.pressure[c.constrained] - p).max() <= 1e-12 * p           # measured <= 2.8e-15 p
    for k in (0, 1):
        assert np.abs(sol.traction(k)[1] - p).max() <= 1e-12 * p              # measured <= 3.0e-15 p


def test_nested_gamma3_is_the_fine_sides_nodal_rows_and_stricter_than_the_coarse_sides():
    """A fine upper block (4 x 4 faces) pushed onto a coarse lower one (one face): "gamma3" is the fine side's
    nodal rows ("sigma2" here: the same rows, the same answer); the coarse side's rows ("sigma1", its four
    corners) let the fine face sink into the coarse body between them (the sampled jump), "gamma3" does not, and
    its energy is the larger (a smaller feasible set). The space marks nested rows independent, so "gamma3" takes
    the nodal rows' route (no interior point: benchmarks/results/hex_nested_route.md)."""
    scene = pair(block(1, (0.0, 0.5)), block(4, (0.5, 1.0)), rollers=False)
    a = space(1, "hex").contact(scene, "gamma3", None)
    b = space(1, "hex").contact(scene, "sigma2", None)
    assert (a.E != b.E).nnz == 0 and a.E.shape[0] == 25 and a.independent and not b.independent
    g3, s2, s1 = (cc.solve(scene, c) for c in ("gamma3", "sigma2", "sigma1"))
    assert g3.ok and s2.ok and s1.ok and g3.info.finish == s2.info.finish
    slack, scale = sampled_slack(scene, g3, 1)
    for k in (0, 1):
        assert np.abs(g3.u[k] - s2.u[k]).max() <= 1e-12 * scale               # measured 0 (the same program)
    assert slack.min() >= -1e-12 * scale                                       # measured >= -1.4e-15 scale
    coarse_rows, _ = sampled_slack(scene, s1, 1)
    assert coarse_rows.min() <= -0.1 * scale                                   # measured -1.8 scale
    assert g3.energy - s1.energy >= 1e-2 * abs(s1.energy)                      # measured 0.38 |s1.energy|


@pytest.mark.parametrize("case", ["4 on 2", "skewed 2 on 4"])
def test_either_side_first_gives_the_same_answer(case):
    """The pair written fine side first or second (Contact(lower, "top", upper, "bottom") or the reverse) poses
    the same condition: the same displacements, force and energy."""
    one, _ = nested(case, gap=TILTED, rollers=False, push=PUSH)
    two, _ = nested(case, gap=TILTED, rollers=False, push=PUSH, swap=True)
    a, b = cc.solve(one, "gamma3"), cc.solve(two, "gamma3")
    assert a.ok and b.ok
    scale = max(np.abs(u).max() for u in a.u)
    for k in (0, 1):
        assert np.abs(a.u[k] - b.u[k]).max() <= 1e-10 * scale                  # measured <= 1.4e-16 scale
    assert abs(a.contacts[0].force.sum() - b.contacts[0].force.sum()) <= 1e-10 * abs(a.contacts[0].force.sum())
    assert abs(a.energy - b.energy) <= 1e-10 * abs(a.energy)                   # measured <= 1.6e-16 (both)


@pytest.mark.parametrize("case", list(CROSSING))
def test_gamma3_on_aligned_crossing_faces_holds_everywhere(case):
    """Rectangular faces of two grids that cross (3 on 2, 5 on 3, 3 x 2 on 2 x 5: aligned, not nested): "gamma3"
    is posed at the corners of the pieces where faces of the two sides meet (the product of the two grids' lines;
    fewer rows than overlay vertices), the jump sampled on every face of both sides never exceeds the affine gap,
    the reference backend agrees; a uniform squeeze gives the closed-form force and the pressure each body feels
    (those rows depend on each other: the row forces are not unique, their work is)."""
    (n1, m1), (n2, m2) = CROSSING[case]
    scene = pair(block(n1, (0.0, 0.5), m=m1), block(n2, (0.5, 1.0), m=m2), gap=TILTED, rollers=False, push=PUSH)
    lines = space(1, "hex").contact(scene, "gamma3", None)
    itf = lines.interface.interfaces[0]
    lines_x = np.unique(np.r_[np.linspace(0, 1, n1 + 1), np.linspace(0, 1, n2 + 1)].round(12))
    lines_y = np.unique(np.r_[np.linspace(0, 1, m1 + 1), np.linspace(0, 1, m2 + 1)].round(12))
    assert lines.E.shape[0] == len(lines_x) * len(lines_y) < itf.size
    assert abs(itf.weights("gamma3").sum() - 1.0) <= 1e-14                  # the overlap's area (m^2)
    sol, full = cc.solve(scene, "gamma3"), cc.solve(scene, "gamma3", method="full")
    assert sol.ok and sol.polished and full.ok
    (lower, scale), (upper, _) = (sampled_slack(scene, sol, side, TILTED) for side in (0, 1))
    assert min(lower.min(), upper.min()) >= -1e-12 * scale                 # measured >= -6.2e-16 scale
    assert lower.max() >= 0.1 * scale
    for k in (0, 1):
        assert np.abs(full.u[k] - sol.u[k]).max() <= 1e-10 * scale          # measured <= 1.3e-15 scale
    squeeze = cc.solve(pair(block(n1, (0.0, 0.5), m=m1), block(n2, (0.5, 1.0), m=m2)), "gamma3")
    p = DELTA * float(STEEL.tensors(3)[0][2, 2])                          # uniaxial strain of the unit column
    assert squeeze.ok and abs(squeeze.contacts[0].force.sum() - p) <= 1e-12 * p      # measured <= 1.8e-16 p
    for k in (0, 1):
        assert np.abs(squeeze.traction(k)[1] - p).max() <= 1e-12 * p         # measured <= 2.6e-15 p


def test_a_coarse_face_overhanging_a_finer_part_is_cut_into_pieces():
    """An upper block on [0.1, 0.9] x [0, 1] (one by two faces) on a 4 x 4 lower one: the faces of the lower block
    that straddle x = 0.1 and x = 0.9 lie partly outside the overlap (not nested), the pieces are the overlap's
    parts of them; the jump sampled on the upper block's faces and on the lower's inside the overlap never exceeds
    the gap, and the rows' areas sum to the overlap's, 0.8 m^2."""
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=4, ny=4, nz=1, cell="hex")
    upper = cc.box(x=(0.1, 0.9), y=(0.0, 1.0), z=(0.5, 1.0), nx=1, ny=2, nz=1, cell="hex")
    scene = pair(lower, upper, gap=TILTED, rollers=False, push=PUSH)
    itf = space(1, "hex").contact(scene, "gamma3", None).interface.interfaces[0]
    assert type(itf).__name__ == "CrossingSurface" and abs(itf.weights("gamma3").sum() - 0.8) <= 1e-14
    sol = cc.solve(scene, "gamma3")
    (below, scale), (above, _) = (sampled_slack(scene, sol, side, TILTED) for side in (0, 1))
    assert sol.ok and np.isnan(below).any() and not np.isnan(above).any()
    assert min(np.nanmin(below), above.min()) >= -1e-12 * scale              # measured >= -5.0e-16 scale


def test_faces_neither_matching_nor_nested_nor_aligned_are_refused_naming_why_and_the_alternatives():
    """Typed refusals of "gamma3" between faces that neither match, nest nor run along common directions: grids
    that cross where one is skewed (3 on a warped 2), a skewed fine grid inside one coarse face (its faces are
    not rectangles of the coarse face's bilinear coordinates: the jump is not bilinear there); the message says
    why for each; "sigma1" is taken on each."""
    cases = {"skewed crossing": (block(3, (0.0, 0.5)), block(2, (0.5, 1.0), skewed=True), "lies across"),
             "skewed inside": (block(1, (0.0, 0.5)), block(2, (0.5, 1.0), skewed=True), "not a rectangle")}
    for lower, upper, why in cases.values():
        scene = pair(lower, upper, rollers=False)
        with pytest.raises(UnsupportedError, match=f"not nested.*{why}.*not parallelograms along common directions"
                           r".*not a parallelogram.*condition='sigma1'.*nested or aligned.*tetrahedra"):
            cc.solve(scene, "gamma3")
        assert cc.solve(scene, "sigma1").ok
