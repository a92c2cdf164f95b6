"""The declarative scene description: camera and its animation, shapes, materials, lights, medium.

A :class:`Scene` is plain, frozen data (Python floats and tuples, no tensors): the path tracer
(:mod:`renderers.tracer`) turns one frame of it into tensors, and :mod:`renderers.mitsuba` turns the
same frame into a Mitsuba 3 scene dictionary, so that an independent renderer can check ours.

The model follows Mitsuba 3's plugins where both exist, so that the conversion is exact:

- :class:`Camera`: pinhole (Mitsuba's ``perspective`` without depth of field), posed by
  ``look_at(origin, target, up)``; ``fov`` in degrees along ``fov_axis`` (``x``, ``y``,
  ``smaller``, ``larger``, as in Mitsuba). Image x grows to the right, y downwards.
- :class:`Sphere` (``sphere``), :class:`Rectangle` (``rectangle``: the square [-1, 1]^2 of the
  local xy plane mapped by ``center + a * u + b * v``, normal ``normalize(u x v)``, texture
  coordinates ``((a + 1) / 2, (b + 1) / 2)``), :class:`Box` (``cube``: [-1, 1]^3 mapped by an affine
  ``to_world``).
- :class:`Diffuse`: Lambertian reflection, one-sided like Mitsuba's ``diffuse``: a surface seen
  from behind (direction against its normal) is black and ends the path. The albedo is a constant
  RGB or a cell texture (:class:`Checker`, :class:`Felt`): piecewise constant on a grid of cells in
  texture space, which Mitsuba reproduces exactly as a ``bitmap`` with nearest filtering.
- Area lights: a :class:`Rectangle` with ``emission`` (RGB radiance), emitting on its front side
  only (Mitsuba's ``area`` emitter).
- :class:`HomogeneousMedium`: a homogeneous participating medium filling an axis-aligned box,
  grey extinction ``sigma_t``, RGB single-scattering albedo, isotropic phase function. Its box has
  no surface (Mitsuba: a ``cube`` with a ``null`` BSDF and the medium as ``interior``); no shape
  may lie inside it.
- Animation: every position that moves is a :class:`Motion` (:class:`Fixed`, :class:`Linear`,
  :class:`Orbit`) evaluated at the integer frame index t. Spheres may translate (the only object
  motion); the camera may move. :meth:`Scene.static` freezes every motion at t = 0.

Not for: meshes, glossy or refractive materials, textures on anything but rectangles, light
sources other than rectangles, heterogeneous media, or motion blur inside a frame.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace

import numpy as np
import torch

from bnerr.errors import DtypeError, ValueRangeError, check_name, check_positive_int
from bnerr.hashing import MASK32, lowbias32
from renderers.layout import Layout

__all__ = [
    "Box",
    "Camera",
    "Checker",
    "Diffuse",
    "Felt",
    "Fixed",
    "HomogeneousMedium",
    "Linear",
    "Motion",
    "Orbit",
    "Rectangle",
    "Scene",
    "Sphere",
    "affine",
    "rotation",
]

Vec3 = tuple[float, float, float]
#: 3 x 4 affine matrix (linear part | translation), row-major, as nested tuples.
Affine = tuple[tuple[float, float, float, float], ...]


def _vec3(value: object, name: str) -> Vec3:
    """Validate a 3-vector of finite numbers and return it as a float tuple."""
    try:
        if not isinstance(value, Iterable):
            raise TypeError(name)
        out = tuple(float(v) for v in value)
    except TypeError:
        raise DtypeError(f"{name}: expected 3 numbers, got {type(value).__name__}") from None
    if len(out) != 3 or not all(math.isfinite(v) for v in out):
        raise ValueRangeError(f"{name}: expected 3 finite numbers, got {value!r}")
    return out


# --------------------------------------------------------------------------------------------
# Animation


@dataclass(frozen=True)
class Fixed:
    """A position that never moves."""

    value: Vec3

    def at(self, t: int) -> Vec3:
        return self.value

    def frozen(self) -> Fixed:
        return self


@dataclass(frozen=True)
class Linear:
    """``start + t * velocity``: constant velocity in scene units per frame."""

    start: Vec3
    velocity: Vec3

    def at(self, t: int) -> Vec3:
        (sx, sy, sz), (vx, vy, vz) = self.start, self.velocity
        return sx + t * vx, sy + t * vy, sz + t * vz

    def frozen(self) -> Fixed:
        return Fixed(self.at(0))


@dataclass(frozen=True)
class Orbit:
    """A circle around the vertical axis through ``center``, at ``height`` above it.

    Position at frame t: ``center + (radius sin a, height, radius cos a)`` with
    ``a = angle + t * step`` in degrees (so angle 0 lies on the +z side of the center).
    """

    center: Vec3
    radius: float
    height: float
    angle: float
    step: float

    def at(self, t: int) -> Vec3:
        a = math.radians(self.angle + t * self.step)
        cx, cy, cz = self.center
        return (cx + self.radius * math.sin(a), cy + self.height, cz + self.radius * math.cos(a))

    def frozen(self) -> Fixed:
        return Fixed(self.at(0))


Motion = Fixed | Linear | Orbit


# --------------------------------------------------------------------------------------------
# Materials and textures


def _hash2(key: np.ndarray) -> np.ndarray:
    """``lowbias32(lowbias32(key))`` of the low 32 bits of a uint64 array, as uint32.

    Computed by :func:`bnerr.hashing.lowbias32` on an int32 tensor holding the same bits.
    """
    words = torch.from_numpy((key & MASK32).astype(np.uint32).view(np.int32))
    return lowbias32(lowbias32(words)).numpy().view(np.uint32)


@dataclass(frozen=True)
class Checker:
    """A checkerboard of ``cells_u x cells_v`` squares in texture space; cell (0, 0) is color0."""

    color0: Vec3
    color1: Vec3
    cells_u: int
    cells_v: int

    def texels(self) -> np.ndarray:
        """``[cells_v, cells_u, 3]`` float32: the albedo of every cell (row = v, column = u)."""
        iv, iu = np.meshgrid(np.arange(self.cells_v), np.arange(self.cells_u), indexing="ij")
        odd = ((iu + iv) % 2 == 1)[..., None]
        return np.where(odd, self.color1, self.color0).astype(np.float32)


@dataclass(frozen=True)
class Felt:
    """Cloth: a base colour whose brightness varies per cell (grain) and in bands along u (nap).

    Cell (iu, iv) has albedo ``base * (1 + grain * g + nap * cos(2 pi bands iu / cells_u))``
    with ``g`` in [-1, 1) from an integer hash of (iu, iv, seed): a deterministic, high-frequency
    texture like a snooker table's felt, which a demodulated sort key has to see through.
    """

    base: Vec3
    cells_u: int
    cells_v: int
    grain: float = 0.25
    nap: float = 0.1
    bands: int = 6
    seed: int = 0

    def texels(self) -> np.ndarray:
        """``[cells_v, cells_u, 3]`` float32 albedo, clipped to [0, 1]."""
        iv, iu = np.meshgrid(np.arange(self.cells_v), np.arange(self.cells_u), indexing="ij")
        key = (iu.astype(np.uint64) * 73856093) ^ (iv.astype(np.uint64) * 19349663) ^ self.seed
        h = _hash2(key)
        g = (h >> np.uint32(8)).astype(np.float64) / float(1 << 24) * 2.0 - 1.0
        band = np.cos(2.0 * math.pi * self.bands * iu / self.cells_u)
        scale = 1.0 + self.grain * g + self.nap * band
        return np.clip(scale[..., None] * np.asarray(self.base), 0.0, 1.0).astype(np.float32)

    def mean(self) -> Vec3:
        """The texture's mean albedo (for the untextured twin of a scene)."""
        r, g, b = (float(v) for v in self.texels().reshape(-1, 3).mean(0))
        return r, g, b


