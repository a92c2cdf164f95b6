"""Cycles scenes as scenes of every suite: any ``.blend`` file, or a scene built in Blender by code.

``bnerr bench --scenes path/to/scene.blend`` renders the file's active camera over its
animation's frames (bnerr's frame t is the file's ``frame_start + t``); the named scenes of
:data:`BUILT` are built by code (:mod:`renderers.cycles.builders`): the ``cycles`` suite's three
scenes and bnerr's own ``direct`` and ``indirect`` rebuilt in Blender (their spheres,
rectangles, checker and lights in Blender's axes, the camera keyframed on the same path).

A :class:`CyclesScene` renders itself (:meth:`CyclesScene.render`) in a Blender process
(:mod:`renderers.cycles.session`). **What bnerr takes over** in every render, and records with
the file's own values (:attr:`CyclesScene.info`): samples, seed (and the animated seed off),
sampling pattern, adaptive sampling (off unless the strategy asks for it), scrambling distance
(off unless asked), denoising (Cycles' OIDN with albedo and normal, the accurate prefilter, its
Noisy Image kept), the CPU device, the passes and distinct object indices; motion blur and
compositing are off (Cycles writes motion vectors only without motion blur). The light paths
(bounces, clamping, caustics, light tree, filter) stay the file's and are recorded.

**The frame**, from one render's passes: colour is the Noisy Image (the samples before Cycles'
denoiser), the denoised Combined pass of the same samples rides along as
``own_denoised["cycles_oidn"]`` (:class:`denoisers.cycles_oidn`'s image), albedo the Denoising
Albedo (what Cycles feeds OIDN: a metal's specular colour, not black), normal the world-space
Normal pass, depth the Z pass (0 where the ray escaped), object id the object index pass less
one (-1: background), motion the Vector pass's motion from the previous frame turned into bnerr's
convention (pixels from t-1 to t, y down), ``timings["render"]`` the render's wall time in the
Blender process (Cycles' OIDN included, about 0.1 s at 128 x 128).

**Strategies**: Cycles takes one seed per frame, not one per pixel, so only Cycles' own patterns
run on these scenes (:mod:`renderers.cycles.patterns`): ``white`` is Cycles' classic pattern
(tabulated Sobol) seeded from the strategy's seed image, the references too (with seeds no
strategy uses).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.frame import Frame
from renderers.cycles.patterns import pattern_of
from renderers.cycles.session import CyclesSession, session
from renderers.scene import Checker, Fixed, Rectangle, Scene, Sphere

__all__ = [
    "BUILT",
    "CyclesScene",
    "built_scene",
    "load_blend",
    "recipe_of_scene",
    "save_blend",
    "settings_record",
]

_HERE = Path(__file__).parent
#: Frames every built scene's camera is keyframed on.
BUILT_FRAMES = 64
#: How a .blend file starts: plain (``BLENDER``), or Zstandard-compressed (Blender 3.0 and later).
_BLEND_MAGIC = (b"BLENDER", b"\x28\xb5\x2f\xfd")


@dataclass(frozen=True)
class CyclesScene:
    """A scene Cycles renders (module docstring).

    Attributes:
        name: the registered name (a file's stem, or the built scene's name).
        source: the worker's request that loads it, as JSON text (a ``.blend`` to open or a
            recipe to build).
        version: what keys its cached references: Blender's version and a hash of the file or
            recipe and of the Blender-side code.
        animated: False renders every frame at the first frame's pose (the static variant).
        description: one line for listings.
    """

    name: str
    source: str
    version: str
    animated: bool = True
    description: str = ""

    #: The sampler dimensions the sweep's strategies are told (Cycles' own patterns ignore it).
    dimensions = 2

    @property
    def session(self) -> CyclesSession:
        """The Blender process holding this scene (started on first use)."""
        return session(self.version, json.loads(self.source), f"Cycles scene {self.name}")

    @property
    def info(self) -> dict:
        """What the worker found in the scene before bnerr changed it (Blender's version, the
        camera, the frame range, the patterns it accepts, the settings bnerr overrides)."""
        return self.session.info

    def static(self) -> CyclesScene:
        """The static variant: every frame rendered at the first frame."""
        return dataclasses.replace(self, animated=False)

    def frame_number(self, t: int) -> int:
        """Blender's frame number of bnerr's frame t."""
        return int(self.info["frame_start"]) + (t if self.animated else 0)

    def render(self, t: int, seeds: torch.Tensor, sampler: object, spp: int) -> Frame:
        """Frame ``t`` at ``spp`` with Cycles' pattern ``sampler`` (a :class:`CyclesPattern`, or
        the per-pixel ``owen_sobol`` sampler: the classic pattern seeded from ``seeds``);
        ``seeds [H, W]`` gives the frame's size. Same inputs give the same frame on one machine
        (Cycles renders deterministically on the CPU).

        Raises:
            ValueRangeError: a sampler Cycles does not have (bnerr's per-pixel strategies).
            ExternalProcessError: the render failed inside Blender.
            MissingExtraError: no Python with ``bpy``.
        """
        height, width = (int(n) for n in seeds.shape[-2:])
        pattern = pattern_of(sampler, seeds, self.name)
        with tempfile.TemporaryDirectory(prefix="bnerr-cycles-") as folder:
            out = os.path.join(folder, "frame.exr")
            answer = self.session.ask(
                {
                    "op": "render",
                    "frame": self.frame_number(t),
                    "width": width,
                    "height": height,
                    "spp": int(spp),
                    "denoise": True,
                    "out": out,
                    **pattern.request(),
                }
            )
            frame = read_cycles_frame(out, height, width, self.name)
        frame.timings["render"] = 1000.0 * float(answer["wall_s"])
        if not self.animated or t == 0:
            assert frame.motion is not None
            frame.motion.zero_()
        return frame.to(seeds.device)


#: What every render sets, whatever the file says (the strategy's pattern, seed, spp and
#: adaptive sampling aside): the record written beside the results (:func:`settings_record`).
TAKEN_OVER: dict[str, object] = {
    "use_animated_seed": False,
    "adaptive_threshold": 0.01,
    "adaptive_min_samples": 0,
    "auto_scrambling_distance": False,
    "scrambling_distance": "1.0 (off) unless the strategy sets it",
    "use_denoising": True,
    "denoiser": "OPENIMAGEDENOISE",
    "denoising_input_passes": "RGB_ALBEDO_NORMAL",
    "denoising_prefilter": "ACCURATE",
    "denoising_store_passes": True,
    "device": "CPU",
    "use_motion_blur": False,
    "use_compositing": False,
    "resolution_percentage": 100,
    "pass_index": "1, 2, ... per object, by name",
    "passes": "Z, Normal, Object Index, Vector, denoising data",
}


def settings_record(infos: dict[str, dict]) -> dict:
    """What a Cycles run measured with: per scene, Blender's version, the camera, the frame
    range and the file's own settings before bnerr changed them; and what bnerr set."""
    return {"scenes": infos, "bnerr_sets": TAKEN_OVER}


def _channel(channels: dict, name: str, path: str) -> np.ndarray:
    key = f"ViewLayer.{name}"
    if key not in channels:
        raise FileFormatError(f"{path}: expected Cycles' pass {name}, got {sorted(channels)}")
    return np.asarray(channels[key].pixels, dtype=np.float32)


def _stack(channels: dict, name: str, axes: str, path: str) -> np.ndarray:
    return np.stack([_channel(channels, f"{name}.{a}", path) for a in axes])


def read_cycles_frame(path: str, height: int, width: int, name: str) -> Frame:
    """The :class:`Frame` of one Cycles multilayer EXR (module docstring)."""
    import OpenEXR  # a bnerr dependency; imported where used, as bnerr.io does

    with OpenEXR.File(path) as exr:
        channels = exr.parts[0].channels
        noisy = _channel(channels, "Noisy Image", path)[..., :3].transpose(2, 0, 1)
        denoised = _channel(channels, "Combined", path)[..., :3].transpose(2, 0, 1)
        albedo = _channel(channels, "Denoising Albedo", path)[..., :3].transpose(2, 0, 1)
        normal = _stack(channels, "Normal", "XYZ", path)
        depth = _channel(channels, "Depth.Z", path)[None]
        index = _channel(channels, "IndexOB.X", path)[None]
        vector = _stack(channels, "Vector", "XY", path)
    if noisy.shape[1:] != (height, width):
        raise FileFormatError(
            f"{name}: expected a {width} x {height} frame from Cycles, got "
            f"{noisy.shape[2]} x {noisy.shape[1]}"
        )
    escaped = index < 0.5

    def tensor(a: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(np.ascontiguousarray(a, dtype=np.float32))

    return Frame(
        color=tensor(noisy),
        albedo=tensor(albedo),
        normal=tensor(normal),
        depth=tensor(np.where(escaped | (depth > 1e9), 0.0, depth)),
        motion=tensor(motion_from_vector(vector)),
        object_id=tensor(np.where(escaped, -1.0, index - 1.0)),
        own_denoised={"cycles_oidn": tensor(denoised)},
    )


def motion_from_vector(vector: np.ndarray) -> np.ndarray:
    """bnerr's motion ``[2, H, W]`` (pixels from t-1 to t, x right, y down) from Cycles' Vector
    pass ``[2, H, W]`` (its first two components: the offset, in pixels with y up, from the
    pixel's position at t to its position at t-1)."""
    return np.stack([-vector[0], vector[1]])


def _digest(*parts: bytes) -> str:
    digest = hashlib.sha256()
    for part in parts:
        digest.update(part)
        digest.update(b"\0")
    return digest.hexdigest()[:16]


@functools.cache
def _blender_code() -> bytes:
    """The Blender-side code's bytes: a change in it changes every Cycles scene's version."""
    return b"".join((_HERE / name).read_bytes() for name in ("worker.py", "builders.py"))


def load_blend(path: str | os.PathLike) -> Callable[[], CyclesScene]:
    """The builder of the Cycles scene in ``path`` (a ``.blend`` file), checked as far as can be
    without Blender: the file is readable and is a ``.blend``. Blender checks the rest (a camera)
    when the scene is first used (:meth:`CyclesScene.info`).

    Raises:
        FileFormatError: the file is missing, unreadable or not a ``.blend``.
    """
    resolved = Path(path).resolve()
    try:
        data = resolved.read_bytes()
    except OSError as err:
        raise FileFormatError(
            f"{path}: expected a readable .blend file, got {err.strerror or err}"
        ) from None
    if not data.startswith(_BLEND_MAGIC):
        raise FileFormatError(
            f"{path}: expected a .blend file (it starts with BLENDER, or Zstandard's magic), got "
            f"{data[:7]!r}"
        )
    scene = CyclesScene(
        name=resolved.stem,
        source=json.dumps({"op": "open", "blend": str(resolved)}),
        version=f"cycles-{_digest(data, _blender_code())}",
        description=f"Blender file {resolved.name}, rendered by Cycles",
    )
    return _builder(scene, (str(resolved),))


def _builder(scene: CyclesScene, files: tuple[str, ...]) -> Callable[[], CyclesScene]:
    def build() -> CyclesScene:
        return scene

    build.__doc__ = scene.description
    build.__name__ = build.__qualname__ = scene.name
    build.files = files  # type: ignore[attr-defined]
    return build


def _blender_axes(v: tuple[float, float, float]) -> list[float]:
    """bnerr's y-up point or vector in Blender's z-up axes: (x, y, z) -> (x, -z, y)."""
    return [float(v[0]), -float(v[2]), float(v[1])]


def recipe_of_scene(scene: Scene, frames: int = BUILT_FRAMES) -> dict:
    """The builder recipe of a bnerr scene (``renderers.scene.Scene``): its spheres, rectangles
    (constant or checker albedo) and rectangle lights in Blender's axes, the camera's pose at
    frames 0..frames-1, the field of view along x, and Cycles' bounce count for its depth.

    Raises:
        ValueRangeError: the scene has what the rebuild does not carry (boxes, a medium, felt
            textures, moving spheres, a field of view along another axis).
    """
    s = scene
    fail = [
        what
        for what, bad in (
            ("a medium", getattr(s, "medium", None) is not None),
            ("a field of view along y", s.camera.fov_axis != "x"),
        )
        if bad
    ]
    spheres, rectangles = [], []
    for shape in s.shapes:
        albedo = shape.material.albedo
        if isinstance(shape, Sphere) and isinstance(shape.center, Fixed):
            if not isinstance(albedo, tuple):
                fail.append(f"{shape.name}'s texture")
                continue
            spheres.append(
                {
                    "name": shape.name,
                    "center": _blender_axes(shape.center.at(0)),
                    "radius": shape.radius,
                    "albedo": list(albedo),
                }
            )
        elif isinstance(shape, Rectangle) and isinstance(albedo, (tuple, Checker)):
            rectangles.append(_rectangle_entry(shape, albedo))
        else:
            fail.append(f"{shape.name} ({type(shape).__name__}, a texture or a moving sphere)")
    if fail:
        raise ValueRangeError(
            f"{s.name}: expected spheres, rectangles and rectangle lights to rebuild in "
            f"Blender, got {', '.join(fail)}"
        )
    poses = [[_blender_axes(p) for p in s.camera.pose(t)] for t in range(frames)]
    return {
        "kind": "shapes",
        "spheres": spheres,
        "rectangles": rectangles,
        "poses": poses,
        "fov": float(s.camera.fov),
        "max_bounces": max(int(s.max_depth) - 2, 0),
    }


def _rectangle_entry(shape: Rectangle, albedo: tuple[float, float, float] | Checker) -> dict:
    """A rectangle of the recipe: its corners' frame in Blender's axes and its albedo, checker
    or (a light) radiance."""
    entry: dict = {
        "name": shape.name,
        "center": _blender_axes(shape.center),
        "u": _blender_axes(shape.u),
        "v": _blender_axes(shape.v),
    }
    if shape.emission is not None:
        entry["radiance"] = list(shape.emission)
    elif isinstance(albedo, Checker):
        entry["checker"] = {
            "color0": list(albedo.color0),
            "color1": list(albedo.color1),
            "cells_u": albedo.cells_u,
            "cells_v": albedo.cells_v,
        }
    else:
        entry["albedo"] = list(albedo)
    return entry


def _built_recipe(name: str) -> dict:
    kind = name.removeprefix("cycles_")
    if kind in ("interior", "product", "outdoor"):
        return {"kind": kind, "frames": BUILT_FRAMES}
    from renderers.catalog import get_scene

    return recipe_of_scene(get_scene(kind))


#: The scenes built in Blender by code, by name: the ``cycles`` suite's three, and bnerr's own
#: ``direct`` and ``indirect`` rebuilt (the same-scene comparison with ``cycles_blue``).
BUILT: dict[str, str] = {
    "cycles_interior": "a room lit through a window by a sun and the sky (indirect light)",
    "cycles_product": "a metal sphere, a glossy Suzanne and a gold ring under two small lights",
    "cycles_outdoor": "a sun and sky over 3,000 thin grass blades and a fence of thin posts",
    "cycles_direct": "bnerr's direct scene rebuilt in Blender, rendered by Cycles",
    "cycles_indirect": "bnerr's indirect scene rebuilt in Blender, rendered by Cycles",
}


def save_blend(scene: str, path: str | os.PathLike) -> Path:
    """Write the built Cycles scene ``scene`` (a key of :data:`BUILT`) to the ``.blend`` file
    ``path`` (its camera animation included), as Blender saves it; returns the path."""
    out = Path(path).resolve()
    built_scene(scene)().session.ask({"op": "save", "blend": str(out)})
    return out


def built_scene(name: str) -> Callable[[], CyclesScene]:
    """The builder of the built Cycles scene ``name`` (a key of :data:`BUILT`)."""
    recipe = json.dumps({"op": "build", "recipe": _built_recipe(name)}, sort_keys=True)
    scene = CyclesScene(
        name=name,
        source=recipe,
        version=f"cycles-{_digest(recipe.encode(), _blender_code())}",
        description=BUILT[name],
    )
    return _builder(scene, ())
