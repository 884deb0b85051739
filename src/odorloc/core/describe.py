"""What a registered component is and which parameters it takes, read from the registry.

:func:`describe` gives a :class:`ComponentDoc` (family, name, summary, description and one
:class:`ParamDoc` per parameter: name, type, default, unit, doc). Types and defaults come from the
parameter model itself; units and docs from its numpydoc docstring, whose entries read
``name : type, unit`` (``r_conv, r_err : float, metres``), looked up along the model's bases so
that inherited parameters keep their documentation. ``odorloc components NAME`` prints it
(:func:`render_text`) and the documentation's Components reference is generated from it at build
time (:func:`render_markdown`).

Docstrings are written in reStructuredText; :func:`plain` and :func:`markdown` turn their inline
markup (````code````, ``:class:`~a.b.C```) into plain text or Markdown.
"""

from __future__ import annotations

import enum
import math
import re
import textwrap
import types
import typing
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any, Literal

import annotated_types
import yaml
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

from odorloc.core import registry
from odorloc.core.errors import ConfigError
from odorloc.core.params import Params

__all__ = [
    "ComponentDoc",
    "ParamDoc",
    "class_entries",
    "describe",
    "docstring_entries",
    "find",
    "markdown",
    "plain",
    "render_markdown",
    "render_text",
]

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|mod|attr|data|obj|exc|const):`~?([^`]+)`")
_LITERAL = re.compile(r"``([^`]+)``")
_SECTIONS = ("Parameters", "Attributes", "Other Parameters")


def _role_target(match: re.Match[str]) -> str:
    """The text a role shows: the last dotted part of ``~a.b.C`` (Sphinx's own rule), the whole
    target otherwise; a method's call parentheses kept."""
    text = match.group(1)
    tail = text.split(".")[-1] if match.group(0).split("`")[1].startswith("~") else text
    return tail


def plain(text: str) -> str:
    """``text`` without reStructuredText inline markup (roles and double backquotes)."""
    text = _ROLE.sub(_role_target, text)
    return _LITERAL.sub(r"\1", text).replace("\\", "")


def markdown(text: str) -> str:
    """``text`` with reStructuredText inline markup turned into Markdown code spans."""
    text = _ROLE.sub(lambda m: f"`{_role_target(m)}`", text)
    return _LITERAL.sub(r"`\1`", text)


@dataclass(frozen=True)
class ParamDoc:
    """One parameter of a component.

    Attributes
    ----------
    name : str
        The key in a scenario file.
    type : str
        Its type, from the parameter model (``float``, ``int >= 1``, ``{"a", "b"}``,
        ``component (resampler)``, ``float or None``).
    default : str
        The default as YAML (``required`` when there is none).
    unit : str
        The unit the docstring gives (``metres``, ``m^2/s``), or ``""``.
    doc : str
        Its description, plain text; ``""`` when the docstring has none.
    """

    name: str
    type: str
    default: str
    unit: str
    doc: str

    @property
    def summary(self) -> str:
        """The first sentence of :attr:`doc`."""
        return first_sentence(self.doc)


@dataclass(frozen=True)
class ComponentDoc:
    """A registered component: family, name, one-line summary, description and parameters."""

    family: str
    name: str
    summary: str
    description: str
    params: list[ParamDoc] = field(default_factory=list)
    qualname: str = ""


_ABBREVIATIONS = ("e.g", "i.e", "cf", "eq", "eqs", "Eq", "Eqs", "Fig", "Figs", "Sec", "al", "vs")


def first_sentence(text: str) -> str:
    """Up to the first full stop that ends a sentence (followed by a capital letter or the
    end; not one of an abbreviation such as ``eq.`` or ``e.g.``), or the whole text."""
    for m in re.finditer(r"\.(?=\s+[A-Z(`]|\s*$)", text):
        word = re.search(r"([\w.]+)$", text[: m.start()])
        if word and word.group(1) in _ABBREVIATIONS:
            continue
        return text[: m.start() + 1]
    return text


