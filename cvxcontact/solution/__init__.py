"""Solution: read-back in SI, lambda_h from the duals, and the checks of (26)-(27)."""

from .info import Finish, Route, SolveInfo, Status
from .solution import ContactResult, Solution

__all__ = ["Solution", "ContactResult", "SolveInfo", "Status", "Route", "Finish"]
