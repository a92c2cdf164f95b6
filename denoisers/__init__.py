"""Denoisers: a Frame in, a denoised color ``[3, H, W]`` out, all behind one interface.

Names (the registry, :data:`DENOISERS`):

- ``gaussian``, ``bilateral``, ``median``: kornia filters that read the color only;
- ``joint_bilateral``, ``guided``: kornia filters guided by albedo and normal;
- ``atrous``: the edge-avoiding a-trous wavelet filter, the spatial part of SVGF (normal, depth);
- ``taa``, ``svgf``: temporal accumulation alone, and followed by the a-trous filter guided by the
  variance over time (:mod:`denoisers.temporal`); **stateful**: call ``reset()`` at the start of
  each sequence and feed its frames in order (motion, depth, normal, object_id);
- ``unet``: a small OIDN-style U-Net trained here on white-noise inputs (:mod:`denoisers.train`);
- ``unet_blue``: the same network trained on white and blue-noise inputs (``--mix white+blue``);
- ``oidn``: Intel Open Image Denoise, the production reference (optional extra ``reference``);
- ``cycles_oidn``: Cycles' own OIDN output of a Cycles frame's samples
  (:mod:`denoisers.cycles_oidn`).

**Plug-ins** (:mod:`bnerr.plugins`) join :data:`DENOISERS` under their ``name``: a
:class:`Denoiser` subclass, or a plain function ``Frame -> [3, H, W]`` or ``torch.nn.Module``
(wrapped by :func:`as_denoiser`, its ``name``, ``kind`` and ``grid`` read from its attributes),
given as a spec ``pkg.mod:attr`` / ``path/file.py:Name`` (:func:`load_denoiser`,
``get_denoiser(spec)``), or installed as an entry point of the group ``bnerr.denoisers``
(registered the first time :data:`DENOISERS` is read); a path ending in ``.toml`` or ``.json`` is
an executable denoiser's manifest (``denoisers.external.denoiser_class``).

``get_denoiser(name, **params)`` builds one; filter parameters come from :mod:`denoisers.tuning`
(tuned per scene and spp on white noise, then used unchanged for every strategy). This package
does not import :mod:`renderers`: training data is made in ``benchmarks.training_data``.
"""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path

import torch

from bnerr import plugins
from bnerr.errors import PluginError, UnknownNameError, check_name
from denoisers.base import Denoiser, MissingBufferError, check_frame
from denoisers.cycles_oidn import CyclesOIDN
from denoisers.filters import ATrous, Bilateral, Gaussian, Guided, JointBilateral, Median
from denoisers.identity import DenoiserIdentity, identity_in, of_kind
from denoisers.oidn import OIDN
from denoisers.temporal import SVGF, TAA
from denoisers.unet import UNetBlueDenoiser, UNetDenoiser
from denoisers.wrapped import as_denoiser

__all__ = [
    "DENOISERS",
    "Denoiser",
    "DenoiserIdentity",
    "MissingBufferError",
    "as_denoiser",
    "check_frame",
    "denoiser_identity",
    "denoisers_of_kind",
    "get_denoiser",
    "load_denoiser",
]

#: Spec suffixes of an executable denoiser's manifest (``denoisers.external``).
MANIFEST_SUFFIXES = (".toml", ".json")


def _adapt(plugin: plugins.Plugin) -> tuple[str, type[Denoiser]]:
    """A denoiser plug-in checked, and wrapped when it is a function or a module."""
    obj = plugin.obj
    if isinstance(obj, type) and issubclass(obj, torch.nn.Module):
        obj = plugins.call_plugin(plugin, "module", obj)
    if isinstance(obj, type) and issubclass(obj, Denoiser):
        cls = obj
    elif callable(obj) and not isinstance(obj, type):
        cls = as_denoiser(obj, name=plugins.plugin_name(plugin, "denoiser"))
    else:
        got = obj.__name__ if isinstance(obj, type) else type(obj).__name__
        raise PluginError(
            f"{plugin.who}: expected a denoisers.Denoiser subclass, a function Frame -> "
            f"[3, H, W] or a torch.nn.Module, got {got}"
        )
    if not cls.name:
        raise PluginError(f"{plugin.who}: expected a denoiser class with a name, got none")
    return cls.name, cls


