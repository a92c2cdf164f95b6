"""One colour per strategy, the same in every chart and page of every suite.

Strategies come in families (their class's ``family``, :func:`bnerr.strategies.strategy_identity`),
and a family keeps one hue so that a reader sees them at a glance:

- the baseline (white): grey;
- the rivals, a-priori blue-noise patterns and sequences: blues and greens;
- the temporal permutations and their variants: oranges and reds;
- LDBN and the temporal sort over LDBN's keys: purples;
- the bounds: black and greys, drawn dashed;
- any other family (a plug-in's own, or ``"other"`` for a name no longer registered): a hue
  chosen by a stable hash of the family's name.

:func:`strategy_color` gives a strategy's colour: its class's fixed ``color`` where it sets one
(hand-picked, colour-blind-friendly shades for the strategies every suite runs), else a shade of
its family's hue chosen by a stable hash of the name (so a new variant gets the same colour on
every run and machine). :func:`family` names the family; :func:`strategy_style` adds the line
style (dashed for the bounds, dotted for the baseline).

Not for: ordering strategies (:func:`benchmarks.reports.groups.strategy_order`).
"""

from __future__ import annotations

import colorsys
import hashlib

from bnerr.strategies import strategy_identity

__all__ = ["FAMILIES", "family", "family_hue", "strategy_color", "strategy_style"]

#: Family name -> (hue in [0, 1), saturation) of its generated shades.
FAMILIES: dict[str, tuple[float, float]] = {
    "baseline": (0.0, 0.0),
    "rival": (0.55, 0.65),
    "temporal": (0.06, 0.85),
    "ldbn": (0.78, 0.55),
    "bound": (0.0, 0.0),
}
# Saturation of a family not in FAMILIES.
_NEW_SATURATION = 0.6


def family(strategy: str) -> str:
    """The family of a strategy name (its class's, its variant base's, or ``"other"``)."""
    return strategy_identity(strategy).family


def _digest(text: str) -> bytes:
    return hashlib.sha256(text.encode("utf-8")).digest()


def family_hue(name: str) -> tuple[float, float]:
    """(hue, saturation) of family ``name``: :data:`FAMILIES`' entry, else a hue from a stable
    hash of the name."""
    if name in FAMILIES:
        return FAMILIES[name]
    return (int.from_bytes(_digest(name)[:2], "big") / 65536, _NEW_SATURATION)


def strategy_color(strategy: str) -> str:
    """The ``#rrggbb`` colour of a strategy, the same in every chart and page."""
    identity = strategy_identity(strategy)
    if identity.color is not None:
        return identity.color
    hue, saturation = family_hue(identity.family)
    digest = _digest(strategy)
    shift = (digest[0] / 255 - 0.5) * 0.08  # stay within the family's hue
    lightness = 0.3 + 0.4 * digest[1] / 255
    r, g, b = colorsys.hls_to_rgb((hue + shift) % 1.0, lightness, saturation)
    return f"#{round(r * 255):02x}{round(g * 255):02x}{round(b * 255):02x}"


def strategy_style(strategy: str) -> dict[str, object]:
    """Matplotlib keyword arguments of a strategy's line: colour, line style and marker."""
    kind = family(strategy)
    bound = kind == "bound"
    baseline = kind == "baseline"
    return {
        "color": strategy_color(strategy),
        "linestyle": "--" if bound else (":" if baseline else "-"),
        "marker": "s" if bound else ("D" if baseline else "o"),
    }
