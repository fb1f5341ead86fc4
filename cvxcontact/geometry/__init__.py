"""Geometry: immutable P1 triangle meshes with named boundary parts, generators and gmsh reading."""

from .mesh import Mesh, read_mesh, rectangle

__all__ = ["Mesh", "rectangle", "read_mesh"]
