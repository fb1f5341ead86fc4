"""What a prepared ContactSolver keeps of its geometry between load cases (DiscreteProblem.shared: the rigid fits,
the rows' reach structures of the checks, the electrodes' rows; the estimate's Geometry with its facet roles; a
with_loads body's support checks) and what it must not keep. The oracle is the answer computed afresh: a direct
solve of the same scene, or the functions the kept structures stand in for, called on the whole matrices."""

import numpy as np
import pytest
from conftest import rel, two_blocks

import cvxcontact as cc
from cvxcontact.backends.finish.forces import (
    RowReach,
    force_displacements,
    reach_displacements,
    reach_forces,
)
from cvxcontact.discrete import build_problem
from cvxcontact.fem.space import space
from cvxcontact.solution.estimate import estimate

pytestmark = pytest.mark.numerics

ALU = cc.materials.isotropic(E=70e9, nu=0.3)


def _block_under_circle(x, depth=3e-3, R=0.6):
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), ALU, clamped="bottom", contact="top",
                    name="block", body_force=(0.0, -1e8))
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((x, 0.5 + R - depth), R))])


def _estimates_agree(a, b, tol):
    return (abs(a.absolute - b.absolute) <= tol * b.absolute and abs(a.norm - b.norm) <= tol * b.norm
            and all(rel(x, y) <= tol for x, y in zip(a.indicators, b.indicators)))


def test_a_load_case_has_the_estimate_checks_and_electrodes_of_a_direct_solve():
    """The second load case of a solver (every kept structure in use) against cc.solve of the same scene.
    Measured: identical (0.0) in u, the forces, the estimate (total and indicators), the checks and the
    electrode charges; asserted to 1e-12 relative (the warm start's finish and the program's may differ by
    rounding)."""
    solver = cc.ContactSolver(two_blocks())
    first = solver.solve()
    other = two_blocks(scale=0.37, traction={"right": (0.0, -1e8)})
    again, direct = solver.solve(other), cc.solve(other)
    assert first.ok and again.ok and direct.ok
    assert rel(first.estimate.indicators[0], direct.estimate.indicators[0]) > 1e-2          # the loads matter
    assert _estimates_agree(again.estimate, direct.estimate, 1e-12)
    assert rel(again.u[0], direct.u[0]) < 1e-12 and rel(again.contact.force, direct.contact.force) < 1e-12
    for key, value in direct.residuals().items():
        assert again.residuals()[key] <= max(10 * value, 1e-15), key
    assert rel([e.charge for e in again.electrodes], [e.charge for e in direct.electrodes]) < 1e-12
    kept = {k if isinstance(k, str) else k[0] for k in solver.problem._shared}
    assert {"rigid fits", "row reach", "electrode rows"} <= kept


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")         # a coarse top: not the point here
def test_the_kept_structures_follow_the_rows_of_a_moved_obstacle():
    """The obstacle moved along the top reaches other nodes: the rows' reach structures are keyed by the rows, so
    the re-solve's checks are a direct solve's (the first rows' structure applied to the new rows would not even
    have their size); the rigid fits, of the geometry alone, are kept (the same object)."""
    solver = cc.ContactSolver(_block_under_circle(0.5), method="condensed")
    first = solver.solve()
    fits = solver.problem.rigid_fits
    moved = _block_under_circle(0.61)
    again, direct = solver.solve(moved), cc.solve(moved, method="condensed")
    assert first.ok and again.ok and direct.ok
    assert solver.problem.rigid_fits is fits
    reaches = [k for k in solver.problem._shared if k[0] == "row reach"]
    assert len(reaches) == 2                                      # one per set of rows
    for key, value in direct.residuals().items():
        assert abs(again.residuals()[key] - value) <= 1e-6 * max(value, 1e-12), key
    assert _estimates_agree(again.estimate, direct.estimate, 1e-9)


