"""Sample sequences: the only source of random numbers the renderer sees (docs/METHODS.md,
sections 3 and 7).

A sequence is a deterministic function ``X(seed, index, dim) -> [0, 1)`` of a pixel's seed, the
sample index ``i < spp`` and the integrand dimension ``d``. The renderer asks a :class:`Sampler`
for ``count`` consecutive dimensions of many (seed, index) lanes at once and never calls
``torch.rand`` (Mitsuba 3's ``Sampler.next_1d``, pbrt-v4's ``Get1D``/``Get2D``). One module per
sequence:

- :mod:`~bnerr.sequences.white`: :func:`white` / :class:`WhiteSampler`, a counter-based hash,
  the white-noise baseline.
- :mod:`~bnerr.sequences.owen_sobol`: :func:`owen_sobol` / :class:`OwenSobolSampler`,
  Owen-scrambled Sobol (Burley 2020) padded by 2D pairs; the first 2^m samples of every pair
  ``(2k, 2k+1)`` form a (0, m, 2)-net.
- :mod:`~bnerr.sequences.bnds`: :class:`BNDSSampler`, blue-noise dithered sampling (Georgiev &
  Fajardo 2016), one Owen-Sobol sequence for the whole screen, Cranley-Patterson rotated per pixel
  by a vector mask.
- :mod:`~bnerr.sequences.zsobol`: :func:`zsobol_1d` / :func:`zsobol_2d` /
  :class:`ZSobolSampler`, pbrt-v4's ``ZSobolSampler`` bit for bit (Ahmed & Wonka 2020).
- :mod:`~bnerr.sequences.cycles`: :class:`CyclesPureSampler` / :class:`CyclesFirstSampler`,
  Blender Cycles 4.2's ``BLUE_NOISE_PURE`` and ``BLUE_NOISE_FIRST`` indexing over Owen-Sobol.
- :mod:`~bnerr.sequences.ldbn`: :class:`LDBNSampler`, Heitz et al. 2019's per-pixel ranking and
  scrambling keys over one shared padded Owen-Sobol sequence (LDBN), keys from :mod:`bnerr.ldbn`;
  :class:`LDBNKeyedSampler`, the same lookup with the texel read from the seed
  (:func:`ldbn_key_image`), for the temporal permutation of LDBN's keys.
- :mod:`~bnerr.sequences.zsobol_t`: :class:`ZSobolTSampler`, temporal Z-order (a base-8 digit
  scramble of the 3D Morton code of (x, y, t), after tauray's ``sobol-z3``).

The Z-order samplers take the pixel's key where the others take a random seed: the seed image of
a Z-order strategy holds each pixel's Morton key (:func:`zsobol_keys`, :func:`cycles_keys`), so
the renderer, the sampler seam and the temporal permutation of seeds stay unchanged.

Not for: cryptography, or anything that needs independent streams for more than 2^32 seeds.
"""

from __future__ import annotations

from bnerr.errors import check_name
from bnerr.sequences.base import ONE_MINUS_EPS, Sampler
from bnerr.sequences.bnds import BNDSSampler
from bnerr.sequences.cycles import CyclesFirstSampler, CyclesPureSampler, cycles_keys
from bnerr.sequences.ldbn import LDBNKeyedSampler, LDBNKeys, LDBNSampler, ldbn_key_image
from bnerr.sequences.owen_sobol import OwenSobolSampler, owen_sobol
from bnerr.sequences.white import WhiteSampler, white
from bnerr.sequences.zsobol import ZSobolSampler, zsobol_1d, zsobol_2d, zsobol_keys
from bnerr.sequences.zsobol_t import ZSobolTSampler

__all__ = [
    "BNDSSampler",
    "CyclesFirstSampler",
    "CyclesPureSampler",
    "LDBNKeyedSampler",
    "LDBNKeys",
    "LDBNSampler",
    "ONE_MINUS_EPS",
    "OwenSobolSampler",
    "SAMPLERS",
    "Sampler",
    "WhiteSampler",
    "make_sampler",
    "owen_sobol",
    "white",
    "ZSobolSampler",
    "ZSobolTSampler",
    "cycles_keys",
    "ldbn_key_image",
    "zsobol_1d",
    "zsobol_2d",
    "zsobol_keys",
]

#: Sampler name -> class. ``make_sampler`` looks names up here.
SAMPLERS: dict[str, type[Sampler]] = {
    "bnds": BNDSSampler,
    "cycles_first": CyclesFirstSampler,
    "cycles_pure": CyclesPureSampler,
    "ldbn": LDBNSampler,
    "ldbn_keyed": LDBNKeyedSampler,
    "owen_sobol": OwenSobolSampler,
    "white": WhiteSampler,
    "zsobol": ZSobolSampler,
    "zsobol_t": ZSobolTSampler,
}


def make_sampler(name: str, **options: object) -> Sampler:
    """Build the sampler registered as ``name`` with its options.

    Names and options: ``white``, ``owen_sobol`` (none); ``bnds`` (``mask [D, T, T]``,
    ``offset (oy, ox)``, ``seed0``); ``zsobol`` (``width``, ``height``, ``spp``, ``seed``,
    ``randomizer``); ``zsobol_t`` (``width``, ``height``, ``spp``, ``frame``, ``frames``,
    ``seed``); ``cycles_pure``, ``cycles_first`` (``spp``, ``seed0``); ``ldbn`` (``keys``,
    ``spp``, ``offset``); ``ldbn_keyed`` (``keys``, ``spp``). The Z-order samplers read
    the lane's seed as the pixel's key (:func:`zsobol_keys`, :func:`cycles_keys`). An unknown name
    raises :class:`UnknownNameError` listing the known ones.
    """
    check_name(name, list(SAMPLERS), "sampler")
    return SAMPLERS[name](**options)
