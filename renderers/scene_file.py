"""Scenes in files: a TOML (or JSON, same schema) description of a :class:`~renderers.scene.Scene`.

A user writes a scene for bnerr's tracer without writing Python; ``docs/SCENE_FILES.md`` lists
every key with its unit and default, and ``examples/scenes/`` holds the six shipped scenes as
files written by :func:`dump_scene`. The format maps one to one onto :mod:`renderers.scene`
(camera and its motions, spheres, rectangles, boxes, rectangular area lights, cell textures, a
homogeneous medium), so a shipped scene written by :func:`dump_scene` and read back is equal,
field for field, to the built-in one and renders bit for bit the same: every float is written in
Python's shortest round-trip form.

- :func:`load_scene_file`: ``path -> Callable[[], Scene]``, the type of
  :data:`renderers.catalog.SCENES`' values; ``.json`` files are JSON, everything else TOML.
- :func:`loads_scene` (text or bytes) and :func:`scene_from_dict` (the parsed document).
- :func:`scene_dict`, :func:`dump_scene` (TOML or JSON text) and :func:`write_scene_file`
  (atomic): the other way.

Scene files are data and stay inert: they name no other file (textures are procedural), a file
over :data:`MAX_FILE_BYTES` is refused before it is parsed, more than :data:`MAX_SHAPES` shapes or
:data:`MAX_TEXTURE_CELLS` texture cells before anything is allocated, every number must be finite
and within :data:`MAX_COORDINATE`, and every key must be known. Whatever the bytes, loading either
returns a scene or raises :class:`bnerr.errors.SceneFileError` naming the file and the line (syntax)
or the key (meaning), what was expected and what came.
The format's keys and values are the model :mod:`bnerr.schemas.scene` (``bnerr schema scene``
prints its JSON Schema); this module adds the checks that need the geometry.

Not for: meshes, materials other than Lambertian, or anything :mod:`renderers.scene` cannot
describe; Mitsuba XML scenes (:mod:`renderers.mitsuba_render` renders those).
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np
from pydantic import TypeAdapter

from bnerr.errors import BnerrError, DtypeError, SceneFileError
from bnerr.io import atomic_write
from bnerr.schemas import camera as camera_schema
from bnerr.schemas import scene as schema
from bnerr.schemas.documents import dump_toml, format_of, parse, read
from bnerr.schemas.errors import validate
from bnerr.schemas.scene import (
    FORMAT_VERSION,
    MAX_COORDINATE,
    MAX_DEPTH,
    MAX_FILE_BYTES,
    MAX_SHAPES,
    MAX_TEXTURE_CELLS,
    MIN_LENGTH,
)
from renderers.scene import (
    Affine,
    Box,
    Camera,
    Checker,
    Diffuse,
    Felt,
    Fixed,
    HomogeneousMedium,
    Linear,
    Motion,
    Orbit,
    Rectangle,
    Scene,
    Sphere,
    Texture,
    Vec3,
    affine,
)

__all__ = [
    "FORMAT_VERSION",
    "MAX_COORDINATE",
    "MAX_DEPTH",
    "MAX_FILE_BYTES",
    "MAX_SHAPES",
    "MAX_TEXTURE_CELLS",
    "MIN_LENGTH",
    "dump_scene",
    "load_camera_path",
    "load_scene_file",
    "loads_scene",
    "scene_dict",
    "scene_from_dict",
    "write_scene_file",
]

#: Frames over which the camera must keep a valid pose (origin != target, up not parallel).
CAMERA_CHECK_FRAMES = 1024

_STEM = "name (none given, so the file's name without suffix)"
_NAME: TypeAdapter[str] = TypeAdapter(schema.Name)


# --------------------------------------------------------------------------------------------
# Building the scene of a checked document (bnerr.schemas.scene checked everything but geometry)


#: The dataclass of each kind of motion and texture; its fields are named as the table's keys.
_KINDS: dict[str, Any] = {
    "fixed": Fixed, "linear": Linear, "orbit": Orbit, "checker": Checker, "felt": Felt
}  # fmt: skip


def _built(t: Any) -> Any:
    """The motion of a bare ``[x, y, z]`` or of a motion table, or the texture of a texture
    table, as its :mod:`renderers.scene` dataclass."""
    if isinstance(t, tuple):
        return Fixed(t)
    return _KINDS[t.type](**{key: value for key, value in t if key != "type"})


def _check_pose(origin_motion: Motion, target_motion: Motion, up_vector: Vec3) -> None:
    """Refuse a camera whose pose degenerates in the first :data:`CAMERA_CHECK_FRAMES` frames:
    origin on the target, or up parallel to the viewing direction (no image plane)."""
    up = np.asarray(up_vector)
    moving = not (isinstance(origin_motion, Fixed) and isinstance(target_motion, Fixed))
    frames = range(CAMERA_CHECK_FRAMES if moving else 1)
    origin = np.array([origin_motion.at(t) for t in frames])
    forward = np.array([target_motion.at(t) for t in frames]) - origin
    length = np.linalg.norm(forward, axis=1)
    if length.min() < MIN_LENGTH:
        t = int(length.argmin())
        raise SceneFileError(
            f"camera: expected origin and target apart at every frame, got both at "
            f"{tuple(origin[t].tolist())} at frame {t}"
        )
    sine = np.linalg.norm(np.cross(forward / length[:, None], up / np.linalg.norm(up)), axis=1)
    if sine.min() < MIN_LENGTH:
        t = int(sine.argmin())
        raise SceneFileError(
            f"camera.up: expected a direction not parallel to the view direction, got "
            f"{up_vector} along {tuple(forward[t].tolist())} at frame {t}"
        )


def _camera(c: schema.Camera) -> Camera:
    camera = Camera(_built(c.origin), _built(c.target), c.up, c.fov, c.fov_axis)
    _check_pose(camera.origin, camera.target, camera.up)
    return camera


def _material(t: Any, textures: Mapping, materials: Mapping) -> Diffuse:
    """The material of a shape or a ``[materials.name]`` table (its references checked)."""
    if "albedo" in t.model_fields_set:
        return Diffuse(t.albedo)
    if "texture" in t.model_fields_set:
        return Diffuse(textures[t.texture])
    return materials[t.material]


def _placed(t: schema.Rectangle | schema.Box) -> tuple[str, Affine]:
    """The key of a shape's placement (``to_world`` or ``transform``) and its 3 x 4 matrix;
    a transform is composed as Mitsuba does (T * R * S)."""
    if t.to_world is not None:
        return "to_world", t.to_world
    r = t.transform.rotate
    rotate = (r.axis, r.degrees) if r is not None else None
    return "transform", affine(t.transform.translate, rotate, t.transform.scale)


def _check_edges(u: np.ndarray, v: np.ndarray, at: str) -> None:
    """Refuse half edges shorter than :data:`MIN_LENGTH` or (nearly) parallel: no area."""
    lu, lv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    if min(lu, lv) < MIN_LENGTH or np.linalg.norm(np.cross(u, v)) < MIN_LENGTH * lu * lv:
        raise SceneFileError(
            f"{at}: expected half edges u, v longer than {MIN_LENGTH} and not parallel "
            f"(a rectangle with an area), got u = {tuple(u)}, v = {tuple(v)}"
        )


def _rectangle(t: schema.Rectangle, at: str, material: Diffuse) -> Rectangle:
    if t.center is not None:
        _check_edges(np.asarray(t.u), np.asarray(t.v), at)
        return Rectangle(t.name, t.center, t.u, t.v, material, t.emission)
    key, placed = _placed(t)
    m = np.asarray(placed)
    _check_edges(m[:, 0], m[:, 1], at)
    if np.linalg.det(m[:, :3]) <= 0:
        raise SceneFileError(
            f"{at}.{key}: expected a linear part with determinant > 0 (front side u x v), got "
            f"{np.linalg.det(m[:, :3])}"
        )
    return Rectangle.from_transform(t.name, m.tolist(), material, t.emission)


def _box(t: schema.Box, at: str, material: Diffuse) -> Box:
    key, m = _placed(t)
    linear = np.asarray(m)[:, :3]
    norms = np.linalg.norm(linear, axis=0)
    if norms.min() < MIN_LENGTH or abs(np.linalg.det(linear)) < MIN_LENGTH * norms.prod():
        raise SceneFileError(
            f"{at}.{key}: expected an invertible linear part with columns longer than "
            f"{MIN_LENGTH} (a box with a volume), got {linear.tolist()}"
        )
    return Box(t.name, m, material)


def _shape(t: Any, at: str, textures: Mapping, materials: Mapping) -> Sphere | Rectangle | Box:
    material = _material(t, textures, materials)
    if isinstance(t, schema.Sphere):
        return Sphere(t.name, _built(t.center), t.radius, material)
    if isinstance(t, schema.Rectangle):
        return _rectangle(t, at, material)
    return _box(t, at, material)


def scene_from_dict(document: object, default_name: str = "scene") -> Scene:
    """The :class:`Scene` a parsed scene file describes (the schema of ``docs/SCENE_FILES.md``).

    Args:
        document: the parsed TOML or JSON (a dict of lists, dicts, strings and numbers).
        default_name: the scene's name when the document has no ``name``.

    Raises:
        SceneFileError: the document breaks the schema; the message names the key.
    """
    doc = validate(schema.SceneDocument, document, SceneFileError, "scene")
    name = doc.name or validate(_NAME, default_name, SceneFileError, _STEM)
    textures = {key: _built(t) for key, t in doc.textures.items()}
    materials = {key: _material(m, textures, {}) for key, m in doc.materials.items()}
    try:
        scene = Scene(
            name=name,
            description=doc.description,
            camera=_camera(doc.camera),
            shapes=tuple(
                _shape(s, f"shapes[{i}]", textures, materials) for i, s in enumerate(doc.shapes)
            ),
            max_depth=doc.max_depth,
            medium=HomogeneousMedium(**dict(doc.medium)) if doc.medium is not None else None,
        )
    except SceneFileError:
        raise
    except BnerrError as err:  # a check of renderers.scene that the ones above did not foresee
        raise SceneFileError(str(err)) from err
    return scene if doc.animated else scene.static()


# --------------------------------------------------------------------------------------------
# Files and text


def loads_scene(
    data: bytes | str, format: str = "toml", source: str = "<scene>", default_name: str = "scene"
) -> Scene:
    """The :class:`Scene` of a scene file's text (``format`` ``"toml"`` or ``"json"``).

    Raises:
        SceneFileError: the text is not valid TOML / JSON (the message names the line) or breaks
            the schema (the message names the key); every message starts with ``source``.
    """
    if format not in ("toml", "json"):
        raise SceneFileError(f"{source}: expected format toml or json, got {format!r}")
    if not isinstance(data, (bytes, str)):
        raise DtypeError(f"{source}: expected bytes or str, got {type(data).__name__}")
    document = parse(data, format, source, SceneFileError, MAX_FILE_BYTES)
    try:
        return scene_from_dict(document, default_name)
    except SceneFileError as err:
        raise SceneFileError(f"{source}: {err}") from None


def load_scene_file(path: str | os.PathLike) -> Callable[[], Scene]:
    """The builder of the scene in the file ``path`` (``.toml`` or ``.json``).

    The file is read and checked now, so a bad file fails here, not at the first render; the
    builder returns that (immutable) scene, animated: ``scene.static()`` is its static variant,
    as for :data:`renderers.catalog.SCENES`' builders. A file without ``name`` takes its stem.

    Raises:
        DtypeError: ``path`` is not a str or path.
        SceneFileError: the suffix is neither ``.toml`` nor ``.json``; the file is missing,
            unreadable, not a regular file or over :data:`MAX_FILE_BYTES`; or its content is
            not a valid scene (:func:`loads_scene`).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise DtypeError(f"path: expected a str or os.PathLike, got {type(path).__name__}")
    path = Path(path)
    fmt = format_of(path, SceneFileError)
    scene = loads_scene(read(path, SceneFileError, MAX_FILE_BYTES), fmt, str(path), path.stem)

    def build() -> Scene:
        return scene

    build.__doc__ = scene.description
    build.__name__ = build.__qualname__ = scene.name
    return build


