"""Reading validated YAML files (ROI sets, scenes, stations).

One place turns YAML syntax errors and pydantic validation errors into
:class:`~inspect_validate.errors.InputError` messages that name the file and
the field (``classes.A.shapes.0: ...``). The YAML dialect, strict where YAML 1.1 is
treacherous for configuration, is :mod:`inspect_validate.strict_yaml`'s.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from inspect_validate.errors import InputError
from inspect_validate.strict_yaml import parse_yaml, read_mapping

__all__ = [
    "StrictModel",
    "explain",
    "field_docs",
    "known_keys",
    "load_yaml",
    "one_of",
    "parse_yaml",
    "validate",
]

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """The base of every file model (scene, station, ROI set, golden, camera file).

    Unknown keys are refused (a misspelt key is an error naming it, never a silent
    default), and a model, once read, does not change. A field's docstring documents
    it: the manual's file-format pages are generated from the models and those
    docstrings. (pydantic's ``use_attribute_docstrings`` would read every model's source
    at import, 50 ms of the command line's start; the docs build reads them instead.)
    """

    model_config = ConfigDict(extra="forbid", frozen=True)


def one_of(
    models: dict[str, type[BaseModel]],
    *,
    what: str,
    field: str | None = None,
    shorthand: Callable[[Any], Any] | None = None,
) -> Any:
    """A union of models told apart by one key: a validated model per kind.

    With ``field`` None the kind is the one key of ``models`` that a mapping has
    (``{led: {...}}`` in a scene); otherwise it is the value of ``field``
    (``backend: genicam`` in a station). Unknown keys inside a kind are refused
    by that kind's model. Tags start with "_" so that messages show the user's
    own field path once (:func:`explain` leaves them out). ``shorthand`` maps a
    plain value (a name) to a mapping first.
    """
    from typing import Annotated, Union

    from pydantic import BeforeValidator, Discriminator, Tag

    kinds = tuple(models)

    def tag(value):
        if isinstance(value, dict):
            if field is not None:
                kind = value.get(field)
                return f"_{kind}" if kind in kinds else None
            found = [k for k in kinds if k in value]
            return f"_{found[0]}" if len(found) == 1 else None
        for kind, model in models.items():
            if isinstance(value, model):
                return f"_{kind}"
        return None

    message = (
        f"{what}: give exactly one of {', '.join(kinds)}"
        if field is None
        else f"{field} must be one of {', '.join(kinds)}"
    )
    union = Annotated[  # type: ignore[valid-type]  # a union built at run time
        Union[tuple(Annotated[m, Tag(f"_{k}")] for k, m in models.items())],  # noqa: UP007
        Discriminator(tag, custom_error_type="kind", custom_error_message=message),
    ]
    return Annotated[union, BeforeValidator(shorthand)] if shorthand else union


def field_docs(model: type[BaseModel]) -> dict[str, str]:
    """The docstring under each field of ``model`` and its bases (a string literal right
    after the field's annotated assignment), read from the source: what each key of a
    file means, for the manual's format pages and the comments ``init`` writes."""
    import ast
    import inspect
    import itertools
    import textwrap

    docs: dict[str, str] = {}
    for cls in reversed(model.__mro__):
        if not (isinstance(cls, type) and issubclass(cls, BaseModel)) or cls is BaseModel:
            continue
        try:
            source = ast.parse(textwrap.dedent(inspect.getsource(cls))).body[0]
        except (OSError, TypeError, IndexError):  # made at run time: no source
            continue
        body = source.body if isinstance(source, ast.ClassDef) else []
        for node, after in itertools.pairwise(body):
            if (
                isinstance(node, ast.AnnAssign)
                and isinstance(node.target, ast.Name)
                and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)
            ):
                docs[node.target.id] = inspect.cleandoc(after.value.value)
    return docs


def known_keys(model: type[BaseModel]) -> set[str]:
    """Every key ``model`` and the models nested in it take (through unions, lists and
    mappings), for suggesting the one a misspelt key meant."""
    import typing

    keys: set[str] = set()
    seen: set[type] = set()
    todo: list[Any] = [model]
    while todo:
        tp = todo.pop()
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if tp in seen:
                continue
            seen.add(tp)
            for name, info in tp.model_fields.items():
                keys.add(info.alias or name)
                todo.append(info.annotation)
        else:
            todo.extend(a for a in typing.get_args(tp) if not isinstance(a, str | int | float))
    return keys


def explain(exc: ValidationError, *, known: set[str] | None = None) -> str:
    """pydantic's errors as ``field.path: message; ...``.

    Union members that pydantic adds to the path (``_ClassModel``,
    ``list[dict[str,any]]``) are left out: the user wrote neither. An unknown key gets
    the nearest of ``known`` as a suggestion (``exposure_ms`` → ``exposure_us``).
    """
    import difflib

    def field(part) -> bool:
        return isinstance(part, int) or not (str(part).startswith("_") or "[" in str(part))

    def path(loc) -> str:
        out = ""
        for p in filter(field, loc):
            out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
        return out

    def message(e) -> str:
        text = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden" and known and e["loc"]:
            key = str(e["loc"][-1])
            if key in known:  # another section's key (a simulated camera's width:)
                return f"{text}: '{key}' is not a key of this section"
            near = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.6)
            if near:
                text += f"; did you mean '{near[0]}'?"
        return text

    return "; ".join(
        f"{path(e['loc'])}: {message(e)}" if e["loc"] else message(e) for e in exc.errors()
    )