def test_another_geometry_gets_its_own_store():
    """A problem built for another material starts an empty store; a load case shares its problem's (the same
    dict), and another solver for the other material answers as a direct solve of it (no structure of the first
    geometry reaches it: the solver refuses the scene instead)."""
    sp1 = space(1, "triangle")
    base = build_problem(two_blocks(), sp1, "gamma3", cc.Signorini())
    _ = base.rigid_fits
    stiffer = two_blocks(mat2=cc.materials.isotropic(E=200e9, nu=0.3))
    other = build_problem(stiffer, sp1, "gamma3", cc.Signorini())
    assert other._shared is not base._shared and "rigid fits" not in other._shared
    assert base.with_loads(two_blocks(scale=0.5))._shared is base._shared
    solver = cc.ContactSolver(two_blocks())
    solver.solve()
    with pytest.raises(cc.SceneError, match="only loads may change"):
        solver.solve(stiffer)
    mine, direct = cc.ContactSolver(stiffer).solve(), cc.solve(stiffer)
    assert rel(mine.u[1], direct.u[1]) == 0.0 and mine.estimate.absolute == direct.estimate.absolute


@pytest.mark.parametrize("case", ["p1", "p2", "3d"])
def test_row_reach_gives_the_numbers_of_the_whole_products(case):
    """RowReach reads the rows of the matrices the contact rows touch; every row's sum is the whole product's:
    the same numbers, bit for bit (measured: identical), on P1, P2 and a 3D pair."""
    if case == "3d":
        from scenes3d import stacked_blocks
        scene, degree, condition = stacked_blocks(), 1, "gamma3"
    else:
        scene, degree, condition = two_blocks(), (1 if case == "p1" else 2), ("gamma3" if case == "p1" else "sigma1")
    problem = build_problem(scene, space(degree, scene.cell), condition, cc.Signorini())
    blocks, E = problem.blocks, problem.E
    rng = np.random.default_rng(1)
    u = [rng.standard_normal(b.Kuu.shape[0]) for b in blocks]
    phi = [None if b.Kpp is None else rng.standard_normal(b.Kpp.shape[0]) for b in blocks]
    y = rng.standard_normal(E.shape[0])
    reach = RowReach(blocks, E)
    assert np.array_equal(reach.compliance * np.abs(y), force_displacements(blocks, E, y))
    assert np.array_equal(reach.displacements(u, phi), reach_displacements(blocks, E, u, phi))
    assert np.array_equal(reach.forces(u, phi, problem.rigid_fits), reach_forces(blocks, E, u, phi, problem.rigid_fits))
    assert np.abs(reach.displacements(u, phi)).max() > 0


def test_a_body_with_other_loads_shares_its_geometry_checks_and_checks_its_loads():
    scene = two_blocks()
    upper, lower = scene.bodies
    again = upper.with_loads(body_force=(0.0, 1e9))
    assert again._node_supports is upper._node_supports and again.held_by_contact == upper.held_by_contact
    with pytest.raises(cc.SceneError, match="both clamped and traction"):
        upper.with_loads(traction={"top": (0.0, 1.0)})
    with pytest.raises(cc.SceneError, match="carries no electric"):
        lower.with_loads(surface_charge={"bottom": 1e-3})
    with pytest.raises(cc.SceneError, match="carries no electric"):
        lower.with_loads(volume_charge=1.0)


@pytest.mark.parametrize("degree", [1, 2])
def test_constant_loads_need_no_points(degree):
    """A constant body force and surface charge give the estimate of the same loads written as functions (those
    are evaluated at the quadrature points; the constants are not). Measured: 0.0 (P1) and 0.0 (P2) relative."""
    condition = "gamma3" if degree == 1 else "sigma1"
    constant = two_blocks(n1=(8, 4), n2=(6, 3))
    functions = two_blocks(n1=(8, 4), n2=(6, 3), body_force=lambda x, y: (0.0 * x, -2e9 + 0.0 * x),
                           volume_charge=lambda x, y: 0.0 * x + 1e-4)
    constant = constant.with_loads(0, volume_charge=1e-4)
    a = cc.solve(constant, condition, degree=degree)
    b = cc.solve(functions, condition, degree=degree)
    assert rel(a.u[0], b.u[0]) < 1e-12
    assert _estimates_agree(a.estimate, b.estimate, 1e-12)
    assert a.estimate.parts["element"] > 0 and a.estimate.parts["electric element"] > 0


