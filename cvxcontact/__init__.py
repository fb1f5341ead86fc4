"""cvxcontact: frictionless contact of piezoelectric bodies as convex programs.

Data flow: mesh -> bodies/scene -> assembly -> convex model -> solve -> read-back and checks.

    >>> import cvxcontact as cc
    >>> m1 = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=8, ny=4)
    >>> sol = cc.solve(scene, condition="gamma3")          # doctest: +SKIP

See the README for the full quickstart and the paper's notation mapped to these names.
"""

from . import materials
from .contact import CONDITIONS
from .errors import CvxContactError, MaterialError, MeshError, ResidualWarning, SceneError, SolverError
from .mesh import Mesh, read_mesh, rectangle
from .scene import Body, Scene
from .solve import ContactResult, ContactSolver, Solution, solve

__version__ = "0.1.0"

__all__ = [
    "materials", "CONDITIONS",
    "Mesh", "rectangle", "read_mesh",
    "Body", "Scene",
    "solve", "ContactSolver", "Solution", "ContactResult",
    "CvxContactError", "MeshError", "MaterialError", "SceneError", "SolverError", "ResidualWarning",
]
