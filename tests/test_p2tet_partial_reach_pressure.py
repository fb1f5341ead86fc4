"""The Signorini pressure read back (lambda_h) against obstacles that reach a P2 (10-node) tetrahedral contact part
only in part (contact/quadratic3d.QuadraticSurface._partial_mass, .multiplier; docs/formulation.md §15).

A steel block on [0, 1]^2 x [0, H] (3 x 3 x 1 cells of six tetrahedra, rollers on its sides) pushed down by DELTA
onto two flat obstacles that together are the plane z = 0, each reaching a complementary set of the bottom's P2 nodes:
split at x = 0.4 (the faces 1/3 < x < 2/3 reached in part), at x = 0.15 h (the vertices at x = 0 on no wholly
reached face: "lone"), or along an oblique line across the faces' diagonals. Every node is held by one obstacle, so
the answer is uniaxial strain: u_z = -DELTA z / H, the pressure p = c33 DELTA / H, each node's force p times its
consistent load (0 at a vertex, A/3 per triangle of a midpoint's edge, by hand: reach_scenes.p2_loads). Before,
lambda_h solved M lambda = r with the P2 mass restricted to each obstacle's nodes, which drops the faces' couplings
to the other obstacle's nodes: it read 0.44 ... 1.54 p (x = 0.4), 0 ... 1.875 p (x = 0.15 h: 0 at the lone
vertices, whose forces are 0), 0.031 ... 1.875 p (the oblique line 0.3 x + y = 0.93; 0.38 ... 1.56 p on 6 cells,
0.39 ... 1.62 p on 12), the error not falling with h (3, 6 and 12 cells), its forces and u right.
"""

import functools

import numpy as np
import pytest
from friction_scenes import DIAGONAL3, uniform_layer3d
from hex_scenes import DELTA, SIDES, STEEL, H
from reach_scenes import OBLIQUE, half, p2_loads, strip, triangles_at

import cvxcontact as cc
from cvxcontact.fem.space import space
from cvxcontact.solution.slipestimate import friction_of

pytestmark = [pytest.mark.numerics,
              pytest.mark.filterwarnings("ignore::cvxcontact.ResolutionWarning")]   # coarse: 2, 3 faces span a zone

C33 = float(STEEL.tensors(3)[0][2, 2])
P = C33 * DELTA / H                         # the closed form's pressure (Pa)
A = 1.0 / 18                                # the faces' triangles (m^2)
SPLITS = {"x = 0.4": (strip(-1.0, 0.4), strip(0.4, 2.0)),
          "x = 0.15 h": (strip(-1.0, 0.05), strip(0.05, 2.0)),
          "oblique": (half(*OBLIQUE[1], True), half(*OBLIQUE[1], False))}


def _scene(obstacles, n=3):
    body = cc.Body(cc.box(nx=n, ny=n, nz=1, z=(0.0, H)), STEEL, roller=SIDES,
                   displacement={"top": (None, None, -DELTA)}, contact="bottom")
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", o) for o in obstacles])


@functools.cache
def _solved(split):
    sol = cc.solve(_scene(SPLITS[split]), "sigma1", degree=2)
    assert sol.ok
    return sol


@pytest.mark.parametrize("split", list(SPLITS))
def test_a_uniform_push_on_complementary_obstacles_reads_the_closed_form_at_every_row(split):
    """u and the forces the closed form (they were before), lambda = p at every row of both obstacles (before
    0.44 ... 1.54 p, 0 ... 1.875 p, 0.031 ... 1.875 p: module docstring)."""
    sol = _solved(split)
    for u, x in zip(sol.u, sol.points):
        assert np.abs(u[:, 2] + DELTA * x[:, 2] / H).max() <= 1e-10 * DELTA                 # measured 4.2e-16
    assert sum(len(c.points) for c in sol.contacts) == 49                   # every node of the bottom, once
    for c in sol.contacts:
        assert np.abs(np.asarray(c.force) - P * p2_loads(c.points)).max() <= 1e-10 * P * A   # measured 5.2e-16 P A
        assert np.abs(np.asarray(c.lam) - P).max() <= 1e-10 * P                              # measured 7.4e-15 P


def test_one_obstacle_keeps_the_total_force_by_the_consistent_loads():
    """One obstacle under x < 0.4 (the faces 1/3 < x < 2/3 reached in part, no lone vertex): the read-back's row
    sums are the consistent loads over the whole part (by hand), so sum_a load_a lambda_a = sum_a r_a."""
    sol = cc.solve(_scene((strip(-1.0, 0.4),)), "sigma1", degree=2)
    assert sol.ok
    c = sol.contacts[0]
    force, lam = np.asarray(c.force), np.asarray(c.lam)
    assert force.sum() > 0.3 * P                                            # measured 0.42 P
    assert abs(p2_loads(c.points) @ lam - force.sum()) <= 1e-12 * force.sum()         # measured 2.1e-16


def _pair(obstacle):
    lines = space(2, "tetra").contact(_scene((obstacle,)), "sigma1", cc.Signorini())
    return lines.interface


