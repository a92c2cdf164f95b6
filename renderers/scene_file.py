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

Not for: meshes, materials other than Lambertian, or anything :mod:`renderers.scene` cannot
describe; Mitsuba XML scenes (:mod:`renderers.mitsuba_render` renders those).
"""

from __future__ import annotations

import json
import os
import stat
import tomllib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np
from pydantic import TypeAdapter

from bnerr.errors import BnerrError, DtypeError, SceneFileError, toml_reason
from bnerr.io import atomic_write
from bnerr.schemas import camera as camera_schema
from bnerr.schemas import scene as schema
from bnerr.schemas.errors import validate
from bnerr.schemas.fields import NAME_PATTERN
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

_SUFFIXES = {".toml": "toml", ".json": "json"}
_STEM = "name (none given, so the file's name without suffix)"
_NAME: TypeAdapter[str] = TypeAdapter(schema.Name)


# --------------------------------------------------------------------------------------------
# Building the scene of a checked document (bnerr.schemas.scene checked everything but geometry)


def _motion(motion: object) -> Motion:
    """The motion of a bare ``[x, y, z]`` or a fixed, linear or orbit table."""
    if isinstance(motion, tuple):
        return Fixed(motion)
    if isinstance(motion, schema.FixedMotion):
        return Fixed(motion.value)
    if isinstance(motion, schema.LinearMotion):
        return Linear(motion.start, motion.velocity)
    assert isinstance(motion, schema.OrbitMotion)
    return Orbit(motion.center, motion.radius, motion.height, motion.angle, motion.step)


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
    camera = Camera(_motion(c.origin), _motion(c.target), c.up, c.fov, c.fov_axis)
    _check_pose(camera.origin, camera.target, camera.up)
    return camera


def _texture(t: schema.Checker | schema.Felt) -> Checker | Felt:
    if isinstance(t, schema.Checker):
        return Checker(t.color0, t.color1, t.cells_u, t.cells_v)
    return Felt(t.base, t.cells_u, t.cells_v, t.grain, t.nap, t.bands, t.seed)


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
        return Sphere(t.name, _motion(t.center), t.radius, material)
    if isinstance(t, schema.Rectangle):
        return _rectangle(t, at, material)
    return _box(t, at, material)


def _medium(m: schema.Medium | None) -> HomogeneousMedium | None:
    if m is None:
        return None
    return HomogeneousMedium(m.bounds_min, m.bounds_max, m.sigma_t, m.albedo)


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
    textures = {key: _texture(t) for key, t in doc.textures.items()}
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
            medium=_medium(doc.medium),
        )
    except SceneFileError:
        raise
    except BnerrError as err:  # a check of renderers.scene that the ones above did not foresee
        raise SceneFileError(str(err)) from err
    return scene if doc.animated else scene.static()


# --------------------------------------------------------------------------------------------
# Files and text


def _no_duplicates(pairs: list[tuple[str, object]]) -> dict:
    """JSON object hook: a key given twice is an error (TOML refuses it too)."""
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"key {key!r} given twice")
        out[key] = value
    return out


def _parse(data: bytes | str, fmt: str, source: str) -> object:
    """The document of a TOML or JSON text; syntax errors name the line."""
    if isinstance(data, str):
        data = data.encode("utf-8", "surrogatepass")
    if len(data) > MAX_FILE_BYTES:
        raise SceneFileError(f"{source}: expected at most {MAX_FILE_BYTES} bytes, got {len(data)}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        raise SceneFileError(
            f"{source}: line {line}: expected UTF-8 text, got byte {data[err.start]:#04x}"
        ) from None
    try:
        if fmt == "toml":
            return tomllib.loads(text)
        return json.loads(text, object_pairs_hook=_no_duplicates)
    except json.JSONDecodeError as err:
        raise SceneFileError(
            f"{source}: line {err.lineno}, column {err.colno}: expected JSON, got {err.msg}"
        ) from None
    except tomllib.TOMLDecodeError as err:
        raise SceneFileError(f"{source}: expected TOML, got {toml_reason(err, text)}") from None
    except (ValueError, RecursionError) as err:  # a duplicate JSON key, 5000-digit integers, ...
        raise SceneFileError(f"{source}: expected a {fmt.upper()} document, got {err}") from None


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
    document = _parse(data, format, source)
    try:
        return scene_from_dict(document, default_name)
    except SceneFileError as err:
        raise SceneFileError(f"{source}: {err}") from None


def _read_limited(path: Path) -> bytes:
    """The bytes of the regular file ``path``, refused over :data:`MAX_FILE_BYTES` unread."""
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise SceneFileError(f"{path}: expected a regular file, got another kind of file")
        if info.st_size > MAX_FILE_BYTES:
            raise SceneFileError(
                f"{path}: expected at most {MAX_FILE_BYTES} bytes, got {info.st_size}"
            )
        with path.open("rb") as f:
            data = f.read(MAX_FILE_BYTES + 1)  # the file may have grown since stat
    except OSError as err:
        if isinstance(err, BnerrError):
            raise
        raise SceneFileError(
            f"{path}: expected a readable file, got {err.strerror or err}"
        ) from None
    if len(data) > MAX_FILE_BYTES:
        raise SceneFileError(f"{path}: expected at most {MAX_FILE_BYTES} bytes, got more")
    return data


def _format_of(path: Path) -> str:
    """``"toml"`` or ``"json"``, from the suffix of ``path``."""
    fmt = _SUFFIXES.get(path.suffix.lower())
    if fmt is None:
        raise SceneFileError(f"{path}: expected a suffix .toml or .json, got {path.suffix!r}")
    return fmt


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
    fmt = _format_of(path)
    scene = loads_scene(_read_limited(path), fmt, str(path), path.stem)

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
    document = _parse(_read_limited(path), "toml", str(path))
    try:
        c = validate(camera_schema.CameraPath, document, SceneFileError, "camera path")
        origin, target = _motion(c.origin), _motion(c.target)
        _check_pose(origin, target, c.up)
    except SceneFileError as err:
        raise SceneFileError(f"{path}: {err}") from None
    return origin, target, c.up


# --------------------------------------------------------------------------------------------
# Writing


def _floats(values: Iterable[float]) -> list[float]:
    return [float(v) for v in values]


def _motion_dict(motion: Motion) -> list[float] | dict:
    if isinstance(motion, Fixed):
        return _floats(motion.value)
    if isinstance(motion, Linear):
        return {
            "type": "linear",
            "start": _floats(motion.start),
            "velocity": _floats(motion.velocity),
        }
    return {
        "type": "orbit",
        "center": _floats(motion.center),
        "radius": float(motion.radius),
        "height": float(motion.height),
        "angle": float(motion.angle),
        "step": float(motion.step),
    }


def _texture_dict(texture: Checker | Felt) -> dict:
    if isinstance(texture, Checker):
        colors = {"color0": _floats(texture.color0), "color1": _floats(texture.color1)}
        return {
            "type": "checker",
            **colors,
            "cells_u": int(texture.cells_u),
            "cells_v": int(texture.cells_v),
        }
    return {
        "type": "felt",
        "base": _floats(texture.base),
        "cells_u": int(texture.cells_u),
        "cells_v": int(texture.cells_v),
        "grain": float(texture.grain),
        "nap": float(texture.nap),
        "bands": int(texture.bands),
        "seed": int(texture.seed),
    }


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
            tex = _texture_dict(cast(Texture, shape.material.albedo))
            name = next((k for k, v in textures.items() if v == tex), None)
            if name is None:
                name = shape.name if shape.name not in textures else f"{shape.name}-{len(textures)}"
                textures[name] = tex
        shapes.append(_shape_dict(shape, name))
    if textures:
        out["textures"] = textures
    if scene.medium is not None:
        m = scene.medium
        out["medium"] = {
            "bounds_min": _floats(m.bounds_min),
            "bounds_max": _floats(m.bounds_max),
            "sigma_t": float(m.sigma_t),
            "albedo": _floats(m.albedo),
        }
    out["shapes"] = shapes
    return out


def _toml_key(key: str) -> str:
    return key if NAME_PATTERN.fullmatch(key) else json.dumps(key, ensure_ascii=False)


def _toml_value(value: object) -> str:
    """One TOML value; tables inline. Floats in Python's shortest round-trip form."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    items = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in cast(dict, value).items())
    return "{ " + items + " }"


