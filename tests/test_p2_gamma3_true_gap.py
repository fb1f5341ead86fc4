"""P2 "gamma3" against a curved rigid obstacle's own gap (docs/formulation.md §8, "Rigid obstacles"): the
everywhere condition holds against the obstacle's true distance, not the P2 interpolant of it (which dips below
a sphere between the nodes and used to press a merely touching sphere into the block with 5.3e6 N)."""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.contact.quadratic3d import p2_shape
from cvxcontact.contact.truegap import simplex_grid
from cvxcontact.fem.space import space

ALU = cc.materials.isotropic(E=70e9, nu=0.33)
R = 0.5


def scene(n, gap=0.0, force=None):
    """A clamped aluminium box (1 x 1 x 0.5 m, n x n x n/2 cells) under a sphere of radius R over its centre:
    fixed at ``gap`` (m, < 0: an overlap) above the top, or pressed down by ``force`` (N, guided along z)."""
    mesh = cc.box(x=(-.5, .5), y=(-.5, .5), z=(-.5, 0), nx=n, ny=n, nz=max(n // 2, 1))
    body = cc.Body(mesh, ALU, clamped="bottom", contact="top", name="block")
    ball = cc.Rigid.sphere((0, 0, R + gap), R, force=None if force is None else (0, 0, -force),
                           guided=None if force is None else (0, 0, 1))
    return cc.Scene(body, contacts=[cc.Contact(body, "top", ball)])


def solve(scene, condition="gamma3", degree=2, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")                    # no warning on these scenes
        return cc.solve(scene, condition, degree=degree, **kw)


def true_slack(sc, sol, center_z, samples=200, seed=0):
    """min over ``samples`` random points (plus the P2 nodes) of every constrained face of g(x) - u(x).nu, the
    sphere's vertical distance in closed form (centre (0, 0, ``center_z``)) and u from the block's own P2 face
    functions at the point: independent of the package's gap and X_h."""
    itf = space(2, 3).contact(sc, "sigma1", cc.Signorini()).interface
    trace = itf.traces[0]
    faces = np.asarray(trace.faces)
    x = np.asarray(trace.x)
    reach = (x ** 2).sum(axis=1) < R ** 2
    faces = faces[reach[faces].all(axis=1)]                  # the faces all of whose P2 nodes reach the sphere
    rng = np.random.default_rng(seed)
    L = rng.dirichlet(np.ones(3), samples)
    L = np.concatenate([L, simplex_grid(2)])
    p = np.einsum("pk,fkd->fpd", L, x[faces[:, :3]]).reshape(-1, 2)            # in-plane points (x, y)
    u = np.einsum("pk,fkd->fpd", p2_shape(L), sol.u[0][np.asarray(trace.nodes)[faces]]).reshape(-1, 3)
    g = center_z - np.sqrt(R ** 2 - (p ** 2).sum(axis=1))                      # the top face is z = 0
    return float((g - u[:, 2]).min())


@pytest.mark.parametrize("n", [4, 8])
def test_a_touching_sphere_carries_no_force(n):
    # before: 5.3e6 N (n = 4) and 3.0e4 N (n = 8), max|u| 5e-4 m, ok True (the interpolant penetrated the sphere)
    p2 = solve(scene(n))
    for ref in (solve(scene(n), degree=1), solve(scene(n), "sigma1")):       # P1 and the P2 nodal condition
        assert ref.ok and np.all(ref.obstacles[0].force == 0) and np.all(ref.u[0] == 0)
    assert p2.ok and np.all(p2.obstacles[0].force == 0) and np.all(p2.u[0] == 0)


@pytest.mark.parametrize("method", ["condensed", "full"])
def test_a_fixed_sphere_pressed_in_holds_everywhere_against_its_own_surface(method):
    d = 1e-4
    sol = solve(scene(4, gap=-d), method=method)
    assert sol.ok and sol.polished and sol.info.finish == "accumulated cuts"
    r = sol.residuals()
    assert r["feasibility"] < 1e-12                                            # measured 0
    # the independent sampled check: 200 random points of every face, the sphere in closed form
    assert true_slack(scene(4, gap=-d), sol, R - d) >= -1e-12 * d             # measured min 0 to -3e-20 m


def test_a_pressed_sphere_goes_down_and_its_force_is_the_load():
    # before: pressed by 1e5 N, the sphere rose by 4.5e-4 m (the interpolant's phantom penetration pushed it up)
    taus = []
    for F in (1e4, 1e5, 1e6):
        sol = solve(scene(4, force=F))
        assert sol.ok and sol.polished
        o = sol.obstacles[0]
        assert abs(o.force[2] + F) < 1e-9 * F                                # measured 0 to 1e-8 N
        taus.append(o.translation[2])
        assert true_slack(scene(4, force=F), sol, R + o.translation[2]) >= -1e-12 * abs(o.translation[2])
    taus = np.array(taus)
    assert np.all(taus < 0) and np.all(np.diff(taus) < 0), taus               # measured -1.1e-6, -1.1e-5, -1.1e-4


def test_refinement_converges_to_the_contact_of_the_sphere():
    # a fixed sphere pressed in by 1e-4 m: the force on n = 2, 4, 8 cells per edge approaches a limit
    forces = [solve(scene(n, gap=-1e-4)).obstacles[0].force[2] for n in (2, 4, 8)]
    steps = np.abs(np.diff(forces))
    assert steps[1] < 0.5 * steps[0], forces
