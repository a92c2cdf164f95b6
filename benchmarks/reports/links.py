"""The links of a results page or report, and the check that every one resolves to a file.

A results folder is read from disk or served as it is (``bnerr view``), so every ``href`` and
``src`` of its pages, and every link and image of its Markdown reports, must name a file that is
there, by a path relative to the page, inside the results folder; an ``#anchor`` must name an
``id`` of its page. No link leaves the folder (``http:``, ``https:``, ``//host``, ``mailto:``, an
absolute path): the pages work offline.

- :func:`page_links`: the targets and the ids of an HTML page (:mod:`html.parser`); the image
  comparison's ``<option value="strip|tile|tiles|ref">`` counts its strip as a target;
- :func:`markdown_links`: the targets of ``[text](target)`` and ``![alt](target)`` outside code;
- :func:`broken_links`: what is wrong with each target of a page or report, as messages.

The page writer (:mod:`benchmarks.reports.page`) refuses to write a page with a broken link;
``tests/test_results_links.py`` checks every committed page and report of ``results/``.

Not for: checking that a linked file is well formed.
"""

from __future__ import annotations

import re
from collections.abc import Collection
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote

__all__ = ["broken_links", "markdown_links", "page_links"]

_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")
_MD_LINK = re.compile(r"!?\[[^\]\n]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_CODE = re.compile(r"```.*?```|`[^`\n]*`", re.S)


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.targets: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for name, value in attrs:
            if value is None:
                continue
            if name in ("href", "src"):
                self.targets.append(value)
            elif name == "id" or (tag == "a" and name == "name"):
                self.ids.add(value)
            elif tag == "option" and name == "value" and "|" in value:
                self.targets.append(value.split("|", 1)[0])  # a comparison's strip


def page_links(text: str) -> tuple[list[str], set[str]]:
    """``(targets, ids)`` of an HTML page: every ``href`` and ``src`` (and comparison strip) in
    document order, and every ``id``."""
    parser = _Links()
    parser.feed(text)
    parser.close()
    return parser.targets, parser.ids


def markdown_links(text: str) -> list[str]:
    """The target of every link and image of a Markdown text, code spans and blocks left out."""
    return _MD_LINK.findall(_CODE.sub("", text))


def _problem(page: Path, target: str, ids: set[str], root: Path, coming: set[Path]) -> str:
    """What is wrong with one target of ``page``, or ''."""
    if _SCHEME.match(target) or target.startswith(("/", "\\")):
        return f"{target!r} leaves the results folder (expected a relative path)"
    path, _, anchor = target.partition("#")
    if not path:
        return "" if anchor in ids else f"{target!r} names no id of the page"
    file = (page.parent / unquote(path.split("?", 1)[0])).resolve()
    if not file.is_relative_to(root.resolve()):
        return f"{target!r} points outside {root}"
    if not file.is_file() and file not in coming:
        return f"{target!r} names no file (expected {file})"
    return ""


def broken_links(
    page: str | Path,
    text: str | None = None,
    *,
    root: str | Path | None = None,
    coming: Collection[str | Path] = (),
) -> list[str]:
    """One message per broken link of ``page`` (an ``.html`` page, else Markdown): a target
    leaving the folder, naming no file, or an ``#anchor`` naming no id of the page.

    Args:
        page: the page's path (targets resolve beside it).
        text: its text, when it is not written yet (default: read from ``page``).
        root: the folder no target may leave (default: the page's folder).
        coming: files written after the page (the results index), counted as present.
    """
    page = Path(page)
    text = page.read_text(encoding="utf-8") if text is None else text
    if page.suffix == ".html":
        targets, ids = page_links(text)
    else:
        targets, ids = markdown_links(text), set()
        targets = [t for t in targets if not t.startswith("#")]  # headings' slugs: not checked
    base = Path(root) if root is not None else page.parent
    due = {Path(p).resolve() for p in coming}
    problems = (_problem(page, t, ids, base, due) for t in dict.fromkeys(targets))
    return [f"{page}: {p}" for p in problems if p]
