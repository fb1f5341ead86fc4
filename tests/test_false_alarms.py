"""Checks scaled by the problem, not by solver noise (issue: answers right to rounding reported ``ok`` False).

- An open contact next to a binding user row (cc.Model, 3D): the interior point's contact forces are noise
  (1e-11 of the elastic forces at the contact nodes); normalised by their own maximum they read as contact
  (complementarity 0.70, the finish declined as singular). They are now read against FORCE_FLOOR of the
  elastic forces there.
- A force-controlled sphere that travels far before touching: the moved gap is a cancellation of the gap and the
  translation (0.059 m each, a 3.6e-5 m indentation), whose rounding the rows' displacement scale must count
  (complementarity 3.6e-7 before, near the default tol 1e-6; 1.76e-6 on P1 "gamma3" as reported).
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import hertz3d

from scenes3d import STEEL

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run


def hanging_block(floor=0.0):
    """A block (0, 1)^2 x (1 mm, 0.5 m) clamped at its top, pulled down by its weight-like body force, over a
    rigid plane at z = ``floor`` (its bottom the contact face)."""
    mesh = cc.box(x=(0, 1), y=(0, 1), z=(0.001, 0.5), nx=2, ny=2, nz=2)
    body = cc.Body(mesh, STEEL, clamped="top", contact="bottom", body_force=(0, 0, -4e10), name="block")
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0, 0, floor), (0, 0, 1)))])


def strict(call):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", cc.ResolutionWarning)   # coarse by design: the resolution check names it
        return call()


def test_an_open_contact_next_to_a_binding_user_row_is_finished_and_ok():
    """The bottom may sink 0.2 mm (a user row), less than the 1 mm gap: the row binds, the contact stays open.
    Finished exactly (no force on any contact row, the row closed), ok; and the same answer with the plane 1 m
    further down (an open contact does not matter: invariance)."""
    sols = []
    for floor in (0.0, -1.0):
        model = cc.Model(hanging_block(floor), "sigma1")
        model.add(model.u(0)[:, 2] >= -2e-4)
        sols.append(strict(model.solve))
    near, far = sols
    assert near.ok and near.polished and far.ok and far.polished, near.report()
    assert not near.contact.lam.any()                                   # open: exactly no force
    assert near.residuals()["complementarity"] == 0.0                   # was 0.70 (noise over noise)
    assert abs(near.u[0][:, 2].min() / -2e-4 - 1) < 1e-12               # the user row binds: measured 0
    scale = np.abs(far.u[0]).max()
    assert np.abs(near.u[0] - far.u[0]).max() < 1e-12 * scale           # measured <= 3.3e-16


def test_a_sphere_that_travels_before_touching_is_ok_and_the_same_contact():
    """A guided sphere (quarter block, force-controlled) starting 0.059 m above the block: the same contact as
    from touching (the fields equal, the translation 0.059 m further), and its checks at rounding. Complementarity
    measured 1.25e-8 (Haswell) / 1.1e-8 (Nehalem OpenBLAS kernels), was 3.6e-7: the square root of a product at
    rounding; bound 1.3e-6 (104x)."""
    block = hertz3d.block(4)
    sols = []
    for lift in (0.0, 0.059):
        # posed along the normal (distance="ray"): a translation along z is then exact, so the lifted sphere meets
        # the same rows; the closest-point rows (the default) are linearised where the sphere starts, 3 R above
        sphere = cc.Rigid.sphere((0.0, 0.0, hertz3d.R + lift), hertz3d.R, force=(0.0, 0.0, -hertz3d.FORCE / 4),
                                 guided=(0, 0, 1), distance="ray")
        sols.append(strict(lambda: cc.solve(cc.Scene(block, contacts=[cc.Contact(block, "zone", sphere)]))))
    touching, lifted = sols
    assert touching.ok and lifted.ok and lifted.polished
    assert lifted.residuals()["complementarity"] < 1.3e-6
    dz = lifted.obstacles[0].translation[2] - touching.obstacles[0].translation[2]
    assert abs(dz / -0.059 - 1) < 1e-12                                 # measured <= 8.9e-16
    scale = np.abs(touching.u[0]).max()
    assert np.abs(lifted.u[0] - touching.u[0]).max() < 1e-9 * scale      # measured <= 1.3e-12 (the gap's cancellation)
