"""LDBN strategies: one shared padded Owen-Sobol sequence read through per-pixel ranking and
scrambling keys optimized offline (:class:`bnerr.sequences.LDBNSampler`, :mod:`bnerr.ldbn`).

- ``ldbn``: the screen-space key set (``ldbn_screen_64``): frame t reads the tiles at the R2
  offset of frame t plus a per-seed-set offset, so frames are independent draws of one blue
  pattern (as the engines that shift the tile per frame do);
- ``ldbn_st``: the spatiotemporal key set (``ldbn_st_64x<F>``): frame t reads slice ``t mod F``,
  whose keys are blue in space and make each pixel's errors differ from frame to frame, at one
  offset per seed set, for temporal accumulation;
- ``ldbn_fast``: the key set optimized against the Gaussian denoiser's kernel (``ldbn_fast_64``,
  sigma 0.75, the tuned sigma at 4 spp), read like ``ldbn``;
- ``ldbn_atrous``: the key set optimized against the a-trous filter's kernel as measured on the
  scenes' own buffers at 4 spp (``ldbn_atrous_64``; ``benchmarks.studies.denoiser_kernels``,
  ``python -m bnerr.ldbn.matched``), read like ``ldbn``.

- ``ldbn128``: the 128 x 128 screen set to 64 spp over D = 12, every dimension pair of the first
  two bounces (``ldbn_screen_128``, made on a GPU by ``benchmarks/ldbn_device.sh``), read like
  ``ldbn``; registered only when its table is shipped (:data:`LDBN128_SHIPPED`), so dropping the
  file into ``bnerr/data`` makes it work.

- ``ldbn_lattice``, ``ldbn_zorder``: 64 x 64 screen sets to 64 spp over D = 8 whose keys act on
  another base point set (:mod:`bnerr.sequences.ldbn_bases`): rotations of a rank-1 lattice, or
  chunks of one global Owen-Sobol sequence starting from the Morton order (``ldbn_lattice_64``,
  ``ldbn_zorder_64``; ``bnerr mask --ldbn --base lattice|zorder``), read like ``ldbn``;
  registered only when their tables are shipped.

All of them need ``spp`` (the level of the tiles: the smallest tile for at least spp samples) and
give fresh per-pixel seeds every frame for the dimensions past the optimized ones (the pixel's own
Owen-Sobol sequence there). They dictate their own sampler (``ldbn``).
"""

from __future__ import annotations

from typing import ClassVar

import torch

from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.frame import Frame
from bnerr.hashing import lowbias32_host
from bnerr.ldbn.keys import ldbn_file_name, load_ldbn_keys, shipped_ldbn
from bnerr.masks import frame_offset
from bnerr.sequences import LDBNKeys, LDBNSampler
from bnerr.strategies.base import BuildOptions, RenderFn, Strategy, pixel_seeds, stream_key
from bnerr.strategies.registry import REGISTRY
from bnerr.strategies.variants import TemporalOptions

__all__ = [
    "LDBN128_FILE",
    "LDBN128_SHIPPED",
    "LDBN_BASE_STRATEGIES",
    "LDBN_SETS",
    "LDBN128Strategy",
    "LDBNATrousStrategy",
    "LDBNBaseStrategy",
    "LDBNFastStrategy",
    "LDBNLatticeStrategy",
    "LDBNZOrderStrategy",
    "LDBNSTStrategy",
    "LDBNStrategy",
]

#: Strategy -> the shipped key set it reads: ``(kind, frames, levels)``
#: (:func:`bnerr.ldbn.load_ldbn_keys`; tiles for 1 .. 2^(levels - 1) spp).
LDBN_SETS: dict[str, tuple[str, int, int]] = {
    "ldbn": ("screen", 1, 5),
    "ldbn_fast": ("fast", 1, 5),
    "ldbn_atrous": ("atrous", 1, 5),
    "ldbn_st": ("st", 4, 3),
}


class LDBNStrategy(Strategy):
    """``ldbn``: the screen-space keys, shifted per frame by the R2 step (module docstring).

    Args:
        keys: one :class:`LDBNKeys` per frame slice (one for a screen tile).
        spp: the samples per pixel the renders take (selects the tiles' level).
    """

    name = "ldbn"
    own_sampler = "ldbn"
    stream = 20
    family = "ldbn"
    rank = 60
    color = "#6a3d9a"
    #: whether frame t reads slice t mod F unshifted (True) or shifts slice 0 per frame
    per_frame_slices: ClassVar[bool] = False

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        keys: list[LDBNKeys],
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        if spp is None:
            raise ValueRangeError(f"spp: expected the samples per pixel for {self.name}, got None")
        self.spp = check_positive_int(spp, "spp")
        super().__init__(height, width, seed=seed, device=device)
        if not keys or not all(isinstance(k, LDBNKeys) for k in keys):
            raise ValueRangeError("keys: expected a non-empty list of LDBNKeys")
        self.keys = keys
        self.size = keys[0].size
        key = stream_key(self.seed, 0, self.stream)
        self.shift = (key % self.size, lowbias32_host(key) % self.size)

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        kind, frames, levels = LDBN_SETS[cls.name]
        keys = load_ldbn_keys(kind, build.mask_size, frames, levels)
        return cls(height, width, keys=keys, spp=build.spp, **build.common)  # type: ignore[arg-type]

    def sampler(self, t: int) -> LDBNSampler:
        """Frame ``t``'s sampler: its keys and its offset (module docstring)."""
        if self.per_frame_slices:
            keys, (dy, dx) = self.keys[t % len(self.keys)], (0, 0)
        else:
            keys, (dy, dx) = self.keys[0], frame_offset(t, self.size)
        return LDBNSampler(keys, spp=self.spp, offset=(self.shift[0] + dy, self.shift[1] + dx))

    def seeds(self, t: int) -> torch.Tensor:
        """Frame ``t``'s fresh per-pixel seeds (read past the optimized dimensions)."""
        key = stream_key(self.seed, t, self.stream)
        return pixel_seeds(self.height, self.width, key, self.device)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        return render(self.seeds(t), self.sampler(t))


