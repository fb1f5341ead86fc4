"""Contact lines: the traces of two meshes on Gamma_3, their merged mesh, and the jump, evaluation
(condition) and mass operators on it. Depends on meshes only, so a Scene validates its pair when built."""

from .interface import CONDITIONS, Interface, lumped_lengths
from .surface import SurfaceInterface

__all__ = ["CONDITIONS", "Interface", "SurfaceInterface", "lumped_lengths"]
