"""Independent checks of friction with P2 elements under "gamma3" (the cones of every element of X_h, a friction row at
each of its nodes; tests/test_friction_p2_gamma3.py holds the closed forms).

Each answer is checked from its fields alone, not from the package's rows or read-back checks: the P2 trace of the
block's bottom sampled on every segment against the obstacle's own gap (a plane, or a disk's closed-form distance
|x - c| - R along d = (c - x) / |c - x|), the friction capacities from Simpson's weights of the bottom nodes
(Tresca) or mu times the normal nodal forces (Coulomb), the slip from the block's nodal displacements along the
obstacle's tangent, the balance of the applied load. A finish that is declined must say so (info.declined, a
ResidualWarning); bodies that do not touch each other must have the answers they have alone; and Coulomb's
capacity mu r_a (r = B^T beta the cones' nodal force) is well defined only where r is unique: in 2D the merged
P2 line's jump map has full rank (checked), on non-matching 3D faces it has not, and Coulomb between two 3D bodies
under the cones is refused.
"""

import warnings

import numpy as np
import pytest
import scipy.sparse as sp
from friction_scenes import P, pair2d, positive_forces, steel, tilted_key
from reference_problems import simpson
from scipy.optimize import minimize_scalar

import cvxcontact as cc
from cvxcontact.discrete import build_problem
from cvxcontact.fem.space import space

P2 = {"condition": "gamma3", "degree": 2}
LAGRANGE = (lambda t: 2 * (t - 0.5) * (t - 1), lambda t: -4 * t * (t - 1), lambda t: 2 * t * (t - 0.5))


def _bottom(sol):
    """The block's nodes on y = 0 sorted by x (vertex, midpoint, vertex, ...) and their displacements."""
    x, u = sol.points[0], sol.u[0]
    on = np.flatnonzero(np.abs(x[:, 1]) < 1e-12)
    on = on[np.argsort(x[on, 0])]
    return x[on], u[on]


def _simpson(x):
    """Simpson's weights of the P2 line through the sorted nodes ``x`` (vertex, midpoint, vertex, ...; (n, 2))."""
    return simpson(np.asarray(x)[0::2, 0])


def _positive(r):
    """Coulomb's normal nodal forces of the sorted P2 line's nodal forces ``r`` (vertex, midpoint, vertex, ...)."""
    return positive_forces(r, [range(a, a + 3) for a in range(0, len(r) - 2, 2)])


