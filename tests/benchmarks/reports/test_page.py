"""Tests of benchmarks.reports.page: the suite page and the results index, in a real browser.

Headless Chromium from Debian's package (``/usr/bin/chromium``, installed by ``make`` where it
runs as root on Debian), driven by Playwright with that executable (Playwright never downloads a
browser here). Without either, the browser tests skip and say why; the HTML tests still run.
"""

import re
import shutil
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest

from benchmarks.reports import write_report
from benchmarks.reports.links import broken_links
from benchmarks.reports.page import ON_DEMAND, PAGE, write_index
from tests._paths import RESULTS

CHROMIUM = Path("/usr/bin/chromium")
ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip
QUICK = RESULTS / "quick"


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """A results folder: the committed quick suite's report rebuilt, and one animation."""
    from PIL import Image

    root = tmp_path_factory.mktemp("results")

    def charts_and_pages(folder, names):  # rebuilt below; the crops' strips are data
        return [n for n in names if n.endswith(".html") or (folder == str(QUICK) and ".png" in n)]

    shutil.copytree(QUICK, root / "quick", ignore=charts_and_pages)
    anim = root / "animations"
    anim.mkdir()
    frames = [Image.fromarray(np.full((8, 8, 3), v, np.uint8)) for v in (0, 255)]
    frames[0].save(anim / "direct.gif", save_all=True, append_images=frames[1:])
    (anim / "direct.mp4").write_bytes(b"not a real video")
    (root / "speed").mkdir()
    (root / "speed" / "speed.md").write_text("# Speed\n")
    write_report(root / "quick", title="quick")
    write_index(root)
    return root


def test_the_suite_page_links_every_file_and_shows_each_scene(site):
    text = (site / "quick" / "index.html").read_text()
    for name in ("table.md", "decision.md", "gap.md", "cells.jsonl", "error_vs_time_direct.png"):
        assert f'href="{name}' in text, name  # cells.jsonl or its archive
    for name in ON_DEMAND:  # named with the command that writes them, never linked
        assert f'href="{name}' not in text and f"<code>{name}</code>" in text
    assert "bnerr bench --suite quick --report-only" in text
    assert broken_links(site / "quick" / PAGE, root=site) == []
    assert 'id="direct"' in text and 'id="indirect"' in text
    assert text.count('class="cmp"') == 2 and "<svg" in text and 'class="sortable"' in text
    assert "http://" not in text.replace("http://www.w3.org/2000/svg", "")  # no network


def test_the_index_links_suites_reports_and_animations(site):
    text = (site / "index.html").read_text()
    assert 'href="quick/index.html"' in text and 'href="speed/speed.md"' in text
    assert 'src="animations/direct.gif"' in text


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    if not CHROMIUM.exists():
        pytest.skip("no /usr/bin/chromium (Debian: apt-get install chromium; make does as root)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    profile = tmp_path_factory.mktemp("chromium-profile")
    with sync_api.sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            str(profile), executable_path=str(CHROMIUM), args=ARGS, headless=True
        )
        yield context
        context.close()


def _open(browser, path: Path):
    page = browser.new_page()
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("requestfailed", lambda r: errors.append(f"failed: {r.url}"))
    page.goto(path.as_uri(), wait_until="load")
    return page, errors


@pytest.mark.parametrize("name", ["index.html", "quick/index.html"])
def test_a_page_loads_without_errors_and_every_image_and_link_resolves(browser, site, name):
    from PIL import Image

    page, errors = _open(browser, site / name)
    page.evaluate("() => document.querySelectorAll('details').forEach(d => d.open = true)")
    # Lazy images load only near the viewport: every one must resolve, however long the page.
    page.evaluate(
        """() => Promise.all([...document.querySelectorAll('img')].map(im => {
             im.loading = 'eager';
             return im.complete ? null : new Promise(done => { im.onload = im.onerror = done; });
           }))"""
    )
    page.wait_for_load_state("networkidle")
    sizes = page.eval_on_selector_all("img", "els => els.map(e => [e.src, e.naturalWidth])")
    assert sizes and all(width > 0 for _, width in sizes), sizes
    sprites = page.evaluate(
        """() => Promise.all([...new Set([...document.querySelectorAll('option')]
             .map(o => o.value.split('|')[0]))].map(src => new Promise(done => {
               const im = new Image(); im.onload = () => done(im.naturalWidth);
               im.onerror = () => done(0); im.src = src; })))"""
    )
    assert all(width > 0 for width in sprites), sprites
    links = page.eval_on_selector_all("a[href]", "els => els.map(e => e.href)")
    for link in links:
        target = Path(unquote(urlparse(link).path))
        assert target.exists(), link
    shot = site / f"{name.replace('/', '_')}.shot.png"
    page.screenshot(path=str(shot), full_page=True)
    with Image.open(shot) as image:
        assert len(image.convert("RGB").getcolors(1 << 24) or []) > 50  # not blank
    assert errors == []
    page.close()


