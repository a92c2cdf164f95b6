"""bnerr's samplers inside Mitsuba 3: a sampler plugin and a ``RenderFn`` adapter.

With these, every bnerr strategy drives Mitsuba unchanged::

    render = mitsuba_render_fn("scene.xml", spp=4)
    strategy = make_strategy("temporal", render.height, render.width)
    frame = strategy.frame(t, render)      # render(seeds [H, W] int64, sampler) -> Frame

**The plugin** (:func:`register`, Mitsuba name ``"bnerr"``) is a Python ``mi.Sampler`` subclass.
Every number it hands Mitsuba comes from a bnerr :class:`~bnerr.sequences.Sampler`, as
``sampler.sample(seed, index, dim, count, pixel)`` of the lane's pixel seed, sample index and
dimension. The dimension is a counter advanced by every ``next_1d`` (1) and ``next_2d`` (2) and
reset by ``seed()``; it is the same for every lane of the wavefront, so it is the dimension of the
integrand (pixel position 0-1, then 6 per bounce for ``path``: emitter 2, BSDF 1 + 2, roulette 1).

**Lanes and pixels.** In Mitsuba's vectorized variants ``SamplingIntegrator::render`` seeds the
sampler once with ``wavefront_size = W * H * spp`` and gives lane ``i`` the pixel ``p = i // spp``
(``x = p % W``, ``y = p // W``) of the film's crop; so lane ``i`` draws sample ``i % spp`` of pixel
``p``, and ``seed()`` gathers the seed image at ``p`` (the pitfall: Mitsuba never tells the
sampler the pixel of a lane; only ``seed()`` can set the per-lane state).

**Variants.** ``llvm_ad_rgb`` (default) or ``cuda_ad_rgb``. Not ``scalar_rgb``: it renders
32x32 blocks on several threads with one ``fork()`` of the sampler each, calling it one sample and
one dimension at a time (a Python call per number, under the GIL) and seeding it per pixel of a
block with no way to know the block's position. The wavefront variants call the sampler once per
dimension for the whole image. Their loops must run *evaluated* (Dr.Jit's ``SymbolicLoops`` flag
off, set around every render here): a recorded loop would call ``next_1d`` once while tracing and
never again, so the dimension counter would stand still and the sampler would have no values to
read. Dr.Jit's LLVM backend needs LLVM >= :data:`MIN_LLVM`: with Debian's LLVM 15 and 16 it aborts
the process in instruction selection (``fminimum``); LLVM 19 (Debian package ``libllvm19``) works.

**Buffers.** Each call renders twice with the same seeds: the colour with the scene's own
integrator, then albedo, shading normal, depth (0 where the ray escaped) and object id (Mitsuba's
shape registry index minus 1, -1 for background) with Mitsuba's ``aov`` integrator, which draws
only the film position (dimensions 0-1, the same as the colour render's) and traces one ray: about
a third of a 1-spp colour render. The AOVs are the means over each pixel's samples, so the object
id is fractional at silhouettes, where the samples hit several objects. (Nesting the path tracer
inside ``aov`` would give both in one render, but Mitsuba 3.9 then runs the whole sampling twice
per render: measured here, ``seed()`` and every dimension are called twice.) The film's
reconstruction filter is replaced by a box: each sample lands in its own pixel, which is what a
per-pixel seed means. ``variance`` and ``motion`` are None.

Mitsuba is optional (the ``reference`` extra); without it, or with an LLVM too old, the functions
here raise :class:`MissingExtraError` saying what to install. The ``bnerr`` package never
imports Mitsuba.

Not for: Mitsuba's scalar or spectral variants, films with ``sample_border``, or integrators that
draw samples outside ``SamplingIntegrator::render`` (particle tracers).
"""

from __future__ import annotations

import contextlib
import copy
import importlib
import importlib.util
import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import torch

from bnerr.errors import (
    BnerrError,
    DtypeError,
    FileFormatError,
    MissingExtraError,
    ShapeError,
    check_dtype,
    check_name,
    check_positive_int,
    check_tensor,
)
from bnerr.frame import Frame
from bnerr.sequences import Sampler, make_sampler
from bnerr.timing import Stopwatch

