"""roslaunch substitution args: $(arg), $(find), $(env), $(optenv), $(anon), $(dirname) and $(eval).

Semantics of roslaunch's substitution_args: `$(eval expr)` must be the whole attribute and is a Python expression
over arg(), env(), optenv(), find(), anon(), dirname(), true/false, math's functions and the args by bare name
(their values converted as a `type="auto"` param); the others are replaced where they stand, `$(find)` last.
Unlike roslaunch, $(eval) is not Python's eval(): its syntax tree is evaluated over a whitelist (names, literals,
arithmetic, comparisons, boolean and conditional operators, subscripts, calls of those functions), so a launch file
cannot reach anything else (no attribute access, lambda, comprehension or generator).
"""

from __future__ import annotations

import ast
import builtins
import math
import operator
import os
import re
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, overload

from racecar_sim.launch.errors import SubstitutionError

COMMANDS = ("arg", "env", "optenv", "find", "anon", "dirname", "eval")
_SUBST = re.compile(r"\$\(([^()]*)\)")
_EVAL_BUILTINS = {name: getattr(builtins, name) for name in ("list", "dict", "map", "str", "float", "int")}


def convert_value(text: str, kind: str = "auto") -> Any:
    """roslaunch's convert_value: a param's text as its `type` (auto: int, float, bool or the string)."""
    kind = (kind or "auto").lower().strip()
    if kind == "auto":
        try:
            return float(text) if "." in text else int(text)
        except ValueError:
            pass
        return convert_value(text, "bool") if text.strip().lower() in ("true", "false") else text
    if kind in ("str", "string"):
        return text
    if kind == "int":
        return int(text.strip())
    if kind in ("double", "float"):
        return float(text.strip())
    if kind in ("bool", "boolean"):
        value = text.strip().lower()
        if value in ("true", "1"):
            return True
        if value in ("false", "0"):
            return False
        raise ValueError(f"{text!r} is not a boolean")
    if kind == "yaml":
        import yaml

        return yaml.safe_load(text)
    raise ValueError(f"unknown param type {kind!r}")


def _find_package(name: str) -> Path:
    from racecar_sim.description.ros_packages import (
        find_package,  # helper module of the package path (ROS_PACKAGE_PATH)
    )

    return find_package(name)


@dataclass
class Context:
    """What substitutions see: the args visible here, the current file, and the run's $(anon) names."""

    args: Mapping[str, str]
    filename: Path | None = None
    anon: dict[str, str] = field(default_factory=dict)
    find: Callable[[str], Path] = _find_package

    def arg(self, name: str) -> str:
        if name not in self.args:
            raise SubstitutionError(
                f"$(arg {name}): no arg {name!r} is declared here; "
                f'declare it with <arg name="{name}" default="..."/> or pass it in'
            )
        return self.args[name]

    def env(self, name: str) -> str:
        if name not in os.environ:
            raise SubstitutionError(
                f"$(env {name}): environment variable {name} is not set; set it, or use $(optenv {name} DEFAULT)"
            )
        return os.environ[name]

    @staticmethod
    def optenv(name: str, default: str = "") -> str:
        return os.environ.get(name, default)

    def find_path(self, name: str) -> str:
        return str(self.find(name))

    def anon_name(self, name: str) -> str:
        if name not in self.anon:
            self.anon[name] = f"{name}_{uuid.uuid4().hex[:12]}"
        return self.anon[name]

    def dirname(self) -> str:
        if self.filename is None:
            raise SubstitutionError("$(dirname): no launch file is known here")
        return str(Path(self.filename).resolve().parent)


@overload
def resolve(text: str, ctx: Context) -> str: ...
@overload
def resolve(text: None, ctx: Context) -> None: ...
@overload
def resolve(text: str | None, ctx: Context) -> str | None: ...
def resolve(text: str | None, ctx: Context) -> str | None:
    """`text` with every substitution resolved (None stays None)."""
    if not text:
        return text
    if text.startswith("$(eval ") and text.endswith(")"):
        return _eval(text[7:-1], ctx)
    text = _replace(text, ctx, find=False)
    return _replace(text, ctx, find=True)


def _replace(text: str, ctx: Context, find: bool) -> str:
    def one(match: re.Match[str]) -> str:
        words = match.group(1).split()
        if not words:
            raise SubstitutionError(f"empty substitution {match.group(0)}; write $(arg NAME), $(find PKG), ...")
        command, rest = words[0], words[1:]
        if command not in COMMANDS:
            raise SubstitutionError(
                f"unknown substitution {match.group(0)}; use one of {', '.join(f'$({c} ...)' for c in COMMANDS)}"
            )
        if (command == "find") != find:
            return match.group(0)
        return _command(command, rest, match.group(0), ctx)

    return _SUBST.sub(one, text)


