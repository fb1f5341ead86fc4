"""The steel box of tests/test_friction3d.py (a 1 m cube of 3 x 3 x 2 cells pressed on a rigid plane z = 0 by
p = 10 MPa on its top), where each scene is checked, shared with benchmarks/friction_finish.py and
benchmarks/friction_sides.py: the box sheared or pushed along a diagonal, on a stiffer box, with a side held along
one tangent, on a non-matching box, and the distance of two solutions. A fixtures module: the test modules do not
import each other.
"""

import numpy as np
import pytest
from friction_scenes import watched_p2

import cvxcontact as cc

P, E = 1e7, 200e9
FLOOR = cc.Rigid.plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
BOX = cc.box(nx=3, ny=3, nz=2)
THETA = 0.5
DIAGONAL = np.array([np.cos(THETA), np.sin(THETA)])


def steel(nu=0.3, scale=1.0):
    """Steel (E = 200 GPa times ``scale``, Poisson ratio ``nu``)."""
    return cc.materials.isotropic(E=E * scale, nu=nu)


def sheared(q, law, mesh=BOX, tied=False):
    """The box under (q_x, q_y, -p) on its top; ``tied``: frictionless, u_x = u_y = 0 on the contact faces."""
    if tied:
        mesh = cc.TetMesh(mesh.points, mesh.tets, {**{t: mesh.boundary(t) for t in mesh.tags},
                                                   "base": mesh.boundary("bottom")})
        b = cc.Body(mesh, steel(), contact="bottom", traction={"top": (q[0], q[1], -P)},
                    displacement={"base": (0.0, 0.0, None)})
        return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR)])
    b = cc.Body(mesh, steel(), contact="bottom", traction={"top": (q[0], q[1], -P)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def pushed(law, s=1e-4):
    """The nu = 0 box pushed by (s cos t, s sin t) on its left face, pressed by p."""
    b = cc.Body(BOX, steel(nu=0.0), contact="bottom", traction={"top": (0.0, 0.0, -P)},
                displacement={"left": (s * DIAGONAL[0], s * DIAGONAL[1], None)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def pair(law, stiffer, q):
    """The box on a box ``stiffer`` times stiffer, clamped at its bottom."""
    a = cc.Body(BOX, steel(), contact="bottom", traction={"top": (q[0], q[1], -P)}, name="top")
    b = cc.Body(BOX.with_points(BOX.points - [0.0, 0.0, 1.0]), steel(scale=stiffer), contact="top",
                clamped="bottom", name="below")
    return cc.Scene(a, b, contacts=[cc.Contact(a, "bottom", b, "top", law=law)])


def mirrored_box():
    """:data:`BOX` reflected about y = 1/2: its tetrahedra (and tagged faces) the mirror images of the first's, their
    vertices reordered to keep the orientation; the tags as they were (front and back swap places)."""
    return cc.TetMesh(BOX.points * [1.0, -1.0, 1.0] + [0.0, 1.0, 0.0], BOX.tets[:, [0, 2, 1, 3]],
                      {t: BOX.boundary(t)[:, ::-1] for t in BOX.tags})


def held_side(law, q=0.2 * P, nu=0.3, push=None, tied=False, mesh=BOX):
    """The box pressed on the plane, its left side held along x, sheared by (0, q) on its top; ``push``: its
    front side moved by (., push, .); ``tied``: frictionless, u_x = u_y = 0 on the contact faces; ``mesh``: the
    box's mesh (e.g. :func:`mirrored_box`)."""
    held = {"left": (0.0, None, None)}
    if tied:
        mesh = cc.TetMesh(mesh.points, mesh.tets, {**{t: mesh.boundary(t) for t in mesh.tags},
                                                   "base": mesh.boundary("bottom")})
        held["base"] = (0.0, 0.0, None)
    if push is not None:
        held["front"] = (None, push, None)
    b = cc.Body(mesh, steel(nu=nu), contact="bottom", traction={"top": (0.0, q, -P)}, displacement=held)
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=None if tied else law)])


def non_matching(law, q=0.2 * P * DIAGONAL, swap=False, nu=0.3, push=None):
    """The box (3 x 3 x 2 cells) on a clamped box of 4 x 4 x 2 cells under (q_x, q_y, -p), the pair posed from
    the top box (``swap``: from the lower one); ``push``: the top box's left side moved by push (cos t, sin t)."""
    lower = cc.box(nx=4, ny=4, nz=2)
    a = cc.Body(BOX, steel(nu=nu), contact="bottom", traction={"top": (q[0], q[1], -P)}, name="top",
                displacement={} if push is None else {"left": (push * DIAGONAL[0], push * DIAGONAL[1], None)})
    b = cc.Body(lower.with_points(lower.points - [0.0, 0.0, 1.0]), steel(nu=nu), contact="top", clamped="bottom",
                name="below")
    pair = cc.Contact(b, "top", a, "bottom", law=law) if swap else cc.Contact(a, "bottom", b, "top", law=law)
    return cc.Scene(a, b, contacts=[pair])


LIFTING = {"sheared": lambda law: sheared((0.2 * P, 0.1 * P), law), "held-side": held_side}
"""The boxes that lift at a corner under friction (tests/test_friction_p2_lifting3d.py, test_friction_p2_ridges3d.py):
sheared by (0.2, 0.1) p; with its left side held, sheared along y. Their finished P2 answers under Tresca (3 MPa) are
shared across those modules by :func:`lifting_key` (conftest's ``shared``)."""


def counted_directions(monkeypatch):
    """Counts (in the returned dict) the sparse LUs of the directions' mixed system, Lawson-Hanson's finishes (one
    per step on the directions) and, per call of ``fixed_directions``, its steps and how it ended (a Declined or
    not), on ``monkeypatch`` (the functions themselves are called: the same answers)."""
    from cvxcontact.backends.finish import Declined, directions
    from cvxcontact.backends.finish import friction as finish_friction

    count = {"lu": 0, "steps": 0, "runs": []}
    lu, finish, steps = directions.superlu, directions.independent_active_set, finish_friction.fixed_directions

    def counted_lu(*args, **kwargs):
        count["lu"] += 1
        return lu(*args, **kwargs)

    def counted_finish(*args, **kwargs):
        count["steps"] += 1
        count["runs"][-1][0] += 1
        return finish(*args, **kwargs)

    def counted_steps(*args, **kwargs):
        count["runs"].append([0, None])
        out = steps(*args, **kwargs)
        count["runs"][-1][1] = isinstance(out, Declined)
        return out

    monkeypatch.setattr(directions, "superlu", counted_lu)
    monkeypatch.setattr(directions, "independent_active_set", counted_finish)
    monkeypatch.setattr(finish_friction, "fixed_directions", counted_steps)
    return count


def lifting_key(name):
    """(key, make) of conftest's ``shared`` for the finished P2 answer of the box ``LIFTING[name]`` under Tresca 3 MPa
    with the finish's outcomes (``friction_scenes.watched_p2``) and the counts of its steps on the directions
    (:func:`counted_directions`): ``shared(*lifting_key(name))`` is (solution, outcomes, counts), read by
    tests/test_friction_p2_lifting3d.py, test_friction_p2_ridges3d.py and test_friction_directions.py."""

    def make():
        with pytest.MonkeyPatch.context() as monkeypatch:
            count = counted_directions(monkeypatch)
            return *watched_p2(LIFTING[name](cc.Tresca(3e6))), count

    return ("P2 box lifting at a corner, Tresca 3 MPa", name), make


def coulomb_key():
    """(key, make) of conftest's ``shared`` for the finished P2 answer of the box sheared by 0.2 p along
    :data:`DIAGONAL` under Coulomb mu = 0.3, with the finish's outcomes (``friction_scenes.watched_p2``, one per
    polish of Coulomb's fixed point): tests/test_friction_p2_lifting3d.py and test_friction_p2_ridges3d.py."""
    return ("P2 box sheared along a diagonal, Coulomb 0.3",), \
        lambda: watched_p2(sheared(0.2 * P * DIAGONAL, cc.Coulomb(0.3)))


def apart(one, other):
    """The largest difference of two solutions' displacements over the largest displacement."""
    scale = max(np.abs(u).max() for u in one.u)
    return max(np.abs(u - v).max() for u, v in zip(one.u, other.u)) / scale