Texture = Checker | Felt


@dataclass(frozen=True)
class Diffuse:
    """Lambertian reflectance ``albedo / pi``: an RGB triple in [0, 1] or a cell texture."""

    albedo: Vec3 | Texture

    def __post_init__(self) -> None:
        if isinstance(self.albedo, (Checker, Felt)):
            return
        value = _vec3(self.albedo, "Diffuse.albedo")
        if not all(0.0 <= v <= 1.0 for v in value):
            raise ValueRangeError(f"Diffuse.albedo: expected values in [0, 1], got {value}")
        object.__setattr__(self, "albedo", value)

    @property
    def textured(self) -> bool:
        return not isinstance(self.albedo, tuple)


# --------------------------------------------------------------------------------------------
# Shapes


@dataclass(frozen=True)
class Sphere:
    """A sphere; ``center`` may move (translation is the only object motion)."""

    name: str
    center: Motion
    radius: float
    material: Diffuse

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ValueRangeError(f"Sphere {self.name!r} radius: expected > 0, got {self.radius}")


@dataclass(frozen=True)
class Rectangle:
    """The parallelogram ``center + a u + b v``, a, b in [-1, 1]; ``u``, ``v`` are half edges.

    Front side: ``normalize(u x v)``. With ``emission`` (RGB radiance) it is an area light that
    emits from its front side.
    """

    name: str
    center: Vec3
    u: Vec3
    v: Vec3
    material: Diffuse
    emission: Vec3 | None = None

    def __post_init__(self) -> None:
        u, v = np.asarray(_vec3(self.u, "u")), np.asarray(_vec3(self.v, "v"))
        if np.linalg.norm(np.cross(u, v)) <= 1e-12:
            raise ValueRangeError(
                f"Rectangle {self.name!r}: expected non-parallel u and v, got {self.u}, {self.v}"
            )
        if self.emission is not None:
            e = _vec3(self.emission, "emission")
            if min(e) < 0:
                raise ValueRangeError(f"Rectangle {self.name!r} emission: expected >= 0, got {e}")

    @property
    def normal(self) -> Vec3:
        n = np.cross(self.u, self.v)
        x, y, z = (float(c) for c in n / np.linalg.norm(n))
        return x, y, z

    @property
    def area(self) -> float:
        return 4.0 * float(np.linalg.norm(np.cross(self.u, self.v)))

    @classmethod
    def from_transform(
        cls, name: str, to_world: Affine, material: Diffuse, emission: Vec3 | None = None
    ) -> Rectangle:
        """Mitsuba's ``rectangle`` with an affine ``to_world`` (3 x 4) of positive determinant."""
        m = np.asarray(to_world, dtype=np.float64)
        if np.linalg.det(m[:, :3]) <= 0:
            raise ValueRangeError(f"Rectangle {name!r}: expected a to_world with det > 0")
        return cls(name, tuple(m[:, 3]), tuple(m[:, 0]), tuple(m[:, 1]), material, emission)


