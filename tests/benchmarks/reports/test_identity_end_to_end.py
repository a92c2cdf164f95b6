"""End to end: a strategy of a new family and a new denoiser, defined here (outside the packages),
reach every report with their class's identity: the tables' order, the charts' legends and
colours, the decision table and the page. And a record's name that is no longer registered falls
back as the contract says (a variant to its base, anything else to the neutral "other")."""

from __future__ import annotations

import colorsys
import csv
import io
import re

import matplotlib
import pytest
import torch

from benchmarks.reports import write_report
from benchmarks.reports.charts import error_vs_time_figure
from benchmarks.reports.decision import decision_excludes, decision_table
from benchmarks.reports.denoisers import accumulators, denoise_markdown
from benchmarks.reports.groups import strategy_order
from benchmarks.reports.palette import family_hue, strategy_color, strategy_style
from benchmarks.reports.table import csv_text, markdown_table, summarize
from bnerr.frame import Frame
from bnerr.strategies import STRATEGIES, WhiteStrategy, strategy_identity
from denoisers import DENOISERS, Denoiser, denoiser_identity
from tests._records import small_record

matplotlib.use("Agg")

_SETS, _FRAMES = 3, 2
_COUNT = 16 * 16


def _pairs(scale: float) -> list:
    """``[S][F][2]`` (sum, count) pairs of a mean squared error near ``scale``."""
    return [
        [[scale * (1 + 0.1 * s + 0.05 * f) * _COUNT, _COUNT] for f in range(_FRAMES)]
        for s in range(_SETS)
    ]


def _record(strategy: str, denoiser: str, den: float, raw: float = 1.0):
    metrics = ("mse", "mse_blur1", "mse_blur2")
    return small_record(
        strategy,
        denoiser,
        raw={m: _pairs(raw) for m in metrics},
        den={m: _pairs(den) for m in metrics},
        frames=_FRAMES,
        seed_sets=_SETS,
    )


@pytest.fixture
def newcomers(monkeypatch):
    """A strategy of the new family ``glow`` ranked between white and every rival, and a
    temporal-kind denoiser, registered as a plug-in would be; removed afterwards."""

    class GlowStrategy(WhiteStrategy):
        name = "glow_e2e"
        stream = 9_001
        family = "glow"
        rank = 5

    class SoftDenoiser(Denoiser):
        name = "soft_e2e"
        kind = "temporal"
        grid = {"width": (1, 2)}

        def denoise(self, frame: Frame) -> torch.Tensor:
            return frame.color

    monkeypatch.setitem(DENOISERS, SoftDenoiser.name, SoftDenoiser)
    yield GlowStrategy, SoftDenoiser
    STRATEGIES.remove(GlowStrategy.name)


def _records():
    den = {"white": 1.0, "glow_e2e": 0.5, "temporal": 0.8, "oracle": 0.3}
    return [
        _record(s, d, value * (1.2 if d == "soft_e2e" else 1.0))
        for d in ("gaussian", "soft_e2e")
        for s, value in den.items()
    ]


def _hue(color: str) -> float:
    r, g, b = (int(color[i : i + 2], 16) / 255 for i in (1, 3, 5))
    return colorsys.rgb_to_hls(r, g, b)[0]


def test_the_newcomers_identity_is_their_classes(newcomers):
    glow = strategy_identity("glow_e2e")
    assert (glow.family, glow.rank, glow.bound, glow.registered) == ("glow", 5, False, True)
    soft = denoiser_identity("soft_e2e")
    assert soft.kind == "temporal" and dict(soft.grid) == {"width": (1, 2)}
    assert "soft_e2e" in accumulators()


