"""The discrete problem the backends share: scaled blocks (:mod:`.blocks`) and the problem object (:mod:`.problem`)."""

from .blocks import Block, Units, units
from .problem import DiscreteProblem, build_problem

__all__ = ["Block", "Units", "units", "DiscreteProblem", "build_problem"]