@dataclass(frozen=True)
class Box:
    """Mitsuba's ``cube``: the box [-1, 1]^3 mapped by the affine ``to_world`` (3 x 4, det != 0)."""

    name: str
    to_world: Affine
    material: Diffuse

    def __post_init__(self) -> None:
        m = np.asarray(self.to_world, dtype=np.float64)
        if m.shape != (3, 4) or abs(np.linalg.det(m[:, :3])) < 1e-12:
            raise ValueRangeError(
                f"Box {self.name!r} to_world: expected an invertible 3 x 4 affine matrix"
            )


Shape = Sphere | Rectangle | Box


@dataclass(frozen=True)
class HomogeneousMedium:
    """Homogeneous medium filling the box [bounds_min, bounds_max]; isotropic phase function.

    ``sigma_t`` (per scene unit) is grey so that free-flight distances need no spectral MIS;
    ``albedo`` = sigma_s / sigma_t per RGB channel.
    """

    bounds_min: Vec3
    bounds_max: Vec3
    sigma_t: float
    albedo: Vec3

    def __post_init__(self) -> None:
        lo, hi = _vec3(self.bounds_min, "bounds_min"), _vec3(self.bounds_max, "bounds_max")
        if not all(a < b for a, b in zip(lo, hi)):
            raise ValueRangeError(
                f"HomogeneousMedium: expected bounds_min < bounds_max, got {lo}, {hi}"
            )
        if not self.sigma_t > 0:
            raise ValueRangeError(f"HomogeneousMedium sigma_t: expected > 0, got {self.sigma_t}")
        if not all(0.0 <= a <= 1.0 for a in _vec3(self.albedo, "albedo")):
            raise ValueRangeError(
                f"HomogeneousMedium albedo: expected values in [0, 1], got {self.albedo}"
            )


# --------------------------------------------------------------------------------------------
# Camera and scene


FOV_AXES = ("x", "y", "smaller", "larger")


