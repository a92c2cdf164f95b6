"""Tests of benchmarks.reports.heatmap: the decision table as a picture (its cells, colours,
marks and hover text; the browser test is in test_page.py)."""

import math
import re

import pytest

from benchmarks.reports.heatmap import decision_heatmap, jod_heatmap, ratio_colour
from tests._records import table_row


def _row(strategy, spp, mse, *, den="gaussian", half=0.03, jod=None, scene="direct"):
    return table_row(strategy, spp, mse, jod=jod, mse_half=half, den=den, scene=scene)


def _cells(text):
    pattern = (
        r'<td class="hm-cell" data-verdict="(\w+)" data-value="([^"]+)" '
        r'style="background:([^;]+);color:[^"]+" title="([^"]+)">(.*?)</td>'
    )
    return re.findall(pattern, text)


def test_the_scale_diverges_from_a_neutral_middle():
    assert ratio_colour(0.0) == "rgb(247,247,247)"
    assert ratio_colour(-1.0) == ratio_colour(-5.0) == "rgb(33,102,172)"  # blue: better
    assert ratio_colour(1.0) == "rgb(178,24,43)"  # red: worse
    assert ratio_colour(math.nan) == ratio_colour(0.0)
    mid = [int(x) for x in re.findall(r"\d+", ratio_colour(-0.5))]
    assert all(min(g, e) <= m <= max(g, e) for m, g, e in zip(mid, (247,) * 3, (33, 102, 172)))
    assert mid[0] == round(247 + (33 - 247) * 0.5)  # halfway to blue


def test_each_cell_shows_the_winner_its_ratio_verdict_and_interval():
    rows = [
        _row("white", 1, 1.0),
        _row("ldbn", 1, 0.6),  # better
        _row("zsobol", 1, 0.9),
        _row("white", 4, 1.0, den="oidn"),
        _row("ldbn", 4, 1.3, den="oidn", half=0.05),  # worse: white wins
        _row("white", 4, 1.0),
        _row("ldbn", 4, 0.99, half=0.3),  # open
    ]
    text = decision_heatmap(rows)
    cells = _cells(text)
    assert len(cells) == 3 and 'class="heatmap"' in text and "hm-legend" in text
    by = {value: (said, colour, title, inner) for said, value, colour, title, inner in cells}
    said, colour, title, inner = by["0.60"]
    assert said == "better" and inner.startswith("<b>ldbn<br>0.60") and "m = 2" in title
    assert re.search(r"\[0\.\d{3}, 0\.\d{3}\]", title)
    blue = [int(x) for x in re.findall(r"\d+", colour)]
    assert blue[2] > blue[0]
    said, colour, title, inner = by["1.30"]
    assert said == "worse" and inner == "white<br>1.30 worse" and "lowest rival ldbn" in title
    red = [int(x) for x in re.findall(r"\d+", colour)]
    assert red[0] > red[2]
    assert by["0.99"][0] == "open" and by["0.99"][3].endswith(" open")
    # rows: a group and spp each, in order; columns: the denoisers
    assert text.index(">1</th>") < text.index(">4</th>")
    assert re.findall(r"<th>(\w+)</th>", text)[:4] == ["scene", "spp", "gaussian", "oidn"]


def test_a_missing_cell_is_a_dash_and_no_ratio_no_heatmap():
    rows = [_row("white", 1, 1.0), _row("ldbn", 1, 0.6), _row("white", 4, 1.0, den="oidn")]
    rows.append(_row("ldbn", 4, 0.8, den="oidn"))
    rows.append(_row("white", 16, 1.0))
    rows.append(_row("ldbn", 16, 0.8))
    text = decision_heatmap(rows)
    assert text.count('class="hm-none"') == 3  # oidn at 1 and 16 spp, gaussian at 4
    assert decision_heatmap([_row("white", 1, 1.0)]) == ""


@pytest.mark.parametrize("jod", [0.6, -0.6])
def test_the_jod_heatmap_colours_higher_as_better(jod):
    rows = [_row("white", 1, 1.0, jod=0.0), _row("ldbn", 1, 0.8, jod=jod)]
    ((said, value, colour, title, _),) = _cells(jod_heatmap(rows))
    rgb = [int(x) for x in re.findall(r"\d+", colour)]
    assert (rgb[2] > rgb[0]) == (jod > 0) and value == f"{jod:+.2f}"
    assert said == ("better" if jod > 0 else "worse") and "JOD against white" in title
    assert jod_heatmap([_row("white", 1, 1.0), _row("ldbn", 1, 0.8)]) == ""
