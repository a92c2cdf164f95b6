"""HTML pieces of the results pages: the reports' Markdown as HTML, and the page shell.

The reports write a small Markdown: ``#`` headings, paragraphs, lists and pipe tables, with
``**bold**`` and inline code. :func:`markdown_html` turns exactly that into HTML, each table
``class="sortable"`` (the page script sorts it by the clicked column). :func:`page` wraps a body
into a whole document with the style and the script of :mod:`benchmarks.reports.page_assets`
inlined, so a page needs no other file and no network.

Not for: general Markdown (no links, images or nested lists).
"""

from __future__ import annotations

import html
import re

from benchmarks.reports.page_assets import SCRIPT, STYLE

__all__ = ["inline", "markdown_html", "page"]


def inline(text: str) -> str:
    """Escape ``text`` and render its ``**bold**`` and ```code``` spans."""
    out = html.escape(text, quote=False)
    out = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", out)
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", out)


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def _table(lines: list[str]) -> str:
    head = "".join(f"<th>{inline(c)}</th>" for c in _cells(lines[0]))
    body = "".join(
        "<tr>" + "".join(f"<td>{inline(c)}</td>" for c in _cells(line)) + "</tr>\n"
        for line in lines[2:]
    )
    return f'<table class="sortable"><thead><tr>{head}</tr></thead><tbody>\n{body}</tbody></table>'


def _block(lines: list[str]) -> str:
    first = lines[0]
    if first.startswith("|") and len(lines) > 1 and set(lines[1]) <= set("|-: "):
        return _table(lines)
    if first.startswith("#"):
        level = min(len(first) - len(first.lstrip("#")) + 1, 6)  # the page's title is h1
        rest = "".join(f"<p>{inline(x)}</p>" for x in lines[1:])
        return f"<h{level}>{inline(first.lstrip('#').strip())}</h{level}>{rest}"
    if first.startswith(("- ", "* ")):
        items = "".join(f"<li>{inline(x[2:])}</li>" for x in lines if x.startswith(("- ", "* ")))
        return f"<ul>{items}</ul>"
    if first.startswith("    "):
        return f"<pre>{html.escape(chr(10).join(x[4:] for x in lines))}</pre>"
    return f"<p>{inline(' '.join(lines))}</p>"


def markdown_html(text: str) -> str:
    """The HTML of a report's Markdown: blocks split at blank lines and headings."""
    blocks: list[list[str]] = []
    current: list[str] = []
    for line in text.splitlines():
        starts = line.startswith("#") or (
            line.startswith("|") and current and not current[-1].startswith("|")
        )
        if not line.strip() or starts:
            if current:
                blocks.append(current)
            current = [line] if line.strip() else []
        else:
            current.append(line)
    if current:
        blocks.append(current)
    return "\n".join(_block(b) for b in blocks)


def page(title: str, body: str) -> str:
    """A whole self-contained HTML document."""
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head>\n"
        f"<body><h1>{html.escape(title)}</h1>\n{body}\n<script>{SCRIPT}</script></body></html>\n"
    )
