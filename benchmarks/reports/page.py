"""The results pages: ``<out>/index.html`` for a suite, and the index of a results folder.

:func:`write_suite_page` writes a suite's page, static and self-contained (style and script
inlined, :mod:`benchmarks.reports.html`), linking every file of the folder:

- first the decision table as a picture (:mod:`benchmarks.reports.heatmap`: a heatmap of the
  verdicts, and the JOD's where the records hold ColorVideoVDP), then its text, ``perceptual.md``
  where written, then ``gap.md`` and ``denoisers.md`` (``table.md``, every cell, is linked) as
  tables sortable by column;
- per group (scene and condition): the interactive error-against-time charts
  (:mod:`benchmarks.reports.svgchart`), the PNG charts, the image comparison of its crops (the
  strips of :mod:`benchmarks.reports.previews`: reference, each strategy raw and after each key
  denoiser, and their error maps; a slider or a flip between any two, a lens following the
  cursor) and the scene's animation when ``../animations`` holds one.

:func:`write_index` writes ``<results>/index.html``: a link to each suite's page, the other
folders' reports, and the animations.

Not for: serving the pages (``bnerr view``).
"""

from __future__ import annotations

import html
from collections import defaultdict
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path

from benchmarks.reports.charts import key_denoisers
from benchmarks.reports.groups import (
    group_key,
    group_order,
    group_slug,
    group_title,
    strategy_order,
)
from benchmarks.reports.heatmap import decision_heatmap, jod_heatmap
from benchmarks.reports.html import markdown_html, page
from benchmarks.reports.links import broken_links
from benchmarks.reports.previews import ERROR_GAIN, crop_strip
from benchmarks.reports.svgchart import legend_html, ratio_svg
from benchmarks.suites import SUITES
from benchmarks.sweep.records import Record
from bnerr.errors import FileFormatError
from bnerr.io import atomic_write

__all__ = ["ON_DEMAND", "PAGE", "write_index", "write_suite_page"]

#: File name of every page.
PAGE = "index.html"
#: The reports a page names but never links: the per-cell tables, which ``bnerr bench
#: --report-only`` writes from ``cells.jsonl.xz`` on demand and the committed ``results/`` leaves
#: out (``results/.gitignore``), so a page reads the same with or without them.
ON_DEMAND = ("table.csv", "gap.csv")
_REPORTS = ("gap.md", "denoisers.md")
#: The per-cell report, linked rather than inlined (a third of a page's bytes, and results/ has a
#: size limit: the decision table above it holds its verdicts).
_CELL_REPORT = "table.md"
#: The perceptual decision (:mod:`benchmarks.reports.perceptual`), after the MSE one.
_PERCEPTUAL = "perceptual.md"
_CHART_PREFIXES = ("error_vs_time_", "oracle_share_", "spectra_")


def _write(path: Path, text: str, root: Path, coming: tuple[Path, ...] = ()) -> None:
    """Write a page, refusing one that links a file not there (:mod:`~.links`)."""
    broken = broken_links(path, text, root=root, coming=coming)
    if broken:
        raise FileFormatError(
            f"{path}: expected every link to name a file of {root}, got {len(broken)} broken: "
            + "; ".join(broken[:5])
        )
    with atomic_write(path) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def rebuild_command(out: Path) -> str:
    """The command that rebuilds the reports of ``out`` from its cells: ``--suite NAME`` where
    the folder is named after a suite (``results/quick``), else ``--out`` and the folder's name
    (a run into ``--out den`` is not the suite ``den``: issue 54)."""
    if out.name in SUITES:
        return f"bnerr bench --suite {out.name} --report-only"
    return f"bnerr bench --report-only --out {out.name}"


def _files(out: Path) -> str:
    names = sorted(
        p.name
        for p in out.iterdir()
        if p.is_file() and p.name not in (PAGE, *ON_DEMAND) and p.name[0] != "."
    )
    links = " · ".join(f'<a href="{html.escape(n)}">{html.escape(n)}</a>' for n in names)
    tables = " and ".join(f"<code>{n}</code>" for n in ON_DEMAND)
    command = html.escape(rebuild_command(out))
    return (
        f"<p>Files: {links}</p><p>{tables} (every column of every cell) are written from the "
        f"cells on demand by <code>{command}</code>; the committed results leave them out.</p>"
    )


