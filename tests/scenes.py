"""The canonical scenes of the test suite, in one place: name -> (scene builder, solve keywords).

Each entry is a scene the package must solve and the keywords to solve it with (condition, degree, law,
tol). They reuse the builders of the fixtures modules (compliance_scenes, obstacle_scenes, stack_scenes,
foundation_scenes, reference_problems), with which the test modules check each scene against its own
independent reference (closed forms, dense solves of (26), invariances); here they are the common set on which
every way of solving must agree (tests/test_model_agrees.py: cc.Model and cc.solve).
"""

import cvxcontact as cc

from compliance_scenes import held_layer, pressed_block
from conftest import two_blocks
from foundation_scenes import clamped_foundation, moved_foundation
from obstacle_scenes import indenter_scene, punch_scene
from reference_problems import pressed
from stack_scenes import three_blocks


def _stack(conditions, law0=None):
    bodies, pairs, gaps = three_blocks(conditions)
    if law0 is not None:
        top, mid, _ = bodies
        pairs[0] = cc.Contact(top, "bottom", mid, "top", gap=gaps[0], condition=conditions[0], law=law0)
    return cc.Scene(*bodies, contacts=pairs)


K = cc.NormalCompliance(stiffness=1e12)
LIMITED = cc.NormalCompliance(stiffness=1e12, penetration_limit=5e-6)

SCENES = {
    "two blocks, gamma3": (lambda: two_blocks((8, 4), (5, 3)), dict(condition="gamma3")),
    "two blocks, sigma1": (lambda: two_blocks((8, 4), (5, 3)), dict(condition="sigma1")),
    "two blocks, sigma2": (lambda: two_blocks((8, 4), (5, 3)), dict(condition="sigma2")),
    "two blocks, P2 sigma1": (lambda: two_blocks((8, 4), (5, 3)), dict(condition="sigma1", degree=2)),
    "two blocks, P2 gamma3 (cones)": (lambda: two_blocks((8, 4), (5, 3)), dict(condition="gamma3", degree=2)),
    "springs in series, compliance": (lambda: pressed(), dict(condition="gamma3", law=K)),
    "springs in series, P2 compliance": (lambda: pressed(), dict(condition="gamma3", law=K, degree=2)),
    "three blocks, P2 nodal stack": (lambda: _stack(("sigma1", "sigma2")), dict(condition="sigma1", degree=2)),
    "three blocks, P2 compliance next to a cone": (lambda: _stack(("sigma1", "gamma3"), law0=K),
                                                   dict(condition="gamma3", degree=2, tol=2e-5)),
    "force-controlled punch": (lambda: punch_scene(0.5)(force=(0.0, -1e6)), dict(condition="gamma3")),
    "force-controlled punch, compliance": (lambda: pressed_block(2e7, K), dict(condition="gamma3")),
    "force-controlled circle": (lambda: indenter_scene(0.5 + 0.6 - 1e-3, force=(0.0, -2e6)),
                                dict(condition="gamma3")),
    "fixed circle": (lambda: indenter_scene(0.5 + 0.6 - 3e-3), dict(condition="gamma3")),
    "layer held by the contact": (lambda: held_layer(None), dict(condition="gamma3")),
    "layer held through compliance, P2": (lambda: held_layer(K), dict(condition="sigma1", degree=2)),
    "layer held, P2 conic limit": (lambda: held_layer(LIMITED), dict(condition="gamma3", degree=2, tol=2e-5)),
    "clamped foundation": (lambda: clamped_foundation("pair")[1], dict(condition="sigma1")),
    "moved foundation, P2": (lambda: moved_foundation("body", 5e-5)[1], dict(condition="sigma1", degree=2)),
}
"""name -> (builder, keywords of cc.solve / cc.Model)."""
