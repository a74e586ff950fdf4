"""roslaunch XML -> a LaunchPlan, following roslaunch's xmlloader: args and their scoping, includes, groups,
namespaces, if/unless, params (value, type, textfile, command), rosparam, remaps, env and nodes.

<machine>, <test> and <master> are left out with a note: the sim runs everything on this machine and has no tests.
"""

from __future__ import annotations

import logging
import shlex
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, overload

import yaml

from racecar_sim.core.errors import ConfigError
from racecar_sim.launch.errors import LaunchError, SubstitutionError, Where
from racecar_sim.launch.param_command import run_param_command
from racecar_sim.launch.plan import LaunchPlan, NodeSpec
from racecar_sim.launch.rosnames import (
    PRIVATE,
    SEP,
    canonical,
    child_ns,
    global_ns,
    ns_join,
)
from racecar_sim.launch.substitution import Context, convert_value, resolve
from racecar_sim.launch.xml_tree import Tag, parse_file

log = logging.getLogger("racecar_sim.launch")
MAX_DEPTH = 32  # includes within includes: deeper is a loop
IGNORED = {
    "machine": "the sim runs every node on this machine",
    "test": "rostest tests are not run by the sim",
    "master": "the master is the bridge's (--ros)",
}


@dataclass
class _Scope:
    """roslaunch's LoaderContext: namespace, args, launch-scoped remaps, env and private params."""

    file: Path
    ns: str
    args: dict[str, str]
    passed: dict[str, str]  # what the includer (or the command line) gave this file
    declared: set[str]  # arg names this file declares (shared by its groups)
    remaps: list[tuple[str, str]] = field(default_factory=list)
    env: list[tuple[str, str]] = field(default_factory=list)
    private: list[tuple[str, Any]] = field(default_factory=list)
    anon: dict[str, str] = field(default_factory=dict)
    top: bool = False
    lenient: bool = False  # pass_all_args: undeclared passed args are no error

    def child(self, ns: str | None) -> _Scope:
        return replace(
            self,
            ns=child_ns(self.ns, ns),
            args=dict(self.args),
            remaps=list(self.remaps),
            env=list(self.env),
            private=list(self.private),
        )

    def context(self) -> Context:
        return Context(self.args, self.file, self.anon)


def load_launch(path: str | Path, args: Mapping[str, str] | None = None) -> LaunchPlan:
    """Read `path` with the command line's `name:=value` args; LaunchError (one line) for what roslaunch rejects."""
    path = Path(path)
    if not path.is_file():
        raise LaunchError(path, "no such launch file", "check the path")
    plan = LaunchPlan(path.resolve())
    scope = _Scope(path, SEP, {}, dict(args or {}), set(), top=True)
    _Loader(plan).load_file(path, scope, depth=0)
    plan.args = {name: scope.args[name] for name in scope.declared if name in scope.args}
    return plan