__all__ = [
    "MIN_LLVM",
    "PLUGIN",
    "VARIANTS",
    "MitsubaRender",
    "load_mitsuba",
    "mitsuba_reference",
    "mitsuba_render_fn",
    "register",
    "unavailable_reason",
]

#: The name the sampler plugin is registered under (``<sampler type="bnerr">``).
PLUGIN = "bnerr"
#: The Mitsuba variants the plugin runs in (wavefront variants with RGB colour).
VARIANTS = ("llvm_ad_rgb", "cuda_ad_rgb")
#: The oldest LLVM seen to work with Dr.Jit 1.x's LLVM backend here (15 and 16 abort).
MIN_LLVM = (19, 0, 0)
#: The AOVs asked of Mitsuba's ``aov`` integrator, in output order, with their channel counts.
_AOVS: tuple[tuple[str, str, int], ...] = (
    ("albedo", "albedo", 3),
    ("normal", "sh_normal", 3),
    ("depth", "depth", 1),
    ("object_id", "shape_index", 1),
)


# --------------------------------------------------------------------------------------------------
# Availability


def unavailable_reason(variant: str = "llvm_ad_rgb") -> str | None:
    """Why :func:`load_mitsuba` would fail for ``variant`` (None when it would work).

    Loads the variant to ask Dr.Jit which LLVM it found (that compiles nothing, so it cannot hit
    the abort an old LLVM causes).
    """
    with _keep_variant():
        try:
            load_mitsuba(variant)
        except MissingExtraError as err:
            return str(err)
    return None


@contextlib.contextmanager
def _keep_variant() -> Iterator[None]:
    """Restore Mitsuba's active variant on exit (other code, e.g. renderers.mitsuba, relies on
    the variant it set; the functions here set theirs only while they work)."""
    mi = sys.modules.get("mitsuba")
    before = mi.variant() if mi is not None else None
    try:
        yield
    finally:
        mi = sys.modules.get("mitsuba")
        if before is not None and mi is not None and mi.variant() != before:
            mi.set_variant(before)


def load_mitsuba(variant: str = "llvm_ad_rgb") -> ModuleType:
    """The ``mitsuba`` module with ``variant`` set, checked usable for the plugin.

    Raises:
        UnknownNameError: ``variant`` is not one of :data:`VARIANTS`.
        MissingExtraError: Mitsuba is not installed, lacks the variant, or (LLVM variants)
            Dr.Jit found no LLVM >= :data:`MIN_LLVM`.
    """
    check_name(variant, VARIANTS, "Mitsuba variant")
    if importlib.util.find_spec("mitsuba") is None:
        raise MissingExtraError(
            "mitsuba", "reference", "mitsuba==3.9.1", "no module named 'mitsuba'"
        )
    mi = importlib.import_module("mitsuba")
    if variant not in mi.variants():
        raise MissingExtraError(
            "mitsuba",
            "reference",
            f"mitsuba==3.9.1 with the variant {variant!r}",
            f"only {', '.join(mi.variants())}",
        )
    try:
        mi.set_variant(variant)
    except Exception as err:  # Mitsuba raises plain exceptions (no LLVM, no CUDA driver)
        raise MissingExtraError(
            "mitsuba", "reference", f"mitsuba==3.9.1 whose {variant} loads", str(err)
        ) from None
    if variant.startswith("llvm"):
        _check_llvm(importlib.import_module("drjit"))
    return mi


def _check_llvm(dr: ModuleType) -> None:
    try:
        version = tuple(dr.detail.llvm_version())
    except Exception as err:  # no libLLVM found: Dr.Jit raises when the backend is first used
        raise MissingExtraError(
            "mitsuba llvm variant", "llvm", "a shared LLVM library for Dr.Jit", str(err)
        ) from None
    if version < MIN_LLVM:
        raise MissingExtraError(
            "mitsuba llvm variant",
            "llvm",
            f"LLVM >= {'.'.join(map(str, MIN_LLVM))} for Dr.Jit",
            f"LLVM {'.'.join(map(str, version))}, which aborts while compiling the path tracer",
        )