def _command(command: str, rest: list[str], whole: str, ctx: Context) -> str:
    expects = {"arg": (1, 1), "env": (1, 1), "find": (1, 1), "anon": (1, 1), "dirname": (0, 0), "optenv": (1, 99)}
    if command == "eval":
        raise SubstitutionError(f"{whole}: $(eval ...) must be the whole attribute value")
    low, high = expects[command]
    if not low <= len(rest) <= high:
        raise SubstitutionError(
            f"{whole}: $({command}) takes {low if low == high else f'{low} or more'} argument{'s' if high != 1 else ''}"
        )
    if command == "arg":
        return ctx.arg(rest[0])
    if command == "env":
        return ctx.env(rest[0])
    if command == "optenv":
        return ctx.optenv(rest[0], " ".join(rest[1:]))
    if command == "find":
        return ctx.find_path(rest[0])
    if command == "anon":
        return ctx.anon_name(rest[0])
    return ctx.dirname()


class _Names(dict[str, Any]):
    """eval's namespace: the functions first, then the args by bare name (converted as type="auto")."""

    def __init__(self, ctx: Context, functions: dict[str, Any]) -> None:
        super().__init__(functions)
        self.ctx = ctx

    def __missing__(self, key: str) -> Any:
        if key in self.ctx.args:
            return convert_value(self.ctx.args[key])
        raise KeyError(key)


def _eval(expression: str, ctx: Context) -> str:
    """$(eval): the expression evaluated node by node over a whitelist of Python's syntax (_Evaluator), never
    handed to Python's eval(): a launch file computes values with it, it runs no code."""
    if "__" in expression:
        raise SubstitutionError(f"$(eval {expression}): double underscores are not allowed in $(eval)")
    functions: dict[str, Any] = {name: value for name, value in vars(math).items() if not name.startswith("_")}
    functions.update(_EVAL_BUILTINS)
    functions.update(
        {
            "true": True,
            "false": False,
            "True": True,
            "False": False,
            "arg": lambda name: convert_value(ctx.arg(name)),
            "env": ctx.env,
            "optenv": ctx.optenv,
            "find": ctx.find_path,
            "anon": ctx.anon_name,
            "dirname": ctx.dirname,
        }
    )
    try:
        tree = ast.parse(expression.strip(), mode="eval")
    except SyntaxError as exc:
        raise SubstitutionError(f"$(eval {expression}): not a Python expression ({exc.msg})") from None
    try:
        return str(_Evaluator(_Names(ctx, functions), expression).value(tree.body))
    except SubstitutionError:
        raise
    except KeyError as exc:
        raise SubstitutionError(
            f"$(eval {expression}): name {exc.args[0]!r} is not defined; declare the arg or fix the name"
        ) from None
    except Exception as exc:  # a user's expression can raise anything
        raise SubstitutionError(f"$(eval {expression}) failed: {type(exc).__name__}: {exc}") from None


_BINARY: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv,
    ast.Mod: operator.mod,
    ast.Pow: operator.pow,
}
_UNARY: dict[type, Callable[[Any], Any]] = {ast.UAdd: operator.pos, ast.USub: operator.neg, ast.Not: operator.not_}
_COMPARE: dict[type, Callable[[Any, Any], Any]] = {
    ast.Eq: operator.eq,
    ast.NotEq: operator.ne,
    ast.Lt: operator.lt,
    ast.LtE: operator.le,
    ast.Gt: operator.gt,
    ast.GtE: operator.ge,
    ast.In: lambda a, b: a in b,
    ast.NotIn: lambda a, b: a not in b,
    ast.Is: operator.is_,
    ast.IsNot: operator.is_not,
}
_LARGEST = 10**6  # elements a repetition (`'ab' * n`) may make, bits a power may have: values, not memory bombs
_ALLOWED = (
    "the args by name, literals, + - * / // % **, comparisons, and/or/not, `a if c else b`, [], and calls "
    "of arg(), find(), env(), optenv(), anon(), dirname(), str(), int(), float(), list(), dict(), map() and "
    "math's functions"
)