#: The shipped denoisers.
_SHIPPED: tuple[type[Denoiser], ...] = (
    ATrous,
    Bilateral,
    CyclesOIDN,
    Gaussian,
    Guided,
    JointBilateral,
    Median,
    OIDN,
    SVGF,
    TAA,
    UNetBlueDenoiser,
    UNetDenoiser,
)
#: Registry: name -> Denoiser class, the plug-ins included. Sorted by name.
DENOISERS: dict[str, type[Denoiser]] = plugins.PluginRegistry(
    "bnerr.denoisers", _adapt, {cls.name: cls for cls in _SHIPPED}
)


def load_denoiser(name_or_spec: str) -> str:
    """The registered name of ``name_or_spec``: itself when registered (or not a spec), else
    the plug-in it names, loaded and registered: a manifest path (``.toml``, ``.json``) through
    ``denoisers.external.denoiser_class``, or a spec ``pkg.mod:attr`` / ``path/file.py:Name``.

    Raises:
        PluginError: the plug-in cannot be loaded or is not a denoiser.
    """
    registry = DENOISERS
    assert isinstance(registry, plugins.PluginRegistry)
    if name_or_spec in registry:
        return name_or_spec
    if name_or_spec.endswith(MANIFEST_SUFFIXES):
        known = plugins.registered_file("bnerr.denoisers", name_or_spec)
        if known is not None:  # loaded already (the driver, then each unit of work)
            return known
        # denoisers.external, loaded when used (a manifest run only)
        external = importlib.import_module("denoisers.external")
        path = Path(name_or_spec)
        cls = external.denoiser_class(path)
        program = external.program_file(cls.manifest)  # what runs: its edit is seen on --resume
        files = (str(path.resolve()), *([str(program)] if program is not None else []))
        plugin = plugins.Plugin(name_or_spec, cls, None, files=files)
        return registry.add(plugin)
    if not plugins.is_spec(name_or_spec):
        return name_or_spec
    return registry.add(plugins.resolve(name_or_spec))


def get_denoiser(name: str, **params: object) -> Denoiser:
    """Build the denoiser registered as ``name`` with keyword ``params``.

    ``name`` may be a plug-in spec or manifest path (:func:`load_denoiser`).

    Raises:
        UnknownNameError: ``name`` is not registered, or a parameter is not one the denoiser
            takes (the message lists the ones it does).
        PluginError: a plug-in that cannot be loaded, or whose constructor raises.
        DtypeError, ValueRangeError: a parameter has the wrong type or is out of range.
        MissingExtraError: ``oidn`` without the ``reference`` extra installed.
        FileFormatError: ``unet`` with a missing or corrupt weights file.
    """
    name = check_name(load_denoiser(name), list(DENOISERS), "denoiser")
    cls = DENOISERS[name]
    accepted = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    unknown = sorted(set(params) - set(accepted))
    if unknown:
        raise UnknownNameError(
            f"denoiser {name!r}: unknown parameter(s) {', '.join(unknown)}: expected one of "
            f"{', '.join(accepted) or '(none)'}"
        )
    plugin = plugins.loaded("bnerr.denoisers", name)
    if plugin is None:
        return cls(**params)
    return plugins.call_plugin(plugin, "denoiser", cls, **params)


def denoiser_identity(name: str) -> DenoiserIdentity:
    """The kind and tuning grid of denoiser ``name``, by name alone: a registered class's, the
    base's of ``NAME:own``, else kind ``"other"`` (:mod:`denoisers.identity`)."""
    return identity_in(DENOISERS, name)


def denoisers_of_kind(kind: str) -> tuple[str, ...]:
    """The registered denoisers whose class's ``kind`` is ``kind``, sorted by name."""
    return of_kind(DENOISERS, kind)
