"""A block pressed onto a foundation whose contact part its supports hold (clamped, or moved by a prescribed
displacement), shared by tests/test_refusals.py (where each is checked against the block on a rigid plane) and
the canonical set of tests/scenes.py. A fixtures module: the test modules do not import each other.
"""

import cvxcontact as cc

E, NU = 70e9, 0.3
ALU = cc.materials.isotropic(E=E, nu=NU)
H = 0.5                          # block heights (m)
GAP = lambda s: -2e-6 + 2e-3 * (s - 0.4) ** 2            # noqa: E731  partial contact (2 of 5 P1 rows active)


def upper_block(load=-1e8, nx=4):
    """A block [0, 1] x [0, H] clamped at its top, pressed down by its weight ``load`` (N/m^3)."""
    return cc.Body(cc.rectangle(x=(0, 1), y=(0, H), nx=nx, ny=2), ALU, clamped=["top"], contact="bottom",
                   body_force=(0.0, load), name="upper")


def clamped_foundation(where):
    """A lower block [0, 1] x [-0.4, 0] whose top is clamped and is the contact part: given as its contact=
    tag ("body": a segment tag 'pad' covering the clamped top) or as the pair's part ("pair")."""
    mesh = cc.rectangle(x=(0, 1), y=(-0.4, 0), nx=4, ny=2, segments={"pad": ("top", 0.0, 1.0)})
    upper = upper_block()
    if where == "body":
        lower = cc.Body(mesh, ALU, clamped=["top", "bottom"], contact="pad", name="lower")
        return upper, cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "pad", gap=GAP)])
    lower = cc.Body(mesh, ALU, clamped=["top", "bottom"], contact="left", name="lower")
    return upper, cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top", gap=GAP)])


def moved_foundation(where, lift):
    """A lower block between side rollers whose top (the contact part) is moved up by ``lift`` (m): as the
    body's contact= part ("body": a segment tag 'pad' on the moved top) or as the pair's part ("pair")."""
    mesh = cc.rectangle(x=(0, 1), y=(-0.4, 0), nx=4, ny=2, segments={"pad": ("top", 0.0, 1.0)})
    upper = upper_block()
    supports = dict(roller=["left", "right"], displacement={"top": (None, lift)}, name="lower")
    if where == "body":
        lower = cc.Body(mesh, ALU, contact="pad", **supports)
        return upper, cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "pad", gap=GAP)])
    lower = cc.Body(mesh, ALU, contact="bottom", **supports)
    return upper, cc.Scene(upper, lower, contacts=[cc.Contact(upper, "bottom", lower, "top", gap=GAP)])
