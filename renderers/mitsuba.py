"""One frame of a scene as a Mitsuba 3 scene dictionary, and a reference render with Mitsuba.

:func:`to_mitsuba` maps every element of :mod:`renderers.scene` to the Mitsuba 3 plugin with the
same model, so that Mitsuba's ``path`` (or ``volpath``, with a medium) integrator estimates the
same image as our tracer:

- camera: ``perspective`` with the same ``look_at``, ``fov`` and ``fov_axis``; ``hdrfilm`` with a
  box ``rfilter`` (each sample lands in the pixel it was drawn in, as ours) and RGB output;
  ``independent`` sampler;
- integrator: ``max_depth`` is the scene's (the same convention, see :mod:`renderers.layout`);
  Russian roulette is switched off (``rr_depth = max_depth``) like ours; emitters stay visible;
- ``sphere``, ``rectangle`` (``to_world`` with columns u, v, normal and the center), ``cube``
  (the box's ``to_world``); ``diffuse`` BSDFs with an ``rgb`` reflectance or, for a cell texture, a
  ``bitmap`` of its cells with ``nearest`` filtering and no colour conversion (``raw``);
- area lights: an ``area`` emitter with ``rgb`` radiance on the rectangle;
- medium: a ``cube`` over the medium's box with a ``null`` BSDF and a ``homogeneous`` interior
  (``sigma_t``, rgb ``albedo``, ``isotropic`` phase).

Mitsuba's estimator differs from ours (it samples a light point and a BSDF direction at every
vertex including the last, its volpath picks a colour channel and plays Russian roulette on
absorption), but each is unbiased for the same integral, so their expected images agree.

Mitsuba is an optional dependency (the ``reference`` extra): :func:`mitsuba_available` says
whether it imports, and the functions here raise :class:`~bnerr.errors.MissingExtraError` (an
``ImportError``) with the install command when it does not.

Not for: exporting scenes to files, or any Mitsuba feature our scene model does not have.
"""

from __future__ import annotations

import importlib.util
from types import ModuleType
from typing import Any

import numpy as np
import torch

from bnerr.errors import DtypeError, MissingExtraError, ValueRangeError, check_positive_int
from renderers.scene import Rectangle, Scene, Sphere

__all__ = ["mitsuba_available", "render_mitsuba", "to_mitsuba"]


def mitsuba_available() -> bool:
    """Whether ``import mitsuba`` can work (the optional ``reference`` extra)."""
    return importlib.util.find_spec("mitsuba") is not None


def _mi(variant: str | None = None) -> ModuleType:
    """The mitsuba module with ``variant`` set (or any variant already set, else scalar_rgb)."""
    if not mitsuba_available():
        raise MissingExtraError(
            "mitsuba", "reference", "mitsuba==3.9.1", "no module named 'mitsuba'"
        )
    import mitsuba as mi

    if variant is not None:
        mi.set_variant(variant)
    elif mi.variant() is None:
        mi.set_variant("scalar_rgb")
    return mi


def _matrix(linear: np.ndarray, translation: np.ndarray) -> list[list[float]]:
    m = np.eye(4)
    m[:3, :3] = linear
    m[:3, 3] = translation
    return m.tolist()


def _material(mi: ModuleType, shape: Any) -> dict:
    albedo = shape.material.albedo
    if shape.material.textured:
        reflectance = {
            "type": "bitmap",
            "data": mi.TensorXf(np.ascontiguousarray(albedo.texels())),
            "raw": True,
            "filter_type": "nearest",
            "wrap_mode": "clamp",
        }
    else:
        reflectance = {"type": "rgb", "value": list(albedo)}
    return {"type": "diffuse", "reflectance": reflectance}


def _shape(mi: ModuleType, shape: Any, t: int) -> dict:
    T = mi.ScalarTransform4f
    if isinstance(shape, Sphere):
        out = {"type": "sphere", "center": list(shape.center.at(t)), "radius": shape.radius}
    elif isinstance(shape, Rectangle):
        linear = np.stack([shape.u, shape.v, shape.normal], axis=1)
        out = {"type": "rectangle", "to_world": T(_matrix(linear, np.asarray(shape.center)))}
        if shape.emission is not None:
            out["emitter"] = {
                "type": "area",
                "radiance": {"type": "rgb", "value": list(shape.emission)},
            }
    else:
        m = np.asarray(shape.to_world, dtype=np.float64)
        out = {"type": "cube", "to_world": T(_matrix(m[:, :3], m[:, 3]))}
    out["bsdf"] = _material(mi, shape)
    return out