def load_yaml(path: str | Path, model: type[M], *, what: str) -> M:
    """Read ``path`` as YAML and validate it against ``model``.

    Raises
    ------
    InputError
        Missing file, YAML syntax error or a field that fails validation, with
        the file (and field) named.
    """
    path = Path(path)
    return validate(read_mapping(path, what=what), model, what=what, source=str(path))


def validate(doc: dict, model: type[M], *, what: str, source: str) -> M:
    """``doc``, a file's mapping, validated against ``model``; an error names ``source``,
    the field and, where the document is another kind of file, that kind."""
    try:
        return model.model_validate(doc)
    except ValidationError as exc:
        other = _other_kind(doc, model, what)
        raise InputError(other or explain(exc, known=known_keys(model)), source=source) from None


# Top-level keys that only one kind of file has: a file of another kind given in its
# place is named as such, rather than explained as a dozen wrong fields.
_SIGNATURES = (
    ("station file", ("controller", "illuminations")),
    ("scene file", ("lights", "cameras", "optics")),
    ("camera file", ("measured",)),
)


# The JSON documents the tool writes, by their "schema".
_SCHEMAS = {
    "inspect-validate/golden": "golden file",
    "inspect-validate/verification": "verification document",
    "inspect-validate/measurement": "measurement document",
    "inspect-validate/prediction": "prediction document",
    "inspect-validate/design": "design document",
    "inspect-validate/characterization": "characterization document",
    "inspect-validate/watch-status": "watch status file",
    "inspect-validate/spectral-analysis": "spectral analysis",
    "inspect-validate/field": "field file",
    "inspect-validate/sharpness": "sharpness file",
}


def file_kind(doc: object, *, model: type[BaseModel] | None = None) -> tuple[str, str] | None:
    """What kind of the tool's files ``doc`` (a parsed YAML or JSON document) is, and the
    evidence: a document the tool wrote names its ``schema``; a station, scene or camera
    file has top-level keys only its kind has (those ``model`` has itself not counted)."""
    if not isinstance(doc, dict):
        return None
    schema = doc.get("schema")
    if isinstance(schema, str) and schema in _SCHEMAS:
        return _SCHEMAS[schema], f"its schema is {schema}"
    fields = model.model_fields if model is not None else {}
    for kind, keys in _SIGNATURES:
        found = [k for k in keys if k in doc and k not in fields]
        if found:
            return kind, f"it has {', '.join(found)}"
    return None


def _other_kind(doc: dict, model, what: str) -> str | None:
    known = file_kind(doc, model=model)
    if known is None or known[0] == what:
        return None
    kind, evidence = known
    hint = ""
    if kind == "station file" and isinstance(doc.get("scene"), str):
        hint = f" (its scene file is {doc['scene']}, relative to it)"
    return f"this is a {kind} ({evidence}), where the command expects the {what}{hint}"


def read_document(
    path: str | Path, model: type[M], *, schema: str, what: str, todo: str, largest: int
) -> M:
    """A JSON document the tool wrote (its ``schema``), read from ``path`` (a regular file
    of at most ``largest`` bytes) and validated against ``model``.

    Raises
    ------
    InputError
        Missing, not JSON, another of the tool's files (named) or none, or a field out of
        its range (named): each naming the file, ``what`` it should be and ``todo``.
    """
    import json

    from inspect_validate.files import input_file

    path = input_file(path, what, todo=todo, largest=largest)
    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise InputError(f"not a {what} in JSON ({exc}); {todo}", source=str(path)) from None
    if not isinstance(doc, dict) or doc.get("schema") != schema:
        known = file_kind(doc)
        kind = f"this is a {known[0]} ({known[1]})" if known else f"not a {what}"
        raise InputError(f"{kind}, where a {what} is expected: {todo}", source=str(path))
    try:
        return model.model_validate(doc)
    except ValidationError as exc:
        raise InputError(explain(exc), source=str(path)) from None
    except ValueError as exc:  # a validator's own
        raise InputError(str(exc), source=str(path)) from None
