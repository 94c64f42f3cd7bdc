"""Small helpers to write SVG markup: elements with escaped attributes and text, and short numbers."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from xml.sax.saxutils import escape, quoteattr

NAMESPACE = "http://www.w3.org/2000/svg"


def num(value: float) -> str:
    """A coordinate with at most two decimals and no trailing zeros."""
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def rgb(colour: tuple[int, int, int]) -> str:
    return "#{:02x}{:02x}{:02x}".format(*colour)


def element(name: str, attrs: Mapping[str, object] | None = None, *children: str) -> str:
    """`<name a="v">children</name>`, attributes escaped and those that are None left out; children are markup."""
    parts = [name] + [f"{key}={quoteattr(str(value))}" for key, value in (attrs or {}).items() if value is not None]
    head = " ".join(parts)
    body = "".join(children)
    return f"<{head}>{body}</{name}>" if body else f"<{head}/>"


def text(value: object) -> str:
    """Text content, escaped."""
    return escape(str(value))


def tooltip(value: object) -> str:
    """A `<title>` child: the tooltip and accessible name of its parent."""
    return element("title", None, text(value))


def path_d(points: Iterable[tuple[float, float]]) -> str:
    """A closed path through the points."""
    pts = list(points)
    return "M" + " L".join(f"{num(x)} {num(y)}" for x, y in pts) + " Z"


def svg_root(width: float, height: float, attrs: Mapping[str, object], *children: str) -> str:
    """The `<svg>` element: sized by its viewBox, as wide as its container, never stretched."""
    root = {
        "xmlns": NAMESPACE,
        "viewBox": f"0 0 {num(width)} {num(height)}",
        "width": "100%",
        "preserveAspectRatio": "xMidYMid meet",
        "font-family": "DejaVu Sans, Verdana, Arial, sans-serif",
    }
    return element("svg", root | dict(attrs), *children)
