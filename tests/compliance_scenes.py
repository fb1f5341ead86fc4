"""The normal-compliance scenes shared by tests/test_compliance_scenes.py (where each is checked against its closed
form), tests/test_refusals.py, tests/test_tangency.py, tests/test_declined.py, tests/test_mixed_cuts_factored.py and
the canonical set of tests/scenes.py: a block pressed by a force-controlled rigid plane through a law, and a layer
held by the contact only on a clamped foundation (docs/formulation.md §10-§12). A fixtures module: the test
modules do not import each other.
"""

import cvxcontact as cc

ALU = cc.materials.isotropic(E=70e9, nu=0.33)
M = ALU.c[1, 1]                 # P-wave (oedometric) modulus E (1-nu) / ((1+nu) (1-2nu)), Pa
H, W, P = 0.5, 1.0, 2e7         # block height and width (m), pressure (Pa)
H1, H2 = 0.5, 0.2               # foundation and layer thickness (m)


def pressed_block(force, law=None):
    """Block W x H clamped at its bottom, rollers on its sides, a rigid plane on its whole top pushed down
    with the resultant ``force`` (N/m) through ``law``."""
    block = cc.Body(cc.rectangle(x=(0.0, W), y=(0.0, H), nx=4, ny=3), ALU, clamped="bottom",
                    roller=["left", "right"], contact="top", name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0.0, H), (0.0, -1.0),
                                                                               force=(0.0, -force)), law=law)])


def held_layer(law, p=P, nx=3):
    """A layer between side rollers, pressed by p (Pa) on its top, on a foundation clamped at its bottom
    (side rollers too): only the contact (through ``law``) holds the layer vertically. The layer has ``nx``
    elements across, the foundation 4 (non-matching meshes unless nx = 4)."""
    low = cc.rectangle(x=(0.0, 1.0), y=(-H1, 0.0), nx=4, ny=3)
    top = cc.rectangle(x=(0.0, 1.0), y=(0.0, H2), nx=nx, ny=2)
    layer = cc.Body(top, ALU, roller=["left", "right"], contact="bottom", traction={"top": (0.0, -p)}, name="layer")
    base = cc.Body(low, ALU, clamped=["bottom"], roller=["left", "right"], contact="top", name="base")
    return cc.Scene(layer, base, contacts=[cc.Contact(layer, "bottom", base, "top", law=law)])

