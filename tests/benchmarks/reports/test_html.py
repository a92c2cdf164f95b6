"""Tests of benchmarks.reports.html: the reports' Markdown as HTML, and the page shell."""

from benchmarks.reports.html import inline, markdown_html, page


def test_inline_escapes_and_renders_bold_and_code():
    assert inline("a <b> **c** `d`") == "a &lt;b&gt; <b>c</b> <code>d</code>"


def test_markdown_headings_paragraphs_lists_and_sortable_tables():
    text = (
        "# Title\n\nSome text\non two lines.\n\n- one\n- two\n\n| a | b |\n|---|--:|\n| 1 | x |\n"
    )
    out = markdown_html(text)
    assert "<h2>Title</h2>" in out
    assert "<p>Some text on two lines.</p>" in out
    assert "<ul><li>one</li><li>two</li></ul>" in out
    assert '<table class="sortable"><thead><tr><th>a</th><th>b</th></tr></thead>' in out
    assert "<tr><td>1</td><td>x</td></tr>" in out


def test_a_table_right_after_a_paragraph_is_still_a_table():
    out = markdown_html("Intro line\n| a |\n|---|\n| 1 |\n")
    assert "<p>Intro line</p>" in out and "<td>1</td>" in out


def test_page_inlines_style_and_script():
    out = page("T <x>", "<p>body</p>")
    assert out.startswith("<!DOCTYPE html>") and "<title>T &lt;x&gt;</title>" in out
    assert "<style>" in out and "<script>" in out and "<script src" not in out
