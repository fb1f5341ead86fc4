"""The discrete problem the backends share: scaled blocks (:mod:`.blocks`), the problem object (:mod:`.problem`)
and its contact term (:mod:`.terms`)."""

from .blocks import Block, Units, units
from .problem import DiscreteProblem, build_problem
from .terms import TERMS, ContactTerm, contact_term

__all__ = ["Block", "Units", "units", "DiscreteProblem", "build_problem", "ContactTerm", "TERMS", "contact_term"]
