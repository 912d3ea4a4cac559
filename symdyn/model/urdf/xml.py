"""Reading URDF text: the element tree with line numbers, numbers with their place, errors that name it.

The standard library's expat parser is enough for URDF and keeps each
element's line, so every message reads like a compiler's
(`panda.urdf:218: <joint name='panda_hand_joint'> …`); no URDF package is needed.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

__all__ = ["URDFError", "URDFWarning", "Element", "Text", "read", "parse", "where", "numbers"]


class URDFError(ValueError):
    """A URDF the model cannot take; the message names the element and its line.

    `command_line` is the same message in the words of the command line (`--tip LINK`,
    `--exclude LINK`, `--balance-inertia` where the message says `tip_link=…`,
    `exclude=[…]`, `inertia="balance"`); the command line shows it instead.
    """

    def __init__(self, message: str, command_line: str | None = None):
        super().__init__(message)
        self.command_line = command_line or message


class URDFWarning(UserWarning):
    """Something in a URDF that is wrong but cannot affect the robot read from it."""


@dataclass
class Element:
    tag: str
    attrib: dict
    line: int
    children: list = field(default_factory=list)

    @property
    def name(self) -> str | None:
        return self.attrib.get("name")

    def find(self, tag: str) -> "Element | None":
        return next((c for c in self.children if c.tag == tag), None)

    def findall(self, tag: str) -> list:
        return [c for c in self.children if c.tag == tag]


@dataclass(frozen=True)
class Text:
    """A URDF's text and where it came from: `source` names it in messages (the path
    as given), `file` is the name alone (what generated headers record), `sha256` its digest."""

    text: str
    source: str
    file: str

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()


def read(path_or_xml) -> Text:
    """A path (str or Path) or the XML itself."""
    if isinstance(path_or_xml, os.PathLike) or (isinstance(path_or_xml, str) and "<" not in path_or_xml):
        path = Path(path_or_xml)
        try:
            text = path.read_text()
        except OSError as exc:
            raise URDFError(f"cannot read URDF file {str(path)!r}: {exc.strerror}") from None
        return Text(text, str(path), path.name)
    if not isinstance(path_or_xml, str):
        raise URDFError(f"from_urdf needs a path or the URDF text, got {type(path_or_xml).__name__}")
    return Text(path_or_xml, "<urdf string>", "<urdf string>")


def parse(text: str, source: str) -> Element:
    """The XML tree with the line of every element (expat keeps them; ElementTree does not)."""
    if not text.strip():
        raise URDFError(f"{source}: the file is empty: a URDF is a <robot> element with links and joints")
    parser = expat.ParserCreate()
    stack: list[Element] = []
    root: list[Element] = []

    def start(tag, attrib):
        element = Element(tag, attrib, parser.CurrentLineNumber)
        (stack[-1].children if stack else root).append(element)
        stack.append(element)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise URDFError(f"{source}: not well-formed XML: {exc}") from None
    if not root or root[0].tag != "robot":
        raise URDFError(f"{source}: the root element must be <robot>, got <{root[0].tag if root else ''}>")
    if not root[0].findall("link"):
        raise URDFError(f"{source}:{root[0].line}: <robot> has no <link>: there is no robot to read")
    return root[0]


def where(source: str, element: Element) -> str:
    return f"{source}:{element.line}: <{element.tag}{f' name={element.name!r}' if element.name else ''}>"


def numbers(source: str, element: Element | None, attr: str, count: int, default=None) -> list:
    """`count` finite numbers from an attribute; `default` when the element or attribute is absent."""
    if element is None or attr not in element.attrib:
        if default is None:
            raise URDFError(f"{where(source, element)} has no {attr}")
        return list(default)
    try:
        values = [float(x) for x in element.attrib[attr].split()]
    except ValueError:
        values = []
    if len(values) != count or any(v != v or abs(v) == float("inf") for v in values):
        raise URDFError(f"{where(source, element)}: {attr}={element.attrib[attr]!r} must be {count} finite numbers")
    return values