def test_the_tables_order_the_new_strategy_by_its_rank(newcomers):
    rows = summarize(_records(), resamples=200)
    table = list(csv.DictReader(io.StringIO(csv_text(rows))))
    assert {r["strategy"] for r in table} == {"white", "glow_e2e", "temporal", "oracle"}
    assert {r["denoiser"] for r in table} == {"gaussian", "soft_e2e"}
    glow = next(r for r in table if (r["strategy"], r["denoiser"]) == ("glow_e2e", "gaussian"))
    assert float(glow["den_mse_ratio"]) == pytest.approx(0.5)
    text = markdown_table(rows)
    assert "| spp | denoiser | white | glow_e2e | temporal | oracle |" in text
    assert re.search(r"\| 4 \| soft_e2e \| [0-9.]+ \| 0\.500 \[", text)


def test_the_charts_and_the_page_colour_the_new_family_in_its_own_hue(newcomers, tmp_path):
    rows = summarize(_records(), resamples=200)
    fig = error_vs_time_figure("direct", rows, ["gaussian", "soft_e2e"])
    legend = fig.legends[0]
    assert [t.get_text() for t in legend.get_texts()] == ["white", "glow_e2e", "temporal", "oracle"]
    drawn = {
        bars.get_label(): matplotlib.colors.to_hex(bars.lines[0].get_color())
        for bars in fig.axes[0].containers
    }
    color = strategy_color("glow_e2e")
    assert drawn["glow_e2e"] == color and strategy_style("glow_e2e")["linestyle"] == "-"
    hue = family_hue("glow")[0]
    assert min(abs(_hue(color) - hue), 1 - abs(_hue(color) - hue)) < 0.05
    assert color not in {strategy_color(s) for s in ("white", "temporal", "oracle")}
    write_report(tmp_path, _records(), charts=False)
    page = (tmp_path / "index.html").read_text()
    legend_html = re.findall(r'background:(#[0-9a-f]{6})"></i>([a-z_0-9]+)</span>', page)
    assert legend_html[:4] == [
        (strategy_color(s), s) for s in ("white", "glow_e2e", "temporal", "oracle")
    ]
    assert "soft_e2e" in page


def test_the_decision_table_and_the_denoiser_report_take_the_newcomers(newcomers):
    records = _records()
    rows = summarize(records, resamples=200)
    text = decision_table(rows)
    assert "| scene | spp | gaussian | soft_e2e |" in text
    body = next(line for line in text.splitlines() if line.startswith("| direct |"))
    assert body.count("**glow_e2e** 0.") == 2  # the best of both columns, the oracle left out
    assert "Left out: oracle (it renders K candidates per frame" in text
    section = denoise_markdown(records, rows)
    assert "## Temporal accumulation (taa, soft_e2e, svgf)" in section
    assert "| spp | strategy | gaussian | taa | soft_e2e | svgf |" in section
    assert "| 4 | glow_e2e | 0.50 [" in section


def test_an_unregistered_name_in_an_old_record_falls_back():
    retired, variant = strategy_identity("retired_e2e"), strategy_identity("temporal+old_option")
    last = max(c.rank for c in STRATEGIES.classes().values())
    assert (retired.family, retired.rank, retired.registered) == ("other", last + 1, False)
    assert (variant.family, variant.rank) == ("temporal", STRATEGIES["temporal"].rank)
    assert variant.raw_mse_note == STRATEGIES["temporal"].raw_mse_note
    assert strategy_identity("oracle+old_option").bound
    assert decision_excludes(["oracle+old_option"]) == ("oracle", "vertical", "oracle+old_option")
    assert strategy_order(["retired_e2e", "oracle", "white", "temporal+old_option"]) == [
        "white", "oracle", "retired_e2e", "temporal+old_option",
    ]  # fmt: skip
    assert denoiser_identity("retired_denoiser").kind == "other"
    assert denoiser_identity("gaussian:own").kind == "filter"
    old = _record("retired_e2e", "gaussian", 0.7)
    rows = summarize([_record("white", "gaussian", 1.0), old], resamples=200)
    assert "| spp | denoiser | white | retired_e2e |" in markdown_table(rows)
    assert re.fullmatch(r"#[0-9a-f]{6}", strategy_color("retired_e2e"))
