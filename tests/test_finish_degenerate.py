"""The finish of the mixed system (26) on degenerate rows: rows whose force and slack are both zero at the answer
(P2 face vertices under a uniform pressure: their basis integrals are 0), whose status rounding used to decide.
A P2 layer held by a rigid plane only, and two P2 blocks on matching faces held by the contact only: the
primal-dual active-set steps cycled there on an AVX-512 CPU's OpenBLAS kernels (and on the Nehalem kernels here),
declining the finish. The finish (Lawson-Hanson on the dual, ``independent_active_set``) must reach the same exact
answer from any start whatever the rounding: here from random starting sets and forces, i.e. every tie decided
every way."""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.backends import finish, signorini

from scenes3d import P, layer_on_plane, stacked_blocks, uniaxial_modulus

pytestmark = pytest.mark.numerics      # re-run under every OpenBLAS kernel set by .ci/run

SCENES = {"P2 layer on a rigid plane": lambda: layer_on_plane(n=(2, 2, 1)),
          "P2 blocks on matching faces": lambda: stacked_blocks((3, 3), (3, 3), nz=1)}


def uniaxial_error(sol):
    """max |u_z + p (z - z0) / c33| over the bodies, relative to p h / c33 (the layer: z0 = 0; the blocks
    rest on rollers at z = 0 too)."""
    c33 = uniaxial_modulus()
    return max(np.abs(sol.u[k][:, 2] + P * sol.points[k][:, 2] / c33).max() for k in range(len(sol.u))) / (P / c33)


@pytest.mark.parametrize("condition", ["sigma1", "sigma2"])
@pytest.mark.parametrize("name", list(SCENES))
def test_any_start_reaches_the_exact_uniaxial_answer(name, condition, monkeypatch):
    """The finish from the interior point's start (as cc.solve runs it) and from 12 random starts (each row
    closed with probability 1/2, random forces >= 0 on those): every answer is the uniaxial closed form to
    rounding (measured <= 3.0e-15 on the Haswell and Nehalem OpenBLAS kernels; bound 1e-12), the forces >= 0
    and zero on open rows, and the answers' unknowns agree with each other to rounding (measured <= 6.4e-15)."""
    inner = finish.independent_active_set
    answers = []

    def many(kkt, g, y0, start, **kw):
        rng = np.random.default_rng(7)
        first = inner(kkt, g, y0, start, **kw)
        assert not isinstance(first, str), first
        answers.append(kkt.stack(first[0]))
        for _ in range(12):
            closed = rng.uniform(size=len(g)) < 0.5
            out = inner(kkt, g, np.where(closed, rng.uniform(0.1, 2.0, len(g)), 0.0), closed, **kw)
            assert not isinstance(out, str), out
            (_, _, y, *rest), active, _ = out
            assert (y >= 0).all() and not y[~active].any()
            answers.append(kkt.stack(out[0]))
        return first

    monkeypatch.setattr(signorini, "independent_active_set", many)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sol = cc.solve(SCENES[name](), condition, degree=2, method="full")     # the finish on the whole (26)
    assert sol.ok and sol.polished and sol.info.finish == "independent active set"
    assert uniaxial_error(sol) < 1e-12
    ref = answers[0]
    scale = np.abs(ref).max()
    assert len(answers) == 13
    assert max(np.abs(a - ref).max() for a in answers) < 1e-12 * scale