@dataclass(frozen=True)
class Camera:
    """Pinhole camera ``look_at(origin(t), target(t), up)``, ``fov`` degrees along ``fov_axis``."""

    origin: Motion
    target: Motion
    up: Vec3
    fov: float
    fov_axis: str = "x"

    def __post_init__(self) -> None:
        if not 0.0 < self.fov < 180.0:
            raise ValueRangeError(f"Camera fov: expected degrees in (0, 180), got {self.fov}")
        check_name(self.fov_axis, FOV_AXES, "fov_axis")

    def pose(self, t: int) -> tuple[Vec3, Vec3, Vec3]:
        """``(origin, target, up)`` at frame t."""
        return self.origin.at(t), self.target.at(t), self.up

    def frozen(self) -> Camera:
        return replace(self, origin=self.origin.frozen(), target=self.target.frozen())


@dataclass(frozen=True)
class Scene:
    """A named scene: camera, shapes (object id = index in ``shapes``), depth, optional medium.

    Attributes:
        name: registry name (``renderers.get_scene(name)``).
        description: one line saying what the scene models, for ``bnerr scenes``.
        camera: the :class:`Camera` and its animation.
        shapes: spheres, rectangles and boxes; a shape's object id is its index here.
        max_depth: longest path in segments (Mitsuba's convention; 2 = direct lighting only).
        medium: optional :class:`HomogeneousMedium`.
        animated: False for the static variant (every motion frozen at t = 0).
    """

    name: str
    description: str
    camera: Camera
    shapes: tuple[Shape, ...]
    max_depth: int
    medium: HomogeneousMedium | None = None
    animated: bool = True
    _layout: Layout = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_positive_int(self.max_depth, "max_depth", minimum=2)
        for shape in self.shapes:
            if not isinstance(shape, (Sphere, Rectangle, Box)):
                raise DtypeError(
                    f"Scene {self.name!r} shapes: expected Sphere, Rectangle or Box, "
                    f"got {type(shape).__name__}"
                )
        if not self.lights:
            raise ValueRangeError(
                f"Scene {self.name!r}: expected at least one emitting Rectangle, got none"
            )
        object.__setattr__(
            self, "_layout", Layout(self.max_depth, len(self.lights), self.medium is not None)
        )

    @property
    def lights(self) -> tuple[int, ...]:
        """Object ids of the area lights, in order (light choice index -> object id)."""
        return tuple(
            i
            for i, s in enumerate(self.shapes)
            if isinstance(s, Rectangle) and s.emission is not None
        )

    @property
    def layout(self) -> Layout:
        """The dimension layout (:class:`renderers.layout.Layout`)."""
        return self._layout

    @property
    def dimensions(self) -> int:
        """D, the number of sampler dimensions one path consumes."""
        return self._layout.dimensions

    def static(self) -> Scene:
        """The static variant: camera and objects frozen at their t = 0 pose."""
        shapes = tuple(
            replace(s, center=s.center.frozen()) if isinstance(s, Sphere) else s
            for s in self.shapes
        )
        return replace(self, camera=self.camera.frozen(), shapes=shapes, animated=False)


# --------------------------------------------------------------------------------------------
# Transform helpers (Mitsuba's ScalarTransform4f.translate / rotate / scale, composed left to right)


def rotation(axis: Vec3, degrees: float) -> np.ndarray:
    """``[3, 3]`` rotation by ``degrees`` about ``axis`` (right-handed, as Mitsuba's ``rotate``)."""
    a = np.asarray(axis, dtype=np.float64)
    x, y, z = a / np.linalg.norm(a)
    s, c = math.sin(math.radians(degrees)), math.cos(math.radians(degrees))
    return np.array(
        [
            [x * x * (1 - c) + c, x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
            [y * x * (1 - c) + z * s, y * y * (1 - c) + c, y * z * (1 - c) - x * s],
            [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, z * z * (1 - c) + c],
        ]
    )


def affine(
    translate: Vec3 = (0.0, 0.0, 0.0),
    rotate: tuple[Vec3, float] | None = None,
    scale: Vec3 | float = 1.0,
) -> Affine:
    """``T(translate) * R(rotate) * S(scale)`` as a 3 x 4 tuple (Mitsuba's chained order)."""
    linear = np.diag(np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,)))
    if rotate is not None:
        linear = rotation(*rotate) @ linear
    m = np.concatenate([linear, np.asarray(translate, dtype=np.float64)[:, None]], axis=1)
    return tuple((float(r[0]), float(r[1]), float(r[2]), float(r[3])) for r in m)