def test_a_load_case_on_other_parts_has_the_facet_roles_of_a_direct_solve():
    """The estimate's facet roles are kept per set of roles: a load case with a traction on another part too (left
    and right) is estimated as a direct solve (the first roles count the left side as free, not loaded: measured
    0.25 relative in the upper body's indicators when forced on it)."""
    solver = cc.ContactSolver(two_blocks())
    solver.solve()
    left = two_blocks(traction={"left": (0.0, 3e8), "right": (0.0, 3e8)})
    again, direct = solver.solve(left), cc.solve(left)
    assert _estimates_agree(again.estimate, direct.estimate, 1e-9)
    geometry = next(iter(solver._geometry.values()))
    assert len(geometry._roles) == 2
    wrong = {k: g for k, g in solver._geometry.items()}
    for g in wrong.values():                       # hand every load case the first roles: the answer moves
        first = next(iter(g._roles.values()))
        g.roles = lambda *args, first=first: first
    forced = estimate(again, cache=wrong, fingerprints=solver.problem.fingerprints)[0]

    assert rel(forced.indicators[0], direct.estimate.indicators[0]) > 1e-3


@pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")         # a coarse top: not the point here
def test_the_row_keyed_store_does_not_grow_with_the_obstacle_positions():
    """An obstacle moved to many positions gives as many sets of rows; the store keeps the structures of the
    latest ROWS_KEPT of them only (measured before the bound: one entry per position, 202 after 200 positions of
    a 96 x 24 mesh, 1.8 MB growing 9 kB a step), and a load case back at a dropped position is a direct solve's."""
    from cvxcontact.discrete.problem import ROWS_KEPT

    solver = cc.ContactSolver(_block_under_circle(0.3), method="condensed", estimate=False)
    positions = np.linspace(0.3, 0.7, 3 * ROWS_KEPT)
    for x in positions:
        solver.solve(_block_under_circle(float(x)))
    rows = {k[1] for k in solver.problem._shared if isinstance(k, tuple)}
    assert len({solver.problem.lines.key()} | rows) == len(rows) == ROWS_KEPT
    back = _block_under_circle(float(positions[0]))
    again, direct = solver.solve(back), cc.solve(back, method="condensed", estimate=False)
    assert rel(again.u[0], direct.u[0]) < 1e-12 and rel(again.contact.force, direct.contact.force) < 1e-12
    for key, value in direct.residuals().items():
        assert abs(again.residuals()[key] - value) <= 1e-6 * max(value, 1e-12), key


def _fingerprint_of(points, cells, e=None, **parts):
    """geometry_fingerprint of a stand-in body with these mesh arrays and piezoelectric constants ``e``."""
    from types import SimpleNamespace

    from cvxcontact.physics.fingerprint import geometry_fingerprint

    mesh = SimpleNamespace(points=points, cells=cells, tags=("a",), boundary=lambda tag: np.array([[0, 1]]), dim=2)
    material = SimpleNamespace(c=np.eye(3), e=e, kappa=None)
    roles = {"clamped": [], "grounded": [], "potential": {}, "contact": None, "roller": [], "floating": {},
             "displacement": {}}
    roles.update(parts)
    return geometry_fingerprint(SimpleNamespace(mesh=mesh, material=material, **roles))


def test_fingerprints_read_the_values_and_shapes_not_the_layout():
    """The SHA-256 over the arrays' bytes: a strided or Fortran-ordered array is hashed as its values (the same
    fingerprint as a contiguous copy), the same bytes in another shape or dtype are other arrays, and an empty
    array is hashed (before: memoryview.cast refused a (0, k) array with a TypeError)."""
    rng = np.random.default_rng(3)
    wide = rng.standard_normal((6, 4))
    points, cells = wide[:, ::2], np.array([[0, 1, 2], [1, 2, 3]])
    base = _fingerprint_of(np.ascontiguousarray(points), cells)
    assert _fingerprint_of(points, cells) == base                                     # a strided view
    assert _fingerprint_of(np.asfortranarray(points), np.asfortranarray(cells)) == base
    assert _fingerprint_of(points.astype(np.float32).astype(np.float64), cells) != base   # other values
    assert _fingerprint_of(points.reshape(4, 3), cells) != base                         # the same bytes, other shape
    assert _fingerprint_of(points, cells.T.copy().reshape(2, 3)) != base
    assert _fingerprint_of(points, cells.astype(np.int32)) == base                      # the same integers
    assert _fingerprint_of(points, cells, e=np.zeros((3, 0))) != _fingerprint_of(points, cells, e=np.zeros((0, 3)))
    assert _fingerprint_of(points, cells, e=np.zeros((3, 0))) != base
    assert _fingerprint_of(points, cells, clamped=["a"]) != base