def load_camera_path(path: str | os.PathLike) -> tuple[Motion, Motion, Vec3]:
    """``(origin, target, up)`` of a camera path file: a TOML file whose keys ``origin`` and
    ``target`` are motions and ``up`` a vector, as in a scene file's ``[camera]`` (without the
    optics): the sidecar ``scene.camera.toml`` of a Mitsuba XML scene
    (:mod:`renderers.mitsuba_scene`). Checked like a scene file's camera.

    Raises:
        SceneFileError: the file is missing, unreadable or too large; not TOML; an unknown or
            missing key, a bad value, or a pose that degenerates within
            :data:`CAMERA_CHECK_FRAMES` frames.
    """
    path = Path(path)
    data = read(path, SceneFileError, MAX_FILE_BYTES)
    document = parse(data, "toml", str(path), SceneFileError)
    try:
        c = validate(camera_schema.CameraPath, document, SceneFileError, "camera path")
        origin, target = _built(c.origin), _built(c.target)
        _check_pose(origin, target, c.up)
    except SceneFileError as err:
        raise SceneFileError(f"{path}: {err}") from None
    return origin, target, c.up


# --------------------------------------------------------------------------------------------
# Writing


def _floats(values: Iterable[float]) -> list[float]:
    return [float(v) for v in values]


