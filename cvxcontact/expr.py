"""A restricted evaluator for load expressions in scene files, e.g. ``"-2e9 * (1 + cos(pi * x))"``.

The text is parsed with :mod:`ast` and walked node by node; only numbers, the
variables ``x`` and ``y`` (metres), the constants ``pi`` and ``e``, the operators
``+ - * / ** %``, comparisons, and the whitelisted NumPy functions below are
accepted. Nothing is ever passed to ``eval`` or ``exec``: a scene file is data.
"""

from __future__ import annotations

import ast
import operator

import numpy as np

__all__ = ["Expression", "ExpressionError", "FUNCTIONS"]

FUNCTIONS = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "arcsin": np.arcsin, "arccos": np.arccos, "arctan": np.arctan,
    "arctan2": np.arctan2, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh, "exp": np.exp, "log": np.log,
    "log10": np.log10, "sqrt": np.sqrt, "abs": np.abs, "minimum": np.minimum, "maximum": np.maximum,
    "where": np.where, "heaviside": lambda a: np.heaviside(a, 0.5),
}
_CONSTANTS = {"pi": np.pi, "e": np.e}
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow, ast.Mod: operator.mod}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_COMPARE = {ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge}
_MAX_LENGTH = 1000


class ExpressionError(ValueError):
    """An expression uses a name, operator or construct outside the whitelist, or is malformed."""


class Expression:
    """A parsed, validated expression in x and y; call it with arrays: ``expr(x, y)``."""

    def __init__(self, text: str):
        if not isinstance(text, str):
            raise ExpressionError(f"an expression must be a string, got {type(text).__name__}")
        if len(text) > _MAX_LENGTH:
            raise ExpressionError(f"expression longer than {_MAX_LENGTH} characters")
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as exc:
            raise ExpressionError(f"cannot parse {text!r}: {exc.msg}") from None
        self.text = text
        self._body = tree.body
        _check(self._body, text)

    def __repr__(self):
        return f"Expression({self.text!r})"

    def __call__(self, x, y):
        with np.errstate(all="ignore"):  # NaN/inf are reported by the caller, naming the load
            return np.asarray(_eval(self._body, {"x": x, "y": y}), dtype=float) + 0.0 * x


def _check(node, text):
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise ExpressionError(f"in {text!r}: only numbers are allowed as constants, got {node.value!r}")
    elif isinstance(node, ast.Name):
        if node.id not in ("x", "y") and node.id not in _CONSTANTS:
            raise ExpressionError(f"in {text!r}: unknown name {node.id!r}; allowed: x, y, pi, e and functions "
                                  f"{sorted(FUNCTIONS)}")
    elif isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        _check(node.left, text)
        _check(node.right, text)
    elif isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        _check(node.operand, text)
    elif isinstance(node, ast.Compare) and all(type(op) in _COMPARE for op in node.ops):
        for n in [node.left, *node.comparators]:
            _check(n, text)
    elif isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            name = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
            raise ExpressionError(f"in {text!r}: function {name!r} is not allowed; allowed: {sorted(FUNCTIONS)}")
        if node.keywords:
            raise ExpressionError(f"in {text!r}: keyword arguments are not allowed")
        for a in node.args:
            _check(a, text)
    else:
        raise ExpressionError(f"in {text!r}: {type(node).__name__} ({ast.unparse(node)!r}) is not allowed")


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
    return FUNCTIONS[node.func.id](*(_eval(a, env) for a in node.args))
