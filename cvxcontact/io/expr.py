"""A restricted evaluator for load expressions in scene files, e.g. ``"-2e9 * (1 + cos(pi * x))"``.

The text is parsed with :mod:`ast` and walked node by node; only numbers, the
variables ``x`` and ``y`` (metres; with ``variables=("x", "y", "z")`` also ``z``, for 3D scenes), the constants
``pi`` and ``e``, the operators
``+ - * / ** %``, comparisons, and the whitelisted NumPy functions below are
accepted. Nothing is ever passed to ``eval`` or ``exec``: a scene file is data.

Every function takes exactly its arity (``ARITY``), checked at parse time: NumPy
would read an extra positional argument as an output array and write into it.
Evaluation works on read-only copies of the coordinates and returns a new array.
Nesting depth and node count are bounded and measured without recursion.
"""

from __future__ import annotations

import ast
import operator

import numpy as np

from ..errors import SceneError, locked

__all__ = ["Expression", "ExpressionError", "FUNCTIONS", "ARITY", "VARIABLES"]

FUNCTIONS = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "arcsin": np.arcsin, "arccos": np.arccos, "arctan": np.arctan,
    "arctan2": np.arctan2, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh, "exp": np.exp, "log": np.log,
    "log10": np.log10, "sqrt": np.sqrt, "abs": np.abs, "minimum": np.minimum, "maximum": np.maximum,
    "where": np.where, "heaviside": lambda a: np.heaviside(a, 0.5),
}
ARITY = {name: 1 for name in FUNCTIONS} | {"arctan2": 2, "minimum": 2, "maximum": 2, "where": 3}
"""Number of positional arguments each function of ``FUNCTIONS`` takes, exactly."""

_CONSTANTS = {"pi": np.pi, "e": np.e}
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow, ast.Mod: operator.mod}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_COMPARE = {ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge}
_MAX_LENGTH = 1000   # characters
_MAX_DEPTH = 200     # nested sub-expressions; the checker and evaluator recurse this deep
_MAX_NODES = 2000    # sub-expressions in all


class ExpressionError(SceneError):
    """An expression uses a name, operator or construct outside the whitelist, or is malformed."""


VARIABLES = {2: ("x", "y"), 3: ("x", "y", "z")}
"""The coordinate names (m) an expression may use, by dimension."""


class Expression:
    """A parsed, validated expression in x and y (m), or in x, y and z with ``variables=("x", "y", "z")``;
    call it with arrays: ``expr(x, y)`` or ``expr(x, y, z)`` (one array per variable).

    With ``where`` (e.g. ``"scene.toml: body[0].body_force[1]"``), a NaN or infinite value is an
    ``ExpressionError`` naming that place, the expression and the first point where it happens.
    """

    def __init__(self, text: str, where: str | None = None, variables: tuple[str, ...] = ("x", "y")):
        if tuple(variables) not in VARIABLES.values():
            raise ExpressionError(f"variables must be one of {list(VARIABLES.values())}, got {variables!r}")
        self.variables = tuple(variables)
        if not isinstance(text, str):
            raise ExpressionError(f"an expression must be a string, got {type(text).__name__}")
        if len(text) > _MAX_LENGTH:
            raise ExpressionError(f"expression of {len(text)} characters; at most {_MAX_LENGTH} are allowed")
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as exc:
            raise ExpressionError(f"cannot parse {_short(text)}: {exc.msg}") from None
        except (RecursionError, MemoryError):
            raise ExpressionError(f"expression nested too deeply to parse; at most {_MAX_DEPTH} levels "
                                  "are allowed") from None
        _check_size(tree.body)
        self.text, self.where = text, where
        self._body = tree.body
        _check(self._body, text, self.variables)

    def __repr__(self):
        return f"Expression({self.text!r})"

    def __call__(self, *coords) -> np.ndarray:
        """Values at points (x, y) (or (x, y, z)) in metres, a new float array of the broadcast shape."""
        if len(coords) != len(self.variables):
            raise ExpressionError(f"{_short(self.text)} is a function of ({', '.join(self.variables)}); called with "
                                  f"{len(coords)} coordinate array(s)")
        coords = [locked(c, float) for c in coords]
        env = dict(zip(self.variables, coords))
        with np.errstate(all="ignore"):  # NaN/inf are reported below (with ``where``) or by the caller
            out = np.asarray(_eval(self._body, env), dtype=float) + 0.0 * sum(coords)
        if self.where is not None and not np.isfinite(out).all():
            i = np.flatnonzero(~np.isfinite(out))[0]
            at = ", ".join(f"{np.broadcast_to(c, out.shape).flat[i]:.6g}" for c in coords)
            raise ExpressionError(f"{self.where}: {_short(self.text)} is {out.flat[i]} at ({', '.join(self.variables)}) "
                                  f"= ({at}) m; expected finite values wherever the load is evaluated")
        return out