class _Evaluator:
    """Evaluates the AST of a $(eval) expression; a node of any kind it does not list (attribute access, lambda,
    comprehension, generator, walrus, f-string...) is refused before it is reached, with the whole expression."""

    def __init__(self, names: _Names, expression: str) -> None:
        self.names, self.expression = names, expression
        self.functions = {id(value) for value in names.values() if callable(value)}

    def refuse(self, node: ast.AST, why: str = "") -> SubstitutionError:
        what = why or f"{_describe(node)} is not allowed"
        return SubstitutionError(f"$(eval {self.expression}): {what}; $(eval) takes expressions only: {_ALLOWED}")

    def value(self, node: ast.AST) -> Any:
        for inner in ast.walk(node):  # the whole tree first: nothing is evaluated if any part is refused
            if not isinstance(inner, _NODES):
                raise self.refuse(inner)
        return self._value(node)

    def _value(self, node: ast.AST) -> Any:  # one branch per kind of node, as ast lists them
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.Name):
            return self.names[node.id]
        if isinstance(node, ast.BinOp):
            left, right = self._value(node.left), self._value(node.right)
            _check_size(node.op, left, right)
            return _BINARY[type(node.op)](left, right)
        if isinstance(node, ast.UnaryOp):
            return _UNARY[type(node.op)](self._value(node.operand))
        if isinstance(node, ast.BoolOp):
            result = None
            for operand in node.values:  # short-circuit, as Python's and/or
                result = self._value(operand)
                if bool(result) == isinstance(node.op, ast.Or):
                    break
            return result
        if isinstance(node, ast.Compare):
            left = self._value(node.left)
            for op, comparator in zip(node.ops, node.comparators):
                right = self._value(comparator)
                if not _COMPARE[type(op)](left, right):
                    return False
                left = right
            return True
        if isinstance(node, ast.IfExp):
            return self._value(node.body) if self._value(node.test) else self._value(node.orelse)
        if isinstance(node, ast.Call):
            function = self._value(node.func)
            if not isinstance(node.func, ast.Name) or id(function) not in self.functions:
                raise self.refuse(node, f"{ast.unparse(node.func)} is not a function $(eval) may call")
            args = [self._value(a) for a in node.args]
            # `f(**m)` has arg None: Python's call refuses it ("keywords must be strings"), the message $(eval) gives
            return function(*args, **{k.arg: self._value(k.value) for k in node.keywords})  # type: ignore[arg-type]
        if isinstance(node, ast.Subscript):
            return self._value(node.value)[self._value(node.slice)]
        if isinstance(node, ast.Slice):
            return slice(*(None if part is None else self._value(part) for part in (node.lower, node.upper, node.step)))
        if isinstance(node, (ast.List, ast.Tuple, ast.Set)):
            items = [self._value(e) for e in node.elts]
            return {ast.List: list, ast.Tuple: tuple, ast.Set: set}[type(node)](items)
        if isinstance(node, ast.Dict):
            # `{**m}` has key None: _value refuses it ("NoneType is not allowed")
            return {self._value(k): self._value(v) for k, v in zip(node.keys, node.values)}  # type: ignore[arg-type]
        raise self.refuse(node)


# Every kind of node an $(eval) may hold (with their operators and the Load context); nothing else is evaluated.
_NODES = (
    ast.Constant,
    ast.Name,
    ast.Load,
    ast.BinOp,
    ast.UnaryOp,
    ast.BoolOp,
    ast.And,
    ast.Or,
    ast.Compare,
    ast.IfExp,
    ast.Call,
    ast.keyword,
    ast.Subscript,
    ast.Slice,
    ast.List,
    ast.Tuple,
    ast.Set,
    ast.Dict,
    *_BINARY,
    *_UNARY,
    *_COMPARE,
)


def _describe(node: ast.AST) -> str:
    """How a refused node reads in the message: its source and what Python calls it."""
    kinds = {
        ast.Attribute: "attribute access",
        ast.Lambda: "a lambda",
        ast.NamedExpr: "an assignment (:=)",
        ast.GeneratorExp: "a generator",
        ast.ListComp: "a comprehension",
        ast.SetComp: "a comprehension",
        ast.DictComp: "a comprehension",
        ast.JoinedStr: "an f-string",
        ast.Starred: "unpacking (*)",
    }
    kind = kinds.get(type(node), type(node).__name__)
    try:
        text = ast.unparse(node)
    except Exception:  # an operator or context node has no source of its own
        text = ""
    return f"{kind} `{text}`" if text and len(text) <= 60 else kind


def _check_size(op: ast.operator, left: Any, right: Any) -> None:
    """Refuse a repetition or power whose result would be huge (a value for a launch file is small)."""
    if isinstance(op, ast.Mult):
        for seq, times in ((left, right), (right, left)):
            if isinstance(seq, (str, bytes, list, tuple)) and isinstance(times, int) and len(seq) * times > _LARGEST:
                raise ValueError(f"the repetition makes {len(seq) * times} elements (at most {_LARGEST})")
    if (
        isinstance(op, ast.Pow)
        and isinstance(left, int)
        and isinstance(right, int)
        and abs(left) > 1
        and right * left.bit_length() > _LARGEST
    ):
        raise ValueError(f"{left} ** {right} is too large (more than {_LARGEST} bits)")
