"""Scenes of one block under a rigid obstacle, shared by tests/test_force_control.py (where the force-controlled
obstacles are checked against the displacement-controlled ones and closed forms), tests/test_tangency.py,
tests/test_truegap_argmax.py, tests/test_adapt.py, tests/test_adapt_budget.py, tests/test_model_stack.py,
tests/test_mixed_cuts_factored.py, tests/test_wellposed.py, tests/test_warning_location.py and the canonical set of
tests/scenes.py: a rigid flat punch on a block's footprint, a rigid circle indenter (displacement or force
controlled), the circle of the tangency tests, the indented block of the adapt tests and a force-controlled circle
on a block's symmetry line (the half model) (docs/formulation.md §12, §18). A fixtures module: the test modules do
not import each other.
"""

import cvxcontact as cc

ALU = cc.materials.isotropic(E=70e9, nu=0.33)


def punch_scene(top, nx=10, ny=4):
    """A block 1 m x 0.5 m clamped at its bottom, a rigid flat punch (a plane) on its footprint
    [0.3, 0.7] of the top: the plane's face is at y = top (m)."""
    mesh = cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny, segments={"footprint": ("top", 0.3, 0.7)})
    block = cc.Body(mesh, ALU, clamped="bottom", contact="footprint", name="block")
    return lambda **kw: cc.Scene(block, contacts=[cc.Contact(block, "footprint",
                                                             cc.Rigid.plane((0.0, top), (0.0, -1.0), **kw))])


def indenter_scene(center_y, radius=0.6, **kw):
    """A block 1 m x 0.5 m (24 x 6 cells) clamped at its bottom under a rigid circle of radius ``radius`` (m)
    centred at (0.47, center_y) (m); ``kw`` go to :meth:`cvxcontact.Rigid.circle` (force=, distance=)."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=24, ny=6), ALU, clamped="bottom", contact="top",
                    name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((0.47, center_y), radius, **kw))])


def circle(distance="closest"):
    """The indenter of :func:`indenter_scene` (R = 0.6 m) 1 mm into the block, force controlled with the resultant
    (0, -2e6) N/m: a curved obstacle touching P2 faces inside elements under "gamma3"; ``distance`` is the
    circle's distance ("closest" or "ray")."""
    return indenter_scene(0.5 + 0.6 - 1e-3, force=(0.0, -2e6), distance=distance)


def indented_block(nx=8, ny=2):
    """A rigid circle (R = 0.6 m) pressed 3 mm into an aluminium block 1 m x 0.5 m (the estimate study's circle,
    on a coarser grid)."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny), cc.materials.isotropic(E=70e9, nu=0.33),
                    clamped="bottom", contact="top", name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((0.47, 0.5 + 0.6 - 3e-3), 0.6))])


def half_model(degree_nx=16, force=(0.0, -1e7), center_x=0.0, roller="left"):
    """A block clamped at its bottom under a force-controlled circle, a symmetry roller on x = 0 (the half
    model: the circle straddles the symmetry line); ``center_x=0.5`` and no roller: the whole model."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=degree_nx, ny=4), ALU, clamped="bottom",
                    roller=roller, contact="top", name="block")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.circle((center_x, 1.1), 0.6, force=force))])