def _short(text):
    """The expression quoted for a message, cut to 60 characters."""
    return repr(text if len(text) <= 60 else text[:57] + "...")


def _check_size(root):
    """Refuse trees deeper than _MAX_DEPTH or larger than _MAX_NODES, with an explicit stack."""
    stack, count = [(root, 1)], 0
    while stack:
        node, depth = stack.pop()
        count += 1
        if depth > _MAX_DEPTH:
            raise ExpressionError(f"expression nested more than {_MAX_DEPTH} levels deep")
        if count > _MAX_NODES:
            raise ExpressionError(f"expression has more than {_MAX_NODES} terms")
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node) if isinstance(child, ast.expr))


def _check(node, text, variables=("x", "y")):
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise ExpressionError(f"in {_short(text)}: only numbers are allowed as constants, "
                                  f"got a {type(node.value).__name__}")
        try:
            float(node.value)
        except OverflowError:
            raise ExpressionError(f"in {_short(text)}: the integer constant is too large for a float") from None
    elif isinstance(node, ast.Name):
        if node.id not in variables and node.id not in _CONSTANTS:
            hint = " (z exists in 3D scenes only)" if node.id == "z" else ""
            raise ExpressionError(f"in {_short(text)}: unknown name {node.id[:60]!r}{hint}; allowed: "
                                  f"{', '.join(variables)}, pi, e and functions {sorted(FUNCTIONS)}")
    elif isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        _check(node.left, text, variables)
        _check(node.right, text, variables)
    elif isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        _check(node.operand, text, variables)
    elif isinstance(node, ast.Compare) and all(type(op) in _COMPARE for op in node.ops):
        for n in [node.left, *node.comparators]:
            _check(n, text, variables)
    elif isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            name = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)[:60]
            raise ExpressionError(f"in {_short(text)}: function {name!r} is not allowed; "
                                  f"allowed: {sorted(FUNCTIONS)}")
        if node.keywords:
            raise ExpressionError(f"in {_short(text)}: keyword arguments are not allowed")
        name, want = node.func.id, ARITY[node.func.id]
        if any(isinstance(a, ast.Starred) for a in node.args):
            raise ExpressionError(f"in {_short(text)}: starred arguments are not allowed in {name}()")
        if len(node.args) != want:
            raise ExpressionError(f"in {_short(text)}: function {name!r} takes exactly {want} argument"
                                  f"{'s' if want > 1 else ''}, got {len(node.args)}")
        for a in node.args:
            _check(a, text, variables)
    else:
        raise ExpressionError(f"in {_short(text)}: {type(node).__name__} ({_short(ast.unparse(node))}) "
                              "is not allowed")


def _eval(node, env):
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        return env[node.id] if node.id in env else _CONSTANTS[node.id]
    if isinstance(node, ast.BinOp):
        return _BINARY[type(node.op)](_eval(node.left, env), _eval(node.right, env))
    if isinstance(node, ast.UnaryOp):
        return _UNARY[type(node.op)](_eval(node.operand, env))
    if isinstance(node, ast.Compare):
        left, out = _eval(node.left, env), True
        for op, right in zip(node.ops, node.comparators):
            right = _eval(right, env)
            out = np.logical_and(out, _COMPARE[type(op)](left, right))
            left = right
        return out
    return FUNCTIONS[node.func.id](*[_eval(a, env) for a in node.args])