def _largest_slack(x, rows, gap, samples=2001):
    """max over every segment of the P2 interpolant of the nodal ``rows`` minus ``gap`` at the point: a grid of
    ``samples`` points per segment, then a bounded scalar search around the grid's best point."""
    t = np.linspace(0.0, 1.0, samples)
    best = -np.inf
    for s in range((len(x) - 1) // 2):
        a = 2 * s + np.arange(3)

        def slack(t, a=a):
            L = [f(t) for f in LAGRANGE]
            return sum(Lk * rows[k] for Lk, k in zip(L, a)) - gap(sum(Lk * x[k, 0] for Lk, k in zip(L, a)))

        k = int(np.argmax(slack(t)))
        found = minimize_scalar(lambda z: -slack(z), bounds=(t[max(k - 1, 0)], t[min(k + 1, samples - 1)]),
                                method="bounded", options={"xatol": 1e-14})
        best = max(best, float(slack(t[k])), -float(found.fun))
    return best


def _friction_law(sol, capacity, slip, tol):
    """|f_a| <= c_a at every node; where it slips (|s_a| > tol U) f_a = -c_a sign(s_a); where |f_a| < c_a it sticks
    (a capacity above 1e-6 of the largest: beside a lifted part r_a is rounding): the largest violation of each,
    relative to max c and U."""
    f, U = sol.contact.shear_force, np.abs(sol.u[0]).max()
    c = capacity.max()
    slips = np.abs(slip) > tol * U
    inside = (np.abs(f) < capacity * (1 - 1e-6)) & (capacity > 1e-6 * c)      # capacities above rounding
    return (max(0.0, float((np.abs(f) - capacity).max())) / c,
            float(np.abs(f[slips] + capacity[slips] * np.sign(slip[slips])).max(initial=0.0)) / c,
            float(np.abs(slip[inside]).max(initial=0.0)) / U)


@pytest.mark.numerics
@pytest.mark.parametrize("g", [1e3, 1e7])
def test_a_block_pressed_into_a_disk_touches_it_at_points_and_follows_tresca_law(g):
    """The clamped block of tests/test_friction_p2_gamma3.py pressed 1e-4 m into a disk (R = 1 m), its contact a
    patch inside the two elements beside x = 0 (the node there is 6.6e-3 of the displacements off the disk):
    finished at cut points. Sampled, the P2 slack against the disk's own distance reaches 0 (measured 7e-13 and
    1.1e-12 of the displacements, at t = 0.009, 0.991 of those elements) and nowhere exceeds it; Tresca's law holds with the
    Simpson capacities along the disk's tangent (measured 1.7e-16); sliding (g = 1e3 Pa: 16 of 17 nodes slip)
    and sticking (g = 1e7 Pa: 4 slip)."""
    radius = 1.0 + 1e-4
    m = cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=8, ny=4)
    body = cc.Body(m, steel(), contact="bottom", clamped="top")
    disk = cc.Rigid.circle(center=(0.0, -1.0), radius=radius)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cc.ResidualWarning)
        sol = cc.solve(cc.Scene(body, contacts=[cc.Contact(body, "bottom", disk, law=cc.Tresca(g))]), **P2)
    assert sol.ok and sol.polished, sol.info.declined
    x, u = _bottom(sol)
    U = np.abs(sol.u[0]).max()
    d = np.array([0.0, -1.0]) - x
    d /= np.linalg.norm(d, axis=1)[:, None]                     # towards the disk's closest point
    slack = _largest_slack(x, (u * d).sum(axis=1), lambda s: np.hypot(s, 1.0) - radius) / U
    assert -1e-9 <= slack <= 1e-9                               # measured 7.0e-13, 1.1e-12: touches, never beyond
    tangent = np.column_stack([-d[:, 1], d[:, 0]])              # the disk's tangent, (1, 0) at x = 0
    slip = (u * tangent).sum(axis=1)
    assert np.abs(sol.contact.slip - slip).max() <= 1e-12 * U
    excess, sliding, stuck = _friction_law(sol, g * _simpson(x), slip, 1e-8)
    assert max(excess, sliding) <= 1e-10 and stuck <= 1e-10        # measured <= 1.7e-16, 1.7e-16, 8.4e-18
    assert (sol.contact.force[np.abs(x[:, 0]) > 0.13] == 0).all()   # no force beyond the two elements