def _options(
    out: Path, records: list[Record], denoisers: list[str], kept: Mapping[str, Collection[str]]
) -> list[tuple[str, str]]:
    """(value, label) of every image a comparison offers: the reference once, then per strategy
    the raw frame and each key denoiser's, each also as an error map. A value is
    ``strip|tile|tiles|reference tile`` (-1: not an error map) for the page script. A strip
    written here keeps those tiles and the ones ``kept`` names for its crop file (the
    disagreement pictures', so that ``--report-only`` draws them again from the strips)."""
    options: list[tuple[str, str]] = []
    order = strategy_order(r.cell.strategy for r in records)
    for rec in sorted(records, key=lambda r: order.index(r.cell.strategy)):
        shown = ["reference", "raw", *(f"denoised/{d}" for d in denoisers)]
        more = sorted(set(kept.get(rec.crop or "", ())) - set(shown))
        found = crop_strip(out, rec.crop, keep=[*shown, *more])
        if found is None or "reference" not in found[1]:
            continue
        rel, names = found
        ref = names.index("reference")
        if not options:
            options.append((f"{rel}|{ref}|{len(names)}|-1", "reference"))
        for name in ["raw"] + [f"denoised/{d}" for d in denoisers]:
            if name in names:
                label = f"{rec.cell.strategy}: {name}"
                value = f"{rel}|{names.index(name)}|{len(names)}"
                options += [(f"{value}|-1", label), (f"{value}|{ref}", f"{label}, error")]
    return options


def _comparison(
    out: Path,
    slug: str,
    records: list[Record],
    denoisers: list[str],
    kept: Mapping[str, Collection[str]],
) -> str:
    """The comparison widget of one group's crops, or '' when it has none."""
    options = _options(out, records, denoisers, kept)
    if len(options) < 2:
        return ""
    spp = records[0].cell.spp
    raws = [i for i, (_, label) in enumerate(options) if label.endswith(": raw")]
    chosen_a, chosen_b = (raws[0], raws[1]) if len(raws) > 1 else (1, 0)  # white and a rival

    def select(cls: str, chosen: int) -> str:
        opts = "".join(
            f'<option value="{html.escape(v)}"{" selected" if i == chosen else ""}>'
            f"{html.escape(label)}</option>"
            for i, (v, label) in enumerate(options)
        )
        return f'<label>{cls.upper()} <select class="{cls}">{opts}</select></label>'

    return (
        f'<h4>Images at {spp} spp (centre crop)</h4><div class="cmp" id="cmp-{slug}">'
        f'<div class="cmp-controls">{select("a", chosen_a)}{select("b", chosen_b)}'
        '<label>slider <input type="range" min="0" max="100" value="50"></label>'
        '<button class="flip" type="button">flip A / B (key f)</button>'
        f"<small>Error: |image - reference| x{ERROR_GAIN}. Hover for a 4x lens.</small></div>"
        '<div class="cmp-view"><div class="cmp-layer a"></div><div class="cmp-layer b"></div>'
        '<div class="cmp-lens"></div><span class="cmp-label a"></span>'
        '<span class="cmp-label b"></span></div></div>'
    )


def _group_section(
    out: Path,
    slug: str,
    rows: list[dict],
    records: list[Record],
    kept: Mapping[str, Collection[str]],
) -> str:
    title = group_title(group_key(rows[0]))
    denoisers = key_denoisers(sorted({r["denoiser"] for r in rows}))
    svgs = "".join(
        f"<figure>{svg}<figcaption>{html.escape(d)}</figcaption></figure>"
        for d in denoisers
        if (svg := ratio_svg(rows, d))
    )
    charts = "".join(
        f'<img src="{prefix}{slug}{suffix}.png" alt="{prefix}{slug}{suffix}" loading="lazy">'
        for prefix in _CHART_PREFIXES
        for suffix in ("", "_other")
        if (out / f"{prefix}{slug}{suffix}.png").exists()
    )
    runs: dict[int, dict[str, Record]] = defaultdict(dict)
    for r in records:  # one record per run: its crop holds every denoiser
        if r.crop:
            runs[r.cell.spp].setdefault(r.cell.strategy, r)
    images = "".join(
        _comparison(out, f"{slug}-{spp}", list(runs[spp].values()), denoisers, kept)
        for spp in sorted(runs)
    )
    scene = rows[0]["scene"]
    anim = out.parent / "animations" / f"{scene}.gif"
    animation = (
        f'<h4>Animation</h4><p><img src="../animations/{scene}.gif" alt="{scene} animation">'
        f" {_MP4}</p>"
        if anim.exists()
        else ""
    )
    return (
        f'<h2 id="{slug}">{html.escape(title)}</h2>'
        "<p>Post-denoise MSE / white's (below 1: better than white) against ms per frame; "
        "hover a point for its strategy, spp, ratio and interval.</p>"
        f'<div class="svgs">{svgs}</div>{legend_html({r["strategy"] for r in rows})}'
        f'<details><summary>Charts</summary><div class="charts">{charts}</div></details>'
        f"{images}{animation}"
    )


