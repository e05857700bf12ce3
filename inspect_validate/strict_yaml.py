"""The strict YAML dialect every file of the tool is read in, without validation: a
mapping of plain values that a file model (:mod:`inspect_validate.config`) then checks.

Kept apart from the models so that a command reading one small file in the common form
(``measure``'s ROI file) starts without loading pydantic.

* only ``true``/``false`` are booleans (YAML 1.2): ``off:``, ``on:``, ``yes``,
  ``no`` stay strings, so a protocol's ``off:`` command is not read as ``False``;
* a key given twice in one mapping is an error naming both lines, not a silent
  "last one wins";
* a document nested beyond reason is refused rather than exhausting the stack.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

from inspect_validate.errors import InputError
from inspect_validate.files import input_file

__all__ = ["YAML_MAX_BYTES", "parse_yaml", "read_mapping"]

_MAX_DEPTH = 64
_MAX_VALUES = 2_000_000  # a scene of 100 spectra of 10,000 samples each is 10⁶
YAML_MAX_BYTES = 64 * 2**20
"""The largest YAML file read (station, scene, ROI, camera file): 2·10⁶ values
(``_MAX_VALUES``) written out are tens of MB."""


@functools.cache
def _loader():
    import re

    import yaml

    # libyaml's parser where PyYAML was built with it (3x faster); the constructor and
    # resolvers below are Python either way.
    class StrictLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):
        def construct_mapping(self, node, deep: bool = False):
            seen: dict = {}
            for key_node, _ in node.value:
                try:
                    key = self.construct_object(key_node, deep=True)
                    hash(key)
                except TypeError:
                    continue  # yaml reports unhashable keys itself
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        f"key {key!r} first given on line {seen[key] + 1}",
                        node.start_mark,
                        f"given again on line {key_node.start_mark.line + 1}",
                        key_node.start_mark,
                    )
                seen[key] = key_node.start_mark.line
            return super().construct_mapping(node, deep=deep)

    # YAML 1.2 booleans: drop 1.1's yes/no/on/off resolver, keep true/false.
    StrictLoader.yaml_implicit_resolvers = {
        first: [(tag, rx) for tag, rx in resolvers if tag != "tag:yaml.org,2002:bool"]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
    }
    StrictLoader.add_implicit_resolver(
        "tag:yaml.org,2002:bool",
        re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"),
        list("tTfF"),
    )
    return StrictLoader


def _extent(node) -> tuple[int, int]:
    """Nesting depth and number of values of a composed YAML node as it would expand,
    each node measured once: an alias (``*a``) shares its anchor's node, so an alias
    bomb (a billion values from a few lines) is measured in the time of its text, not
    expanded. Iterative: no recursion to exhaust. A node that contains itself (a
    recursive alias) counts as unbounded."""
    memo: dict[int, tuple[int, int]] = {}
    open_: set[int] = set()
    stack = [(node, False)]

    def children(n):
        if not isinstance(n.value, list):
            return []
        return [x for item in n.value for x in (item if isinstance(item, tuple) else (item,))]

    while stack:
        n, done = stack.pop()
        if id(n) in memo:
            continue
        kids = children(n)
        if not done:
            if id(n) in open_:
                return (1 << 62, 1 << 62)  # reached again while open: it contains itself
            open_.add(id(n))
            stack.append((n, True))
            stack += [(c, False) for c in kids if id(c) not in memo]
            continue
        open_.discard(id(n))
        depth = 1 + max((memo[id(c)][0] for c in kids), default=0)
        values = 1 + sum(memo[id(c)][1] for c in kids)
        memo[id(n)] = (depth, values)
    return memo[id(node)]


def parse_yaml(text: str, *, source: str) -> Any:
    """Parse YAML text with the strict dialect above; errors name ``source`` and the line."""
    import yaml

    loader = _loader()(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        depth, values = _extent(node)
        if depth > _MAX_DEPTH:
            raise InputError(
                f"nested more than {_MAX_DEPTH} levels deep; this is not a configuration file",
                source=source,
            )
        if values > _MAX_VALUES:
            raise InputError(
                f"expands to more than {_MAX_VALUES:.0e} values (through aliases, *name, or "
                "sheer size); this is not a configuration file",
                source=source,
            )
        return loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        where = exc.problem_mark or exc.context_mark
        if exc.problem == "found unexpected end of stream" and exc.context_mark is not None:
            where = exc.context_mark  # an unclosed quote or bracket: where it opened
        what = "; ".join(x for x in (exc.context, exc.problem) if x)
        colonless = _colonless_line(text, exc)
        if colonless is not None:
            key = text.splitlines()[colonless].strip()
            what = f"{key!r} has no ':' after its key (write 'key: value')"
        line = f"line {(where.line if colonless is None else colonless) + 1}: " if where else ""
        raise InputError(f"{line}not valid YAML: {what}", source=source) from None
    except yaml.YAMLError as exc:
        raise InputError(f"not valid YAML: {exc}", source=source) from None
    except RecursionError:
        raise InputError("nested too deeply to read", source=source) from None
    finally:
        loader.dispose()


def _colonless_line(text: str, exc) -> int | None:
    """The line of a key that lacks its ':', when that is what ``exc`` reports late.

    PyYAML notices a missing ':' only on a later line: 'could not find expected :'
    at the next key, or 'mapping values are not allowed' when the colonless line was
    read as the first part of a multi-line scalar whose last line has the colon.
    """
    lines = text.splitlines()
    if exc.context == "while scanning a simple key" and exc.context_mark is not None:
        return exc.context_mark.line if exc.context_mark.line < len(lines) else None
    mark = exc.problem_mark
    if not (exc.problem or "").startswith("mapping values are not allowed") or mark is None:
        return None
    if mark.line >= len(lines):
        return None

    def indent(row: str) -> int:
        return len(row) - len(row.lstrip(" "))

    first = mark.line
    while (
        first > 0
        and (row := lines[first - 1]).strip()
        and ":" not in row
        and indent(row) == indent(lines[mark.line])
        and not row.lstrip().startswith(("-", "#"))
    ):
        first -= 1
    return first if first < mark.line else None


def read_mapping(path: str | Path, *, what: str) -> dict:
    """The mapping a YAML file holds, read in the strict dialect; errors name ``path`` and
    say what a ``what`` (``"ROI file"``) must be."""
    return read_mapping_and_hash(path, what=what)[0]


def read_mapping_and_hash(path: str | Path, *, what: str) -> tuple[dict, str]:
    """:func:`read_mapping`, and the SHA-256 of the file's bytes as read (which version of
    the file it was), the file read once."""
    import hashlib

    path = input_file(path, what, todo=f"give the path of a {what} (YAML)", largest=YAML_MAX_BYTES)
    try:
        data = path.read_bytes()
        # As read_text reads: universal newlines (a file written on Windows parses alike).
        text = data.decode().replace("\r\n", "\n").replace("\r", "\n")
    except UnicodeDecodeError:
        raise InputError(f"not a text file; a {what} is YAML", source=str(path)) from None
    except OSError as exc:
        raise InputError(f"cannot read the {what} ({exc.strerror})", source=str(path)) from None
    doc = parse_yaml(text, source=str(path))
    if not isinstance(doc, dict):
        found = "empty" if doc is None else f"a {type(doc).__name__}"
        raise InputError(
            f"the {what} is {found}; it must be a mapping of fields (see the manual's file formats)",
            source=str(path),
        )
    return doc, hashlib.sha256(data).hexdigest()