def _fields(obj: Any, kind: str | None = None) -> dict:
    """A dataclass of :mod:`renderers.scene` (a motion, a texture, the medium) as a table, with
    ``type = kind`` first where given: its int fields as ints, its other numbers as floats."""
    out: dict = {} if kind is None else {"type": kind}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        out[f.name] = {"int": int, "float": float}.get(str(f.type), _floats)(value)
    return out


def _motion_dict(motion: Motion) -> list[float] | dict:
    if isinstance(motion, Fixed):
        return _floats(motion.value)
    return _fields(motion, type(motion).__name__.lower())


def _shape_dict(shape: Sphere | Rectangle | Box, texture_name: str | None) -> dict:
    out: dict = {"type": type(shape).__name__.lower(), "name": shape.name}
    if isinstance(shape, Sphere):
        out.update(center=_motion_dict(shape.center), radius=float(shape.radius))
    elif isinstance(shape, Rectangle):
        out.update(center=_floats(shape.center), u=_floats(shape.u), v=_floats(shape.v))
    else:
        out["to_world"] = [_floats(row) for row in shape.to_world]
    if texture_name is None:
        out["albedo"] = _floats(cast(Vec3, shape.material.albedo))
    else:
        out["texture"] = texture_name
    if isinstance(shape, Rectangle) and shape.emission is not None:
        out["emission"] = _floats(shape.emission)
    return out