@pytest.mark.numerics
@pytest.mark.parametrize("law", [cc.Tresca(0.6 * P), cc.Coulomb(0.6)], ids=["tresca", "coulomb"])
@pytest.mark.parametrize("nx", [7, 8])
def test_a_tilted_free_block_balances_its_load_and_a_declined_finish_says_so(law, nx, shared):
    """Finished or not (measured: Tresca finished at nx = 7, the equal of "sigma1" to 3.4e-14, and at nx = 8 (its cut
    rounds' cycle followed by Murty's rule); Coulomb finished at nx = 7 and 8, its capacities those of the nodal
    forces made non-negative by patches, :func:`_positive`, as reported by its thresholds), the answer
    balances the load exactly (the floor holds p L and 0.3 p L),
    its P2 trace never dips below the floor beyond the interior point's rounding (measured at most 1e-15 of the
    displacements, exactly 0 where finished), sum r_a q_a = beta . b vanishes (complementarity) and the friction
    capacities bound the shear. A declined finish is named in info.declined and warned."""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        sol = shared(*tilted_key(law, nx))   # friction_scenes.tilted(law, nx), q = 0.3; test_friction_p2_cuts too
    warned = [w for w in record if issubclass(w.category, cc.ResidualWarning)]
    assert sol.polished == (sol.info.declined is None) and bool(warned) == (not sol.polished)
    c = sol.contact
    x, u = _bottom(sol)
    U = np.abs(sol.u[0]).max()
    assert abs(c.force.sum() / P - 1) <= 1e-10 and abs(c.shear_force.sum() / (-0.3 * P) - 1) <= 1e-10
    assert _largest_slack(x, -u[:, 1], np.zeros_like) / U <= 1e-9
    assert abs(c.force @ (-u[:, 1])) <= 1e-9 * np.abs(c.force).sum() * U   # measured 1e-15 (flat floor: g_h = 0)
    capacity = 0.6 * P * _simpson(x)
    if law.friction.pressure_dependent:    # Coulomb: the thresholds mu p_a reported, on Simpson's weights
        capacity = c.threshold * _simpson(x)
        assert np.abs(capacity - 0.6 * _positive(c.force)).max() <= 1e-12 * capacity.max()   # measured <= 8.1e-17
    excess, sliding, stuck = _friction_law(sol, capacity, u[:, 0], 1e-5)
    assert excess <= 1e-10 and sliding <= 1e-6 and stuck <= 1e-10   # measured at most 1.2e-17, 1.2e-9, 2.3e-14
    if sol.polished:
        assert stuck <= 1e-12 and max(excess, sliding) <= 1e-12


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "gamma3"])
def test_two_bodies_apart_have_their_answers_alone(condition):
    """Two clamped blocks pressed into two disks, far apart, one pair under "gamma3" with Tresca, the other under
    ``condition`` with Tresca (its nodal rows then degenerate cones beside the cones): each body's answer is the
    one it has alone (measured at most 4.1e-15 and 5.7e-15 of the displacements), all finished."""
    def block(x0, name):
        m = cc.rectangle(x=(x0 - 0.5, x0 + 0.5), y=(0.0, 0.5), nx=8, ny=4)
        return cc.Body(m, steel(), contact="bottom", clamped="top", name=name)

    a, b = block(0.0, "a"), block(3.0, "b")
    pa = cc.Contact(a, "bottom", cc.Rigid.circle(center=(0.0, -1.0), radius=1.0 + 1e-4), law=cc.Tresca(1e4))
    pb = cc.Contact(b, "bottom", cc.Rigid.circle(center=(3.0, -1.0), radius=1.0 + 1e-4), law=cc.Tresca(1e4),
                    condition=condition)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        both = cc.solve(cc.Scene(a, b, contacts=[pa, pb]), degree=2)
        alone = [cc.solve(cc.Scene(k, contacts=[p]), degree=2) for k, p in ((a, pa), (b, pb))]
    assert both.ok and both.polished and all(s.polished for s in alone), both.info.declined
    for k, s in enumerate(alone):
        assert np.abs(both.u[k] - s.u[0]).max() <= 1e-10 * np.abs(s.u[0]).max()


def _jump_rank(scene, cell):
    """(nodes of X_h, rank of the normal jump map from the free displacements to them)."""
    problem = build_problem(scene, space(2, cell), "gamma3", None)
    J = sp.hstack([b.jump for b in problem.blocks]).toarray()
    s = np.linalg.svd(J, compute_uv=False)
    return J.shape[0], int((s > 1e-10 * s[0]).sum())


def _renumbered(mesh, seed):
    """``mesh`` (a TetMesh) with its nodes in a random order: the same body."""
    order = np.random.default_rng(seed).permutation(len(mesh.points))
    new = np.empty_like(order)
    new[order] = np.arange(len(order))
    return cc.TetMesh(mesh.points[order], new[np.asarray(mesh.tets)],
                      {t: new[np.asarray(mesh.boundary(t))] for t in mesh.tags})


