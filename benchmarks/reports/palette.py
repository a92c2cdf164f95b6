"""One colour per strategy, the same in every chart and page of every suite.

Strategies come in families, and a family keeps one hue so that a reader sees them at a glance:

- the baseline (``white``): grey;
- the rivals, a-priori blue-noise patterns and sequences (``bnds``, ``zsobol``, ...): blues and
  greens;
- the temporal permutations and their variants (``temporal``, ``temporal+demod``, ...): oranges
  and reds;
- LDBN (``ldbn``, ``ldbn_st``, ``ldbn_fast``, ``temporal_ldbn``): purples;
- the bounds (``oracle``): black.

:func:`strategy_color` gives a strategy's colour: the fixed one of :data:`FIXED` where listed,
else a shade of its family's hue chosen by a stable hash of the name (so a new variant gets the
same colour on every run and machine). :func:`family` names the family;
:func:`strategy_style` adds the line style (dashed for the bounds).

Not for: ordering strategies (:func:`benchmarks.reports.groups.strategy_order`).
"""

from __future__ import annotations

import colorsys
import hashlib

__all__ = ["FAMILIES", "FIXED", "family", "strategy_color", "strategy_style"]

#: Family name -> (hue in [0, 1), saturation) of its generated shades.
FAMILIES: dict[str, tuple[float, float]] = {
    "baseline": (0.0, 0.0),
    "rival": (0.55, 0.65),
    "temporal": (0.06, 0.85),
    "ldbn": (0.78, 0.55),
    "bound": (0.0, 0.0),
}

#: Hand-picked colours of the strategies every suite runs (hex, colour-blind-friendly shades).
FIXED: dict[str, str] = {
    "white": "#8c8c8c",
    "bnds": "#1f77b4",
    "bnds_st": "#6baed6",
    "zsobol": "#2ca02c",
    "zsobol_t": "#98df8a",
    "cycles_blue": "#17becf",
    "temporal": "#d62728",
    "temporal_sort": "#ff7f0e",
    "temporal_zsobol": "#8c564b",
    "ldbn": "#6a3d9a",
    "ldbn_st": "#9467bd",
    "ldbn_fast": "#c5b0d5",
    "temporal_ldbn": "#e377c2",
    "oracle": "#000000",
}


def family(strategy: str) -> str:
    """The family of a strategy name: ``baseline``, ``rival``, ``temporal``, ``ldbn`` or
    ``bound``."""
    if strategy == "white":
        return "baseline"
    if strategy == "oracle" or strategy.startswith("oracle"):
        return "bound"
    if "ldbn" in strategy:
        return "ldbn"
    if strategy.startswith("temporal"):
        return "temporal"
    return "rival"


def strategy_color(strategy: str) -> str:
    """The ``#rrggbb`` colour of a strategy, the same in every chart and page."""
    if strategy in FIXED:
        return FIXED[strategy]
    hue, saturation = FAMILIES[family(strategy)]
    digest = hashlib.sha256(strategy.encode("utf-8")).digest()
    shift = (digest[0] / 255 - 0.5) * 0.08  # stay within the family's hue
    lightness = 0.3 + 0.4 * digest[1] / 255
    r, g, b = colorsys.hls_to_rgb((hue + shift) % 1.0, lightness, saturation)
    return f"#{round(r * 255):02x}{round(g * 255):02x}{round(b * 255):02x}"


def strategy_style(strategy: str) -> dict[str, object]:
    """Matplotlib keyword arguments of a strategy's line: colour, line style and marker."""
    bound = family(strategy) == "bound"
    baseline = family(strategy) == "baseline"
    return {
        "color": strategy_color(strategy),
        "linestyle": "--" if bound else (":" if baseline else "-"),
        "marker": "s" if bound else ("D" if baseline else "o"),
    }
