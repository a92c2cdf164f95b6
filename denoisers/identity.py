"""A denoiser's identity by name alone: its kind and tuning grid.

The reports read records whose denoisers may no longer be registered (an old ``cells.jsonl``),
so they ask :func:`denoisers.denoiser_identity` with the name a record carries (it applies
:func:`identity_in` to :data:`denoisers.DENOISERS`; this module takes the registry as an argument
so that it does not import the package that imports it):

- a registered name (:data:`denoisers.DENOISERS`): its class's ``kind`` and ``grid``;
- a variant ``NAME:own`` (tuned on each strategy's own frames) or any ``NAME:...``: NAME's;
- any other name: kind ``"other"``, no grid.

Not for: building denoisers (:func:`denoisers.get_denoiser`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

from denoisers.base import Denoiser

__all__ = ["OTHER_KIND", "DenoiserIdentity", "identity_in", "of_kind"]

#: The kind of a name that is not registered.
OTHER_KIND = "other"


@dataclass(frozen=True)
class DenoiserIdentity:
    """What the reports know of a denoiser name.

    Attributes:
        name: the name asked for (``gaussian:own`` keeps its own name).
        kind: ``"filter"``, ``"temporal"``, ``"learned"``, ``"reference"``, a plug-in's own kind,
            or ``"other"`` (unknown name).
        grid: its tuning grid, parameter -> candidate values; empty when it is not tuned.
    """

    name: str
    kind: str
    grid: Mapping[str, Sequence[object]] = field(default_factory=lambda: MappingProxyType({}))


def identity_in(registry: Mapping[str, type[Denoiser]], name: str) -> DenoiserIdentity:
    """The identity of denoiser ``name`` in ``registry``: its class's, its base's (``NAME:own``),
    or a neutral one (module docstring)."""
    cls = registry.get(name) or registry.get(name.split(":")[0])
    if cls is None:
        return DenoiserIdentity(name, OTHER_KIND)
    return DenoiserIdentity(name, cls.kind, MappingProxyType(dict(cls.grid)))


def of_kind(registry: Mapping[str, type[Denoiser]], kind: str) -> tuple[str, ...]:
    """The denoisers of ``registry`` of ``kind``, sorted by name."""
    return tuple(sorted(n for n, c in registry.items() if c.kind == kind))
