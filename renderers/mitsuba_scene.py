"""Mitsuba 3 XML scenes as scenes of every suite: ``bnerr bench --scenes path/to/scene.xml``.

:func:`load_mitsuba_scene` reads an XML scene and its optional **camera path** and returns the
builder :data:`renderers.catalog.SCENES` holds; the builder gives a :class:`MitsubaScene`, which
the sweep drives like a built-in scene but which renders itself (:meth:`MitsubaScene.render`,
through :func:`renderers.mitsuba_render.mitsuba_render_fn`, bnerr's samplers inside Mitsuba):
noisy frames and references alike, the references at the reference spp.

**The camera path** is a sidecar TOML file next to the XML: ``scene.xml`` takes
``scene.camera.toml`` when it exists. Its keys are ``origin`` and ``target`` (motions, as in a
scene file's ``[camera]``: ``[x, y, z]`` or a ``fixed``, ``linear`` or ``orbit`` table, steps per
frame) and ``up`` (a vector, default ``[0, 1, 0]``); see ``docs/SCENE_FILES.md``. Frame t's
sensor ``to_world`` is ``look_at(origin(t), target(t), up)``, which replaces the XML's; field of
view, film and everything else stay the XML's. Without a sidecar the XML's camera stands still.
The XML itself stays a plain Mitsuba scene (Mitsuba 3 has no animated transforms).

**Buffers.** Colour, albedo, shading normal, depth and object id come from
:class:`~renderers.mitsuba_render.MitsubaRender` (Mitsuba's ``aov`` integrator). ``motion``
``[2, H, W]`` (pixels from frame t-1 to t) is computed as the tracer's: one ray through each
pixel's centre at frame t (Mitsuba's ``sample_ray`` and ``ray_intersect``), its first hit
projected into frame t-1's camera (a ray that escapes is projected as a direction, so the
background follows the camera's rotation; points behind the camera at t-1 get zero motion). The
scene's objects do not move (only the camera does), so the first hit needs no object motion.
``variance`` is None (the denoisers that need it cannot run).

The film's size is the run's (``--res``), the integrator's ``max_depth`` the depth condition's
when one is set; :attr:`MitsubaScene.dimensions` (D) is measured: the sampler dimensions one
1-spp render draws. :attr:`MitsubaScene.version` (Mitsuba's version and a hash of the XML and the
sidecar) keys the cached references. Files the XML names (meshes, textures) do not enter it;
each must lie inside the XML's folder (an absolute path, ``..`` or a symlink out is refused).

Not for: moving objects (a Mitsuba scene has no motion over frames here), Mitsuba's scalar or
spectral variants (see :mod:`renderers.mitsuba_render`).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.metadata
import os
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import torch

from bnerr.errors import DtypeError, FileFormatError
from bnerr.frame import Frame
from bnerr.sequences import Sampler, make_sampler
from renderers.mitsuba_render import MitsubaRender, mitsuba_render_fn
from renderers.scene import Motion, Vec3
from renderers.scene_file import load_camera_path

__all__ = [
    "CAMERA_SUFFIX",
    "CameraPath",
    "MitsubaScene",
    "camera_motion",
    "camera_path_file",
    "load_mitsuba_scene",
]

#: The camera path of ``scene.xml`` is ``scene`` + this suffix, in the same folder.
CAMERA_SUFFIX = ".camera.toml"
_FILM_FOR_D = (4, 4)  # the film of the 1-spp render that measures D


@dataclass(frozen=True)
class CameraPath:
    """``look_at(origin(t), target(t), up)`` over frames t (the sidecar's camera path)."""

    origin: Motion
    target: Motion
    up: Vec3

    def pose(self, t: int) -> tuple[Vec3, Vec3, Vec3]:
        """``(origin, target, up)`` at frame t."""
        return self.origin.at(t), self.target.at(t), self.up

    def frozen(self) -> CameraPath:
        """The path standing at its frame-0 pose."""
        return CameraPath(self.origin.frozen(), self.target.frozen(), self.up)


@dataclass(frozen=True)
class MitsubaScene:
    """A Mitsuba 3 XML scene as a scene of the sweep (see the module docstring).

    Attributes:
        name: the registered name (the file's stem).
        path: the XML file, resolved.
        camera: the camera path, or None (the XML's camera, still).
        version: ``"mitsuba-<version>-<16 hex digits of SHA-256 of the XML and the sidecar>"``.
        max_depth: the integrator's ``max_depth`` instead of the XML's, or None.
        animated: False freezes the camera at frame 0 (the static variant).
        description: one line for listings.
    """

    name: str
    path: str
    camera: CameraPath | None
    version: str
    max_depth: int | None = None
    animated: bool = True
    description: str = ""

    @property
    def dimensions(self) -> int:
        """D: the sampler dimensions one path of the colour render draws (measured once)."""
        return _dimensions(self.path, self.max_depth)

    def static(self) -> MitsubaScene:
        """The static variant: the camera frozen at its frame-0 pose."""
        camera = None if self.camera is None else self.camera.frozen()
        return dataclasses.replace(self, camera=camera, animated=False)

    def pose(self, t: int) -> tuple[Vec3, Vec3, Vec3] | None:
        """The camera's ``(origin, target, up)`` at frame t, or None (the XML's camera)."""
        return None if self.camera is None else self.camera.pose(t)

    def render(self, t: int, seeds: torch.Tensor, sampler: Sampler | None, spp: int) -> Frame:
        """Frame ``t`` rendered by Mitsuba with ``sampler`` at ``seeds [H, W]`` int64: colour,
        albedo, normal, depth, object id and motion, as the tracer's frames. Same inputs give
        bit-identical frames.

        Raises:
            MissingExtraError: Mitsuba or a recent enough LLVM is missing.
            FileFormatError: the XML cannot be loaded as a scene.
        """
        if seeds.dim() != 2:
            raise DtypeError(f"seeds: expected [H, W] int64, got shape {list(seeds.shape)}")
        height, width = (int(n) for n in seeds.shape)
        render = _renderer(self.path, spp, self.max_depth, height, width)
        pose = self.pose(t)
        if pose is not None:
            _set_pose(render, pose)
        frame = render(seeds, sampler)
        previous = self.pose(t - 1)
        frame.motion = camera_motion(render, previous).to(seeds.device)
        return frame


def camera_path_file(xml: str | os.PathLike) -> Path:
    """The sidecar camera path file of ``xml``: ``scene.xml`` -> ``scene.camera.toml``."""
    path = Path(xml)
    return path.with_name(path.stem + CAMERA_SUFFIX)


def load_mitsuba_scene(xml: str | os.PathLike) -> Callable[[], MitsubaScene]:
    """The builder of the Mitsuba XML scene ``xml`` and its camera path (if the sidecar exists).

    The files are read and checked now (the XML parses and has a ``<sensor>``; the sidecar is a
    valid camera path); Mitsuba itself is needed only to render. The builder carries ``files``,
    the paths whose bytes identify the scene (the XML, and the sidecar when there is one).

    Raises:
        FileFormatError: the XML is missing, unreadable, not XML or has no ``<sensor>``, or
            names a file (``<include>``, a ``filename`` string) outside its folder.
        SceneFileError: the sidecar is not a valid camera path.
    """
    path = Path(xml).resolve()
    try:
        data = path.read_bytes()
    except OSError as err:
        raise FileFormatError(
            f"{xml}: expected a readable Mitsuba XML scene, got {err.strerror or err}"
        ) from None
    try:
        root = ET.fromstring(data)
    except ET.ParseError as err:
        raise FileFormatError(f"{xml}: expected a Mitsuba XML scene, got {err}") from None
    if root.tag != "scene" or root.find("sensor") is None:
        raise FileFormatError(f"{xml}: expected a <scene> with a <sensor>, got <{root.tag}>")
    _check_files(root, path.parent, xml)
    sidecar = camera_path_file(path)
    files = [path]
    camera = None
    if sidecar.exists():
        camera = CameraPath(*load_camera_path(sidecar))
        files.append(sidecar)
    digest = hashlib.sha256()
    for file in files:
        digest.update(file.read_bytes())
        digest.update(b"\0")
    scene = MitsubaScene(
        name=path.stem,
        path=str(path),
        camera=camera,
        version=f"mitsuba-{_mitsuba_version()}-{digest.hexdigest()[:16]}",
        description=f"Mitsuba 3 scene {path.name}"
        + (f" along {sidecar.name}" if camera is not None else " (still camera)"),
    )

    def build() -> MitsubaScene:
        return scene

    build.__doc__ = scene.description
    build.__name__ = build.__qualname__ = scene.name
    build.files = tuple(str(f) for f in files)  # type: ignore[attr-defined]
    return build


def _named_files(root: ET.Element) -> list[tuple[str, str]]:
    """``(element, path)`` of every file the XML names: ``<include filename=...>`` and
    ``<string name="filename" value=...>`` (meshes, textures, environment maps)."""
    found = []
    for element in root.iter():
        if element.tag == "include" and element.get("filename") is not None:
            found.append(("<include> filename", element.get("filename", "")))
        elif element.tag == "string" and element.get("name") == "filename":
            found.append(('<string name="filename">', element.get("value", "")))
    return found


def _check_files(root: ET.Element, folder: Path, xml: str | os.PathLike) -> None:
    """Refuse a file named in the XML that lies outside its folder (an absolute path, or one
    that escapes through ``..`` or a symlink): a scene is data, and reads only its own folder.
    A value holding a ``$`` parameter is Mitsuba's to resolve (it has no path yet)."""
    for what, value in _named_files(root):
        if "$" in value:
            continue
        resolved = (folder / value).resolve()
        if Path(value).is_absolute() or not resolved.is_relative_to(folder):
            raise FileFormatError(
                f"{xml}: {what}: expected a path inside the scene's folder {folder}, got "
                f"{value!r}, which resolves to {resolved}"
            )


def _mitsuba_version() -> str:
    try:
        return importlib.metadata.version("mitsuba")
    except importlib.metadata.PackageNotFoundError:
        return "none"


# --------------------------------------------------------------------------------------------
# Rendering: one loaded Mitsuba scene per file, spp, depth and film size


@functools.lru_cache(maxsize=16)
def _renderer(path: str, spp: int, max_depth: int | None, height: int, width: int) -> MitsubaRender:
    return mitsuba_render_fn(path, spp, max_depth=max_depth, size=(height, width))


@functools.lru_cache(maxsize=16)
def _dimensions(path: str, max_depth: int | None) -> int:
    render = _renderer(path, 1, max_depth, *_FILM_FOR_D)
    render(torch.zeros(_FILM_FOR_D, dtype=torch.int64), make_sampler("white"))
    return render.dimensions


def _look_at(mi: ModuleType, pose: tuple[Vec3, Vec3, Vec3]) -> Any:
    origin, target, up = (list(map(float, v)) for v in pose)
    return mi.ScalarTransform4f().look_at(origin=origin, target=target, up=up)


def _set_pose(render: MitsubaRender, pose: tuple[Vec3, Vec3, Vec3]) -> None:
    """Pose the render's sensor at ``look_at(*pose)``."""
    params = render.mi.traverse(render.sensor)
    params["to_world"] = _look_at(render.mi, pose)
    params.update()


def _matrix(transform: Any) -> np.ndarray:
    """A Mitsuba transform's 4 x 4 matrix as float64."""
    return np.array(transform.matrix, dtype=np.float64).reshape(4, 4)


def camera_motion(render: MitsubaRender, previous: tuple[Vec3, Vec3, Vec3] | None) -> torch.Tensor:
    """Motion ``[2, H, W]`` float32 in pixels from the camera at ``previous`` (``look_at``
    pose; None: the sensor's own pose, so zero motion) to the sensor's current pose.

    One ray through each pixel centre at the current pose; its first hit (or, for a ray that
    escapes, its direction) projected into the previous camera with Mitsuba's ``perspective``
    projection (``x_fov``, the film's size and crop). Zero where the point is behind the previous
    camera.
    """
    with render.active():  # its variant, whatever other code made active since
        return _camera_motion(render, previous)


def _camera_motion(render: MitsubaRender, previous: tuple[Vec3, Vec3, Vec3] | None) -> torch.Tensor:
    mi, sensor = render.mi, render.sensor
    height, width = render.height, render.width
    if previous is None:
        return torch.zeros(2, height, width)
    dr = importlib.import_module("drjit")
    index = dr.arange(mi.UInt32, height * width)
    cx, cy = mi.Float(index % width) + 0.5, mi.Float(index // width) + 0.5
    position = mi.Point2f(cx / width, cy / height)
    ray, _ = sensor.sample_ray(0.0, 0.5, position, mi.Point2f(0.5, 0.5))
    hit = render.scene.ray_intersect(ray)
    valid = np.array(hit.is_valid(), dtype=bool)
    point = np.array(hit.p, dtype=np.float64).reshape(3, -1)
    direction = np.array(ray.d, dtype=np.float64).reshape(3, -1)
    to_camera = np.linalg.inv(_matrix(_look_at(mi, previous)))
    local = np.where(
        valid[None],
        to_camera[:3, :3] @ point + to_camera[:3, 3:],
        to_camera[:3, :3] @ direction,
    )
    x_prev, y_prev, front = _project(render, local)
    centre = np.stack([np.array(cx, dtype=np.float64), np.array(cy, dtype=np.float64)])
    motion = np.where(front[None], centre - np.stack([x_prev, y_prev]), 0.0)
    return torch.from_numpy(motion.astype(np.float32)).reshape(2, height, width)


def _project(render: MitsubaRender, local: np.ndarray) -> tuple[np.ndarray, ...]:
    """Pixel coordinates ``x, y`` of camera-space points ``[3, N]`` and whether each is in front,
    by Mitsuba's ``perspective_projection`` (camera x to the left, y up, z forward)."""
    film = render.sensor.film()
    size = np.array(film.size(), dtype=np.float64).reshape(-1)
    offset = np.array(film.crop_offset(), dtype=np.float64).reshape(-1)
    x_fov = float(np.array(render.mi.traverse(render.sensor)["x_fov"]).reshape(-1)[0])
    tan_x = np.tan(np.radians(x_fov) / 2)
    z = local[2]
    front = z > 0
    z_safe = np.where(front, z, 1.0)
    aspect = size[0] / size[1]
    sx = 0.5 * (1.0 - local[0] / (z_safe * tan_x))
    sy = 0.5 * (1.0 - aspect * local[1] / (z_safe * tan_x))
    return sx * size[0] - offset[0], sy * size[1] - offset[1], front
