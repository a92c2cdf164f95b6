"""Temporal variants: the options of docs/METHODS.md, section 8, named ``base+option+option``.

Base ``temporal`` or ``temporal_zsobol``, options in this order, at most one of each group:

- sort key: ``residual`` or ``relative`` (:func:`bnerr.permutation.sortkeys.sort_key`; default
  luminance), and ``demod`` (radiance divided by albedo first; alone, it demodulates the luminance
  key);
- groups: ``groups`` (object id), ``groups_normal`` (and the normal's dominant axis) or
  ``groups_depth`` (and a depth bin): each block sorts each group on its own;
- grid shift: ``shift`` ((B/2, B/2) on odd frames) or ``shift_r2`` (an R2 point in [0, B)^2,
  period B^2): the block grid moves between frames so that seeds cross block boundaries;
- ``reproject``: after sorting and retargeting, each seed moves along the frame's motion buffer
  (forward prediction: the renderer is bound to frame t by the caller, so the next frame's motion
  is not reachable; a constant-velocity guess from frame t's own t-1 -> t motion);
- ``fast``: sort against the shipped FAST mask (:func:`bnerr.masks.fast.load_fast_mask`, optimized
  for the Gaussian denoiser's tuned sigma) instead of the void-and-cluster mask, and retarget with
  the field optimized for it (:func:`bnerr.masks.fast.load_fast_retarget`).

e.g. ``temporal+relative+demod+groups``. :func:`bnerr.strategies.make_strategy` builds any
well-formed one (:func:`parse_variant`, :class:`TemporalOptions`); :data:`VARIANTS` lists those
registered for the benchmark's command line. ``temporal_zsobol+...`` renders with the ``zsobol``
sampler, whose raw MSE differs from the per-pixel samplers'.
"""

from __future__ import annotations

from dataclasses import dataclass

from bnerr.errors import ValueRangeError, check_name
from bnerr.strategies.registry import REGISTRY

__all__ = [
    "VARIANTS",
    "VARIANT_BASES",
    "VARIANT_OPTIONS",
    "TemporalOptions",
    "check_strategy_name",
    "parse_variant",
]

#: The strategies a variant name may start with.
VARIANT_BASES: tuple[str, ...] = ("temporal", "temporal_zsobol")
#: The options a variant name may carry, in the order they must appear (one per group at most).
VARIANT_OPTIONS: tuple[str, ...] = (
    "residual",
    "relative",
    "demod",
    "groups",
    "groups_normal",
    "groups_depth",
    "shift",
    "shift_r2",
    "reproject",
    "fast",
)
#: The registered temporal variants (docs/METHODS.md, section 8): each option alone, then the
#: combinations the ablation measures. make_strategy builds any well-formed variant; these are
#: the ones the benchmark's command line knows by name.
VARIANTS: tuple[str, ...] = (
    "temporal+residual",
    "temporal+relative",
    "temporal+demod",
    "temporal+relative+demod",
    "temporal+groups",
    "temporal+groups_normal",
    "temporal+shift",
    "temporal+shift_r2",
    "temporal+reproject",
    "temporal+fast",
    "temporal+relative+demod+groups",
    "temporal+relative+demod+groups+reproject",
    "temporal_zsobol+relative+demod+groups",
)
# Options that exclude each other: one sort key, one kind of group, one grid shift.
_EXCLUSIVE: tuple[tuple[str, ...], ...] = (
    ("residual", "relative"),
    ("groups", "groups_normal", "groups_depth"),
    ("shift", "shift_r2"),
)
# The R2 sequence's generator for two dimensions (1 / plastic number and its square).
_R2_ALPHA = (0.7548776662466927, 0.5698402909980532)
_GROUP_OPTION = {"object": "groups", "normal": "groups_normal", "depth": "groups_depth"}
_SHIFT_OPTION = {"half": "shift", "r2": "shift_r2"}