def scene_dict(scene: Scene) -> dict:
    """``scene`` as the document of a scene file (textures named after their first shape)."""
    if not isinstance(scene, Scene):
        raise DtypeError(f"scene: expected a renderers Scene, got {type(scene).__name__}")
    camera = scene.camera
    out: dict = {"format": FORMAT_VERSION, "name": scene.name, "description": scene.description}
    out["max_depth"] = int(scene.max_depth)
    if not scene.animated:
        out["animated"] = False
    out["camera"] = {
        "origin": _motion_dict(camera.origin),
        "target": _motion_dict(camera.target),
        "up": _floats(camera.up),
        "fov": float(camera.fov),
        "fov_axis": camera.fov_axis,
    }
    textures: dict[str, dict] = {}
    shapes = []
    for shape in scene.shapes:
        name = None
        if shape.material.textured:
            texture = cast(Texture, shape.material.albedo)
            tex = _fields(texture, type(texture).__name__.lower())
            name = next((k for k, v in textures.items() if v == tex), None)
            if name is None:
                name = shape.name if shape.name not in textures else f"{shape.name}-{len(textures)}"
                textures[name] = tex
        shapes.append(_shape_dict(shape, name))
    if textures:
        out["textures"] = textures
    if scene.medium is not None:
        out["medium"] = _fields(scene.medium)
    out["shapes"] = shapes
    return out


_HEADER = (
    "# A bnerr scene (docs/SCENE_FILES.md lists every key, its unit and default).\n"
    "# Written by renderers.scene_file.dump_scene; render: bnerr render --scene <this file>.\n"
)


def dump_scene(scene: Scene, format: str = "toml") -> str:
    """``scene`` as the text of a scene file (``format`` ``"toml"`` or ``"json"``).

    Every float is written in Python's shortest round-trip form, so :func:`loads_scene` of the
    text gives a scene equal to ``scene``, field for field.

    Raises:
        DtypeError: ``scene`` is not a Scene.
        SceneFileError: ``format`` is neither, or the scene breaks a rule of the format (a name
            with a space, more than :data:`MAX_SHAPES` shapes, ...): it is checked by reading the
            document back before any text is returned.
    """
    if format not in ("toml", "json"):
        raise SceneFileError(f"format: expected toml or json, got {format!r}")
    document = scene_dict(scene)
    try:
        scene_from_dict(document)
    except SceneFileError as err:
        raise SceneFileError(
            f"scene {scene.name!r} cannot be written as a scene file: {err}"
        ) from None
    if format == "json":
        return json.dumps(document, indent=2, ensure_ascii=False) + "\n"
    return _HEADER + dump_toml(document)


def write_scene_file(scene: Scene, path: str | os.PathLike) -> Path:
    """Write :func:`dump_scene` of ``scene`` to ``path`` atomically (format from the suffix).

    Raises:
        SceneFileError: the suffix is neither ``.toml`` nor ``.json`` (or see :func:`dump_scene`).
    """
    path = Path(path)
    text = dump_scene(scene, format_of(path, SceneFileError))
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path
