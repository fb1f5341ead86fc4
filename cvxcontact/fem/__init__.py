"""Finite elements: P1 assembly of the electro-elastic operators and derived fields."""

from .assembly import BodySystem, assemble, assemble_loads, assemble_matrices

__all__ = ["BodySystem", "assemble", "assemble_matrices", "assemble_loads"]
