"""Arithmetic expressions of a case file (an inflow profile ``u(y, t)``), parsed and
evaluated without ``eval``: the text is read by :mod:`ast`, every node is checked against a
short list (numbers, the named variables, ``pi``, ``+ - * / **``, unary minus and a few
functions of numpy) and the tree is evaluated by walking it. Anything else is a
``ValueError`` that says what is allowed.

>>> f = Expression("1.5 * y * (1 - y) * (1 - cos(pi * t))", ("y", "t"))
>>> round(float(f(y=0.5, t=0.5)), 12)
0.375
"""

from __future__ import annotations

import ast
import operator

import numpy as np

FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
             "sqrt": np.sqrt, "tanh": np.tanh, "abs": np.abs, "min": np.minimum,
             "max": np.maximum}
CONSTANTS = {"pi": np.pi}
BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
          ast.Div: operator.truediv, ast.Pow: operator.pow}
UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}
MAX_LENGTH = 500


class Expression:
    """A checked arithmetic expression of the variables ``names``; call it with them as
    keyword arguments (numbers or numpy arrays)."""

    def __init__(self, text: str, names: tuple[str, ...]):
        if len(text) > MAX_LENGTH:
            raise ValueError(f"expression longer than {MAX_LENGTH} characters")
        self.text = text
        self.names = tuple(names)
        try:
            tree = ast.parse(text, mode="eval")
        except SyntaxError as e:
            raise ValueError(f"not an arithmetic expression ({e.msg}): {text!r}") from None
        self._check(tree.body)
        self.tree = tree.body

    def allowed(self) -> str:
        return (f"numbers, the variables {', '.join(self.names)}, pi, + - * / ** and "
                f"the functions {', '.join(FUNCTIONS)}")

    def _check(self, node):
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, int | float):
                raise ValueError(f"{node.value!r} is not a number; allowed: {self.allowed()}")
        elif isinstance(node, ast.Name):
            if node.id not in self.names and node.id not in CONSTANTS:
                raise ValueError(f"unknown name {node.id!r}; allowed: {self.allowed()}")
        elif isinstance(node, ast.BinOp) and type(node.op) in BINARY:
            self._check(node.left)
            self._check(node.right)
        elif isinstance(node, ast.UnaryOp) and type(node.op) in UNARY:
            self._check(node.operand)
        elif isinstance(node, ast.Call):
            if (not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS
                    or node.keywords):
                raise ValueError(f"only the functions {', '.join(FUNCTIONS)} may be called "
                                 f"(positional arguments); allowed: {self.allowed()}")
            for a in node.args:
                self._check(a)
        else:
            raise ValueError(f"{type(node).__name__} is not allowed; allowed: {self.allowed()}")

    def __call__(self, **values):
        return self._eval(self.tree, values)

    def _eval(self, node, values):
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.Name):
            return values[node.id] if node.id in self.names else CONSTANTS[node.id]
        if isinstance(node, ast.BinOp):
            return BINARY[type(node.op)](self._eval(node.left, values),
                                         self._eval(node.right, values))
        if isinstance(node, ast.UnaryOp):
            return UNARY[type(node.op)](self._eval(node.operand, values))
        return FUNCTIONS[node.func.id](*(self._eval(a, values) for a in node.args))
