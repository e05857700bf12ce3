"""A file format's reference table, generated from its validation model.

A format page holds, between ::

    <!-- file-model inspect_validate.scene_file:SceneFile "scene file" -->
    <!-- /file-model -->

every key of the model (type, constraints, default, description from the field's
docstring) and, below it, the same for every model nested in it, as plain Markdown that
reads in a checkout too; ``python docs/_ext/file_models.py`` writes them, and
tests/test_docs.py fails while a page differs from its models. (The ``file-model``
directive renders the same tables inside the built manual only.)
"""

from __future__ import annotations

import importlib
import re
import types
import typing
from pathlib import Path

import annotated_types as at
from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList
from pydantic import BaseModel, Discriminator, Tag
from pydantic.fields import FieldInfo

from inspect_validate.config import field_docs

_NAMES = {str: "text", int: "integer", float: "number", bool: "true/false", Path: "path"}
_BOUNDS = ((at.Gt, "gt", ">"), (at.Ge, "ge", "≥"), (at.Lt, "lt", "<"), (at.Le, "le", "≤"))
_PATTERNS = {"^[^,]+$": "no comma"}  # patterns said in words
_SUPERSCRIPT = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def _number(x) -> str:
    """A bound as a person writes it: 100000 → 100 000, 1e+09 → 10⁹, 1e-09 → 10⁻⁹."""
    if abs(x) >= 1e6 or 0 < abs(x) < 1e-3:
        mantissa, _, exponent = f"{x:e}".partition("e")
        power = "10" + str(int(exponent)).translate(_SUPERSCRIPT)
        m = float(mantissa)
        return power if m == 1 else ("−" + power if m == -1 else f"{m:g}·{power}")
    if float(x).is_integer() and abs(x) >= 10_000:
        return f"{int(x):,}".replace(",", " ").replace("-", "−")
    return f"{x:g}".replace("-", "−")


def _constraints(metadata, kind: str = "") -> list[str]:
    """The metadata's bounds in words: ``0 ≤ x ≤ 1``, ``1–100 characters``, ``no comma``,
    ``at least 2 entries``; ``finite`` only where no bound says it already."""
    low = high = lo_len = hi_len = None
    out: list[str] = []
    finite = False
    for m in metadata:
        if isinstance(m, FieldInfo):
            out += _constraints(m.metadata, kind)
            continue
        for cls, attr, sign in _BOUNDS:
            if isinstance(m, cls):
                if sign in (">", "≥"):
                    low = (sign, getattr(m, attr))
                else:
                    high = (sign, getattr(m, attr))
        if isinstance(m, at.MinLen) and m.min_length:
            lo_len = m.min_length
        if isinstance(m, at.MaxLen):
            hi_len = m.max_length
        pattern = getattr(m, "pattern", None)
        if isinstance(pattern, str):
            out.append(_PATTERNS.get(pattern, f"matching `{pattern}`"))
        if getattr(m, "allow_inf_nan", None) is False:
            finite = True
    if lo_len or hi_len:
        unit, one = ("characters", "character") if kind == "text" else ("entries", "entry")
        if lo_len and hi_len:
            length = f"{_number(lo_len)}–{_number(hi_len)} {unit}"
        elif lo_len:
            length = f"at least {_number(lo_len)} {one if lo_len == 1 else unit}"
        else:
            length = f"at most {_number(hi_len)} {unit}"
        out.insert(0, length)
    if low and high:
        left = "<" if low[0] == ">" else "≤"
        out.insert(0, f"{_number(low[1])} {left} x {high[0]} {_number(high[1])}")
    elif low or high:
        sign, value = low or high
        out.insert(0, f"x {sign} {_number(value)}")
    if finite and not (low and high):  # bounded on both sides says finite already
        out.append("finite")
    return out


_COUNTS = {2: "a pair", 3: "three"}


def _bounded(text: str, bounds: list[str]) -> str:
    """``text`` with its ``bounds``: a list's count goes next to "list", so that it is not
    read as its items' (``list (at least 1 entry) of text (at least 1 character)``)."""
    if not bounds:
        return text
    said = ", ".join(bounds)
    if text.startswith("list of "):
        return f"list ({said}) of {text.removeprefix('list of ')}"
    return f"{text} ({said})"


