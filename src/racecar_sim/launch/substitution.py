"""roslaunch substitution args: $(arg), $(find), $(env), $(optenv), $(anon), $(dirname) and $(eval).

Semantics of roslaunch's substitution_args: `$(eval expr)` must be the whole attribute and is a Python expression
over arg(), env(), optenv(), find(), anon(), dirname(), true/false, math's functions and the args by bare name
(their values converted as a `type="auto"` param); the others are replaced where they stand, `$(find)` last.
"""

from __future__ import annotations

import builtins
import math
import os
import re
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

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
    from racecar_sim.core.ros_packages import (
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
            raise SubstitutionError(f"$(arg {name}): no arg {name!r} is declared here; "
                                    f"declare it with <arg name=\"{name}\" default=\"...\"/> or pass it in")
        return self.args[name]

    def env(self, name: str) -> str:
        if name not in os.environ:
            raise SubstitutionError(f"$(env {name}): environment variable {name} is not set; set it, "
                                    f"or use $(optenv {name} DEFAULT)")
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


def resolve(text: str | None, ctx: Context) -> str | None:
    """`text` with every substitution resolved (None stays None)."""
    if not text:
        return text
    if text.startswith("$(eval ") and text.endswith(")"):
        return _eval(text[7:-1], ctx)
    text = _replace(text, ctx, find=False)
    return _replace(text, ctx, find=True)


def _replace(text: str, ctx: Context, find: bool) -> str:
    def one(match: re.Match) -> str:
        words = match.group(1).split()
        if not words:
            raise SubstitutionError(f"empty substitution {match.group(0)}; write $(arg NAME), $(find PKG), ...")
        command, rest = words[0], words[1:]
        if command not in COMMANDS:
            raise SubstitutionError(f"unknown substitution {match.group(0)}; use one of "
                                    f"{', '.join(f'$({c} ...)' for c in COMMANDS)}")
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
        raise SubstitutionError(f"{whole}: $({command}) takes {low if low == high else f'{low} or more'} "
                                f"argument{'s' if high != 1 else ''}")
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


class _Names(dict):
    """eval's namespace: the functions first, then the args by bare name (converted as type="auto")."""

    def __init__(self, ctx: Context, functions: dict[str, Any]) -> None:
        super().__init__(functions)
        self.ctx = ctx

    def __missing__(self, key: str) -> Any:
        if key in self.ctx.args:
            return convert_value(self.ctx.args[key])
        raise KeyError(key)


def _eval(expression: str, ctx: Context) -> str:
    if "__" in expression:
        raise SubstitutionError(f"$(eval {expression}): double underscores are not allowed in $(eval)")
    functions: dict[str, Any] = {name: value for name, value in vars(math).items() if not name.startswith("_")}
    functions.update({"true": True, "false": False, "True": True, "False": False,
                      "arg": lambda name: convert_value(ctx.arg(name)), "env": ctx.env, "optenv": ctx.optenv,
                      "find": ctx.find_path, "anon": ctx.anon_name, "dirname": ctx.dirname})
    try:
        return str(eval(expression, {"__builtins__": _EVAL_BUILTINS}, _Names(ctx, functions)))
    except SubstitutionError:
        raise
    except NameError as exc:
        raise SubstitutionError(f"$(eval {expression}): {exc}; declare the arg or fix the name") from None
    except Exception as exc:  # a user's expression can raise anything
        raise SubstitutionError(f"$(eval {expression}) failed: {type(exc).__name__}: {exc}") from None
