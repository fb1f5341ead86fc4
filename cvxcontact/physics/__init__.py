"""Physics: materials, bodies with their boundary parts and loads, the scene."""

from . import materials
from .loads import LOAD_FIELDS, SCENE_LOAD_FIELDS
from .scene import Body, Load, Scene

__all__ = ["materials", "Body", "Load", "Scene", "LOAD_FIELDS", "SCENE_LOAD_FIELDS"]
