"""A tiny, deterministic MJCF builder.

Components describe their bodies as :class:`Element` trees; the composer renders the scene to one
MJCF string. Attribute order is insertion order and numbers are printed with a fixed format, so the
same description always gives byte-identical XML (tests compare strings and load them in MuJoCo).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Iterator, Sequence

__all__ = ["Element", "fmt", "walk"]


def fmt(value: Any) -> str:
  """Formats an attribute value: numbers with 6 significant digits, sequences space-separated."""
  if isinstance(value, str):
    return value
  if isinstance(value, bool):
    return "true" if value else "false"
  if isinstance(value, (int, float)):
    text = f"{float(value):.6g}"
    return "0" if text == "-0" else text
  if isinstance(value, Sequence):
    return " ".join(fmt(v) for v in value)
  raise TypeError(f"cannot write {value!r} ({type(value).__name__}) as an MJCF attribute")


@dataclasses.dataclass
class Element:
  """One MJCF element: a tag, its attributes (insertion-ordered) and its children."""

  tag: str
  attrs: dict[str, Any] = dataclasses.field(default_factory=dict)
  children: list["Element"] = dataclasses.field(default_factory=list)

  def add(self, tag: str, **attrs: Any) -> "Element":
    """Appends a child element and returns it (for nesting)."""
    child = Element(tag, {k: v for k, v in attrs.items() if v is not None})
    self.children.append(child)
    return child

  def to_xml(self, indent: int = 0) -> str:
    pad = "  " * indent
    attrs = "".join(f' {k}="{fmt(v)}"' for k, v in self.attrs.items())
    if not self.children:
      return f"{pad}<{self.tag}{attrs}/>"
    inner = "\n".join(c.to_xml(indent + 1) for c in self.children)
    return f"{pad}<{self.tag}{attrs}>\n{inner}\n{pad}</{self.tag}>"


def walk(element: Element) -> Iterator[Element]:
  """Yields ``element`` and all its descendants, depth first, in document order."""
  yield element
  for child in element.children:
    yield from walk(child)
