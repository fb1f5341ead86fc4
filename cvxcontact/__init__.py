"""cvxcontact: frictionless contact of piezoelectric bodies as convex programs.

Layers (imports flow one way, tests/test_layers.py): geometry -> contact -> physics -> fem ->
discrete -> backends -> solution -> solve -> io -> apps. See docs/architecture.md.

    >>> import cvxcontact as cc
    >>> m1 = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=8, ny=4)
    >>> sol = cc.solve(scene, condition="gamma3")          # doctest: +SKIP

See the README for the full quickstart and the paper's notation mapped to these names.
"""

from .physics import materials
from .contact.interface import CONDITIONS
from .errors import CvxContactError, MaterialError, MeshError, ResidualWarning, SceneError, SolverError
from .geometry.mesh import Mesh, read_mesh, rectangle
from .geometry.generators import graded_block, half_disk
from .physics.scene import Body, Scene
from .solution.info import Finish, Route, SolveInfo, Status
from .solve import ContactResult, ContactSolver, Solution, solve
from .model import Model

__version__ = "0.1.0"

__all__ = [
    "materials", "CONDITIONS",
    "Mesh", "rectangle", "read_mesh", "graded_block", "half_disk",
    "Body", "Scene",
    "solve", "ContactSolver", "Solution", "ContactResult", "Model", "SolveInfo", "Status", "Route", "Finish",
    "CvxContactError", "MeshError", "MaterialError", "SceneError", "SolverError", "ResidualWarning",
]