def test_sorting_a_table_reorders_it(browser, site):
    page, errors = _open(browser, site / "quick" / "index.html")
    table = page.locator("table.sortable").first
    column = "() => [...document.querySelector('table.sortable').tBodies[0].rows]"
    column += ".map(r => r.cells[1].textContent)"
    before = page.evaluate(column)
    table.locator("th").nth(1).click()
    table.locator("th").nth(1).click()  # descending: a reorder whatever the first order
    after = page.evaluate(column)
    assert after == sorted(before, key=float, reverse=True) and after != before
    assert errors == []
    page.close()


def test_the_flip_and_the_slider_change_what_is_shown(browser, site):
    page, errors = _open(browser, site / "quick" / "index.html")
    cmp = page.locator(".cmp").first
    layer_b = cmp.locator(".cmp-layer.b")

    def shown():
        return (cmp.get_attribute("data-shown"), layer_b.evaluate("e => e.style.display"),
                layer_b.evaluate("e => e.style.clipPath"))  # fmt: skip

    start = shown()
    assert start[0] == "slider" and "50%" in start[2]
    cmp.locator("button.flip").click()
    assert shown()[:2] == ("a", "none")
    cmp.locator("button.flip").click()
    assert shown() == ("b", "", "none")
    cmp.locator("input[type=range]").fill("20")
    assert shown() == ("slider", "", "inset(0px 0px 0px 20%)")
    layer_a = cmp.locator(".cmp-layer.a")
    before = layer_a.evaluate("e => e.style.backgroundImage + e.style.backgroundPosition")
    cmp.locator("select.a").select_option(index=0)
    assert layer_a.evaluate("e => e.style.backgroundImage + e.style.backgroundPosition") != before
    error = cmp.locator("select.a option", has_text="error").first.get_attribute("value")
    cmp.locator("select.a").select_option(value=error)  # an error map: two tiles blended
    assert layer_a.evaluate("e => e.style.backgroundBlendMode") == "difference"
    cmp.locator(".cmp-view").hover()
    assert cmp.locator(".cmp-lens").evaluate("e => e.style.display") == "block"
    assert errors == []
    page.close()


def test_the_page_opens_with_the_decision_heatmap(browser, site):
    """Item 5 of issue 53: the decision table as a picture before any text table, a cell per
    scene, spp and denoiser coloured by its ratio to white, marked with its verdict, named by
    its strategy, its interval on hover."""
    from benchmarks.reports.decision import cell_verdicts
    from benchmarks.reports.table import summarize
    from benchmarks.sweep.records import final_records, load_records

    page, errors = _open(browser, site / "quick" / "index.html")
    first = page.evaluate(
        "() => [...document.querySelectorAll('figure.hm, table')].map(e => e.className)[0]"
    )
    assert first == "hm"  # before decision.md's sortable table
    figures = page.evaluate(
        """() => [...document.querySelectorAll('figure.hm')].map(f => [
            f.querySelector('figcaption').innerText,
            [...f.querySelectorAll('td.hm-cell')].map(e => [e.dataset.verdict, e.dataset.value,
                e.title, e.innerText, getComputedStyle(e).backgroundColor,
                e.getBoundingClientRect().width])])"""
    )
    # the MSE decision first; the quick suite measures cvvdp, so its JOD judgement follows
    assert [caption.split(" (")[0] for caption, _ in figures][:1] == ["The decision"]
    cells = figures[0][1]
    rows = summarize([r for r in final_records(load_records(site / "quick")) if r.has_pixels])
    verdicts = cell_verdicts(rows)
    assert len(cells) == len(verdicts)  # every cell of the decision, one colour each
    assert [len(f[1]) for f in figures[1:]] == [len(verdicts)] * (len(figures) - 1)
    assert sorted(c[0] for c in cells) == sorted(v for v, _ in verdicts.values())
    for said, value, title, text, colour, width in cells:
        assert re.search(r"\[\d\.\d{3}, \d\.\d{3}\]", title) and said in title  # the interval
        assert text.split()[0] in title and value in text and width > 40
        blue = float(value) < 1.0
        r, _, b = (int(x) for x in re.findall(r"\d+", colour)[:3])
        assert (b > r) == blue or abs(float(value) - 1.0) < 0.02, (value, colour)
    hover = page.locator("table.heatmap td.hm-cell").first
    hover.hover()
    assert hover.get_attribute("title").startswith(hover.inner_text().split("\n")[0])
    page.locator("figure.hm").first.screenshot(path=str(site / "heatmap.shot.png"))
    assert errors == []
    page.close()


def test_the_rebuild_command_names_a_suite_only_for_a_suite_folder(tmp_path):
    """Issue 54: a run into ``--out den`` was told to rebuild with ``--suite den``."""
    from benchmarks.reports.page import rebuild_command

    assert rebuild_command(tmp_path / "quick") == "bnerr bench --suite quick --report-only"
    assert rebuild_command(tmp_path / "den") == "bnerr bench --report-only --out den"
