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
- :mod:`~bnerr.sequences.openqmc`: :class:`OpenQMCSobolBNSampler` /
  :class:`OpenQMCLatticeBNSampler`, OpenQMC's ``sobolbn`` and ``latticebn`` bit for bit
  (:func:`openqmc_draw`): per-pixel blue-noise ranks and keys from OpenQMC's 256x256 tables over
  Owen-scrambled Sobol or a rank-1 lattice.

The Z-order samplers take the pixel's key where the others take a random seed: the seed image of
a Z-order strategy holds each pixel's Morton key (:func:`zsobol_keys`, :func:`cycles_keys`), so
the renderer, the sampler seam and the temporal permutation of seeds stay unchanged.

**Plug-in samplers** (:mod:`bnerr.plugins`): a :class:`Sampler` subclass given as a spec
(``make_sampler("path/file.py:MySampler")``, :func:`load_sampler`) or installed as an entry point
of the group ``bnerr.samplers`` registers in :data:`SAMPLERS` under its class's ``name`` (else the
entry point's name). One that builds without options is also a per-pixel sampler
(:func:`per_pixel_samplers`): the benchmark's ``sampler`` condition, which white, temporal,
temporal_sort and oracle render with.

Not for: cryptography, or anything that needs independent streams for more than 2^32 seeds.
"""

from __future__ import annotations

from bnerr import plugins
from bnerr.errors import PluginError, check_name
from bnerr.sequences.base import ONE_MINUS_EPS, Sampler
from bnerr.sequences.bnds import BNDSSampler
from bnerr.sequences.cycles import CyclesFirstSampler, CyclesPureSampler, cycles_keys
from bnerr.sequences.ldbn import LDBNKeyedSampler, LDBNKeys, LDBNSampler, ldbn_key_image
from bnerr.sequences.openqmc import (
    OpenQMCLatticeBNSampler,
    OpenQMCSobolBNSampler,
    openqmc_draw,
    openqmc_float,
)
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
    "OpenQMCLatticeBNSampler",
    "OpenQMCSobolBNSampler",
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
    "load_sampler",
    "per_pixel_samplers",
    "ldbn_key_image",
    "openqmc_draw",
    "openqmc_float",
    "zsobol_1d",
    "zsobol_2d",
    "zsobol_keys",
]

#: The shipped per-pixel samplers (what the benchmark's ``sampler`` condition names).
_PER_PIXEL = ("owen_sobol", "white")


def _adapt(plugin: plugins.Plugin) -> tuple[str, type[Sampler]]:
    """A sampler plug-in checked: a subclass of :class:`Sampler`."""
    cls = plugin.obj
    if not (isinstance(cls, type) and issubclass(cls, Sampler)):
        got = cls.__name__ if isinstance(cls, type) else type(cls).__name__
        raise PluginError(
            f"{plugin.who}: expected a subclass of bnerr.sequences.Sampler, got {got}"
        )
    return plugins.plugin_name(plugin, "sampler"), cls


#: Sampler name -> class, the installed plug-ins (entry points of ``bnerr.samplers``) and the
#: loaded ones included. ``make_sampler`` looks names up here.
SAMPLERS: dict[str, type[Sampler]] = plugins.PluginRegistry(
    "bnerr.samplers",
    _adapt,
    {
        "bnds": BNDSSampler,
        "cycles_first": CyclesFirstSampler,
        "cycles_pure": CyclesPureSampler,
        "ldbn": LDBNSampler,
        "ldbn_keyed": LDBNKeyedSampler,
        "openqmc_latticebn": OpenQMCLatticeBNSampler,
        "openqmc_sobolbn": OpenQMCSobolBNSampler,
        "owen_sobol": OwenSobolSampler,
        "white": WhiteSampler,
        "zsobol": ZSobolSampler,
        "zsobol_t": ZSobolTSampler,
    },
)


def load_sampler(name_or_spec: str) -> str:
    """The registered name of ``name_or_spec``: itself when registered (or not a spec), else the
    plug-in sampler it specifies, loaded and registered in :data:`SAMPLERS`."""
    if name_or_spec in SAMPLERS or not plugins.is_spec(name_or_spec):
        return name_or_spec
    registry = SAMPLERS
    assert isinstance(registry, plugins.PluginRegistry)
    return registry.add(plugins.resolve(name_or_spec))


def per_pixel_samplers() -> tuple[str, ...]:
    """The samplers a strategy can take as its per-pixel sampler: ``owen_sobol``, ``white`` and
    every plug-in sampler (which must build without options)."""
    extra = tuple(n for n in SAMPLERS if plugins.loaded("bnerr.samplers", n) is not None)
    return _PER_PIXEL + extra


def make_sampler(name: str, **options: object) -> Sampler:
    """Build the sampler registered as ``name`` with its options.

    Names and options: ``white``, ``owen_sobol`` (none); ``bnds`` (``mask [D, T, T]``,
    ``offset (oy, ox)``, ``seed0``); ``zsobol`` (``width``, ``height``, ``spp``, ``seed``,
    ``randomizer``); ``zsobol_t`` (``width``, ``height``, ``spp``, ``frame``, ``frames``,
    ``seed``); ``cycles_pure``, ``cycles_first`` (``spp``, ``seed0``); ``ldbn`` (``keys``,
    ``spp``, ``offset``); ``ldbn_keyed`` (``keys``, ``spp``); ``openqmc_sobolbn``,
    ``openqmc_latticebn`` (``frame``). The Z-order samplers read
    the lane's seed as the pixel's key (:func:`zsobol_keys`, :func:`cycles_keys`). An unknown name
    raises :class:`UnknownNameError` listing the known ones; a plug-in spec
    (``path/file.py:MySampler``) is loaded first (:func:`load_sampler`), and a plug-in's
    constructor that raises is a :class:`PluginError` naming it.
    """
    name = check_name(load_sampler(name), list(SAMPLERS), "sampler")
    plugin = plugins.loaded("bnerr.samplers", name)
    if plugin is None:
        return SAMPLERS[name](**options)
    return plugins.call_plugin(plugin, "sampler", SAMPLERS[name], **options)
