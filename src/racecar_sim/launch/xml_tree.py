"""A launch file's XML as a small tree with line numbers (xml.etree keeps none), read with expat."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

from racecar_sim.launch.errors import LaunchError


@dataclass
class Tag:
    """One XML element: its tag, attributes, children, text and line."""

    name: str
    attrs: dict[str, str]
    line: int
    children: list[Tag] = field(default_factory=list)
    text: str = ""

    def describe(self) -> str:
        """How the element reads in a message: `<node name="servo" ...>` with its identifying attribute."""
        for key in ("name", "file", "pkg", "from", "param"):
            if key in self.attrs:
                return f'<{self.name} {key}="{self.attrs[key]}">'
        return f"<{self.name}>"


def parse_file(path: Path) -> Tag:
    """The root element of `path`; LaunchError for a file that cannot be read or is not well-formed XML."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise LaunchError(
            path,
            f"cannot read the launch file ({exc.strerror or exc})",
            "check the path (and the $(find ...) package it is in)",
        ) from None
    parser = expat.ParserCreate()
    stack: list[Tag] = []
    root: list[Tag] = []

    def start(name: str, attrs: dict[str, str]) -> None:
        tag = Tag(name, dict(attrs), parser.CurrentLineNumber)
        (stack[-1].children if stack else root).append(tag)
        stack.append(tag)

    def end(name: str) -> None:
        stack.pop()

    def text(data: str) -> None:
        if stack:
            stack[-1].text += data

    parser.StartElementHandler, parser.EndElementHandler, parser.CharacterDataHandler = start, end, text
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise LaunchError(
            f"{path}:{exc.lineno}",
            f"bad XML: {expat.ErrorString(exc.code)} (column {exc.offset + 1})",
            "fix the XML (every tag closed, attributes quoted)",
        ) from None
    return root[0]
