"""Reading and writing the documents of every format: TOML or JSON text, within a size limit.

- :func:`format_of`: a file's format from its suffix (``.toml`` or ``.json``);
- :func:`read`: the bytes of a regular file, refused unread over the limit;
- :func:`parse`: the document of a TOML or JSON text; a syntax error names its line, a key given
  twice in JSON is refused as TOML refuses it, and so is text that is not UTF-8;
- :func:`dump_toml`: a document as TOML text, every float in Python's shortest round-trip form
  (so that reading it back gives the same floats), tables as sections.

Every failure is the caller's error class (a :class:`~bnerr.errors.BnerrError`), its message
starting with the file (``source``).
"""

from __future__ import annotations

import json
import stat
import tomllib
from pathlib import Path
from typing import cast

from bnerr.errors import BnerrError, toml_reason
from bnerr.schemas.fields import NAME_PATTERN

__all__ = ["dump_toml", "format_of", "parse", "read"]


def format_of(path: Path, error: type[BnerrError]) -> str:
    """``"toml"`` or ``"json"``, from the suffix of ``path``."""
    fmt = {".toml": "toml", ".json": "json"}.get(path.suffix.lower())
    if fmt is None:
        raise error(f"{path}: expected a suffix .toml or .json, got {path.suffix!r}")
    return fmt


def read(path: Path, error: type[BnerrError], limit: int) -> bytes:
    """The bytes of the regular file ``path``, refused over ``limit`` bytes unread."""
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise error(f"{path}: expected a regular file, got another kind of file")
        if info.st_size > limit:
            raise error(f"{path}: expected at most {limit} bytes, got {info.st_size}")
        with path.open("rb") as f:
            data = f.read(limit + 1)  # the file may have grown since stat
    except OSError as err:
        if isinstance(err, BnerrError):
            raise
        raise error(f"{path}: expected a readable file, got {err.strerror or err}") from None
    if len(data) > limit:
        raise error(f"{path}: expected at most {limit} bytes, got more")
    return data


def _no_duplicates(pairs: list[tuple[str, object]]) -> dict:
    """JSON object hook: a key given twice is an error (TOML refuses it too)."""
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"key {key!r} given twice")
        out[key] = value
    return out


def parse(
    data: bytes | str,
    fmt: str,
    source: str,
    error: type[BnerrError],
    limit: int | None = None,
    what: str = "",
) -> object:
    """The document of a TOML (``fmt`` ``"toml"``) or JSON text; syntax errors name the line.
    ``what`` names the document in a syntax error's "expected ..." (default: the format)."""
    what = what or fmt.upper()
    if isinstance(data, str):
        data = data.encode("utf-8", "surrogatepass")
    if limit is not None and len(data) > limit:
        raise error(f"{source}: expected at most {limit} bytes, got {len(data)}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        raise error(
            f"{source}: line {line}: expected UTF-8 text, got byte {data[err.start]:#04x}"
        ) from None
    try:
        if fmt == "toml":
            return tomllib.loads(text)
        return json.loads(text, object_pairs_hook=_no_duplicates)
    except json.JSONDecodeError as err:
        raise error(
            f"{source}: expected {what}, got {err.msg} (at line {err.lineno}, column {err.colno})"
        ) from None
    except tomllib.TOMLDecodeError as err:
        raise error(f"{source}: expected {what}, got {toml_reason(err, text)}") from None
    except (ValueError, RecursionError) as err:  # a duplicate JSON key, 5000-digit integers, ...
        raise error(f"{source}: expected a {fmt.upper()} document, got {err}") from None


def _toml_key(key: str) -> str:
    return key if NAME_PATTERN.fullmatch(key) else json.dumps(key, ensure_ascii=False)


def _toml_value(value: object) -> str:
    """One TOML value; tables inline. Floats in Python's shortest round-trip form."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    items = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in cast(dict, value).items())
    return "{ " + items + " }"


def _section(value: object) -> bool:
    """Whether ``value`` is written as its own section: a table or an array of tables."""
    return isinstance(value, dict) or (
        isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)
    )


def _toml_table(path: str, table: dict, lines: list[str]) -> None:
    """``[path]`` with its plain values, then its sub-tables as ``[path.key]`` sections."""
    if path and (not table or not all(_section(v) for v in table.values())):
        lines += ["", f"[{path}]"]  # TOML implies a header that holds only sub-tables
    lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in table.items() if not _section(v)]
    for k, v in table.items():
        if isinstance(v, dict):
            _toml_table(f"{path}.{_toml_key(k)}" if path else _toml_key(k), v, lines)
    for k, v in table.items():
        if _section(v) and isinstance(v, list):
            for item in v:
                lines += ["", f"[[{_toml_key(k)}]]"]
                lines += [f"{_toml_key(ik)} = {_toml_value(iv)}" for ik, iv in item.items()]


def dump_toml(document: dict) -> str:
    """``document`` (a dict of lists, dicts, strings, bools and numbers) as TOML text: its plain
    values first, then each table as a ``[section]`` and each array of tables as ``[[key]]``."""
    lines: list[str] = []
    _toml_table("", document, lines)
    return "\n".join(lines) + "\n"
