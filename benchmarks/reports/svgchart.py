"""The interactive error-against-time chart of the results page: inline SVG, no script.

:func:`ratio_svg` draws one denoiser's panel of the error-against-time chart
(:mod:`benchmarks.reports.charts`): post-denoise MSE / white's against milliseconds per frame
(log scale), one line per strategy in its :mod:`benchmarks.reports.palette` colour, the interval
as a vertical bar; hovering a point shows its ``<title>``: strategy, spp, ratio and interval, and
the time. :func:`legend_html` is the legend under the charts, outside the data.

Not for: the PNG charts (matplotlib draws those).
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Iterable, Sequence

from benchmarks.reports.groups import strategy_order
from benchmarks.reports.palette import strategy_color

__all__ = ["legend_html", "ratio_svg"]

_W, _H, _L, _R, _T, _B = 360, 240, 48, 10, 10, 34


def _points(rows: Sequence[dict], denoiser: str) -> list[dict]:
    return [
        r
        for r in rows
        if r["denoiser"] == denoiser and r["den_mse_ratio"] is not None and r["total_ms"]
    ]


#: A scale: data value -> SVG coordinate.
_Scale = Callable[[float], float]


def _scales(pts: list[dict]) -> tuple[_Scale, _Scale, tuple[float, float, float, float]]:
    xs = [math.log10(r["total_ms"]) for r in pts]
    ys = [v for r in pts for v in (r["den_mse_ratio_lo"], r["den_mse_ratio_hi"]) if v is not None]
    ys += [r["den_mse_ratio"] for r in pts] + [1.0]
    x0, x1 = min(xs) - 0.05, max(xs) + 0.05
    y0, y1 = min(ys), max(ys)
    pad = 0.05 * (y1 - y0 or 1.0)
    y0, y1 = y0 - pad, y1 + pad

    def sx(ms: float) -> float:
        return _L + (math.log10(ms) - x0) / (x1 - x0) * (_W - _L - _R)

    def sy(v: float) -> float:
        return _T + (y1 - v) / (y1 - y0) * (_H - _T - _B)

    return sx, sy, (x0, x1, y0, y1)


def _axes(sx: _Scale, sy: _Scale, box: tuple[float, float, float, float]) -> list[str]:
    x0, x1, y0, y1 = box
    out = [f'<line x1="{_L}" y1="{sy(1.0):.1f}" x2="{_W - _R}" y2="{sy(1.0):.1f}" stroke="#aaa"/>']
    for k in range(5):
        v = y0 + (y1 - y0) * (k + 0.5) / 5
        out.append(f'<text x="{_L - 4}" y="{sy(v) + 3:.1f}" text-anchor="end">{v:.2f}</text>')
    for e in range(math.floor(x0), math.ceil(x1) + 1):
        for m in (1, 2, 5):
            lg = e + math.log10(m)
            if x0 <= lg <= x1:
                x = sx(10**lg)
                out.append(
                    f'<text x="{x:.1f}" y="{_H - _B + 14}" text-anchor="middle">{10**lg:g}</text>'
                )
    out.append(f'<text x="{(_L + _W) / 2}" y="{_H - 4}" text-anchor="middle">ms per frame</text>')
    w, h = _W - _L - _R, _H - _T - _B
    out.append(f'<rect x="{_L}" y="{_T}" width="{w}" height="{h}" fill="none" stroke="#999"/>')
    return out


def _point(r: dict, strategy: str, color: str, sx: _Scale, sy: _Scale) -> str:
    """One point: its interval bar and a circle whose ``<title>`` the browser shows on hover."""
    lo, hi, ratio = r["den_mse_ratio_lo"], r["den_mse_ratio_hi"], r["den_mse_ratio"]
    x, y = sx(r["total_ms"]), sy(ratio)
    interval = "" if lo is None or hi is None else f" [{lo:.3f}, {hi:.3f}]"
    tip = f"{strategy}, {r['spp']} spp: {ratio:.3f}{interval} of white, {r['total_ms']:.3g} ms"
    bar = ""
    if lo is not None and hi is not None:
        bar = f'<line x1="{x:.1f}" x2="{x:.1f}" y1="{sy(lo):.1f}" y2="{sy(hi):.1f}" '
        bar += f'stroke="{color}"/>'
    radius = 3 + min(r["spp"], 64) ** 0.5 / 2
    return (
        f'<g class="pt" data-strategy="{html.escape(strategy)}">{bar}'
        f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{radius:.1f}" fill="{color}">'
        f"<title>{html.escape(tip)}</title></circle></g>"
    )


def _series(pts: list[dict], sx: _Scale, sy: _Scale) -> list[str]:
    out = []
    for s in strategy_order(r["strategy"] for r in pts):
        line = sorted((r for r in pts if r["strategy"] == s), key=lambda r: r["spp"])
        color = strategy_color(s)
        coords = " ".join(f"{sx(r['total_ms']):.1f},{sy(r['den_mse_ratio']):.1f}" for r in line)
        out.append(f'<polyline points="{coords}" fill="none" stroke="{color}" stroke-width="1.5"/>')
        out += [_point(r, s, color, sx, sy) for r in line]
    return out


def ratio_svg(rows: Sequence[dict], denoiser: str) -> str:
    """One denoiser's error-against-time panel as an inline ``<svg>`` ('' without points)."""
    pts = _points(rows, denoiser)
    if not pts:
        return ""
    sx, sy, box = _scales(pts)
    body = "".join(_axes(sx, sy, box) + _series(pts, sx, sy))
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{_W}" height="{_H}" '
        f'viewBox="0 0 {_W} {_H}" font-size="10" role="img" '
        f'aria-label="{html.escape(denoiser)}">{body}</svg>'
    )


def legend_html(strategies: Iterable[str]) -> str:
    """The colour legend of the given strategies, in table order."""
    items = "".join(
        f'<span><i style="background:{strategy_color(s)}"></i>{html.escape(s)}</span>'
        for s in strategy_order(strategies)
    )
    return f'<p class="legend">{items}</p>'