# --------------------------------------------------------------------------------------------------
# The sampler plugin

_CLASSES: dict[str, type] = {}


def register(variant: str = "llvm_ad_rgb") -> type:
    """Register the ``"bnerr"`` sampler plugin in ``variant`` (idempotent); return its class.

    The plugin's properties: ``sample_count`` (as every sampler) and ``sequence`` (the bnerr
    sampler name used when :meth:`configure` is given none; default ``"owen_sobol"``).
    """
    mi = load_mitsuba(variant)
    if variant not in _CLASSES:
        cls = _sampler_class(mi)
        mi.register_sampler(PLUGIN, lambda props: cls(props))
        _CLASSES[variant] = cls
    return _CLASSES[variant]


def _sampler_class(mi: ModuleType) -> type:
    """The plugin class for the active variant (each variant has its own ``mi.Sampler``)."""
    Float, Point2f = mi.Float, mi.Point2f  # this variant's types, whatever is active later

    class BnerrSampler(mi.Sampler):  # type: ignore[name-defined]  # the active variant's class
        """Mitsuba sampler whose numbers come from a bnerr sampler; see the module docstring."""

        def __init__(self, props: Any) -> None:
            super().__init__(props)
            self.sequence = props.get("sequence", "owen_sobol")
            self.lanes = _Lanes()

        def configure(self, seeds: torch.Tensor, sampler: Sampler | None = None) -> None:
            """Use ``seeds [H, W] int64`` and ``sampler`` (default: ``sequence``) from now on."""
            self.lanes.configure(seeds, sampler or make_sampler(self.sequence))

        def seed(self, seed: Any, wavefront_size: int = 0xFFFFFFFF) -> None:
            super().seed(seed, wavefront_size)
            self.lanes.seed(wavefront_size)

        def next_1d(self, active=True):
            return Float(self.lanes.draw(1)[0])

        def next_2d(self, active=True):
            u = self.lanes.draw(2)
            return Point2f(Float(u[0]), Float(u[1]))

        def fork(self):
            return self._copy()

        def clone(self):
            return self._copy()

        def _copy(self):
            props = mi.Properties()
            props["sample_count"] = self.sample_count()
            props["sequence"] = self.sequence
            out = type(self)(props)
            out.lanes = self.lanes.copy()
            return out

    return BnerrSampler