@dataclass(frozen=True)
class TemporalOptions:
    """What a temporal variant changes in the per-frame passes (all off: Heitz & Belcour's).

    Attributes:
        key: the sort key, ``"luminance"``, ``"residual"`` or ``"relative"``
            (:func:`bnerr.permutation.sortkeys.sort_key`; the smoothing is guided by the group
            labels of the object id and normal where the frame has them).
        demodulate: divide the radiance by the albedo before taking the key.
        groups: None, or sort only among pixels sharing ``"object"`` (the object id),
            ``"normal"`` (and the normal's dominant axis) or ``"depth"`` (and a depth bin):
            :func:`bnerr.permutation.sortkeys.group_labels`.
        shift: None, or the block grid's per-frame offset: ``"half"`` (B/2, B/2) on odd frames,
            (0, 0) on even ones; ``"r2"`` the R2 sequence's point ``t mod B^2`` scaled to
            ``[0, B)^2`` (so that the offsets cycle with period B^2).
        reproject: after the sort and retarget passes, move each seed along the frame's motion
            (forward prediction: frame t's motion t-1 -> t stands for t -> t + 1;
            :func:`bnerr.permutation.reproject.reproject_seeds`, collisions resolved by depth).
        fast: sort against the FAST mask (:mod:`bnerr.masks.fast`) and retarget with its field
            instead of the void-and-cluster mask's; make_strategy loads both.
    """

    key: str = "luminance"
    demodulate: bool = False
    groups: str | None = None
    shift: str | None = None
    reproject: bool = False
    fast: bool = False

    @property
    def suffix(self) -> str:
        """The options as a name suffix, ``"+residual+groups+shift+reproject+fast"`` ('' for
        none)."""
        parts = [] if self.key == "luminance" else [self.key]
        parts += ["demod"] if self.demodulate else []
        parts += [] if self.groups is None else [_GROUP_OPTION[self.groups]]
        parts += [] if self.shift is None else [_SHIFT_OPTION[self.shift]]
        parts += ["reproject"] if self.reproject else []
        parts += ["fast"] if self.fast else []
        return "".join("+" + p for p in parts)

    @property
    def plain(self) -> bool:
        """Whether every option is off (the paper's passes, bit for bit)."""
        return self == TemporalOptions()

    def grid_offset(self, t: int, block: int) -> tuple[int, int]:
        """Frame ``t``'s block grid offset ``(oy, ox)`` in ``[0, B)^2``."""
        if self.shift == "half":
            return (block // 2, block // 2) if t % 2 else (0, 0)
        if self.shift == "r2":
            k = t % (block * block)
            oy, ox = (int(block * ((0.5 + k * a) % 1.0)) for a in _R2_ALPHA)
            return oy, ox
        return (0, 0)

    def grid_period(self, block: int) -> int:
        """Frames after which :meth:`grid_offset` repeats."""
        return {None: 1, "half": 2, "r2": block * block}[self.shift]


def parse_variant(name: object) -> tuple[str, TemporalOptions]:
    """``(base, options)`` of a strategy name; a name without ``+`` has no options.

    Args:
        name: ``base`` or ``base+option+...``: base one of :data:`VARIANT_BASES` (with options)
            or a registered strategy; options from :data:`VARIANT_OPTIONS`, in that order, at
            most one of each exclusive group (one key kind, one kind of groups, one shift).

    Raises:
        UnknownNameError: an unknown base or option. ValueRangeError: options repeated, out of
        order or exclusive (the message gives the accepted spelling).
    """
    if not isinstance(name, str) or "+" not in name:
        return check_name(name, REGISTRY, "strategy"), TemporalOptions()
    base, *opts = name.split("+")
    check_name(base, VARIANT_BASES, "variant base")
    for opt in opts:
        check_name(opt, VARIANT_OPTIONS, "temporal option")
    ranks = [VARIANT_OPTIONS.index(o) for o in opts]
    clash = next((g for g in _EXCLUSIVE if len(set(opts) & set(g)) > 1), None)
    if clash is not None or ranks != sorted(set(ranks)):
        why = f"at most one of {'/'.join(clash)}" if clash else "each option once"
        order = "+".join(VARIANT_OPTIONS)
        raise ValueRangeError(
            f"strategy: expected options in the order {order}, {why}, got {name!r}"
        )
    groups = {v: k for k, v in _GROUP_OPTION.items()}
    shifts = {v: k for k, v in _SHIFT_OPTION.items()}
    return base, TemporalOptions(
        key=next((o for o in opts if o in ("residual", "relative")), "luminance"),
        demodulate="demod" in opts,
        groups=next((groups[o] for o in opts if o in groups), None),
        shift=next((shifts[o] for o in opts if o in shifts), None),
        reproject="reproject" in opts,
        fast="fast" in opts,
    )


def check_strategy_name(name: object) -> str:
    """``name`` checked: a registered strategy or a well-formed variant (:func:`parse_variant`)."""
    parse_variant(name)
    assert isinstance(name, str)
    return name