class LDBNSTStrategy(LDBNStrategy):
    """``ldbn_st``: the spatiotemporal keys, slice ``t mod F`` in frame t, one offset per seed
    set (module docstring)."""

    name = "ldbn_st"
    stream = 21
    per_frame_slices = True
    rank = 70
    color = "#9467bd"


class LDBNFastStrategy(LDBNStrategy):
    """``ldbn_fast``: the keys optimized for the tuned Gaussian denoiser (module docstring)."""

    name = "ldbn_fast"
    stream = 22
    rank = 80
    color = "#c5b0d5"


class LDBNATrousStrategy(LDBNStrategy):
    """``ldbn_atrous``: the keys optimized for the a-trous filter's measured kernel (module
    docstring)."""

    name = "ldbn_atrous"
    stream = 28
    rank = 82
    color = "#8c6bb1"


#: The table ``ldbn128`` reads, and whether it is shipped (the strategy is registered only then).
LDBN128_FILE = ldbn_file_name("screen", 128)
LDBN128_SHIPPED = LDBN128_FILE in shipped_ldbn()

#: Why the LDBN keys' raw MSE may differ from white's.
SHARED_SEQUENCE_NOTE = (
    "one shared Owen-Sobol sequence digitally shifted per pixel, not a fresh Owen scramble per "
    "pixel: 1.03-1.23x per-pixel Owen-Sobol's MSE on 2D test integrands at 2-16 samples "
    "(docs/METHODS.md, section 10)"
)


class LDBN128Strategy(LDBNStrategy):
    """``ldbn128``: the 128 x 128 screen keys to 64 spp over D = 12, read like ``ldbn`` (module
    docstring). ``name`` is set, and the class registered, only when its table is shipped."""

    name = ""
    stream = 26
    rank = 65
    color = "#3f007d"
    raw_mse_note = SHARED_SEQUENCE_NOTE
    #: the tile side of the key set it reads
    tile: ClassVar[int] = 128

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        keys = load_ldbn_keys("screen", cls.tile)
        return cls(height, width, keys=keys, spp=build.spp, **build.common)  # type: ignore[arg-type]


if LDBN128_SHIPPED:
    LDBN128Strategy.name = "ldbn128"
    REGISTRY.add(LDBN128Strategy)


class LDBNBaseStrategy(LDBNStrategy):
    """Keys over another base point set (``kind`` in :data:`bnerr.ldbn.keys.KIND_BASES`), a
    64 x 64 screen set read like ``ldbn`` (module docstring). A subclass is registered under its
    ``label`` only when its table is shipped (:meth:`register_if_shipped`)."""

    name = ""
    #: the key set's kind (its file ``ldbn_<kind>_64.npy``) and the name it registers under
    kind: ClassVar[str] = ""
    label: ClassVar[str] = ""
    tile: ClassVar[int] = 64

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        keys = load_ldbn_keys(cls.kind, cls.tile)
        return cls(height, width, keys=keys, spp=build.spp, **build.common)  # type: ignore[arg-type]

    @classmethod
    def register_if_shipped(cls) -> bool:
        """Name and register the class when its key table is shipped; whether it was."""
        if ldbn_file_name(cls.kind, cls.tile) not in shipped_ldbn():
            return False
        cls.name = cls.label
        REGISTRY.add(cls)
        return True


class LDBNLatticeStrategy(LDBNBaseStrategy):
    """``ldbn_lattice``: our keys as rotations of a rank-1 lattice (module docstring)."""

    kind = "lattice"
    label = "ldbn_lattice"
    stream = 29
    rank = 66
    color = "#54278f"
    raw_mse_note = (
        "a rotated rank-1 lattice per pixel, not a scrambled net: lattices stratify "
        "discontinuous integrands less well at low spp (every 4-point rank-1 lattice lies on "
        "a diagonal; bnerr.sequences.ldbn_bases)"
    )


class LDBNZOrderStrategy(LDBNBaseStrategy):
    """``ldbn_zorder``: our keys as chunks of one global sequence (module docstring)."""

    kind = "zorder"
    label = "ldbn_zorder"
    stream = 30
    rank = 67
    color = "#807dba"
    raw_mse_note = (
        "chunks of one global Owen-Sobol sequence: each pixel alone is a scrambled net, as "
        "white's, but the pixels' points are not independent"
    )


#: The key sets over other bases whose tables are shipped (registered), one class per kind.
LDBN_BASE_STRATEGIES = [
    c for c in (LDBNLatticeStrategy, LDBNZOrderStrategy) if c.register_if_shipped()
]
