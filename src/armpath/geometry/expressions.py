"""Safe arithmetic expressions of one parameter, for curves given in scene files.

An expression such as ``"210 + 150*cos(t)"`` is parsed with :mod:`ast` and checked node by node
against a whitelist (numbers, the parameter, ``+ - * / **``, unary minus, and the functions and
constants in :data:`FUNCTIONS` and :data:`CONSTANTS`); it is never passed to ``eval``. The
result evaluates vectorized over a numpy array of parameter values.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.errors import InvalidInputError

FloatArray = NDArray[np.float64]

#: Functions an expression may call (one argument each, except ``atan2``, ``min``, ``max``).
FUNCTIONS: dict[str, Callable[..., FloatArray]] = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "asin": np.arcsin,
    "acos": np.arccos,
    "atan": np.arctan,
    "atan2": np.arctan2,
    "sinh": np.sinh,
    "cosh": np.cosh,
    "tanh": np.tanh,
    "exp": np.exp,
    "log": np.log,
    "sqrt": np.sqrt,
    "abs": np.abs,
    "min": np.minimum,
    "max": np.maximum,
}
#: Named constants.
CONSTANTS: dict[str, float] = {"pi": float(np.pi), "e": float(np.e), "tau": float(2 * np.pi)}
_ARITY = {"atan2": 2, "min": 2, "max": 2}
_BINARY: dict[type, Callable[[FloatArray, FloatArray], FloatArray]] = {
    ast.Add: np.add,
    ast.Sub: np.subtract,
    ast.Mult: np.multiply,
    ast.Div: np.divide,
    ast.Pow: np.power,
}
#: Longest expression accepted (characters; the README lists it among the limits).
_MAX_LENGTH = 2000
#: Deepest nesting of operations and calls (``-(-(-t))`` is 3 deep; a sum of n terms n - 1):
#: checking and evaluating recurse once per level, within Python's recursion limit.
_MAX_DEPTH = 400


@dataclass(frozen=True)
class Expression:
    """A parsed expression of the parameter ``variable``; call it with parameter values."""

    text: str
    variable: str
    _tree: ast.expr

    def __call__(self, values: ArrayLike) -> FloatArray:
        v = np.asarray(values, dtype=np.float64)
        with np.errstate(all="ignore"):
            out = np.broadcast_to(np.asarray(_evaluate(self._tree, v, self.variable)), v.shape)
        return np.asarray(out, dtype=np.float64)


def parse_expression(text: str, variable: str = "t") -> Expression:
    """Parse ``text`` as an arithmetic expression of ``variable``.

    Raises :class:`InvalidInputError` naming the offending part when the text is not valid
    arithmetic, uses a name other than ``variable``, a constant or a listed function, or any
    other Python construct (attributes, subscripts, comprehensions, keyword arguments, ...).
    """
    if not isinstance(text, str) or not text.strip():
        raise InvalidInputError("expression must be a non-empty string")
    if len(text) > _MAX_LENGTH:
        raise InvalidInputError(f"expression longer than {_MAX_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval").body
    except SyntaxError as exc:
        shown = text if len(text) <= 80 else f"{text[:60]}...{text[-12:]}"
        why = exc.msg
        if "nested parentheses" in why:  # Python's parser takes at most 200 levels
            why += " (at most 200 levels of parentheses)"
        raise InvalidInputError(f"expression {shown!r} is not valid arithmetic: {why}") from None
    except (RecursionError, MemoryError):
        raise InvalidInputError(f"expression nests deeper than {_MAX_DEPTH} levels") from None
    _check(tree, text, variable)
    return Expression(text, variable, tree)


def _check(node: ast.AST, text: str, variable: str, depth: int = 0) -> None:
    if depth > _MAX_DEPTH:
        raise InvalidInputError(f"expression nests deeper than {_MAX_DEPTH} levels")
    allowed = ", ".join(sorted(FUNCTIONS))
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, int | float):
            raise InvalidInputError(f"expression {text!r}: only numbers are allowed as constants")
        return
    if isinstance(node, ast.Name):
        if node.id != variable and node.id not in CONSTANTS:
            raise InvalidInputError(
                f"expression {text!r}: unknown name {node.id!r} (use {variable!r}, "
                f"{', '.join(CONSTANTS)} or a function: {allowed})"
            )
        return
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        _check(node.left, text, variable, depth + 1)
        _check(node.right, text, variable, depth + 1)
        return
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
        _check(node.operand, text, variable, depth + 1)
        return
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            name = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
            raise InvalidInputError(
                f"expression {text!r}: unknown function {name!r} (allowed: {allowed})"
            )
        if node.keywords or len(node.args) != _ARITY.get(node.func.id, 1):
            raise InvalidInputError(
                f"expression {text!r}: {node.func.id} takes "
                f"{_ARITY.get(node.func.id, 1)} positional argument(s)"
            )
        for arg in node.args:
            _check(arg, text, variable, depth + 1)
        return
    raise InvalidInputError(
        f"expression {text!r}: {type(node).__name__} is not allowed "
        "(numbers, the parameter, + - * / **, and functions only)"
    )


def _evaluate(node: ast.expr, t: FloatArray, variable: str) -> FloatArray:
    if isinstance(node, ast.Constant):
        assert isinstance(node.value, int | float)
        return np.asarray(float(node.value))
    if isinstance(node, ast.Name):
        return t if node.id == variable else np.asarray(CONSTANTS[node.id])
    if isinstance(node, ast.BinOp):
        op = _BINARY[type(node.op)]
        return op(_evaluate(node.left, t, variable), _evaluate(node.right, t, variable))
    if isinstance(node, ast.UnaryOp):
        value = _evaluate(node.operand, t, variable)
        return -value if isinstance(node.op, ast.USub) else value
    assert isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
    args = [_evaluate(a, t, variable) for a in node.args]
    return FUNCTIONS[node.func.id](*args)
