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
import math
import os
import re
import stat
import tomllib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np

from bnerr.errors import BnerrError, DtypeError, SceneFileError, toml_reason
from bnerr.io import atomic_write
from renderers.scene import (
    FOV_AXES,
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

#: The version this module reads and writes (top-level key ``format``).
FORMAT_VERSION = 1
#: Largest scene file read, in bytes (checked before parsing).
MAX_FILE_BYTES = 1 << 20
#: Most shapes in one scene: the tracer tests every ray against every primitive.
MAX_SHAPES = 256
#: Most cells in all textures of a scene together (12 bytes of float32 albedo each).
MAX_TEXTURE_CELLS = 1 << 22
#: Largest ``max_depth`` (D grows by 5 per vertex; the medium scene's 9 makes D = 40).
MAX_DEPTH = 64
#: Largest magnitude of any number in a scene file: keeps every packed float32 finite.
MAX_COORDINATE = 1e6
#: Shortest length (radius, half edge, transform column) and smallest sine between two edges.
MIN_LENGTH = 1e-6
#: Frames over which the camera must keep a valid pose (origin != target, up not parallel).
CAMERA_CHECK_FRAMES = 1024

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
#: Keys of the Mitsuba dictionary (renderers.mitsuba) that a shape's name must not take.
_RESERVED_NAMES = frozenset({"type", "integrator", "sensor", "medium-box"})
_MAX_DESCRIPTION = 1000
_SUFFIXES = {".toml": "toml", ".json": "json"}
_STEM = "name (none given, so the file's name without suffix)"

_TOP_KEYS = ("format", "name", "description", "max_depth", "animated", "camera")
_TOP_TABLES = ("textures", "materials", "medium", "shapes")
_MATERIAL_KEYS = ("albedo", "texture", "material")
_SHAPE_KEYS = {
    "sphere": ("type", "name", "center", "radius", *_MATERIAL_KEYS),
    "rectangle": (
        "type",
        "name",
        "center",
        "u",
        "v",
        "to_world",
        "transform",
        *_MATERIAL_KEYS,
        "emission",
    ),
    "box": ("type", "name", "to_world", "transform", *_MATERIAL_KEYS),
}
_MOTION_KEYS = {
    "fixed": ("type", "value"),
    "linear": ("type", "start", "velocity"),
    "orbit": ("type", "center", "radius", "height", "angle", "step"),
}
_TEXTURE_KEYS = {
    "checker": ("type", "color0", "color1", "cells_u", "cells_v"),
    "felt": ("type", "base", "cells_u", "cells_v", "grain", "nap", "bands", "seed"),
}


# --------------------------------------------------------------------------------------------
# Reading values: every reader takes the key path ``at`` for its error message


class _Missing:
    """Marks a key without default (required)."""


_REQUIRED = _Missing()


def _describe(value: object) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def _fail(at: str, expected: str, value: object) -> SceneFileError:
    return SceneFileError(f"{at}: expected {expected}, got {_describe(value)}")


def _table(value: object, at: str, known: tuple[str, ...]) -> dict:
    """``value`` as a table whose keys are all in ``known``."""
    if not isinstance(value, dict):
        raise _fail(at, "a table", value)
    unknown = [k for k in value if k not in known]
    if unknown:
        raise SceneFileError(
            f"{at}: unknown key {unknown[0]!r}, expected one of {', '.join(known)}"
        )
    return value


def _get(table: dict, key: str, at: str, default: object) -> object:
    if key in table:
        return table[key]
    if default is _REQUIRED:
        raise SceneFileError(f"{at}: expected key {key!r}, got none")
    return default


def _number(
    value: object, at: str, lo: float = -MAX_COORDINATE, hi: float = MAX_COORDINATE
) -> float:
    """A finite int or float in [lo, hi], as a float (bools are refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(at, "a number", value)
    if isinstance(value, int) and abs(value) > 2 * MAX_COORDINATE:
        raise _fail(at, f"a number in [{lo}, {hi}]", value)
    x = float(value)
    if not math.isfinite(x) or not lo <= x <= hi:
        raise _fail(at, f"a finite number in [{lo}, {hi}]", value)
    return x


def _integer(value: object, at: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(at, "an integer", value)
    if not lo <= value <= hi:
        raise _fail(at, f"an integer in [{lo}, {hi}]", value)
    return value


def _vector(
    value: object, at: str, n: int = 3, lo: float = -MAX_COORDINATE, hi: float = MAX_COORDINATE
) -> Any:
    """A list of ``n`` numbers in [lo, hi], as a tuple of floats."""
    if not isinstance(value, list) or len(value) != n:
        raise _fail(at, f"an array of {n} numbers", value)
    return tuple(_number(v, f"{at}[{i}]", lo, hi) for i, v in enumerate(value))


def _color(value: object, at: str) -> tuple[float, float, float]:
    return _vector(value, at, 3, 0.0, 1.0)


def _name(value: object, at: str) -> str:
    if not isinstance(value, str) or not _NAME.fullmatch(value):
        raise _fail(at, "a name of 1 to 64 letters, digits, '_' or '-' (not first)", value)
    return value


def _string(value: object, at: str) -> str:
    if not isinstance(value, str) or len(value) > _MAX_DESCRIPTION or not value.isprintable():
        raise _fail(at, f"a printable string of at most {_MAX_DESCRIPTION} characters", value)
    return value


def _kind(table: object, at: str, kinds: Mapping[str, tuple[str, ...]]) -> tuple[str, dict]:
    """The ``type`` of a table and the table checked against that type's keys."""
    if not isinstance(table, dict):
        raise _fail(at, "a table", table)
    kind = table.get("type", _REQUIRED)
    if kind is _REQUIRED:
        raise SceneFileError(f"{at}: expected key 'type' (one of {', '.join(kinds)}), got none")
    if not isinstance(kind, str) or kind not in kinds:
        raise _fail(f"{at}.type", f"one of {', '.join(kinds)}", kind)
    return kind, _table(table, at, kinds[kind])


# --------------------------------------------------------------------------------------------
# Reading the parts of a scene


def _motion(value: object, at: str) -> Motion:
    """``[x, y, z]`` (fixed) or a table of type fixed, linear or orbit."""
    if isinstance(value, list):
        return Fixed(_vector(value, at))
    kind, t = _kind(value, at, _MOTION_KEYS)
    if kind == "fixed":
        return Fixed(_vector(_get(t, "value", at, _REQUIRED), f"{at}.value"))
    if kind == "linear":
        start = _vector(_get(t, "start", at, _REQUIRED), f"{at}.start")
        velocity = _vector(_get(t, "velocity", at, [0.0, 0.0, 0.0]), f"{at}.velocity")
        return Linear(start, velocity)
    return Orbit(
        _vector(_get(t, "center", at, [0.0, 0.0, 0.0]), f"{at}.center"),
        _number(_get(t, "radius", at, _REQUIRED), f"{at}.radius", 0.0),
        _number(_get(t, "height", at, 0.0), f"{at}.height"),
        _number(_get(t, "angle", at, 0.0), f"{at}.angle"),
        _number(_get(t, "step", at, 0.0), f"{at}.step"),
    )


def _camera(value: object) -> Camera:
    t = _table(value, "camera", ("origin", "target", "up", "fov", "fov_axis"))
    fov_axis = _get(t, "fov_axis", "camera", "x")
    if fov_axis not in FOV_AXES:
        raise _fail("camera.fov_axis", f"one of {', '.join(FOV_AXES)}", fov_axis)
    camera = Camera(
        _motion(_get(t, "origin", "camera", _REQUIRED), "camera.origin"),
        _motion(_get(t, "target", "camera", _REQUIRED), "camera.target"),
        _vector(_get(t, "up", "camera", [0.0, 1.0, 0.0]), "camera.up"),
        _number(_get(t, "fov", "camera", _REQUIRED), "camera.fov", 1e-3, 179.0),
        fov_axis,
    )
    _check_pose(camera.origin, camera.target, camera.up)
    return camera


def _check_pose(origin_motion: Motion, target_motion: Motion, up_vector: Vec3) -> None:
    """Refuse a camera whose pose degenerates in the first :data:`CAMERA_CHECK_FRAMES` frames:
    origin on the target, or up parallel to the viewing direction (no image plane)."""
    up = np.asarray(up_vector)
    if np.linalg.norm(up) < MIN_LENGTH:
        raise _fail("camera.up", f"a vector longer than {MIN_LENGTH}", list(up_vector))
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


def _texture(value: object, at: str) -> Checker | Felt:
    kind, t = _kind(value, at, _TEXTURE_KEYS)
    cells = 1 << 16
    cells_u = _integer(_get(t, "cells_u", at, _REQUIRED), f"{at}.cells_u", 1, cells)
    cells_v = _integer(_get(t, "cells_v", at, _REQUIRED), f"{at}.cells_v", 1, cells)
    if kind == "checker":
        color0 = _color(_get(t, "color0", at, _REQUIRED), f"{at}.color0")
        return Checker(
            color0, _color(_get(t, "color1", at, _REQUIRED), f"{at}.color1"), cells_u, cells_v
        )
    return Felt(
        _color(_get(t, "base", at, _REQUIRED), f"{at}.base"),
        cells_u,
        cells_v,
        _number(_get(t, "grain", at, 0.25), f"{at}.grain"),
        _number(_get(t, "nap", at, 0.1), f"{at}.nap"),
        _integer(_get(t, "bands", at, 6), f"{at}.bands", -cells, cells),
        _integer(_get(t, "seed", at, 0), f"{at}.seed", 0, (1 << 32) - 1),
    )


def _textures(value: object) -> dict[str, Checker | Felt]:
    if not isinstance(value, dict):
        raise _fail("textures", "a table of named textures", value)
    out, cells = {}, 0
    for key, table in value.items():
        at = f"textures.{_name(key, 'textures (a texture name)')}"
        texture = _texture(table, at)
        cells += texture.cells_u * texture.cells_v
        if cells > MAX_TEXTURE_CELLS:
            raise SceneFileError(
                f"{at}: expected at most {MAX_TEXTURE_CELLS} texture cells in all, got {cells}"
            )
        out[key] = texture
    return out


def _material(t: dict, at: str, textures: Mapping, materials: Mapping, textured: bool) -> Diffuse:
    """The material of a shape or of a ``[materials.name]`` table: exactly one of ``albedo``
    (RGB), ``texture`` (a texture's name; rectangles only) or ``material`` (a material's name)."""
    given = [k for k in _MATERIAL_KEYS if k in t]
    if len(given) != 1:
        raise SceneFileError(
            f"{at}: expected exactly one of {', '.join(_MATERIAL_KEYS)}, got "
            f"{', '.join(given) or 'none'}"
        )
    key = given[0]
    if key == "albedo":
        return Diffuse(_color(t[key], f"{at}.albedo"))
    known = textures if key == "texture" else materials
    if not isinstance(t[key], str) or t[key] not in known:
        raise _fail(
            f"{at}.{key}", f"the name of a {key} ({', '.join(known) or 'none defined'})", t[key]
        )
    if key == "texture":
        if not textured:
            raise SceneFileError(f"{at}.texture: expected textures on rectangles only, got one")
        return Diffuse(textures[t[key]])
    material = materials[t[key]]
    if material.textured and not textured:
        raise SceneFileError(f"{at}.material: expected an untextured material, got {t[key]!r}")
    return material


def _materials(value: object, textures: Mapping) -> dict[str, Diffuse]:
    if not isinstance(value, dict):
        raise _fail("materials", "a table of named materials", value)
    out: dict[str, Diffuse] = {}
    for key, table in value.items():
        at = f"materials.{_name(key, 'materials (a material name)')}"
        t = _table(table, at, ("albedo", "texture"))
        out[key] = _material(t, at, textures, {}, True)
    return out


def _matrix(value: object, at: str) -> Affine:
    """A 3 x 4 affine matrix: three rows of four numbers (linear part | translation)."""
    if not isinstance(value, list) or len(value) != 3:
        raise _fail(at, "3 rows of 4 numbers", value)
    return tuple(_vector(row, f"{at}[{i}]", 4) for i, row in enumerate(value))


def _transform(value: object, at: str) -> Affine:
    """``{translate, rotate = {axis, degrees}, scale}``, composed as Mitsuba does (T * R * S)."""
    t = _table(value, at, ("translate", "rotate", "scale"))
    translate = _vector(_get(t, "translate", at, [0.0, 0.0, 0.0]), f"{at}.translate")
    rotate = None
    if "rotate" in t:
        r = _table(t["rotate"], f"{at}.rotate", ("axis", "degrees"))
        axis = _vector(_get(r, "axis", f"{at}.rotate", _REQUIRED), f"{at}.rotate.axis")
        if np.linalg.norm(axis) < MIN_LENGTH:
            raise _fail(f"{at}.rotate.axis", f"a vector longer than {MIN_LENGTH}", list(axis))
        rotate = (
            axis,
            _number(_get(r, "degrees", f"{at}.rotate", _REQUIRED), f"{at}.rotate.degrees"),
        )
    scale = _get(t, "scale", at, 1.0)
    factors = (
        _vector(scale, f"{at}.scale") if isinstance(scale, list) else _number(scale, f"{at}.scale")
    )
    return affine(translate, rotate, factors)


def _placed(t: dict, key: str, at: str) -> Affine:
    """The 3 x 4 matrix of a shape's ``to_world`` or ``transform`` (``key``)."""
    reader = _matrix if key == "to_world" else _transform
    return reader(t[key], f"{at}.{key}")


def _check_edges(u: np.ndarray, v: np.ndarray, at: str) -> None:
    """Refuse half edges shorter than :data:`MIN_LENGTH` or (nearly) parallel: no area."""
    lu, lv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    if min(lu, lv) < MIN_LENGTH or np.linalg.norm(np.cross(u, v)) < MIN_LENGTH * lu * lv:
        raise SceneFileError(
            f"{at}: expected half edges u, v longer than {MIN_LENGTH} and not parallel "
            f"(a rectangle with an area), got u = {tuple(u)}, v = {tuple(v)}"
        )


def _placement(t: dict, at: str, keys: tuple[str, ...]) -> str:
    """Which of the mutually exclusive placements ``keys`` the shape table ``t`` uses."""
    given = [k for k in keys if k in t]
    if len(given) != 1:
        raise SceneFileError(
            f"{at}: expected exactly one of {', '.join(keys)}, got {', '.join(given) or 'none'}"
        )
    return given[0]


def _rectangle(t: dict, at: str, name: str, material: Diffuse) -> Rectangle:
    emission = None
    if "emission" in t:
        emission = _vector(t["emission"], f"{at}.emission", 3, 0.0)
        if max(emission) <= 0:
            raise _fail(f"{at}.emission", "a radiance above 0 (leave emission out)", t["emission"])
    if _placement(t, at, ("center", "to_world", "transform")) == "center":
        missing = [k for k in ("u", "v") if k not in t]
        if missing:
            raise SceneFileError(f"{at}: expected key {missing[0]!r} with center, got none")
        center, u, v = (_vector(t[k], f"{at}.{k}") for k in ("center", "u", "v"))
        _check_edges(np.asarray(u), np.asarray(v), at)
        return Rectangle(name, center, u, v, material, emission)
    for k in ("u", "v"):
        if k in t:
            raise SceneFileError(f"{at}: expected {k} only with center, got it with a transform")
    key = "to_world" if "to_world" in t else "transform"
    m = np.asarray(_placed(t, key, at))
    _check_edges(m[:, 0], m[:, 1], at)
    if np.linalg.det(m[:, :3]) <= 0:
        raise SceneFileError(
            f"{at}.{key}: expected a linear part with determinant > 0 (front side u x v), got "
            f"{np.linalg.det(m[:, :3])}"
        )
    return Rectangle.from_transform(name, m.tolist(), material, emission)


def _box(t: dict, at: str, name: str, material: Diffuse) -> Box:
    key = _placement(t, at, ("to_world", "transform"))
    m = _placed(t, key, at)
    linear = np.asarray(m)[:, :3]
    norms = np.linalg.norm(linear, axis=0)
    if norms.min() < MIN_LENGTH or abs(np.linalg.det(linear)) < MIN_LENGTH * norms.prod():
        raise SceneFileError(
            f"{at}.{key}: expected an invertible linear part with columns longer than "
            f"{MIN_LENGTH} (a box with a volume), got {linear.tolist()}"
        )
    return Box(name, m, material)


def _shape(
    value: object, at: str, textures: Mapping, materials: Mapping
) -> Sphere | Rectangle | Box:
    kind, t = _kind(value, at, _SHAPE_KEYS)
    name = _name(_get(t, "name", at, _REQUIRED), f"{at}.name")
    if name in _RESERVED_NAMES:
        raise _fail(f"{at}.name", f"a name other than {', '.join(sorted(_RESERVED_NAMES))}", name)
    material = _material(t, at, textures, materials, kind == "rectangle")
    if kind == "sphere":
        center = _motion(_get(t, "center", at, _REQUIRED), f"{at}.center")
        radius = _number(_get(t, "radius", at, _REQUIRED), f"{at}.radius", MIN_LENGTH)
        return Sphere(name, center, radius, material)
    if kind == "rectangle":
        return _rectangle(t, at, name, material)
    return _box(t, at, name, material)


def _shapes(value: object, textures: Mapping, materials: Mapping) -> tuple:
    if not isinstance(value, list) or not value:
        raise _fail("shapes", "a non-empty array of tables ([[shapes]])", value)
    if len(value) > MAX_SHAPES:
        raise SceneFileError(f"shapes: expected at most {MAX_SHAPES} shapes, got {len(value)}")
    shapes, names = [], set()
    for i, table in enumerate(value):
        shape = _shape(table, f"shapes[{i}]", textures, materials)
        if shape.name in names:
            raise _fail(f"shapes[{i}].name", "a name no other shape has", shape.name)
        names.add(shape.name)
        shapes.append(shape)
    if not any(isinstance(s, Rectangle) and s.emission is not None for s in shapes):
        raise SceneFileError("shapes: expected at least one rectangle with emission, got none")
    return tuple(shapes)


def _medium(value: object) -> HomogeneousMedium:
    t = _table(value, "medium", ("bounds_min", "bounds_max", "sigma_t", "albedo"))
    lo = _vector(_get(t, "bounds_min", "medium", _REQUIRED), "medium.bounds_min")
    hi = _vector(_get(t, "bounds_max", "medium", _REQUIRED), "medium.bounds_max")
    if not all(b - a >= MIN_LENGTH for a, b in zip(lo, hi)):
        raise SceneFileError(
            f"medium: expected bounds_min < bounds_max on every axis, got {lo} and {hi}"
        )
    sigma_t = _number(_get(t, "sigma_t", "medium", _REQUIRED), "medium.sigma_t", MIN_LENGTH)
    albedo = _color(_get(t, "albedo", "medium", _REQUIRED), "medium.albedo")
    return HomogeneousMedium(lo, hi, sigma_t, albedo)


def scene_from_dict(document: object, default_name: str = "scene") -> Scene:
    """The :class:`Scene` a parsed scene file describes (the schema of ``docs/SCENE_FILES.md``).

    Args:
        document: the parsed TOML or JSON (a dict of lists, dicts, strings and numbers).
        default_name: the scene's name when the document has no ``name``.

    Raises:
        SceneFileError: the document breaks the schema; the message names the key.
    """
    top = _table(document, "scene", _TOP_KEYS + _TOP_TABLES)
    _integer(_get(top, "format", "scene", FORMAT_VERSION), "format", 1, FORMAT_VERSION)
    max_depth = _integer(_get(top, "max_depth", "scene", _REQUIRED), "max_depth", 2, MAX_DEPTH)
    animated = _get(top, "animated", "scene", True)
    if not isinstance(animated, bool):
        raise _fail("animated", "true or false", animated)
    textures = _textures(top.get("textures", {}))
    materials = _materials(top.get("materials", {}), textures)
    try:
        scene = Scene(
            name=_name(top.get("name", default_name), "name" if "name" in top else _STEM),
            description=_string(_get(top, "description", "scene", ""), "description"),
            camera=_camera(_get(top, "camera", "scene", _REQUIRED)),
            shapes=_shapes(_get(top, "shapes", "scene", _REQUIRED), textures, materials),
            max_depth=max_depth,
            medium=_medium(top["medium"]) if "medium" in top else None,
        )
    except SceneFileError:
        raise
    except BnerrError as err:  # a check of renderers.scene that the ones above did not foresee
        raise SceneFileError(str(err)) from err
    return scene if animated else scene.static()


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
        t = _table(document, "camera path", ("origin", "target", "up"))
        origin = _motion(_get(t, "origin", "camera path", _REQUIRED), "origin")
        target = _motion(_get(t, "target", "camera path", _REQUIRED), "target")
        up = _vector(_get(t, "up", "camera path", [0.0, 1.0, 0.0]), "up")
        _check_pose(origin, target, up)
    except SceneFileError as err:
        raise SceneFileError(f"{path}: {err}") from None
    return origin, target, up


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
    return key if _NAME.fullmatch(key) else json.dumps(key, ensure_ascii=False)


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