class _Formatter:
    """Type expressions as words; nested models collected with the path they sit at."""

    def __init__(self):
        self.nested: list[tuple[str, type[BaseModel]]] = []

    def __call__(self, tp, where: str) -> str:
        origin, args = typing.get_origin(tp), typing.get_args(tp)
        if origin is typing.Annotated:
            inner, meta = args[0], args[1:]
            tag = next((m.tag for m in meta if isinstance(m, Tag)), None)
            if tag is not None:
                kind = tag.lstrip("_")
                self(inner, f"{where} ({kind})")
                return f"`{kind}:` …"
            text = self(inner, where)
            if any(isinstance(m, Discriminator) for m in meta):
                return text
            return _bounded(text, _constraints(meta, text))
        if origin in (typing.Union, types.UnionType):
            parts = [self(a, where) for a in args if a is not type(None)]
            if any(p.startswith("`") and p.endswith(":` …") for p in parts):
                return "one of " + ", ".join(parts)
            text = " or ".join(parts)
            return f"{text} or null" if type(None) in args else text
        if origin is typing.Literal:
            return " \\| ".join(f"`{a}`" for a in args)
        if origin is list:
            if not args:
                return "list"
            item = self(args[0], f"{where}[]")
            return f"list of {item.replace('a pair of ', 'pairs of ', 1)}"
        if origin is tuple:
            items = [self(a, where) for a in args if a is not Ellipsis]
            if len(args) == 2 and args[1] is Ellipsis:
                return f"list of {items[0]}"
            if len(set(items)) == 1:  # [number (…), number (…)]: said once
                word, _, rest = items[0].partition(" ")
                plural = {"number": "numbers", "integer": "integers"}.get(word, word)
                return f"{_COUNTS.get(len(items), len(items))} of {plural} {rest}".strip()
            return "[" + ", ".join(items) + "]"
        if origin is dict:
            key, value = args
            return f"mapping from {self(key, where)} to {self(value, f'{where}.<key>')}"
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if all(m is not tp for _, m in self.nested):
                self.nested.append((where, tp))
            return f"mapping, see *{where}* below"
        if tp is type(None):
            return "null"
        if tp is typing.Any:
            return "any"
        return _NAMES.get(tp, getattr(tp, "__name__", str(tp)))


def _default(field: FieldInfo) -> str:
    if field.is_required():
        return "**required**"
    if field.default_factory is not None:
        return "(computed)"
    value = field.default
    if isinstance(value, BaseModel):
        return "its defaults"
    if value is None:
        return "`null`"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, dict | list) and not value:
        return "none"
    if isinstance(value, str) and not value.isprintable():  # a terminator: "\r" as written
        return f"`{value.encode('unicode_escape').decode()}`"
    return f"`{value}`"


def _one_line(text: str | None) -> str:
    return " ".join((text or "").split())


def model_tables(
    model: type[BaseModel], title: str
) -> list[tuple[str, str, list[tuple[str, str, str, str]]]]:
    """``model``'s table and those of the models nested in it: each (where, what the
    model is, rows of key, type, default, meaning)."""
    fmt = _Formatter()
    fmt.nested.append((title, model))
    tables = []
    done = 0
    while done < len(fmt.nested):
        where, current = fmt.nested[done]
        done += 1
        doc = _one_line(current.__doc__ if current.__doc__ != BaseModel.__doc__ else "")
        if doc.startswith("Usage docs"):
            doc = ""
        rows = []
        docs = field_docs(current)
        for name, field in current.model_fields.items():
            if field.exclude:  # set on reading (path, sha256), never written
                continue
            key = field.alias or name
            path = key if where == title else f"{where}.{key}"
            kind = fmt(field.annotation, path)
            # The field's own bounds, unless the type's words already hold them.
            bounds = [b for b in _constraints(field.metadata, kind) if f"({b}" not in kind]
            kind = _bounded(kind, bounds)
            rows.append(
                (key, kind, _default(field), _one_line(field.description or docs.get(name)))
            )
        tables.append((where, doc, rows))
    return tables


def model_rst(model: type[BaseModel], title: str) -> list[str]:
    """MyST Markdown of ``model``'s table and those of the models nested in it, as
    list-tables (each row's cells on lines of their own)."""
    lines: list[str] = []
    for where, doc, rows in model_tables(model, title):
        lines += ["```{rubric} " + where, "```", ""]
        if doc:
            lines += [doc, ""]
        lines += [
            "````{list-table}",
            ":header-rows: 1",
            ":widths: 18 34 12 36",
            "",
            "* - key",
            "  - type",
            "  - default",
            "  - meaning",
        ]
        for key, kind, default, meaning in rows:
            lines += [f"* - `{key}`", f"  - {kind}", f"  - {default}", f"  - {meaning or ' '}"]
        lines += ["````", ""]
    return lines


