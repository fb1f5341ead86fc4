"""A law on the P2 rows of a partial overlap under a pressure that varies along it (docs/formulation.md §10, "P2";
docs/refusals.md row 4): where the overlap's end cuts a segment of the constrained trace, the one node outside with
a share gives it to its nearest row, half a segment inward. A constant is integrated exactly; a linear function is
not, and the bias has a closed form, built here from the mesh's abscissae alone (not from the package):

    the overlap's end at t half-pieces past a node of the trace (0 < t < 1, the half-pieces h/2 long), the node
    outside the overlap has the share s = (h/2) (1 - t)^2 / 2 of its hat over the overlap and moves it by h/2, so
    sum_i w_i f(x_i) - int f = s (h/2) f' = f' h^2 (1 - t)^2 / 8 (f linear, the end at the start of the overlap)

(the other parts of the rule, Simpson's and the red refinement's hats, integrate a linear function exactly): the law's
total force and moment are biased by O(h^2), half a segment's strip moved inward, and tend to the exact ones at rate 2.
"""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.contact.quadratic import quadratic_interface
from cvxcontact.geometry.quadratic import P2Nodes

E1, E2, H1, H2 = 70e9, 200e9, 0.5, 0.3        # Pa, m: stiff blocks, a soft law (k C ~ 1e-7)
DELTA = 1e-4                                   # m, the interference at s = 0


