"""Two-body and obstacle scenes of tests/test_pairs.py (where each is checked against a dense solve of (26), a
limit case or closed-form obstacle distances), shared with tests/test_sparse_route.py: an elastic punch narrower
than its substrate (partial overlap) and a block on a rigid obstacle or on an elastic foundation. A fixtures
module: the test modules do not import each other.
"""

import cvxcontact as cc

STEEL = cc.materials.isotropic(E=200e9, nu=0.3)
ALU = cc.materials.isotropic(E=70e9, nu=0.33)


def elastic_punch(condition=None, width=(0.3, 0.7)):
    """An elastic punch narrower than its elastic substrate, pressed by a prescribed approach: (scene, gap), the
    gap (m) a function of the abscissa."""
    punch = cc.Body(cc.rectangle(x=width, y=(0.0, 0.2), nx=5, ny=2), STEEL, clamped="top", contact="bottom",
                    body_force=(0.0, -1e9), name="punch")
    base = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=8, ny=4), ALU, clamped="bottom", contact="top",
                   name="substrate")
    gap = lambda s: -2e-4 + 5e-3 * (s - 0.52) ** 2                       # noqa: E731
    contact = cc.Contact(punch, "bottom", base, "top", gap=gap, condition=condition)
    return cc.Scene(punch, base, contacts=[contact]), gap


def block_on(obstacle_or_body, E_found=None):
    """A block 1 m x 0.4 m clamped at its top, pressed down by its weight and sheared by a traction on its right
    side, interfering by 1e-4 m with ``obstacle_or_body`` (a cc.Rigid) or, given ``E_found`` (Pa), with an elastic
    foundation of that modulus clamped at its base."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.4), nx=6, ny=3), ALU, clamped="top", contact="bottom",
                    body_force=(0.0, -3e9), traction={"right": (2e8, 0.0)}, name="block")
    if E_found is None:
        return cc.Scene(block, contacts=[cc.Contact(block, "bottom", obstacle_or_body, gap=-1e-4)])
    found = cc.Body(cc.rectangle(x=(-0.2, 1.2), y=(-0.3, 0.0), nx=7, ny=2), cc.materials.isotropic(E=E_found, nu=0.3),
                    clamped="bottom", contact="top", name="foundation")
    return cc.Scene(block, found, contacts=[cc.Contact(block, "bottom", found, "top", gap=-1e-4)])