# ----------------------------------------------------------------------------- docstrings


def _split_top(text: str) -> list[str]:
    """``text`` split at commas outside brackets, braces, parentheses and quotes."""
    parts, depth, quote, cur = [], 0, "", []
    for ch in text:
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append("".join(cur).strip())
            cur = []
            continue
        cur.append(ch)
    parts.append("".join(cur).strip())
    return [p for p in parts if p]


def _unit_of(spec: str) -> tuple[str, str]:
    """``(type, unit)`` of a numpydoc type spec ``type[, optional][, unit]``."""
    parts = _split_top(spec)
    if not parts:
        return "", ""
    rest = [
        p
        for p in parts[1:]
        if p.lower() != "optional" and not p.lower().startswith(("default", "shape"))
    ]
    return parts[0], ", ".join(rest)


_OTHER_SECTIONS = (
    "Returns",
    "Yields",
    "Raises",
    "Warns",
    "Examples",
    "Notes",
    "References",
    "See Also",
    "Methods",
)


def _is_rule(line: str) -> bool:
    text = line.strip()
    return bool(text) and set(text) == {"-"}


def docstring_entries(
    doc: str | None, names: Iterable[str] | None = None
) -> dict[str, tuple[str, str, str]]:
    """Every ``name : type, unit`` entry of a numpydoc docstring.

    Entries are read in the ``Parameters``/``Attributes`` sections and in a docstring's body
    outside other sections (``Returns``, ``Notes``, ...): a line at the docstring's indentation
    reading ``name : spec`` (or ``a, b : spec``) followed by an indented description. With
    ``names`` (the model's fields), a line of names alone (``a, b``) also counts when every
    name is one of them.

    Returns
    -------
    dict
        ``name -> (type, unit, description)``, the description as one line of plain text
        (``a, b : float, m`` gives both names the same entry).
    """
    out: dict[str, tuple[str, str, str]] = {}
    if not doc:
        return out
    known = set(names or ())
    lines = doc.expandtabs().splitlines()
    # the first line of a docstring is not indented like the rest
    lines = [lines[0].strip(), *textwrap.dedent("\n".join(lines[1:])).splitlines()]
    i, n, skipping = 0, len(lines), False
    while i < n:
        line = lines[i]
        if i + 1 < n and _is_rule(lines[i + 1]) and line.strip():
            skipping = line.strip() in _OTHER_SECTIONS
            i += 2
            continue
        head = re.match(r"^([A-Za-z_]\w*(?:\s*,\s*[A-Za-z_]\w*)*)\s*(?::\s*(.*))?$", line)
        if skipping or head is None or line.startswith((" ", "\t")):
            i += 1
            continue
        entry_names = [x.strip() for x in head.group(1).split(",")]
        if head.group(2) is None and not (known and set(entry_names) <= known):
            i += 1
            continue
        typ, unit = _unit_of(head.group(2) or "")
        desc: list[str] = []
        i += 1
        while i < n and (not lines[i].strip() or lines[i].startswith((" ", "\t"))):
            if i + 1 < n and _is_rule(lines[i + 1]):
                break
            desc.append(lines[i].strip())
            i += 1
        if not any(desc):
            continue  # a line of prose that happens to look like a name
        text = plain(" ".join(x for x in desc if x))
        for name in entry_names:
            out.setdefault(name, (typ, unit, text))
    return out


def class_entries(cls: type) -> dict[str, tuple[str, str, str]]:
    """Docstring entries of ``cls`` and its bases, the nearest class first."""
    out: dict[str, tuple[str, str, str]] = {}
    for klass in cls.__mro__:
        if klass in (object, BaseModel, Params):
            continue
        fields = getattr(cls, "model_fields", {})
        for name, entry in docstring_entries(klass.__doc__, fields).items():
            out.setdefault(name, entry)
    return out


# ----------------------------------------------------------------------------- types


