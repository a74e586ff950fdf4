"""robot_state_publisher's /tf numbers from a joint state's positions, where the simulation publishes them and where a
writer process packs them.

revolute_numbers() makes one function from the moving joints' constants; RobotStatePublisher calls it on each joint
state, and TfRows calls the same function, made again from the same constants, on the rows a recorded run hands its
writer (the joint state's numbers), so /tf's bytes are the same bits either way. Light to import: a writer process
unpickles TfRows.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from racecar_sim.msgs.cdr_layout import CdrLayout

Step = tuple[Any, ...]
"""A frame's step: (index, parent, child, 3 origin translation, 4 origin rotation w x y z, 3 unit axis) for a moving
joint, (index, joint) for a prismatic one."""
REVOLUTE = 13  # the length of a moving joint's step


class TfRows:
    """Packs /tf messages (`layout`: their CdrLayout) from joint-state rows ``(sec, nanosec, positions...,
    velocities..., efforts...)``, a JointState's numbers in wire order: the frames of `plan` (moving joints' steps
    alone), each turned by its joint's position as RobotStatePublisher turns it. Pickles as its layout and plan."""

    def __init__(self, layout: CdrLayout, plan: Sequence[Step]) -> None:
        self.layout, self.plan = layout, tuple(plan)
        numbers = revolute_numbers(list(self.plan))
        if numbers is None:
            raise ValueError("TfRows packs moving joints' frames alone")
        self._numbers = numbers

    def pack_many(self, rows: Sequence[Sequence[Any]]) -> list[bytes]:
        """The CDR bytes of the /tf message of each row."""
        pack, numbers = self.layout.pack, self._numbers
        return [pack(numbers(row[2:], row[0], row[1])) for row in rows]

    def __reduce__(self) -> tuple[type[TfRows], tuple[CdrLayout, tuple[Step, ...]]]:
        return TfRows, (self.layout, self.plan)


def revolute_numbers(plan: Sequence[Step]) -> Callable[[Sequence[float], int, int], list[Any]] | None:
    """One function that gives the /tf numbers of `plan`'s frames, all of moving joints, from the joint positions,
    bit for bit those of RobotStatePublisher._stepped_numbers (sensors/robot_state.py): each joint's constants written
    in (repr() reads back to the same float), the numbers in one list display, and each rotation component that has
    one product left once the constant zeros' products are dropped computed as that product alone (see _rotation).
    None where a frame is a prismatic joint's (this runs for every joint state, 50 a second a car)."""
    if not plan or any(len(step) != REVOLUTE for step in plan):
        return None
    lines, items = [], []
    for k, (index, _, _, *constants) in enumerate(plan):
        if not all(math.isfinite(value) for value in constants):
            return None
        lines += [
            f"    h = 0.5 * p[{index}]",
            "    s, c = sin(h), cos(h)",
            *_rotation(k, constants[3:7], constants[7:10]),
        ]
        items += ["sec", "nanosec", *(f"({value!r})" for value in constants[:3]), f"qx{k}, qy{k}, qz{k}, qw{k}"]
    source = "\n".join(["def numbers(p, sec, nanosec):", *lines, f"    return [{', '.join(items)}]"])
    names: dict[str, Any] = {"sin": math.sin, "cos": math.cos}
    exec(compile(source, "<robot_state /tf numbers>", "exec"), names)  # made from the joints' constants alone
    return names["numbers"]


# origin (a) * axis-angle (b): each rotation component x y z w as its four signed products, as quat_mul sums them
_PRODUCTS = (
    (("+", "w", "x"), ("+", "x", "w"), ("+", "y", "z"), ("-", "z", "y")),
    (("+", "w", "y"), ("-", "x", "z"), ("+", "y", "w"), ("+", "z", "x")),
    (("+", "w", "z"), ("+", "x", "y"), ("-", "y", "x"), ("+", "z", "w")),
    (("+", "w", "w"), ("-", "x", "x"), ("-", "y", "y"), ("-", "z", "z")),
)
_SMALLEST = 1e-50  # the least magnitude of a constant a short form multiplies (with |sin| >= 1e-150: no underflow)


def _rotation(k: int, origin: list[float], axis: list[float]) -> list[str]:
    """Lines that set joint k's rotation qx{k} qy{k} qz{k} qw{k} from s = sin(h) and c = cos(h) (h, half its
    angle): the origin rotation `origin` (w x y z) times the axis-angle (c, `axis` * s), summed in quat_mul's order.
    A product with a zero constant (an origin or axis component) is a zero, and adding a zero to a number that is not
    zero gives that number: where one product of a component is left and it cannot be zero (s not zero: then nor is
    any product of constants of at least _SMALLEST, and a cosine never is), the component is that product (negated
    if it is subtracted), the same float. Where s is zero (or NaN), each component is the whole sum (its zero's
    sign, the NaN's bits)."""
    a = dict(zip("wxyz", origin))
    u = {"w": 1.0, **dict(zip("xyz", axis))}
    b = {"w": "c", **{v: f"({u[v]!r} * s)" for v in "xyz"}}  # the axis-angle's components

    def whole(products: tuple[tuple[str, str, str], ...]) -> str:
        terms = [f"{sign} ({a[i]!r}) * {b[j]}" for sign, i, j in products]
        return " ".join(terms)[2:]  # the first product is added: no leading sign

    full = ", ".join(whole(products) for products in _PRODUCTS)
    short = []
    for products in _PRODUCTS:
        left = [(sign, i, j) for sign, i, j in products if a[i] != 0.0 and u[j] != 0.0]
        if len(left) != 1 or abs(a[left[0][1]]) < _SMALLEST or abs(u[left[0][2]]) < _SMALLEST:
            short.append(whole(products))
            continue
        sign, i, j = left[0]
        product = f"({a[i]!r}) * {b[j]}"
        short.append(product if sign == "+" else f"-({product})")
    names = f"qx{k}, qy{k}, qz{k}, qw{k}"
    if short == full.split(", "):
        return [f"    {names} = {full}"]
    return [
        "    if s >= 1e-150 or s <= -1e-150:",
        f"        {names} = {', '.join(short)}",
        "    else:",
        f"        {names} = {full}",
    ]