def _toml_table(path: str, table: dict, lines: list[str]) -> None:
    """``[path]`` with its plain values, then its sub-tables as ``[path.key]`` sections."""
    if path and (not table or not all(_section(v) for v in table.values())):
        lines += ["", f"[{path}]"]  # TOML implies a header that holds only sub-tables
    lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in table.items() if not _section(v)]
    for k, v in table.items():
        if isinstance(v, dict):
            _toml_table(f"{path}.{_toml_key(k)}" if path else _toml_key(k), v, lines)
    for k, v in table.items():
        if _section(v) and isinstance(v, list):
            for item in v:
                lines += ["", f"[[{_toml_key(k)}]]"]
                lines += [f"{_toml_key(ik)} = {_toml_value(iv)}" for ik, iv in item.items()]


def _section(value: object) -> bool:
    """Whether ``value`` is written as its own section: a table or an array of tables."""
    return isinstance(value, dict) or (
        isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)
    )


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
    lines: list[str] = []
    _toml_table("", document, lines)
    return _HEADER + "\n".join(lines) + "\n"


def write_scene_file(scene: Scene, path: str | os.PathLike) -> Path:
    """Write :func:`dump_scene` of ``scene`` to ``path`` atomically (format from the suffix).

    Raises:
        SceneFileError: the suffix is neither ``.toml`` nor ``.json`` (or see :func:`dump_scene`).
    """
    path = Path(path)
    text = dump_scene(scene, _format_of(path))
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path