def test_lone_vertices_tied_to_their_midpoints_read_a_uniform_load_as_itself():
    """An obstacle under x < 0.05 reaches only the 4 vertices and 3 midpoints at x = 0, every face at them in part:
    the consistent loads of p over the whole part there (0 at the vertices, p A/3 at the midpoints) read p at all 7
    (the lone vertices' mass rows alone are a graph Laplacian among them; tied to the midpoints next to them).
    Before, the restricted mass read 0 at the vertices and 1.875 p at the midpoints."""
    pair = _pair(strip(-1.0, 0.05))
    x = np.asarray(pair.points)
    assert len(x) == 7 and np.abs(x[:, 0]).max() == 0.0
    loads = p2_loads(x)
    assert (loads[np.rint(x[:, 1] * 6).astype(int) % 2 == 0] == 0).all()
    assert np.abs(pair.multiplier(P * loads) - P).max() <= 1e-12 * P                   # measured 3.5e-16 P


def test_a_lone_vertex_with_no_midpoint_reads_its_force_over_its_red_hat():
    """An obstacle that reaches the corner vertex (0, 0) alone: no midpoint to tie it to, it reads its force over
    the law's red hat, A/12 per triangle at it (by hand), not a singular solve."""
    pair = _pair(cc.Rigid("corner", lambda x, nu: np.where((x[:, 0] < 0.05) & (x[:, 1] < 0.05), x[:, 2], np.inf),
                          "the plane z = 0 under x, y < 0.05",
                          sensitivity=lambda x, nu: np.tile([0.0, 0.0, 1.0], (len(x), 1)), dim=3))
    assert pair.size == 1
    w = triangles_at(0.0, 0.0) * A / 12
    assert abs(pair.multiplier(np.array([2.0]))[0] - 2.0 / w) <= 1e-12 * 2.0 / w        # measured 0


# p / P along the part (x, y in m) and the split: the oblique line's p has a gradient sqrt(5) P / m
LINEAR = {"x = 0.4": (lambda x: 1.0 + x[:, 0], (strip(-1.0, 0.4), strip(0.4, 2.0))),
          "oblique": (lambda x: 1.0 + x[:, 0] + 2.0 * x[:, 1], (half(*OBLIQUE[1], True), half(*OBLIQUE[1], False)))}


@pytest.mark.parametrize("split", list(LINEAR))
def test_a_linear_pressure_is_read_to_first_order_next_to_where_the_reach_stops(split):
    """The consistent loads of a linear pressure p over the whole part (P2 face mass times p at its nodes: what
    the two obstacles' forces are when the contact carries p), each obstacle given its own nodes' rows, on 3, 6, 12
    cells a side: lambda_h reads p to O(h), the error on the rows next to where the reach stops (the couplings to
    the other obstacle's nodes lumped onto the diagonal are exact for a constant, first order for a slope; the P2
    mass of a part reached at every node reads p to rounding). Measured max |lambda - p| / P: x = 0.4, p = P (1 +
    x): 0.314, 0.150, 0.0746 (times nx 0.94, 0.90, 0.90; 0.0373 on 24); oblique, p = P (1 + x + 2 y): 0.795, 0.463,
    0.201 (times nx 2.39, 2.78, 2.41). Before, the restricted mass read it to O(1): 0.90, 0.82, 0.75 and 2.6,
    1.8, 1.9. (A rate: the bounds are the rate's, rounding is 1e-15 of them.)"""
    field, obstacles = LINEAR[split]
    errors = []
    for n in (3, 6, 12):
        stack = space(2, "tetra").contact(_scene(obstacles, n), "sigma1", cc.Signorini()).interface
        error = 0.0
        for pair in stack.interfaces:
            t, hit = pair.traces[0], np.asarray(pair.reach)
            p = P * field(np.asarray(t.points))
            error = max(error, np.abs(pair.multiplier((t.mass @ p)[hit]) - p[hit]).max() / P)
        errors.append(error * n)
    assert max(errors) <= 4.0                                    # measured 0.94 (x = 0.4), 2.78 (oblique)
    assert errors[2] / 12 <= errors[0] / 3 / 3                   # measured 4.2, 4.0 times smaller on 12 than on 3


def test_the_shear_of_a_stuck_uniform_layer_is_read_at_every_row_of_both_obstacles():
    """3D P2 friction's t_h against complementary obstacles (split at x = 0.4: friction_scenes.uniform_layer3d
    on 3 x 3 cells, Tresca 2 p, tau = 0.2 p, stuck) is read by the same matrix as lambda_h (``friction_of``,
    ``QuadraticTrace.friction_fields``): the traction on the body is -tau along the shear's diagonal at every
    row (its equilibrium with the top's tau), lambda_h = p. Measured 5.8e-14 tau, 1.2e-14 p. Before, 0.49 tau
    off on the obstacle under x < 0.4, 0.29 tau on the other."""
    tau, p = 0.2e7, 1e7                                          # friction_scenes.P
    sol = cc.solve(uniform_layer3d(tau, cc.Tresca(2 * p), n=3, obstacles=(strip(-1.0, 0.4), strip(0.4, 2.0))),
                   degree=2, condition="sigma1")
    assert sol.ok
    assert sum(len(c.points) for c in sol.contacts) == 49
    for i, c in enumerate(sol.contacts):
        assert np.abs(friction_of(sol, i).t + tau * DIAGONAL3).max() <= 1e-10 * tau      # measured 5.8e-14 tau
        assert np.abs(np.asarray(c.lam) - p).max() <= 1e-10 * p                          # measured 1.2e-14 p