class _Lanes:
    """The per-lane state of the plugin: seed, sample index and pixel of every wavefront lane."""

    def __init__(self) -> None:
        self.seeds: torch.Tensor | None = None  # [H, W] int64
        self.sampler: Sampler | None = None
        self.lane_seed: torch.Tensor | None = None
        self.lane_index: torch.Tensor | None = None
        self.lane_pixel: torch.Tensor | None = None
        self.dim = 0

    def copy(self) -> _Lanes:
        out = _Lanes()
        out.seeds, out.sampler = self.seeds, self.sampler
        return out

    def configure(self, seeds: torch.Tensor, sampler: Sampler) -> None:
        check_tensor(seeds, "seeds")
        check_dtype(seeds, torch.int64, "seeds")
        if seeds.dim() != 2:
            raise ShapeError(f"seeds: expected [H, W], got {list(seeds.shape)}")
        if not isinstance(sampler, Sampler):
            raise DtypeError(f"sampler: expected a bnerr Sampler, got {type(sampler).__name__}")
        self.seeds, self.sampler = seeds.cpu(), sampler
        self.lane_seed = None

    def seed(self, wavefront_size: int) -> None:
        """Gather the per-lane seeds: lane i is sample ``i % spp`` of pixel ``i // spp``."""
        self.dim = 0
        self.lane_seed = None
        if self.seeds is None:
            return
        pixels = self.seeds.numel()
        if wavefront_size % pixels:  # Mitsuba's reset call (size 1), or a film of another size
            return
        spp = wavefront_size // pixels
        lane = torch.arange(wavefront_size, dtype=torch.int64)
        pixel = lane // spp
        self.lane_seed = self.seeds.reshape(-1)[pixel]
        self.lane_index = lane - pixel * spp
        width = self.seeds.shape[1]
        self.lane_pixel = torch.stack((pixel // width, pixel % width), dim=1)

    def draw(self, count: int) -> np.ndarray:
        """Dimensions ``dim .. dim + count - 1`` of every lane: ``[count, N]`` float32."""
        if self.lane_seed is None or self.lane_index is None or self.sampler is None:
            raise BnerrError(
                "bnerr sampler: expected a seed image matching the film (render through "
                "renderers.mitsuba_render.mitsuba_render_fn, or call configure(seeds) first), "
                "got none"
            )
        u = self.sampler.sample(
            self.lane_seed, self.lane_index, self.dim, count, pixel=self.lane_pixel
        )
        self.dim += count
        return u.t().contiguous().numpy()


# --------------------------------------------------------------------------------------------------
# Scene preparation: our sampler and a box filter

SceneSource = str | os.PathLike | dict
_SAMPLERS = {"independent", "stratified", "multijitter", "orthogonal", "ldsampler", PLUGIN}
_SENSORS = {"perspective", "thinlens", "orthographic"}


def _sampler_spec(spp: int, sampler: str, sequence: str) -> dict:
    spec = {"type": sampler, "sample_count": spp}
    if sampler == PLUGIN:
        spec["sequence"] = sequence
    return spec


def _prepare_dict(scene: dict, spec: dict) -> dict:
    """A copy of a scene dict with the sampler ``spec`` and a box filter."""
    out = copy.copy(scene)
    sensors = [k for k, v in out.items() if isinstance(v, dict) and v.get("type") in _SENSORS]
    if len(sensors) != 1:
        raise FileFormatError(
            f"scene: expected one perspective/thinlens/orthographic sensor, got {len(sensors)}"
        )
    sensor = out[sensors[0]] = copy.copy(out[sensors[0]])
    for key in [k for k, v in sensor.items() if isinstance(v, dict) and v.get("type") in _SAMPLERS]:
        del sensor[key]
    sensor["sampler"] = spec
    film = copy.copy(sensor.get("film", {"type": "hdrfilm"}))
    film["rfilter"] = {"type": "box"}
    sensor["film"] = film
    return out


def _prepare_xml(
    text: str,
    spec: dict,
    where: str,
    max_depth: int | None = None,
    size: tuple[int, int] | None = None,
) -> str:
    """The XML scene ``text`` with the sampler ``spec``, a box filter and (unless None) the
    integrator's ``max_depth`` and the film's ``size`` (height, width)."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:
        raise FileFormatError(f"{where}: expected a Mitsuba XML scene, got {err}") from None
    sensor = root.find("sensor")
    if sensor is None:
        raise FileFormatError(f"{where}: expected a <sensor> in the scene, got none")
    for old in sensor.findall("sampler"):
        sensor.remove(old)
    sampler = ET.SubElement(sensor, "sampler", type=spec["type"])
    ET.SubElement(sampler, "integer", name="sample_count", value=str(spec["sample_count"]))
    if "sequence" in spec:
        ET.SubElement(sampler, "string", name="sequence", value=spec["sequence"])
    film = sensor.find("film")
    if film is None:
        film = ET.SubElement(sensor, "film", type="hdrfilm")
    for old in film.findall("rfilter"):
        film.remove(old)
    ET.SubElement(film, "rfilter", type="box")
    if max_depth is not None:
        _set_max_depth(root, max_depth, where)
    if size is not None:
        for key, value in zip(("height", "width"), size, strict=True):
            for old in film.findall(f"integer[@name='{key}']"):
                film.remove(old)
            ET.SubElement(film, "integer", name=key, value=str(value))
    return ET.tostring(root, encoding="unicode")


def _set_max_depth(root: ET.Element, max_depth: int, where: str) -> None:
    """Set the top-level integrator's ``max_depth`` (the sweep's depth condition)."""
    integrator = root.find("integrator")
    if integrator is None:
        raise FileFormatError(f"{where}: expected an <integrator> to set max_depth on, got none")
    for old in integrator.findall("integer[@name='max_depth']"):
        integrator.remove(old)
    ET.SubElement(integrator, "integer", name="max_depth", value=str(max_depth))


def _aov_string() -> str:
    return ",".join(f"{name}:{kind}" for name, kind, _ in _AOVS)


def _load(
    mi: ModuleType,
    scene: SceneSource,
    spec: dict,
    params: dict,
    max_depth: int | None = None,
    size: tuple[int, int] | None = None,
) -> Any:
    """Load ``scene`` (an XML path or a scene dict) prepared by the functions above."""
    if isinstance(scene, dict):
        if max_depth is not None or size is not None:
            raise DtypeError("scene: expected an XML file path for max_depth or size, got a dict")
        return mi.load_dict(_prepare_dict(scene, spec))
    if not isinstance(scene, (str, os.PathLike)):
        raise DtypeError(
            f"scene: expected an XML file path or a Mitsuba scene dict, got {type(scene).__name__}"
        )
    path = Path(scene)
    try:
        text = path.read_text()
    except OSError as err:
        raise FileFormatError(f"{path}: expected a readable Mitsuba XML scene, got {err}") from None
    resolver = mi.file_resolver()
    folder = str(path.resolve().parent)
    if folder not in [str(p) for p in resolver]:
        resolver.prepend(folder)  # relative paths inside the scene (meshes, textures)
    return mi.load_string(_prepare_xml(text, spec, str(path), max_depth, size), **params)


# --------------------------------------------------------------------------------------------------
# The RenderFn adapter and the reference


class MitsubaRender:
    """``render(seeds [H, W] int64, sampler=None) -> Frame``: Mitsuba renders with bnerr samples.

    Built by :func:`mitsuba_render_fn`. Attributes: ``height``, ``width`` (the film's crop),
    ``spp``, ``scene`` (the loaded ``mi.Scene``), ``plugin`` (the sensor's sampler),
    ``dimensions`` (the sampler dimensions the last colour render drew, 0 before the first: the
    integrand's D, measured).
    """

    def __init__(self, mi: ModuleType, loaded: Any, spp: int, aovs: bool = True) -> None:
        self.mi, self.scene, self.spp = mi, loaded, spp
        self.variant = mi.variant()
        self.sensor = loaded.sensors()[0]
        self.integrator = loaded.integrator()
        self.aov = mi.load_dict({"type": "aov", "aovs": _aov_string()}) if aovs else None
        self.plugin = self.sensor.sampler()
        self.dimensions = 0
        self.width, self.height = (int(v) for v in self.sensor.film().crop_size())
        if self.sensor.film().sample_border():
            raise FileFormatError("film: expected sample_border = false, got true")

    @contextlib.contextmanager
    def active(self) -> Iterator[None]:
        """This render's Mitsuba variant active inside the block (``mi.Float``, ``mi.UInt32``
        and the rest resolve to it), the variant active before restored after."""
        with _keep_variant():
            if self.mi.variant() != self.variant:
                self.mi.set_variant(self.variant)
            yield

    def __call__(self, seeds: torch.Tensor, sampler: Sampler | None = None) -> Frame:
        check_tensor(seeds, "seeds")
        if tuple(seeds.shape) != (self.height, self.width):
            raise ShapeError(
                f"seeds: expected [{self.height}, {self.width}] (the film), got {list(seeds.shape)}"
            )
        self.plugin.configure(seeds, sampler)
        with self.active():
            watch = Stopwatch()
            color = self._render(self.integrator)
            self.dimensions = self.plugin.lanes.dim
            aovs = None if self.aov is None else self._render(self.aov)
            ms = watch.ms()
        return _frame(color, aovs, ms, seeds.device)

    def _render(self, integrator: Any) -> torch.Tensor:
        """One render of the scene by ``integrator`` with evaluated loops: ``[H, W, C]``."""
        dr = importlib.import_module("drjit")
        with dr.scoped_set_flag(dr.JitFlag.SymbolicLoops, False):
            image = integrator.render(
                self.scene, self.sensor, seed=0, spp=self.spp, develop=True, evaluate=True
            )
        return torch.from_numpy(np.array(image, dtype=np.float32))

    def __repr__(self) -> str:
        return f"MitsubaRender({self.height}x{self.width}, spp={self.spp}, {self.variant})"


def _frame(
    color: torch.Tensor, aovs: torch.Tensor | None, ms: float, device: torch.device
) -> Frame:
    """Colour ``[H, W, >= 3]`` and the AOV render ``[H, W, C]`` (``_AOVS`` last) as a Frame."""
    out = Frame(color=color[..., :3].permute(2, 0, 1).contiguous().to(device))
    if aovs is not None:
        chw = aovs.permute(2, 0, 1).to(device)
        start = chw.shape[0] - sum(c for _, _, c in _AOVS)
        for name, _, channels in _AOVS:
            setattr(out, name, chw[start : start + channels].contiguous())
            start += channels
        object_id = out.object_id
        assert object_id is not None  # set by the loop above
        out.object_id = object_id - 1.0  # registry index 1, 2, ...; 0 was background
    out.timings = {"render": ms}
    return out


def mitsuba_render_fn(
    scene: SceneSource,
    spp: int,
    sampler_name: str = "owen_sobol",
    variant: str = "llvm_ad_rgb",
    params: dict | None = None,
    aovs: bool = True,
    max_depth: int | None = None,
    size: tuple[int, int] | None = None,
) -> MitsubaRender:
    """A ``RenderFn`` that renders ``scene`` with Mitsuba and bnerr's samplers.

    Args:
        scene: a Mitsuba XML file (relative paths inside resolve against its folder) or a scene
            dict for ``mi.load_dict``. Its sensor's sampler is replaced by the ``"bnerr"`` plugin
            and its film's filter by a box; its integrator renders the colour.
        spp: samples per pixel of every render.
        sampler_name: the bnerr sampler used when the render is called without one.
        variant: one of :data:`VARIANTS`.
        params: values of the XML's ``$name`` parameters (``mi.load_string``'s keyword arguments).
        aovs: False renders colour only (no second, AOV render).
        max_depth: the integrator's ``max_depth`` instead of the scene's (None keeps it; an XML
            scene only).
        size: the film's ``(height, width)`` instead of the scene's (None keeps it; an XML
            scene only).

    Returns:
        :class:`MitsubaRender`: ``render(seeds [H, W] int64, sampler) -> Frame`` with ``color``,
        ``albedo``, ``normal`` ``[3, H, W]``, ``depth``, ``object_id`` ``[1, H, W]`` (float32, on
        the seeds' device) and ``timings["render"]`` in ms. Same seeds and sampler give
        bit-identical frames.

    Raises:
        MissingExtraError: Mitsuba, the variant or a recent enough LLVM is missing.
        UnknownNameError: unknown variant or sampler name.
        FileFormatError: unreadable scene, no sensor, or a film with ``sample_border``.
    """
    spp = check_positive_int(spp, "spp")
    make_sampler(sampler_name)  # the name is checked now rather than in the middle of a render
    with _keep_variant():
        mi = load_mitsuba(variant)
        register(variant)
        spec = _sampler_spec(spp, PLUGIN, sampler_name)
        loaded = _load(mi, scene, spec, params or {}, max_depth, size)
        return MitsubaRender(mi, loaded, spp, aovs)


def mitsuba_reference(
    scene: SceneSource,
    spp: int,
    *,
    seed: int = 0,
    variant: str = "llvm_ad_rgb",
    params: dict | None = None,
) -> torch.Tensor:
    """A reference colour ``[3, H, W]`` float32: Mitsuba's own ``independent`` sampler at ``spp``.

    The scene is prepared as in :func:`mitsuba_render_fn` (box filter, same integrator) and
    rendered with recorded (symbolic) loops: fast at high spp.
    """
    spp = check_positive_int(spp, "spp")
    seed = check_positive_int(seed, "seed", minimum=0)
    with _keep_variant():
        mi = load_mitsuba(variant)
        loaded = _load(mi, scene, _sampler_spec(spp, "independent", ""), params or {})
        image = np.array(mi.render(loaded, spp=spp, seed=seed), dtype=np.float32)
    return torch.from_numpy(image).permute(2, 0, 1)[:3].contiguous()
