"""The Hencky material's scenes and closed form (docs/materials.md, model.md), shared by tests/test_bulk_energy.py
(the full route and its Newton finish, where each is checked) and tests/test_hencky_fast.py (the fast route) and by
benchmarks/bench_hencky.py and benchmarks/newton_floor.py: the material's constants, the closed form of the axial
stress under uniaxial strain, a block pressed in uniaxial strain and a block indented by a rigid circle. A
fixtures module: the test modules do not import each other.
"""

import numpy as np

import cvxcontact as cc

E, NU, SIGMA_Y, H = 70e9, 0.3, 200e6, 0.1
MU, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
EXACT = 1e-12       # the Newton finish: equilibrium measured <= 3e-16, complementarity 0 (planes), 6e-9 (circles:
#                     the check's own, the linear material's is 1.1e-8 on the same scene)


def uniaxial_stress(strain, sigma_y=SIGMA_Y, h=H):
    """model.md's closed form: sigma_axis = K eps + mu psi'(s) (2/sqrt(6)) sign(eps), s = sqrt(6)/3 |eps|."""
    s, s_y = np.sqrt(6) / 3 * abs(strain), sigma_y / (np.sqrt(6) * MU)
    return K * strain + MU * (2 * h * s + 2 * (1 - h) * min(s, s_y)) * 2 / np.sqrt(6) * np.sign(strain)


def pressed_block(material, strain):
    """A block on a rigid plane, rollers on its sides, its top moved down: uniaxial strain ``strain`` along y."""
    m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=2)
    b = cc.Body(m, material, roller=["left", "right"], displacement={"top": (None, strain * 0.5)}, contact="bottom")
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", cc.Rigid.plane((0, 0), (0, 1)))])


def indented(material, nx=16, ny=6, depth=3e-3, radius=0.6):
    """A rigid circle pressed ``depth`` into a block 1 m x 0.5 m clamped at its bottom (yields under the circle)."""
    b = cc.Body(cc.rectangle(x=(0, 1), y=(0, 0.5), nx=nx, ny=ny), material, clamped="bottom", contact="top")
    return cc.Scene(b, contacts=[cc.Contact(b, "top", cc.Rigid.circle((0.47, 0.5 + radius - depth), radius))])
