"""Physics: materials, bodies with their boundary parts and loads, the scene."""

from . import materials
from .scene import Body, Load, Scene

__all__ = ["materials", "Body", "Load", "Scene"]