def _blocks(lo, hi, n1, n2, gap=-DELTA, law=None, condition=None, shear=None):
    """An upper block on [0, 1] (n1 cells) over a lower one on [lo, hi] (n2 cells); the upper one clamped on its
    top, or held by the contact only under ``shear`` = (q, -p) on its top."""
    mat1, mat2 = cc.materials.isotropic(E=E1, nu=0.0), cc.materials.isotropic(E=E2, nu=0.0)
    held = {"traction": {"top": shear}} if shear is not None else {"clamped": ["top"]}
    b1 = cc.Body(cc.rectangle(x=(0, 1), y=(0, H1), nx=n1, ny=2), mat1, contact="bottom", **held)
    b2 = cc.Body(cc.rectangle(x=(lo, hi), y=(-H2, 0), nx=n2, ny=2), mat2, clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", gap=gap, law=law, condition=condition)])


def _bias(h, t):
    """Sum of the rows' weights times f minus the integral of f, for f(x) = x, the overlap's start t half-pieces past
    a node of the upper trace (cells h): the outside node's share (h/2)(1 - t)^2/2 moved by h/2 inward."""
    return (h / 2) * (1 - t) ** 2 / 2 * (h / 2)


@pytest.mark.parametrize("t", [0.1, 0.5, 0.9, 1.3, 1.7])
def test_a_linear_pressure_over_a_cut_end_is_biased_by_the_moved_share(t):
    """The lower block on [lo, 1], lo t half-pieces past the upper trace's vertex h (t < 1: between the vertex h
    and the midpoint 1.5 h; t > 1: between that midpoint and the vertex 2 h), under "sigma1": the weights integrate
    1 exactly and x with the closed-form bias (module docstring) to rounding (measured <= 2.2e-16 m, 1.5e-16 m^2;
    bound 1e-13), at every
    mesh; the bias is h^2 (1 - t)^2 / 16, so the relative error of a linear pressure's force and moment tends to 0
    at rate 2. The mirrored overlap [0, 1 - lo] has the opposite bias (its end the far one)."""
    for n in (4, 8, 16, 32, 64):
        h = 1.0 / n
        lo = h + t * h / 2
        frac = t if t < 1 else t - 1
        for a, b, sign in ((lo, 1.0, 1.0), (0.0, 1.0 - lo, -1.0)):
            scene = _blocks(a, b, n, 3)
            itf = quadratic_interface(scene, [P2Nodes(body.mesh) for body in scene.bodies])
            w, x = itf.weights("sigma1"), np.asarray(itf.sigma_x[0])
            assert (w > 0).all()
            assert abs(w.sum() - (b - a)) <= 1e-13
            assert abs(w @ x - (b ** 2 - a ** 2) / 2 - sign * _bias(h, frac)) <= 1e-13


def _rule(f, antiderivative, lo, h):
    """What the rows under "sigma1" integrate of ``f`` over [lo, 1] with lo in (h, 1.5 h) (the upper trace's segment
    [h, 2 h] cut between its vertex h and its midpoint; every other segment inside): Simpson's on [2 h, 1] (exact for
    a quadratic), the red refinement's P1 hats on [lo, 2 h] (the integral of f's piecewise-linear interpolant through
    h, 1.5 h, 2 h), and the share s = (h/2)(1 - t)^2/2 of the node h (outside) moved to 1.5 h."""
    a, m, b = h, 1.5 * h, 2 * h
    t = (lo - a) / (h / 2)
    interp = lambda x: f(a) + (f(m) - f(a)) * (x - a) / (m - a)
    cut = (m - lo) * interp((lo + m) / 2) + (b - m) * (f(m) + f(b)) / 2
    return antiderivative(1.0) - antiderivative(b) + cut + (h / 2) * (1 - t) ** 2 / 2 * (f(m) - f(a))


@pytest.mark.numerics
@pytest.mark.parametrize("condition", ["sigma1", "sigma2", "gamma3"])
def test_a_soft_law_on_a_tilted_gap_presses_its_integral_over_the_overlap(condition):
    """The interference DELTA (1 + 2 s) over the overlap [lo, 1], lo = 1.15 h (h = 1/8: the upper trace's segment
    [h, 2 h] cut at t = 0.3 half-pieces past its vertex h), through a law so soft (k = 1e4 Pa/m) that the blocks
    barely deform: the rows press k DELTA (1 + 2 x_i) with their weights. "sigma2" and "gamma3" sit on the lower
    trace's and the merged nodes, Simpson's on segments ending at the overlap's ends: the total force and moment are
    k times the integrals of the interference and of s times it (quadratic) over the overlap. "sigma1": what its rule
    integrates of them, in closed form (:func:`_rule`): 1.0e-3 above the force's integral (the moved share), 1.5e-3
    above the moment's (the share and the P1 hats on the cut segment). Measured under each condition: force and
    moment <= 8.7e-8 relative from these (the springs in series); bound 1e-5."""
    k, h = 1e4, 1 / 8
    lo = 1.15 * h
    pen = lambda s: DELTA * (1 + 2 * np.asarray(s))
    sol = cc.solve(_blocks(lo, 1.0, 8, 5, gap=lambda s: -pen(s)), condition, degree=2,
                   law=cc.NormalCompliance(stiffness=k))
    assert sol.ok
    x, f = np.asarray(sol.contact.x), np.asarray(sol.contact.force)
    Fp = lambda s: DELTA * (s + s ** 2)
    Fm = lambda s: DELTA * (s ** 2 / 2 + 2 * s ** 3 / 3)
    if condition == "sigma1":
        force, moment = k * _rule(pen, Fp, lo, h), k * _rule(lambda s: s * pen(s), Fm, lo, h)
    else:
        force, moment = k * (Fp(1.0) - Fp(lo)), k * (Fm(1.0) - Fm(lo))
    assert abs(f.sum() / force - 1) <= 1e-5
    assert abs(f @ x / moment - 1) <= 1e-5


@pytest.mark.numerics
def test_rows_beginning_at_a_vertex_count_the_overlap_before_it():
    """The lower block on [0.2, 1] under "sigma1": the upper trace's (cells of 0.25) first row is the vertex 0.25,
    but the overlap begins at 0.2. A soft law (k = 1e4 Pa/m) on the interference DELTA presses k DELTA over the whole
    overlap, 0.8 m, as under "sigma2" and "gamma3" (measured <= 8.4e-8: the springs; the rows' weights before
    row 4 was lifted summed to 0.75 m, leaving [0.2, 0.25] without force); and Tresca's capacity is g times 0.8 m:
    a net shear 2 % below it holds (shear forces balancing it to 3.5e-15 of g), 2 % above it is refused naming
    800000 N/m."""
    k = 1e4
    forces = {c: cc.solve(_blocks(0.2, 1.0, 4, 3), c, degree=2, law=cc.NormalCompliance(stiffness=k)).contact.force
              for c in ("sigma1", "sigma2", "gamma3")}
    for c, f in forces.items():
        assert abs(f.sum() / (k * DELTA * 0.8) - 1) <= 1e-5, c
    g, p = 1e6, 1e7
    sol = cc.solve(_blocks(0.2, 1.0, 4, 3, gap=0.0, law=cc.Tresca(g), condition="sigma1",
                           shear=(0.98 * 0.8 * g, -p)), degree=2)
    assert sol.ok and abs(sol.contact.shear_force.sum() + 0.98 * 0.8 * g) < 1e-9 * g
    with pytest.raises(cc.SceneError, match=r"exceeds the friction capacity 800000 N/m"):
        cc.solve(_blocks(0.2, 1.0, 4, 3, gap=0.0, law=cc.Tresca(g), condition="sigma1",
                         shear=(1.02 * 0.8 * g, -p)), degree=2)
