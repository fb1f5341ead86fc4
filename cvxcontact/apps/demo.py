"""Built-in scenes for the command line's ``demo`` and for quick experiments."""

from __future__ import annotations

from ..physics import materials
from ..geometry.mesh import rectangle
from ..physics.scene import Body, Scene

__all__ = ["two_blocks"]


def two_blocks(nx=16) -> Scene:
    """A PZT-5A block (1 m x 0.5 m, clamped and grounded on top, body force, shear traction and
    surface charge) on an aluminium block (clamped at the bottom); non-matching meshes on y = 0
    (``nx`` and about 0.7 ``nx`` cells). At ``nx=16`` this is the README quickstart scene."""
    nx2 = max(2, round(0.7 * nx))
    upper = rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=max(1, nx // 2))
    lower = rectangle(x=(0.0, 1.0), y=(-0.5, 0.0), nx=nx2, ny=max(1, (nx2 + 1) // 2))
    b1 = Body(upper, materials.PZT5A, clamped=["top"], grounded=["top"], contact="bottom", name="PZT-5A block",
              body_force=(0.0, -2e9), traction={"right": (0.0, 3e8)}, surface_charge={"left": -0.05})
    b2 = Body(lower, materials.isotropic(E=70e9, nu=0.3, name="aluminium"), clamped=["bottom"], contact="top",
              name="aluminium block")
    return Scene(b1, b2)