def to_mitsuba(
    scene: Scene, t: int = 0, *, width: int, height: int, spp: int, seed: int = 0
) -> dict:
    """Frame ``t`` of ``scene`` as a Mitsuba 3 scene dictionary for ``mi.load_dict``.

    Uses the active Mitsuba variant (scalar_rgb if none is set). Shapes are keyed by their names.

    Raises:
        MissingExtraError: Mitsuba is not installed.
        DtypeError: ``scene`` is not a Scene.
        ValueRangeError: width, height or spp < 1.
    """
    if not isinstance(scene, Scene):
        raise DtypeError(f"scene: expected a renderers Scene, got {type(scene).__name__}")
    for value, name in ((width, "width"), (height, "height"), (spp, "spp")):
        check_positive_int(value, name)
    mi = _mi()
    integrator = "volpath" if scene.medium is not None else "path"
    out: dict = {
        "type": "scene",
        "integrator": {
            "type": integrator,
            "max_depth": scene.max_depth,
            "rr_depth": scene.max_depth,
            "hide_emitters": False,
        },
        "sensor": _sensor(mi, scene, t, width, height, spp, seed),
    }
    for shape in scene.shapes:
        out[shape.name] = _shape(mi, shape, t)
    if scene.medium is not None:
        out["medium-box"] = _medium_box(mi, scene.medium)
    return out


def _sensor(
    mi: ModuleType, scene: Scene, t: int, width: int, height: int, spp: int, seed: int
) -> dict:
    """The ``perspective`` sensor of frame ``t``, its box-filtered film and its sampler."""
    origin, target, up = scene.camera.pose(t)
    return {
        "type": "perspective",
        "fov": scene.camera.fov,
        "fov_axis": scene.camera.fov_axis,
        "near_clip": 1e-4,
        "far_clip": 1e4,
        "to_world": mi.ScalarTransform4f().look_at(
            origin=list(origin), target=list(target), up=list(up)
        ),
        "film": {
            "type": "hdrfilm",
            "width": width,
            "height": height,
            "pixel_format": "rgb",
            "component_format": "float32",
            "rfilter": {"type": "box"},
        },
        "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
    }


def _medium_box(mi: ModuleType, medium: Any) -> dict:
    """The medium as the interior of a ``cube`` with a ``null`` BSDF."""
    lo, hi = np.asarray(medium.bounds_min), np.asarray(medium.bounds_max)
    return {
        "type": "cube",
        "to_world": mi.ScalarTransform4f(_matrix(np.diag((hi - lo) / 2), (hi + lo) / 2)),
        "bsdf": {"type": "null"},
        "interior": {
            "type": "homogeneous",
            "sigma_t": float(medium.sigma_t),
            "albedo": {"type": "rgb", "value": list(medium.albedo)},
            "phase": {"type": "isotropic"},
        },
    }


def render_mitsuba(
    scene: Scene,
    t: int = 0,
    *,
    width: int,
    height: int,
    spp: int,
    seed: int = 0,
    passes: int = 1,
    variant: str = "scalar_rgb",
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Render frame ``t`` with Mitsuba: mean ``[3, H, W]`` and the variance of that mean.

    ``passes`` independent renders of ``spp / passes`` samples each (seeds ``seed * passes + k``)
    are averaged; with ``passes = spp`` every render holds one sample per pixel, so the variance is
    the exact per-pixel sample variance over the ``spp`` samples divided by ``spp`` (Mitsuba's own
    ``moment`` integrator reports second moments in XYZ, not RGB, which is why it is not used).
    With ``passes = 1`` the variance is None.

    Raises:
        MissingExtraError: Mitsuba is not installed (a missing variant: Mitsuba's own error).
        ValueRangeError: ``passes`` does not divide ``spp``.
    """
    check_positive_int(passes, "passes")
    check_positive_int(spp, "spp")
    if spp % passes:
        raise ValueRangeError(f"passes: expected a divisor of spp = {spp}, got {passes}")
    mi = _mi(variant)
    per_pass = spp // passes
    loaded = mi.load_dict(to_mitsuba(scene, t, width=width, height=height, spp=per_pass, seed=seed))
    images = torch.stack(
        [
            torch.from_numpy(
                np.array(mi.render(loaded, spp=per_pass, seed=seed * passes + k), dtype=np.float64)
            )
            for k in range(passes)
        ]
    )  # [passes, H, W, 3]
    mean = images.mean(0)
    variance = images.var(0, unbiased=True) / passes if passes > 1 else None
    return _chw(mean), (_chw(variance) if variance is not None else None)


def _chw(x: torch.Tensor) -> torch.Tensor:
    return x.permute(2, 0, 1).to(torch.float32).contiguous()
