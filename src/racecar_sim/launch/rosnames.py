"""ROS 1 graph names as rosgraph.names resolves them: namespaces, relative, global and private (~) names."""

from __future__ import annotations

SEP = "/"
PRIVATE = "~"


def global_ns(ns: str) -> str:
    """A namespace as roslaunch keeps it: absolute, with a trailing slash ("" and "/" are the root)."""
    ns = ns or SEP
    if not ns.startswith(SEP):
        ns = SEP + ns
    return ns if ns.endswith(SEP) else ns + SEP


def ns_join(ns: str, name: str) -> str:
    """rosgraph.names.ns_join: a global or private `name` stays as it is, a relative one joins `ns`."""
    if name.startswith((SEP, PRIVATE)) or not ns:
        return name
    if ns == PRIVATE:
        return PRIVATE + name
    return ns + name if ns.endswith(SEP) else ns + SEP + name


def child_ns(ns: str, child: str | None) -> str:
    """The namespace a `<group ns>`, `<include ns>` or `<node ns>` opens: a global child replaces `ns`."""
    if not child:
        return ns
    return global_ns(child if child.startswith(SEP) else ns_join(ns, child))


def canonical(name: str) -> str:
    """No double or trailing slashes ("/" stays "/")."""
    parts = [p for p in name.split(SEP) if p]
    return SEP + SEP.join(parts) if name.startswith(SEP) else SEP.join(parts)


def resolve_name(name: str, ns: str, node: str | None = None) -> str:
    """The absolute name `name` stands for in namespace `ns` (of node `node`, a full name, for `~` names)."""
    if name.startswith(PRIVATE):
        if node is None:
            raise ValueError(f"private name {name!r} outside of a node")
        return canonical(node + SEP + name[1:])
    if name.startswith(SEP):
        return canonical(name)
    return canonical(global_ns(ns) + name)


def strip_ns(name: str, ns: str) -> str:
    """`name` relative to namespace `ns` as an absolute name ("/car1/vesc/odom" in "/car1/" -> "/vesc/odom");
    a name outside `ns` comes back unchanged."""
    ns = global_ns(ns)
    if ns != SEP and (name + SEP).startswith(ns):
        return SEP + name[len(ns) :]
    return name
