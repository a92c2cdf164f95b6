"""Tests of benchmarks.reports.links: the targets of pages and reports, and what is broken."""

import pytest

from benchmarks.reports.links import broken_links, markdown_links, page_links
from benchmarks.reports.page import write_index
from bnerr.errors import FileFormatError


def test_page_links_reads_href_src_ids_and_the_comparison_strips():
    text = (
        '<a href="a.md">a</a><img src="b.png" alt="b"><h2 id="x">x</h2><a href="#x">x</a>'
        '<select><option value="crops/c.webp|0|3|-1">c</option><option value="1">n</option>'
        '</select><svg xmlns="http://www.w3.org/2000/svg"></svg>'
    )
    targets, ids = page_links(text)
    assert targets == ["a.md", "b.png", "#x", "crops/c.webp"] and ids == {"x"}


def test_markdown_links_reads_links_and_images_outside_code():
    text = '![fig](f.png) and [t](t.md "title") `[no](code.md)` | 0.9 [0.8, 1.0] |'
    text += "\n```\n[x](y)\n```"
    assert markdown_links(text) == ["f.png", "t.md"]


def test_broken_links_names_missing_files_anchors_and_links_that_leave(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "ok.png").write_bytes(b"")
    page = tmp_path / "sub" / "index.html"
    text = (
        '<h2 id="here">h</h2><a href="#here">ok</a><img src="../ok.png"><a href="#gone">g</a>'
        '<a href="missing.csv">m</a><a href="https://example.org">e</a>'
        '<a href="../../out.md">o</a><a href="../index.html">coming</a>'
    )
    problems = broken_links(page, text, root=tmp_path, coming=[tmp_path / "index.html"])
    assert len(problems) == 4
    for what in ("#gone", "missing.csv", "https://example.org", "../../out.md"):
        assert any(what in p for p in problems), what
    (tmp_path / "r.md").write_text("![a](ok.png) [b](nothere.md) [c](#heading)")
    assert [p for p in broken_links(tmp_path / "r.md") if "nothere.md" in p] == broken_links(
        tmp_path / "r.md"
    )


def test_the_page_writer_refuses_a_page_that_links_a_file_it_did_not_write(tmp_path):
    (tmp_path / "animations").mkdir()
    (tmp_path / "animations" / "direct.gif").write_bytes(b"GIF89a")
    (tmp_path / "speed").mkdir()
    (tmp_path / "speed" / "speed.md").write_text("# Speed\n")
    write_index(tmp_path)  # every link resolves
    assert not broken_links(tmp_path / "index.html")
    (tmp_path / "speed" / "speed.md").unlink()
    (tmp_path / "speed" / "speed.md").mkdir()  # found by the glob, but no file to link
    with pytest.raises(FileFormatError, match="speed.md"):
        write_index(tmp_path)