def _layers3d(law, seed=None):
    """A 2 x 2 x 1 layer under (0.2 p, 0, -p) on its top on a wider clamped 3 x 3 x 1 one: non-matching faces."""
    a = cc.Body(cc.box(nx=2, ny=2, nz=1), steel(), contact="bottom", traction={"top": (0.2 * P, 0.0, -P)},
                name="upper")
    lower = cc.box(x=(-0.25, 1.25), y=(-0.25, 1.25), nx=3, ny=3, nz=1)
    lower = lower.with_points(lower.points - [0.0, 0.0, 1.0])
    lower = lower if seed is None else _renumbered(lower, seed)
    b = cc.Body(lower, steel(), contact="top", clamped="bottom", name="lower")
    return cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=law)])


def test_the_cones_nodal_force_is_unique_on_a_2d_pair_not_on_non_matching_3d_faces():
    """r = B^T beta enters the equilibrium through the jump map J^T: it is unique where J has full rank on the
    nodes of X_h. The merged P2 line of two non-matching 2D traces: full rank (27 nodes), so Coulomb's mu r_a is
    well defined in 2D; the overlay of non-matching 3D faces: rank 59 of 81 nodes (22 directions of r that no
    displacement sees)."""
    n, rank = _jump_rank(pair2d(cc.Tresca(0.03 * P), condition="gamma3"), "triangle")
    assert rank == n
    n, rank = _jump_rank(_layers3d(cc.Tresca(P)), "tetra")
    assert (n, rank) == (81, 59)


def test_coulomb_on_non_matching_3d_faces_is_refused_where_its_capacities_would_depend_on_the_representation():
    """Where r is not unique (above), Coulomb's capacities mu r_a would depend on the representation the solver lands
    on (measured before the refusal: 17 of 81 r_a < 0 under a uniform pressure, the fixed point wandering at 5e-6 to
    6e-5 for 50 iterations, the upper layer's answer moving by 1.6e-7 of its displacements when the lower mesh is
    numbered otherwise, both declined): refused, whatever the numbering."""
    for seed in (None, 1):
        with pytest.raises(cc.UnsupportedError, match="not unique"):
            cc.solve(_layers3d(cc.Coulomb(0.5), seed), **P2)


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "gamma3"])
def test_a_block_dragged_over_a_disk_carries_at_most_mu_times_its_normal_force(condition):
    """A block (6 x 4 cells) whose top is moved by (1e-4, -4e-5) m over a disk (R = 500 m), Coulomb mu = 0.2:
    every node slides, so the friction force is mu times the normal force at every node, and in total at most mu N
    (Coulomb's law summed). "sigma1": mu N to rounding (nodal forces >= 0). The cones: r_a < 0 at the nodes beside
    the contact's ends (a P2 node's share of a force between nodes; their sum -0.117 N here), so capacities
    mu max(r_a, 0) carried 1.115 mu N; each negative r_a taken from the positive forces of its patch (sums kept,
    docs/howto/friction.md, :func:`_positive` written here node by node) they carry mu N to rounding, every node
    at its capacity."""
    m = cc.rectangle(x=(-0.5, 0.5), y=(0.0, 0.5), nx=6, ny=4)
    b = cc.Body(m, steel(nu=0.0), contact="bottom", displacement={"top": (1e-4, -4e-5)})
    disk = cc.Rigid.circle(center=(0.0, -500.0), radius=500.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sol = cc.solve(cc.Scene(b, contacts=[cc.Contact(b, "bottom", disk, law=cc.Coulomb(0.2))]), condition=condition,
                       degree=2)
    c = sol.contact
    assert sol.ok and sol.polished, sol.info.declined
    assert (np.abs(c.slip) > 1e-3 * np.abs(sol.u[0]).max()).all()
    assert np.abs(c.shear_force).sum() <= 0.2 * c.force.sum() * (1 + 1e-6)   # measured 1, 1 + 2.9e-14
    capacity = 0.2 * _positive(c.force)                                      # = 0.2 r_a under "sigma1" (r >= 0)
    assert np.abs(c.threshold * _simpson(_bottom(sol)[0]) - capacity).max() <= 1e-12 * capacity.max()  # <= 1.3e-16
    assert np.abs(np.abs(c.shear_force) - capacity).max() <= 1e-10 * capacity.max()   # measured 2.4e-16, 4.8e-13
