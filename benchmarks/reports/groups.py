"""How the reports group and order table rows: one scene and condition per group, strategies in
a fixed order from the baseline to the bound.

Strategies are ordered by their class's ``rank`` (:func:`bnerr.strategies.strategy_identity`).

A **group** is a scene with its condition (camera motion, path depth, pixel region, per-pixel
sampler): the rows the report compares strategy against strategy, ``(scene, motion, depth,
region, sampler)`` as :func:`group_key` gives it from a ``table.csv`` row. Every report module
(:mod:`benchmarks.reports`, :mod:`benchmarks.reports.denoisers`) titles, orders and names groups
through these functions, so that their tables line up.

Not for: grouping records for statistics (:mod:`benchmarks.reports.gap` pairs records by their whole
cell).
"""

from __future__ import annotations

from collections.abc import Iterable

from bnerr.strategies import strategy_identity

__all__ = [
    "group_key",
    "group_order",
    "group_slug",
    "group_title",
    "strategy_order",
]


def group_key(row: dict) -> tuple:
    """``(scene, motion, depth, region, sampler)`` of a ``table.csv`` row."""
    return (row["scene"], row["motion"], row["depth"], row["region"], row["sampler"])


def group_order(key: tuple) -> tuple:
    """Sort key of a group: scene, motion, depth (the scene's own first), region, sampler."""
    return (key[0], key[1], -1 if key[2] is None else key[2], key[3], key[4])


def group_title(key: tuple) -> str:
    """A group's title: the scene, and its condition where it is not the default."""
    scene, motion, depth, region, sampler = key
    extra = [
        "static camera" if motion == 0 else (f"motion x{motion}" if motion != 1 else None),
        f"max depth {depth}" if depth is not None else None,
        "object edges only" if region == "edges" else None,
        "coherent regions only" if region == "coherent" else None,
        "away from visible lights" if region == "unlit" else None,
        f"{sampler} sequences" if sampler != "owen_sobol" else None,
    ]
    shown = [e for e in extra if e]
    return scene + (f" ({', '.join(shown)})" if shown else "")


def group_slug(key: tuple) -> str:
    """A group's file-name stem (``snooker_m8_edges``): the scene and its non-default condition."""
    scene, motion, depth, region, sampler = key
    return (
        scene
        + ("" if motion == 1 else f"_m{motion}")
        + ("" if depth is None else f"_d{depth}")
        + ("" if region == "all" else f"_{region}")
        + ("" if sampler == "owen_sobol" else f"_{sampler}")
    )


def strategy_order(names: Iterable[str]) -> list[str]:
    """The distinct ``names`` in table order: the registered strategies by their class's ``rank``
    (the baseline, the a-priori patterns, LDBN, the a-posteriori permutations, the bounds), then
    the others (temporal variants, names no longer registered) by name."""

    def rank(s: str) -> tuple:
        identity = strategy_identity(s)
        return (0, identity.rank, s) if identity.registered else (1, 0, s)

    return sorted(set(names), key=rank)
