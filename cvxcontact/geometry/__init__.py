"""Geometry: immutable P1 triangle and tetrahedral meshes with named boundary parts, generators and
gmsh reading."""

from .generators3d import box, cylinder
from .mesh import Mesh, read_mesh, rectangle
from .hexmesh import HexMesh
from .quadmesh import QuadMesh
from .tetmesh import TetMesh

__all__ = ["Mesh", "QuadMesh", "HexMesh", "TetMesh", "rectangle", "box", "cylinder", "read_mesh"]
