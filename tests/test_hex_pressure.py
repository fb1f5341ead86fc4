"""lambda_h on hexahedral faces (fem/hexfaces.LumpedPressure): a uniform pressure reads uniform at every node of
X_h, Q1 and Q2, against a rigid plane and between two bodies (matching and nested faces). Before, the read-back
solved the representer in the P1/P2 functions of the faces' triangles, whose mass does not weigh the Q1/Q2
rows' forces alike: a uniform 14 MPa read 5.9-30 MPa (Q1) and 1.3-63 MPa (Q2)."""

import numpy as np
import pytest

import cvxcontact as cc
from hex_scenes import ALU, DELTA, STEEL, block, pair

pytestmark = pytest.mark.numerics

P = 14e6
H = 0.5


def _on_plane(degree, condition):
    """A steel block on a rigid plane, rollers on two sides, a uniform traction -P on its top."""
    mesh = cc.box(nx=3, ny=3, nz=2, cell="hex")
    b = cc.Body(mesh, STEEL, roller=["left", "front"], traction={"top": (0.0, 0.0, -P)})
    scene = cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])
    return cc.solve(scene, condition, degree=degree), P


def _two_blocks(degree, condition, lower_n, upper_n):
    """A steel block under an aluminium one (hex_scenes.pair), pushed by DELTA: uniaxial strain, the closed-form
    pressure p = DELTA / (H / M_steel + H / M_alu)."""
    scene = pair(block(lower_n, (0.0, H)), block(upper_n, (H, 2 * H)), materials=(STEEL, ALU))
    M_s, M_a = float(STEEL.tensors(3)[0][2, 2]), float(ALU.tensors(3)[0][2, 2])
    return cc.solve(scene, condition, degree=degree), DELTA / (H / M_s + H / M_a)


CASES = {
    "Q1 plane gamma3": lambda: _on_plane(1, "gamma3"),
    "Q1 plane sigma1": lambda: _on_plane(1, "sigma1"),
    "Q2 plane sigma1": lambda: _on_plane(2, "sigma1"),
    "Q1 matching gamma3": lambda: _two_blocks(1, "gamma3", 3, 3),
    "Q1 matching sigma2": lambda: _two_blocks(1, "sigma2", 3, 3),
    "Q1 nested gamma3 (fine upper)": lambda: _two_blocks(1, "gamma3", 2, 4),
    "Q1 nested gamma3 (fine lower)": lambda: _two_blocks(1, "gamma3", 4, 2),
    "Q1 nested sigma2 (the fine side's rows)": lambda: _two_blocks(1, "sigma2", 2, 4),
    "Q2 matching sigma1": lambda: _two_blocks(2, "sigma1", 2, 2),
    "Q2 matching sigma2": lambda: _two_blocks(2, "sigma2", 2, 2),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_uniform_pressure_reads_uniform_on_hexahedral_faces(case):
    sol, p = CASES[case]()
    assert sol.ok
    c = sol.contacts[0]
    assert abs(c.force.sum() - p) <= 1e-10 * p                    # the closed form's total (A = 1 m^2)
    assert np.abs(c.lam - p).max() <= 1e-10 * p                   # measured <= 1e-14 p; before: 0.42 p .. 4.5 p
    assert (c.lam >= 0).all()