def _bounds(metadata: Iterable[Any]) -> str:
    marks = []
    for m in metadata:
        if isinstance(m, annotated_types.Gt):
            marks.append(f"> {_num(m.gt)}")
        elif isinstance(m, annotated_types.Ge):
            marks.append(f">= {_num(m.ge)}")
        elif isinstance(m, annotated_types.Lt):
            marks.append(f"< {_num(m.lt)}")
        elif isinstance(m, annotated_types.Le):
            marks.append(f"<= {_num(m.le)}")
    return ", ".join(marks)


def _num(v: Any) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return str(v)


def type_text(annotation: Any, metadata: Iterable[Any] = ()) -> str:
    """A readable type: ``float``, ``int >= 1``, ``{"a", "b"}``, ``list of float``,
    ``float or None``, ``component (family)``."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        return type_text(args[0], [*metadata, *annotation.__metadata__])
    for meta in metadata:
        if isinstance(meta, registry.RefFamily):
            return f"component ({meta.family})"
    if origin is Literal:
        return "{" + ", ".join(f'"{a}"' if isinstance(a, str) else repr(a) for a in args) + "}"
    if origin in (typing.Union, types.UnionType):
        members = [a for a in args if a is not type(None)]
        text = " or ".join(type_text(a) for a in members)
        if len(members) < len(args):
            text += " or None"
        bounds = _bounds(metadata)
        return f"{text} ({bounds})" if bounds else text
    if origin in (list, tuple, set, frozenset) or annotation in (list, tuple):
        inner = [a for a in args if a is not Ellipsis]
        what = {list: "list", tuple: "tuple", set: "set", frozenset: "set"}.get(origin, "list")
        if not inner:
            return what
        if origin is tuple and Ellipsis not in args and len(set(map(str, inner))) > 1:
            return f"({', '.join(type_text(a) for a in inner)})"
        n = (
            f"{len(inner)} x "
            if origin is tuple and Ellipsis not in args and len(inner) > 1
            else ""
        )
        return f"{what} of {n}{type_text(inner[0])}"
    if origin is dict:
        return f"dict of {type_text(args[0])} to {type_text(args[1])}" if args else "dict"
    if isinstance(annotation, type):
        if issubclass(annotation, registry.ComponentRef):
            return "component"
        if issubclass(annotation, enum.Enum):
            return "{" + ", ".join(f'"{m.value}"' for m in annotation) + "}"
        name = {"str": "str", "int": "int", "float": "float", "bool": "bool"}.get(
            annotation.__name__, annotation.__name__
        )
        if issubclass(annotation, BaseModel):
            name = "mapping"
        bounds = _bounds(metadata)
        return f"{name} {bounds}".strip() if bounds else name
    return str(annotation).replace("typing.", "")


def _yaml_value(v: Any) -> Any:
    if isinstance(v, BaseModel):
        data = v.model_dump(mode="json")
        if isinstance(v, registry.ComponentRef):
            data = {"type": v.type, **v.values}
        return data
    if isinstance(v, tuple | list):
        return [_yaml_value(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _yaml_value(x) for k, x in v.items()}
    if isinstance(v, enum.Enum):
        return v.value
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    return v


def default_text(info: FieldInfo) -> str:
    """The default of a field as one line of YAML (``required`` without one)."""
    if info.default is PydanticUndefined and info.default_factory is None:
        return "required"
    value = info.get_default(call_default_factory=True)
    if value is None:
        return "null"
    text = yaml.safe_dump(
        _yaml_value(value), default_flow_style=True, width=10_000, sort_keys=False
    ).strip()
    return text.removesuffix("\n...").removesuffix("...").strip()


# ----------------------------------------------------------------------------- components


def describe(family: str, name: str) -> ComponentDoc:
    """The documentation of ``family/name`` from the registry (see the module docstring).

    Raises
    ------
    ConfigError
        ``name`` (naming the family) when it is not registered.
    """
    e = registry.entry(family, name, field="name")
    params_cls = e.params
    docs = class_entries(params_cls)
    out = []
    for pname, info in params_cls.model_fields.items():
        if info.exclude:
            continue
        typ = type_text(info.annotation, info.metadata)
        _, unit, doc = docs.get(pname, ("", "", ""))
        if not doc and info.description:
            doc = plain(info.description)
        out.append(ParamDoc(pname, typ, default_text(info), unit, doc))
    obj = e.build
    description = plain(_paragraph(obj.__doc__)) or plain(_paragraph(params_cls.__doc__))
    qual = f"{obj.__module__}.{getattr(obj, '__qualname__', obj.__class__.__name__)}"
    return ComponentDoc(family, name, plain(e.summary), description, out, qual)


def _paragraph(doc: str | None) -> str:
    """The first paragraph of a docstring, as one line."""
    if not doc:
        return ""
    para = []
    for line in doc.strip().splitlines():
        if not line.strip():
            break
        para.append(line.strip())
    return " ".join(para)


def find(name: str) -> list[tuple[str, str]]:
    """Every ``(family, name)`` registered under ``name`` (one name may serve several
    families: ``vergassola`` is a plume and a measurement model).

    Raises
    ------
    ConfigError
        ``name``, listing close names, when no family has it.
    """
    hits = [(fam, name) for fam in registry.families() if name in registry.names(fam)]
    if hits:
        return hits
    every = sorted({n for fam in registry.families() for n in registry.names(fam)})
    close = [n for n in every if name.lower() in n.lower() or n.lower() in name.lower()]
    hint = f" (did you mean {', '.join(close[:6])}?)" if close else ""
    raise ConfigError("name", f"no component {name!r}{hint}; `odorloc components` lists them all")


# ----------------------------------------------------------------------------- rendering


def render_text(doc: ComponentDoc, width: int = 80) -> str:
    """``doc`` as plain text for a terminal of ``width`` columns: a heading, the description,
    then each parameter as ``name  type  = default  [unit]`` with its first sentence below."""
    lines = [f"{doc.name}  ({doc.family})", ""]
    wrap = textwrap.TextWrapper(width=width, break_on_hyphens=False)
    if doc.description:
        lines += wrap.wrap(doc.description)
    elif doc.summary:
        lines += wrap.wrap(doc.summary)
    lines.append("")
    if not doc.params:
        lines.append("No parameters.")
        return "\n".join(lines) + "\n"
    lines.append(f"Parameters ({len(doc.params)}; in a scenario: {{type: {doc.name}, ...}}):")
    indent = "      "
    body = textwrap.TextWrapper(
        width=width, initial_indent=indent, subsequent_indent=indent, break_on_hyphens=False
    )
    for p in doc.params:
        unit = f"  [{p.unit}]" if p.unit else ""
        head = f"  {p.name} : {p.type} = {p.default}{unit}"
        if len(head) > width:
            head = f"  {p.name} : {p.type}{unit}"
            lines.append(head)
            lines += body.wrap(f"default: {p.default}")
        else:
            lines.append(head)
        if p.summary:
            lines += body.wrap(p.summary)
    return "\n".join(lines) + "\n"


def _cell(text: str) -> str:
    return markdown(text).replace("|", "\\|").replace("\n", " ")


def render_markdown(doc: ComponentDoc, level: int = 3) -> str:
    """``doc`` as a Markdown section: heading, description, and a table of the parameters
    (name, type, default, unit, doc)."""
    out = [f"{'#' * level} `{doc.name}`", ""]
    text = doc.description or doc.summary
    if text:
        out += [_cell(text), ""]
    if not doc.params:
        out += ["No parameters.", ""]
        return "\n".join(out)
    out += ["| parameter | type | default | unit | description |", "|---|---|---|---|---|"]
    for p in doc.params:
        default = p.default if len(p.default) <= 60 else p.default[:57] + "..."
        out.append(
            f"| `{p.name}` | {_cell(p.type)} | `{default.replace('|', '/')}` | "
            f"{_cell(p.unit)} | {_cell(p.doc)} |"
        )
    out.append("")
    return "\n".join(out)
