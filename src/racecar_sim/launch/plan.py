"""What a launch file asks for, resolved: the parameter tree (absolute names) and the nodes."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from racecar_sim.launch.errors import Where
from racecar_sim.launch.rosnames import SEP, canonical, global_ns, resolve_name


@dataclass(frozen=True)
class NodeSpec:
    """A `<node>`: package, type, name and namespace, args, remaps (launch-scoped then its own) and env."""

    package: str
    type: str
    name: str
    namespace: str  # absolute, with a trailing slash
    args: tuple[str, ...] = ()
    remaps: tuple[tuple[str, str], ...] = ()
    env: tuple[tuple[str, str], ...] = ()
    required: bool = False
    respawn: bool = False
    output: str = "log"
    launch_prefix: str = ""
    where: Where | None = None

    @property
    def full_name(self) -> str:
        return canonical(global_ns(self.namespace) + self.name)

    @property
    def label(self) -> str:
        return f"{self.full_name} ({self.package}/{self.type})"

    def resolve(self, name: str) -> str:
        """The absolute topic (or param) name the node's code means by `name`, after its remaps."""
        absolute = resolve_name(name, self.namespace, self.full_name)
        for source, target in reversed(self.remaps):  # the last remap of a name wins
            if resolve_name(source, self.namespace, self.full_name) == absolute:
                return resolve_name(target, self.namespace, self.full_name)
        return absolute

    def private(self, name: str) -> str:
        """The absolute name of the node's private parameter `name` (`~name`)."""
        return resolve_name("~" + name.lstrip("~"), self.namespace, self.full_name)


@dataclass
class LaunchPlan:
    """The parameter tree (absolute leaf names -> values), the nodes in launch order, and notes for the user."""

    file: Path
    args: dict[str, str] = field(default_factory=dict)
    params: dict[str, Any] = field(default_factory=dict)
    nodes: list[NodeSpec] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    sources: dict[str, Path] = field(default_factory=dict)  # parameter -> the YAML file a <rosparam> read it from

    def set_param(self, name: str, value: Any, source: Path | None = None) -> None:
        """Set `name` (absolute); a dict is unrolled into its leaves as roslaunch does, replacing what was there."""
        name = canonical(name)
        if isinstance(value, dict):
            if not value:
                self.params[name] = {}
            for key, item in value.items():
                self.set_param(f"{name}{SEP}{key}" if name != SEP else f"{SEP}{key}", item, source)
            return
        prefix = name + SEP
        for key in [k for k in self.params if k.startswith(prefix)]:
            del self.params[key]
            self.sources.pop(key, None)
        self.params[name] = value
        if source is not None:
            self.sources[name] = source
        else:
            self.sources.pop(name, None)

    def delete_param(self, name: str) -> None:
        name = canonical(name)
        for key in [k for k in self.params if k == name or k.startswith(name + SEP)]:
            del self.params[key]

    def param(self, name: str, default: Any = None) -> Any:
        """A parameter by absolute name: a leaf value, a subtree as a nested dict, or `default`."""
        name = canonical(name)
        if name in self.params:
            return self.params[name]
        tree = self.subtree(name)
        return tree if tree else default

    def subtree(self, ns: str) -> dict[str, Any]:
        """The parameters under `ns` as a nested dict ({} if none)."""
        prefix = global_ns(ns)
        tree: dict[str, Any] = {}
        for key, value in self.params.items():
            if key.startswith(prefix):
                *parents, leaf = key[len(prefix) :].split(SEP)
                level = tree
                for part in parents:
                    level = level.setdefault(part, {})
                    if not isinstance(level, dict):
                        break
                else:
                    level[leaf] = value
        return tree

    def nodes_of(self, package: str, *types: str) -> list[NodeSpec]:
        return [n for n in self.nodes if n.package == package and (not types or n.type in types)]