class _Loader:
    def __init__(self, plan: LaunchPlan) -> None:
        self.plan = plan

    # --- files and elements --------------------------------------------------------------------
    def load_file(self, path: Path, scope: _Scope, depth: int) -> None:
        root = parse_file(path)
        if root.name != "launch":
            raise LaunchError(
                Where(path, root.line, root.describe()),
                "the root element is not <launch>",
                "a roslaunch file holds <launch> ... </launch>",
            )
        self.children(root, scope, depth)
        unused = [] if scope.lenient else sorted(set(scope.passed) - scope.declared)
        if unused:
            how = "on the command line" if scope.top else "by the <include>"
            raise LaunchError(
                path,
                f"arg{'s' if len(unused) > 1 else ''} {', '.join(unused)} given {how} "
                f"{'are' if len(unused) > 1 else 'is'} not declared in this file",
                f'declare it with <arg name="{unused[0]}" default="..."/> or drop it',
            )

    def children(self, tag: Tag, scope: _Scope, depth: int) -> None:
        for child in tag.children:
            if not self.active(child, scope):
                continue
            handler = getattr(self, f"tag_{child.name}", None)
            if handler is not None:
                handler(child, scope, depth)
            elif child.name in IGNORED:
                self.note(f"{self.where(child, scope)}: ignored ({IGNORED[child.name]})")
            else:
                self.note(f"{self.where(child, scope)}: unknown element, ignored")

    def tag_group(self, tag: Tag, scope: _Scope, depth: int) -> None:
        self.children(tag, scope.child(self.attr(tag, scope, "ns")), depth)

    def tag_arg(self, tag: Tag, scope: _Scope, depth: int) -> None:
        name = self.attr(tag, scope, "name", required=True)
        value, default = self.attr(tag, scope, "value"), self.attr(tag, scope, "default")
        where = self.where(tag, scope)
        if value is not None and default is not None:
            raise LaunchError(where, "an <arg> has value= or default=, not both", "keep one")
        if name in scope.args:
            raise LaunchError(where, f"arg {name!r} is declared twice", "declare each arg once")
        scope.declared.add(name)
        if value is not None:
            if name in scope.passed:
                raise LaunchError(
                    where,
                    f"arg {name!r} has a fixed value= and cannot be set from outside",
                    "use default= to let it be overridden",
                )
            scope.args[name] = value
        elif name in scope.passed:
            scope.args[name] = scope.passed[name]
        elif default is not None:
            scope.args[name] = default
        else:
            how = (
                f"on the command line as {name}:=VALUE"
                if scope.top
                else f'in the <include> with <arg name="{name}" value="..."/>'
            )
            raise LaunchError(where, f"arg {name!r} has no value", f'give it {how}, or add default="..."')

    def tag_include(self, tag: Tag, scope: _Scope, depth: int) -> None:
        where = self.where(tag, scope)
        if depth >= MAX_DEPTH:
            raise LaunchError(
                where, f"includes nest deeper than {MAX_DEPTH}", "an include includes itself: break the loop"
            )
        file = Path(self.attr(tag, scope, "file", required=True))
        inner = scope.child(self.attr(tag, scope, "ns"))
        pass_all = self.boolean(tag, scope, "pass_all_args", False)
        passed = dict(scope.args) if pass_all else {}
        for child in tag.children:
            if not self.active(child, scope):
                continue
            if child.name == "arg":
                name = self.attr(child, scope, "name", required=True)
                value = self.attr(child, scope, "value")
                value = self.attr(child, scope, "default") if value is None else value
                if value is None:
                    raise LaunchError(
                        self.where(child, scope), f'<arg name="{name}"> in an <include> has no value', 'add value="..."'
                    )
                passed[name] = value
            elif child.name == "env":
                self.tag_env(child, inner, depth)
            else:
                self.note(f"{self.where(child, scope)}: ignored inside <include> (it takes <arg> and <env>)")
        if not file.is_file():
            raise LaunchError(
                where,
                f"included file {file} does not exist",
                "check the path and the package $(find ...) resolves to (--package-path DIR)",
            )
        included = _Scope(file, inner.ns, {}, passed, set(), inner.remaps, inner.env, inner.private, scope.anon)
        included.lenient = pass_all  # args passed along but not declared there are fine, as in roslaunch
        self.load_file(file, included, depth + 1)

    def tag_param(self, tag: Tag, scope: _Scope, depth: int, node: str | None = None) -> None:
        where = self.where(tag, scope)
        name = self.attr(tag, scope, "name", required=True)
        kind = (tag.attrs.get("type") or "auto").strip().lower()
        sources = {key: self.attr(tag, scope, key) for key in ("value", "textfile", "binfile", "command")}
        given = [(key, text) for key, text in sources.items() if text is not None]
        if len(given) != 1:
            raise LaunchError(
                where, "a <param> needs exactly one of value=, textfile=, binfile=, command=", "keep one of them"
            )
        source, text = given[0]
        try:
            if source == "value":
                value: Any = convert_value(text, kind)
            elif source in ("textfile", "binfile"):
                raw = Path(text).read_bytes()
                text_kind = "string" if kind == "auto" else kind  # a textfile's text stays text
                value = raw if source == "binfile" else convert_value(raw.decode(), text_kind)
            else:
                output = run_param_command(text)
                value = output if kind in ("auto", "str", "string") else convert_value(output, kind)
        except SubstitutionError as exc:
            raise LaunchError(where, str(exc)) from None
        except OSError as exc:
            raise LaunchError(where, f"cannot read {text} ({exc.strerror or exc})", "check the path") from None
        except (ValueError, yaml.YAMLError) as exc:
            raise LaunchError(where, f"value does not fit type={kind!r} ({exc})", "fix the value or the type") from None
        if node is not None:
            self.plan.set_param(name if name.startswith(SEP) else f"{node}{SEP}{name.lstrip(PRIVATE)}", value)
        elif name.startswith(PRIVATE):
            scope.private.append((name[1:], value))
        else:
            self.plan.set_param(ns_join(scope.ns, name), value)

    def tag_rosparam(self, tag: Tag, scope: _Scope, depth: int, node: str | None = None) -> None:
        where = self.where(tag, scope)
        command = self.attr(tag, scope, "command") or "load"
        file = self.attr(tag, scope, "file")
        param = ns_join(self.attr(tag, scope, "ns") or "", self.attr(tag, scope, "param") or "")
        base = global_ns(node) if node is not None else scope.ns
        full = canonical(ns_join(base, param.lstrip(PRIVATE))) if param else canonical(base) or SEP
        if command == "dump":
            self.note(f"{where}: rosparam dump ignored")
            return
        if command == "delete":
            self.plan.delete_param(full)
            return
        if command != "load":
            raise LaunchError(where, f"rosparam command {command!r} is not load, dump or delete", "fix command=")
        try:
            text = Path(file).read_text() if file is not None else tag.text
        except OSError as exc:
            raise LaunchError(where, f"cannot read {file} ({exc.strerror or exc})", "check the path") from None
        if self.boolean(tag, scope, "subst_value", False):
            text = self.resolve(text, scope, where)
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise LaunchError(
                where, f"bad YAML in {file or 'the <rosparam> text'}: {' '.join(str(exc).split())}", "fix the YAML"
            ) from None
        data = {} if data is None else data
        if full == SEP and not isinstance(data, dict):
            raise LaunchError(where, "a YAML that is not a mapping needs a name", 'add param="NAME"')
        self.plan.set_param(full, data, Path(file) if file is not None else None)

    def tag_remap(self, tag: Tag, scope: _Scope, depth: int) -> None:
        scope.remaps.append(self.remap(tag, scope))

    def tag_env(self, tag: Tag, scope: _Scope, depth: int) -> None:
        scope.env.append((self.attr(tag, scope, "name", required=True), self.attr(tag, scope, "value", required=True)))

    def tag_node(self, tag: Tag, scope: _Scope, depth: int) -> None:
        where = self.where(tag, scope)
        name = self.attr(tag, scope, "name", required=True)
        package, node_type = self.attr(tag, scope, "pkg", required=True), self.attr(tag, scope, "type", required=True)
        ns = child_ns(scope.ns, self.attr(tag, scope, "ns"))
        args_text = self.attr(tag, scope, "args") or ""
        try:
            args = tuple(shlex.split(args_text))
        except ValueError:
            args = tuple(args_text.split())
        remaps, env = list(scope.remaps), list(scope.env)
        full_name = canonical(ns + name)
        for key, value in scope.private:
            self.plan.set_param(f"{full_name}{SEP}{key}", value)
        for child in tag.children:
            if not self.active(child, scope):
                continue
            if child.name == "remap":
                remaps.append(self.remap(child, scope))
            elif child.name == "param":
                self.tag_param(child, scope, depth, node=full_name)
            elif child.name == "rosparam":
                self.tag_rosparam(child, scope, depth, node=full_name)
            elif child.name == "env":
                env.append(
                    (self.attr(child, scope, "name", required=True), self.attr(child, scope, "value", required=True))
                )
            else:
                self.note(f"{self.where(child, scope)}: unknown element inside <node>, ignored")
        self.plan.nodes.append(
            NodeSpec(
                package,
                node_type,
                name,
                ns,
                args,
                tuple(remaps),
                tuple(env),
                required=self.boolean(tag, scope, "required", False),
                respawn=self.boolean(tag, scope, "respawn", False),
                output=self.attr(tag, scope, "output") or "log",
                launch_prefix=self.attr(tag, scope, "launch-prefix") or "",
                where=where,
            )
        )

    def note(self, text: str) -> None:
        """Something of the launch file the sim leaves out: kept in the plan and shown as a warning."""
        self.plan.notes.append(text)
        log.warning("%s", text)

    # --- attributes ----------------------------------------------------------------------------
    def where(self, tag: Tag, scope: _Scope) -> Where:
        return Where(scope.file, tag.line, tag.describe())

    def resolve(self, text: str, scope: _Scope, where: Where) -> str:
        try:
            return resolve(text, scope.context())
        except SubstitutionError as exc:
            raise LaunchError(where, str(exc)) from None
        except ConfigError as exc:  # a package $(find) cannot find
            raise LaunchError(where, str(exc)) from None

    @overload
    def attr(self, tag: Tag, scope: _Scope, key: str, required: Literal[True]) -> str: ...
    @overload
    def attr(self, tag: Tag, scope: _Scope, key: str, required: bool = False) -> str | None: ...
    def attr(self, tag: Tag, scope: _Scope, key: str, required: bool = False) -> str | None:
        """The attribute with its substitutions resolved; None if it is absent (LaunchError if `required`)."""
        if key not in tag.attrs:
            if required:
                raise LaunchError(self.where(tag, scope), f"<{tag.name}> needs a {key}= attribute", f'add {key}="..."')
            return None
        return self.resolve(tag.attrs[key], scope, self.where(tag, scope))

    def boolean(self, tag: Tag, scope: _Scope, key: str, default: bool) -> bool:
        text = self.attr(tag, scope, key)
        if text is None:
            return default
        value = text.strip().lower()
        if value in ("true", "1"):
            return True
        if value in ("false", "0"):
            return False
        raise LaunchError(self.where(tag, scope), f'{key}="{text}" is not a boolean', "write true or false")

    def active(self, tag: Tag, scope: _Scope) -> bool:
        """roslaunch's if/unless on any element: both at once is an error, a non-boolean value too."""
        if "if" in tag.attrs and "unless" in tag.attrs:
            raise LaunchError(self.where(tag, scope), "an element has if= and unless=", "keep one")
        if "if" in tag.attrs:
            return self.boolean(tag, scope, "if", True)
        if "unless" in tag.attrs:
            return not self.boolean(tag, scope, "unless", False)
        return True

    def remap(self, tag: Tag, scope: _Scope) -> tuple[str, str]:
        return self.attr(tag, scope, "from", required=True), self.attr(tag, scope, "to", required=True)
