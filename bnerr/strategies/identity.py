"""A strategy's identity by name alone: its family, table rank, raw-MSE note and colour.

The reports read records whose strategies may no longer be registered (an old ``cells.jsonl``),
so they ask :func:`strategy_identity` with the name a record carries, never the name itself:

- a registered class's name: what its class declares (:class:`bnerr.strategies.base.Strategy`'s
  ``family``, ``rank``, ``raw_mse_note``, ``bound_note``, ``color``), the colour only where the
  class sets it itself (a subclass of white is not drawn in white's grey);
- a temporal variant (``temporal+relative``), registered or not: its base's (the name before the
  first ``+``), except the colour, which stays the base's alone (a variant gets a shade of its
  family's hue, so that it is told apart from its base in a chart);
- any other name: a neutral identity, family ``"other"``, ranked after every registered strategy.

:func:`baseline` and :func:`bounds` name the registered strategies the reports compare against.

Not for: building strategies (:func:`bnerr.strategies.make_strategy`).
"""

from __future__ import annotations

from dataclasses import dataclass

from bnerr import plugins
from bnerr.errors import UnknownNameError
from bnerr.strategies.registry import REGISTRY

__all__ = ["OTHER_FAMILY", "StrategyIdentity", "baseline", "bounds", "strategy_identity"]

#: The family of a name that is neither registered nor a registered strategy's variant.
OTHER_FAMILY = "other"


@dataclass(frozen=True)
class StrategyIdentity:
    """What the reports know of a strategy name.

    Attributes:
        name: the name asked for (a variant keeps its own name).
        family: ``"baseline"``, ``"rival"``, ``"temporal"``, ``"ldbn"``, ``"bound"``, a plug-in's
            own family, or ``"other"`` (unknown name).
        rank: table order, lower first; an unknown name's comes after every registered one.
        raw_mse_note: why its raw MSE may differ from white's; ``""`` when it should not.
        bound: whether it is a bound (``family == "bound"``).
        bound_note: for a bound, why the decision table leaves it out.
        color: its fixed ``#rrggbb`` colour, or None (a shade of its family's hue).
        registered: whether ``name`` is a registered class's own name (not a variant, not
            unknown).
    """

    name: str
    family: str
    rank: int
    raw_mse_note: str = ""
    bound: bool = False
    bound_note: str = ""
    color: str | None = None
    registered: bool = False


def strategy_identity(name: str) -> StrategyIdentity:
    """The identity of strategy ``name``: its class's, its variant base's, or a neutral one
    (module docstring)."""
    classes = REGISTRY.classes()
    own = classes.get(name)
    cls = own if own is not None else classes.get(name.split("+")[0])
    if cls is None:
        last = max((c.rank for c in classes.values()), default=0)
        return StrategyIdentity(name, OTHER_FAMILY, last + 1)
    return StrategyIdentity(
        name,
        cls.family,
        cls.rank,
        cls.raw_mse_note,
        cls.family == "bound",
        cls.bound_note,
        vars(own).get("color") if own is not None else None,
        own is not None,
    )


def baseline() -> str:
    """The name of the registered baseline (the strategy of family ``"baseline"``: white), the
    strategy every ratio is taken to.

    Raises:
        UnknownNameError: no registered strategy, or more than one, has family ``"baseline"``.
    """
    found = [n for n, c in REGISTRY.classes().items() if c.family == "baseline"]
    if len(found) != 1:
        where = [f"{n} ({_origin(n)})" for n in found]
        raise UnknownNameError(
            f"baseline strategy: expected exactly one registered strategy of family 'baseline' "
            f"(a plug-in declares family = 'baseline' only to replace white), got "
            f"{', '.join(where) or 'none'}"
        )
    return found[0]


def _origin(name: str) -> str:
    """Where strategy ``name`` comes from: its plug-in (spec and distribution), or its class."""
    plugin = plugins.loaded("bnerr.strategies", name)
    if plugin is not None:
        return plugin.who
    cls = REGISTRY.classes()[name]
    return f"{cls.__module__}.{cls.__qualname__}"


def bounds() -> tuple[str, ...]:
    """The registered bounds (family ``"bound"``) by rank: the first is the bound the gap's
    shares are measured to (the oracle)."""
    found = [(c.rank, n) for n, c in REGISTRY.classes().items() if c.family == "bound"]
    return tuple(n for _, n in sorted(found))