def write_suite_page(
    out_dir: str | Path,
    rows: Sequence[dict],
    records: Sequence[Record],
    title: str,
    kept: Mapping[str, Collection[str]] | None = None,
) -> Path:
    """Write ``<out_dir>/index.html`` (and the crops' strips it shows, each also keeping the
    tiles ``kept`` names for its crop file: crop file -> tile names); return its path."""
    kept = {} if kept is None else kept
    out = Path(out_dir)
    by_slug: dict[str, list[dict]] = defaultdict(list)
    for row in rows:
        if row["region"] == "all":
            by_slug[group_slug(group_key(row))].append(row)
    recs: dict[str, list[Record]] = defaultdict(list)
    for rec in records:
        if rec.cell.region == "all":
            recs[group_slug(group_key(rec.cell.__dict__))].append(rec)
    order = sorted(by_slug, key=lambda s: group_order(group_key(by_slug[s][0])))
    toc = " · ".join(f'<a href="#{s}">{html.escape(s)}</a>' for s in order)
    parts = ['<p><a href="../index.html">All results</a></p>', f"<p>Scenes: {toc}</p>"]
    parts += [decision_heatmap(rows), jod_heatmap(rows)]
    for name in ("decision.md", _PERCEPTUAL):
        if (out / name).exists():
            parts.append(markdown_html((out / name).read_text(encoding="utf-8")))
    parts += [_group_section(out, s, by_slug[s], recs[s], kept) for s in order]
    if (out / _CELL_REPORT).exists():
        parts.append(
            f'<p>Every cell, with its intervals: <a href="{_CELL_REPORT}">{_CELL_REPORT}</a>.</p>'
        )
    for name in _REPORTS:
        if (out / name).exists():
            text = markdown_html((out / name).read_text(encoding="utf-8"))
            parts.append(f"<details><summary>{name}</summary>{text}</details>")
    parts.append(_files(out))
    path = out / PAGE
    _write(path, page(title, "\n".join(parts)), out.parent, coming=(out.parent / PAGE,))
    return path


def _folder_entry(folder: Path) -> str:
    name = html.escape(folder.name)
    if (folder / PAGE).exists():
        return f'<li><a href="{name}/{PAGE}">{name}</a></li>'
    docs = sorted(p.name for p in folder.glob("*.md"))
    links = ", ".join(f'<a href="{name}/{html.escape(d)}">{html.escape(d)}</a>' for d in docs)
    return f"<li>{name}: {links}</li>" if docs else ""


#: Where the full animations are: ``bnerr animate`` writes ``<scene>.mp4`` (every frame at full
#: size) beside the GIF (a crop), and the committed ``results/`` keeps the GIFs only (a size
#: limit), so no page links an MP4 and a page reads the same with or without them.
_MP4 = (
    "The GIF is a 64-pixel crop of 8 frames; <code>bnerr animate</code> (the command is in "
    "<code>animations/README.md</code>) also writes <code>&lt;scene&gt;.mp4</code>, every frame "
    "at full size, which the committed results leave out."
)
#: What the index says a suite folder keeps, and what is written on demand.
_KEPT = (
    "<p>Each suite folder keeps its cells (<code>cells.jsonl.xz</code>), its reports, charts, "
    "crops and page. <code>bnerr bench --suite NAME --report-only</code> rewrites all of them "
    "from the cells (the charts' pixels follow the matplotlib build), and writes the per-cell "
    "tables " + " and ".join(f"<code>{n}</code>" for n in ON_DEMAND) + ", which the committed "
    "results leave out.</p>"
)


def write_index(results_dir: str | Path) -> Path:
    """Write ``<results_dir>/index.html``: every suite page, report and animation there."""
    root = Path(results_dir)
    folders = sorted(p for p in root.iterdir() if p.is_dir())
    items = "".join(_folder_entry(f) for f in folders)
    gifs = sorted((root / "animations").glob("*.gif")) if (root / "animations").is_dir() else []
    anims = "".join(
        f'<figure><img src="animations/{g.name}" alt="{g.stem}"><figcaption>{g.stem}'
        "</figcaption></figure>"
        for g in gifs
    )
    body = f"<h2>Suites and reports</h2><ul>{items}</ul>{_KEPT}"
    if anims:
        body += f'<h2>Animations</h2><p>{_MP4}</p><div class="anims svgs">{anims}</div>'
    path = root / PAGE
    _write(path, page("bnerr results", body), root)
    return path
