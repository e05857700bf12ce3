"""Reading validated YAML files (ROI sets, scenes, stations).

One place turns YAML syntax errors and pydantic validation errors into
:class:`~inspect_validate.errors.InputError` messages that name the file and
the field (``classes.A.shapes.0: ...``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TypeVar

from pydantic import BaseModel, ValidationError

from inspect_validate.errors import InputError

__all__ = ["explain", "load_yaml"]

M = TypeVar("M", bound=BaseModel)


def explain(exc: ValidationError) -> str:
    """pydantic's errors as ``field.path: message; ...``.

    Union members that pydantic adds to the path (``_ClassModel``,
    ``list[dict[str,any]]``) are left out: the user wrote neither.
    """

    def field(part) -> bool:
        return isinstance(part, int) or not (str(part).startswith("_") or "[" in str(part))

    return "; ".join(
        f"{'.'.join(str(p) for p in e['loc'] if field(p))}: {e['msg']}" for e in exc.errors()
    )


def load_yaml(path: str | Path, model: type[M], *, what: str) -> M:
    """Read ``path`` as YAML and validate it against ``model``.

    Raises
    ------
    InputError
        Missing file, YAML syntax error or a field that fails validation, with
        the file (and field) named.
    """
    import yaml

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{what} not found", source=str(path))
    try:
        doc = yaml.safe_load(path.read_text())
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise InputError(f"not valid YAML: {exc}", source=str(path)) from None
    try:
        return model.model_validate(doc)
    except ValidationError as exc:
        raise InputError(explain(exc), source=str(path)) from None
