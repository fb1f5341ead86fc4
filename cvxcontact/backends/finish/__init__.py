"""Exact finishes (docs/formulation.md §7, §12, §13): the steps that turn an interior point into the exact
answer of the discrete problem, one module per algorithm.

- :mod:`.lcp`: the condensed interface problem as a linear complementarity problem (active-set steps, then
  Lawson-Hanson on the factor);
- :mod:`.normal_compliance`: Newton on a normal compliance law's interface equation, dense or on the sparse mixed
  system;
- :mod:`.forces`: nodal forces, row reaches and scales, the interior point's active set;
- :mod:`.rows`: the rows carrying the forces kept independent and factored, updated a row at a time;
- :mod:`.dependent`: the finish on rows that may be linearly dependent (independent active sets, Lawson-Hanson);
- :mod:`.friction`: semismooth Newton on the mixed system with a friction law's rows (Tresca, Coulomb);
- :mod:`.declined`: why a finish stopped without an answer (:class:`Declined`, a typed result).
"""

from .declined import CYCLE, MAX_ITER, SINGULAR, SINGULAR_FORCES, STALL, Declined, Stop
from .dependent import purified, independent_active_set, independent_interface, lawson_hanson, rows_kkt
from .forces import (FORCE_FLOOR, coefficient_rounding, force_displacements, force_scale, friction_scale,
                     ipm_active, node_scales, reach_displacements, reach_forces, row_compliance, slack_terms,
                     slip_reach)
from .lcp import SIGN_TOL, active_set_steps, closed_solve, lcp_start, row_scales, signs_hold, solve_lcp
from .normal_compliance import solve_compliance, solve_linear_compliance, solve_sparse_compliance
from .rows import (DEPENDENT_PIVOT, CholeskySystem, CompliantRows, FactoredRows, UpdatedSystem, independent_columns,
                   independent_rows, row_scale,
                   factored_rows, refined_solve, row_reach)

__all__ = ["solve_lcp", "closed_solve", "lcp_start", "row_scales", "signs_hold", "reach_displacements", "reach_forces",
           "row_compliance", "slack_terms", "coefficient_rounding", "force_scale", "friction_scale", "slip_reach",
           "FORCE_FLOOR", "solve_compliance",
           "solve_linear_compliance",
           "solve_sparse_compliance", "SIGN_TOL", "active_set_steps", "independent_active_set", "rows_kkt",
           "independent_interface", "lawson_hanson", "force_displacements", "ipm_active", "node_scales",
           "FactoredRows", "UpdatedSystem", "CholeskySystem", "CompliantRows", "factored_rows", "refined_solve",
           "row_reach",
           "DEPENDENT_PIVOT", "Declined", "Stop", "SINGULAR", "CYCLE", "MAX_ITER", "SINGULAR_FORCES", "STALL",
           "independent_columns", "independent_rows", "purified", "row_scale"]