def model_markdown(model: type[BaseModel], title: str) -> str:
    """``model``'s tables as plain Markdown (pipe tables under a bold title), which reads
    the same in a checkout, on a forge's page and in the built manual."""

    def cell(text: str) -> str:
        return re.sub(r"(?<!\\)\|", r"\\|", text)

    out = []
    for where, doc, rows in model_tables(model, title):
        out += [f"**{where}**", ""]
        if doc:
            out += [doc, ""]
        out += ["| key | type | default | meaning |", "|---|---|---|---|"]
        out += [
            f"| `{key}` | {cell(kind)} | {cell(default)} | {cell(meaning)} |"
            for key, kind, default, meaning in rows
        ]
        out.append("")
    return "\n".join(out)


_BLOCK = re.compile(
    r"(<!-- file-model (?P<target>\S+) \"(?P<title>[^\"]+)\"[^\n]*-->\n)(?P<body>.*?)(<!-- /file-model -->)",
    re.S,
)


def _target(text: str) -> type[BaseModel]:
    module, _, name = text.partition(":")
    target = importlib.import_module(module)
    for part in name.split("."):
        target = getattr(target, part)
    if not (isinstance(target, type) and issubclass(target, BaseModel)):
        target = target()  # a factory of a model built on first use
    return target


def render_page(text: str) -> str:
    """A page with each generated block made anew: a file model's (between ``<!--
    file-model TARGET "TITLE" -->`` and ``<!-- /file-model -->``) from its model, the
    health quantities' (between ``<!-- health-table -->`` and ``<!-- /health-table
    -->``) from their table."""
    text = _BLOCK.sub(
        lambda m: (
            m.group(1)
            + "\n"
            + model_markdown(_target(m.group("target")), m.group("title"))
            + m.group(5)
        ),
        text,
    )
    return _HEALTH.sub(lambda m: m.group(1) + "\n" + health_markdown() + m.group(2), text)


_HEALTH = re.compile(r"(<!-- health-table -->)\n.*?(<!-- /health-table -->)", re.S)


def health_markdown() -> str:
    """The health quantities as the manual's table: each quantity, where each backend
    reads it, its limit in ``acceptance.health`` (or why it has none)."""
    from inspect_validate.camera.health import BACKENDS, QUANTITIES

    rows = [
        "| quantity | " + " | ".join(BACKENDS) + " | limit (`acceptance.health`) |",
        "|---" * (len(BACKENDS) + 2) + "|",
    ]
    for q in QUANTITIES:
        limit = f"`{q.limit.key}`" if q.limit is not None else f"none: {q.unlimited}"
        # A source as the backend before it's is "the same" (the old table's way).
        cells = [
            "the same" if k and src == q.sources[k - 1] and src != "—" else src
            for k, src in enumerate(q.sources)
        ]
        rows.append(f"| `{q.name}` | " + " | ".join(cells) + f" | {limit} |")
    return "\n".join(rows) + "\n"


def main() -> None:
    """Write the format pages' generated tables from the models (run after changing a
    model; tests/test_docs.py fails while a page differs from its models)."""
    docs = Path(__file__).parents[1]
    for page in [*sorted((docs / "formats").glob("*.md")), docs / "guide" / "capture.md"]:
        text = page.read_text()
        made = render_page(text)
        if made != text:
            page.write_text(made)
            print(f"wrote {page}")


class FileModel(Directive):
    required_arguments = 1
    optional_arguments = 0
    final_argument_whitespace = False
    option_spec: typing.ClassVar = {"title": str}

    def run(self):
        target = _target(self.arguments[0])
        lines = model_rst(target, self.options.get("title", "top level"))
        container = StringList(lines, source=f"<file-model {self.arguments[0]}>")
        node = nodes.section()
        node.document = self.state.document
        self.state.nested_parse(container, self.content_offset, node)
        return node.children


def setup(app):
    app.add_directive("file-model", FileModel)
    return {"parallel_read_safe": True, "parallel_write_safe": True}


if __name__ == "__main__":
    main()
