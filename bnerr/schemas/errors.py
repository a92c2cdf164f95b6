"""The one mapping from a validation library's error to bnerr's one-line typed error.

:func:`validate` checks a parsed document against a model of :mod:`bnerr.schemas` and, on the
first problem, raises the :mod:`bnerr.errors` class the check named (the format's class by
default) with the message ``"<path>: expected X, got Y"``: ``shapes[3].radius: expected a finite
number in [1e-06, 1000000.0], got float -0.7``. The path is the key's, written as the user wrote
it (``a.b[3].c``); the tags pydantic puts into its locations for a union's branch are dropped.
"""

from __future__ import annotations

from typing import TypeVar

from pydantic import BaseModel, TypeAdapter, ValidationError

from bnerr import errors
from bnerr.schemas.fields import describe

__all__ = ["message", "validate"]

M = TypeVar("M")


def _path(loc: tuple[int | str, ...], document: object, root: str) -> str:
    """``loc`` as the path a user reads (``shapes[3].radius``), ``root`` for the document."""
    text, node = "", document
    for key in loc:
        if isinstance(node, list) and isinstance(key, int) and 0 <= key < len(node):
            text, node = f"{text}[{key}]", node[key]
        elif isinstance(node, dict) and key in node:
            text, node = f"{text}.{key}" if text else str(key), node[key]
        elif not isinstance(node, dict) or node.get("type") == key:
            continue  # the tag of a union's branch, not a key of the document
        else:
            text, node = f"{text}.{key}" if text else str(key), {}
    return text or root


def message(err: ValidationError, document: object, root: str) -> tuple[str, str]:
    """The one-line message of ``err``'s first problem in ``document`` and the name of the error
    class it asks for ("" for the format's own)."""
    first = err.errors(include_url=False)[0]
    loc, ctx = tuple(first["loc"]), first.get("ctx") or {}
    if first["type"] == "missing":
        at, text, kind = _path(loc[:-1], document, root), f"expected key {loc[-1]!r}, got none", ""
    elif "message" in ctx:
        at, text, kind = ctx.get("at") or _path(loc, document, root), ctx["message"], first["type"]
        if ctx.get("key"):  # one of the value's keys: after its path, or alone at the top
            at = f"{at}.{ctx['key']}" if loc or ctx.get("at") else ctx["key"]
    else:
        what = first["msg"][0].lower() + first["msg"][1:]
        at, text, kind = _path(loc, document, root), f"{what}, got {describe(first['input'])}", ""
    return (f"{at}: {text}" if at else text), kind


def validate(
    model: type[M] | TypeAdapter[M],
    document: object,
    error: type[errors.BnerrError],
    root: str,
    source: str = "",
) -> M:
    """``document`` validated as ``model`` (a model class or a TypeAdapter).

    Raises:
        error (or the :mod:`bnerr.errors` class the failed check names): the first problem, as
            :func:`message` writes it (``root`` names the document itself; "" for nothing),
            after ``source: `` where ``source`` is given (the file).
    """
    try:
        if isinstance(model, TypeAdapter):
            return model.validate_python(document)
        assert issubclass(model, BaseModel)
        return model.model_validate(document)
    except ValidationError as err:
        text, name = message(err, document, root)
        kind = getattr(errors, name, None) if name else None
        cls = kind if isinstance(kind, type) and issubclass(kind, errors.BnerrError) else error
        raise cls(f"{source}: {text}" if source else text) from None
