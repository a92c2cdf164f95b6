"""The scene file's model (docs/SCENE_FILES.md): a TOML or JSON description of a scene for
bnerr's tracer, read by :mod:`renderers.scene_file`.

Everything a scene file can say without geometry is checked here: the keys of every table, the
type and range of every value (finite numbers within :data:`MAX_COORDINATE`, colors in [0, 1],
names), which keys go together (exactly one material, exactly one placement of a rectangle or a
box, ``u`` and ``v`` with ``center``), the names that tie shapes to ``[materials]`` and
``[textures]``, and the limits that keep a file from asking for too much (:data:`MAX_SHAPES`,
:data:`MAX_TEXTURE_CELLS`). What needs the scene's geometry (a camera that keeps a pose, a
rectangle with an area, a box with a volume) is checked where the scene is built.
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal

from pydantic import AfterValidator, BeforeValidator, Discriminator, Field, Tag, model_validator

from bnerr.schemas.fields import (
    NAME_PATTERN,
    Boolean,
    Check,
    Kinds,
    Table,
    array,
    choice,
    describe,
    expected,
    integer,
    number,
    problem,
    string,
)

__all__ = [
    "FORMAT_VERSION",
    "MATERIAL_KEYS",
    "MAX_COORDINATE",
    "MAX_DEPTH",
    "MAX_FILE_BYTES",
    "MAX_SHAPES",
    "MAX_TEXTURE_CELLS",
    "MIN_LENGTH",
    "RESERVED_NAMES",
    "Box",
    "Camera",
    "Checker",
    "Felt",
    "FixedMotion",
    "LinearMotion",
    "Medium",
    "OrbitMotion",
    "Rectangle",
    "SceneDocument",
    "ShapeName",
    "Sphere",
    "Transform",
]

#: The version this format is at (top-level key ``format``).
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
#: Keys of the Mitsuba dictionary (renderers.mitsuba) that a shape's name must not take.
RESERVED_NAMES = frozenset({"type", "integrator", "sensor", "medium-box"})
#: A shape's material: exactly one of these keys.
MATERIAL_KEYS = ("albedo", "texture", "material")
_MAX_DESCRIPTION = 1000
_MAX_CELLS = 1 << 16

Coordinate = Annotated[float, number(-MAX_COORDINATE, MAX_COORDINATE)]
Length = Annotated[float, number(MIN_LENGTH, MAX_COORDINATE)]
_3 = array(3, "an array of 3 numbers")
Vec3 = Annotated[tuple[Coordinate, Coordinate, Coordinate], _3]
_Unit = Annotated[float, number(0.0, 1.0)]
Color = Annotated[tuple[_Unit, _Unit, _Unit], _3]
_Positive = Annotated[float, number(0.0, MAX_COORDINATE)]
Radiance = Annotated[tuple[_Positive, _Positive, _Positive], _3]
_Row = Annotated[
    tuple[Coordinate, Coordinate, Coordinate, Coordinate], array(4, "an array of 4 numbers")
]
Matrix = Annotated[tuple[_Row, _Row, _Row], array(3, "3 rows of 4 numbers")]
Cells = Annotated[int, integer(1, _MAX_CELLS)]
Name = Annotated[
    str, string("a name of 1 to 64 letters, digits, '_' or '-' (not first)", NAME_PATTERN)
]
Text = Annotated[
    str,
    string(
        f"a printable string of at most {_MAX_DESCRIPTION} characters",
        test=lambda s: len(s) <= _MAX_DESCRIPTION and s.isprintable(),
    ),
]
#: The name of a texture or material a shape uses (checked against those the file defines).
Reference = Annotated[Any, Field(json_schema_extra={"type": "string"})]


def _not_reserved(name: str) -> str:
    if name in RESERVED_NAMES:
        raise expected(f"a name other than {', '.join(sorted(RESERVED_NAMES))}", name)
    return name


ShapeName = Annotated[Name, AfterValidator(_not_reserved)]


def _long(axis: tuple[float, ...]) -> tuple[float, ...]:
    if sum(x * x for x in axis) ** 0.5 < MIN_LENGTH:
        raise expected(f"a vector longer than {MIN_LENGTH}", list(axis))
    return axis


def _lit(radiance: tuple[float, ...]) -> tuple[float, ...]:
    if max(radiance) <= 0:
        raise expected("a radiance above 0 (leave emission out)", list(radiance))
    return radiance


# --------------------------------------------------------------------------------------------
# Motions, the camera and the medium


class FixedMotion(Table):
    type: Literal["fixed"]
    value: Vec3


class LinearMotion(Table):
    type: Literal["linear"]
    start: Vec3
    velocity: Vec3 = (0.0, 0.0, 0.0)


class OrbitMotion(Table):
    type: Literal["orbit"]
    center: Vec3 = (0.0, 0.0, 0.0)
    radius: _Positive
    height: Coordinate = 0.0
    angle: Coordinate = 0.0
    step: Coordinate = 0.0


#: ``[x, y, z]`` (fixed) or a table of type fixed, linear or orbit.
Motion = Annotated[
    FixedMotion | LinearMotion | OrbitMotion | Vec3,
    Kinds(FixedMotion, LinearMotion, OrbitMotion, plain=Vec3),
]


#: A direction: a vector no shorter than :data:`MIN_LENGTH`.
Direction = Annotated[Vec3, AfterValidator(_long)]


class Camera(Table):
    origin: Motion
    target: Motion
    up: Direction = (0.0, 1.0, 0.0)
    fov: Annotated[float, number(1e-3, 179.0)]
    fov_axis: Annotated[str, choice("x", "y", "smaller", "larger")] = "x"


class Medium(Table):
    bounds_min: Vec3
    bounds_max: Vec3
    sigma_t: Length
    albedo: Color

    @model_validator(mode="after")
    def _apart(self) -> Medium:
        lo, hi = self.bounds_min, self.bounds_max
        if not all(b - a >= MIN_LENGTH for a, b in zip(lo, hi)):
            raise problem(f"expected bounds_min < bounds_max on every axis, got {lo} and {hi}")
        return self


# --------------------------------------------------------------------------------------------
# Textures and materials


class Checker(Table):
    type: Literal["checker"]
    color0: Color
    color1: Color
    cells_u: Cells
    cells_v: Cells


class Felt(Table):
    type: Literal["felt"]
    base: Color
    cells_u: Cells
    cells_v: Cells
    grain: Coordinate = 0.25
    nap: Coordinate = 0.1
    bands: Annotated[int, integer(-_MAX_CELLS, _MAX_CELLS)] = 6
    seed: Annotated[int, integer(0, (1 << 32) - 1)] = 0


def _named(what: str) -> Any:
    """A table of named ``what`` (``[textures.felt]``): each key a :data:`Name`."""

    def check(value: object) -> object:
        if not isinstance(value, dict):
            raise expected(f"a table of named {what}s", value)
        for key in value:
            if not isinstance(key, str) or not NAME_PATTERN.fullmatch(key):
                raise problem(
                    f"expected a name of 1 to 64 letters, digits, '_' or '-' (not first), got "
                    f"{describe(key)}",
                    at=f"{what}s (a {what} name)",
                )
        return value

    return Check(check)


def _cells(textures: dict[str, Checker | Felt]) -> dict[str, Checker | Felt]:
    cells = 0
    for key, texture in textures.items():
        cells += texture.cells_u * texture.cells_v
        if cells > MAX_TEXTURE_CELLS:
            raise problem(
                f"expected at most {MAX_TEXTURE_CELLS} texture cells in all, got {cells}",
                at=f"textures.{key}",
            )
    return textures


class Material(Table):
    """A ``[materials.name]`` table: exactly one of ``albedo`` or ``texture``."""

    albedo: Color = None  # type: ignore[assignment]
    texture: Reference = None

    @model_validator(mode="after")
    def _one(self) -> Material:
        return _one_of(self, MATERIAL_KEYS)


def _one_of(table: Table, keys: tuple[str, ...], listed: tuple[str, ...] = ()) -> Any:
    """``table`` if exactly one of ``keys`` was given (``listed``: the keys the message names,
    default ``keys``)."""
    given = [k for k in keys if k in table.model_fields_set]
    if len(given) != 1:
        raise problem(
            f"expected exactly one of {', '.join(listed or keys)}, got {', '.join(given) or 'none'}"
        )
    return table


# --------------------------------------------------------------------------------------------
# Shapes


class Rotation(Table):
    axis: Direction
    degrees: Coordinate


def _scale_kind(value: object) -> str:
    return "vector" if isinstance(value, list) else "factor"


class Transform(Table):
    """``{translate, rotate = {axis, degrees}, scale}``, composed as Mitsuba does (T * R * S)."""

    translate: Vec3 = (0.0, 0.0, 0.0)
    rotate: Rotation = None  # type: ignore[assignment]
    scale: Annotated[
        Annotated[Vec3, Tag("vector")] | Annotated[Coordinate, Tag("factor")],
        Discriminator(_scale_kind),
    ] = 1.0


class _Shape(Table):
    """What every shape has: exactly one material."""

    @model_validator(mode="after")
    def _material(self) -> _Shape:
        return _one_of(self, MATERIAL_KEYS)


class Sphere(_Shape):
    type: Literal["sphere"]
    name: ShapeName
    center: Motion
    radius: Length
    albedo: Color = None  # type: ignore[assignment]
    texture: Reference = None
    material: Reference = None


class Rectangle(_Shape):
    """Placed by ``center`` with half edges ``u`` and ``v``, or by ``to_world`` or
    ``transform`` (of the unit square [-1, 1]^2 in the plane z = 0)."""

    type: Literal["rectangle"]
    name: ShapeName
    center: Vec3 = None  # type: ignore[assignment]
    u: Vec3 = None  # type: ignore[assignment]
    v: Vec3 = None  # type: ignore[assignment]
    to_world: Matrix = None  # type: ignore[assignment]
    transform: Transform = None  # type: ignore[assignment]
    albedo: Color = None  # type: ignore[assignment]
    texture: Reference = None
    material: Reference = None
    emission: Annotated[Radiance, AfterValidator(_lit)] = None  # type: ignore[assignment]

    @model_validator(mode="after")
    def _placement(self) -> Rectangle:
        given = self.model_fields_set
        if _one_of(self, ("center", "to_world", "transform")) and "center" in given:
            missing = [k for k in ("u", "v") if k not in given]
            if missing:
                raise problem(f"expected key {missing[0]!r} with center, got none")
        for k in ("u", "v"):
            if k in given and "center" not in given:
                raise problem(f"expected {k} only with center, got it with a transform")
        return self


class Box(_Shape):
    """The cube [-1, 1]^3 placed by ``to_world`` or ``transform``."""

    type: Literal["box"]
    name: ShapeName
    to_world: Matrix = None  # type: ignore[assignment]
    transform: Transform = None  # type: ignore[assignment]
    albedo: Color = None  # type: ignore[assignment]
    texture: Reference = None
    material: Reference = None

    @model_validator(mode="after")
    def _placement(self) -> Box:
        return _one_of(self, ("to_world", "transform"))


Shape = Annotated[Sphere | Rectangle | Box, Kinds(Sphere, Rectangle, Box)]


def _shape_list(value: object) -> object:
    """A non-empty array of at most :data:`MAX_SHAPES` tables, counted before any is read."""
    if not isinstance(value, list) or not value:
        raise expected("a non-empty array of tables ([[shapes]])", value)
    if len(value) > MAX_SHAPES:
        raise problem(f"expected at most {MAX_SHAPES} shapes, got {len(value)}")
    return value


def _distinct_and_lit(shapes: list[Sphere | Rectangle | Box]) -> list[Sphere | Rectangle | Box]:
    names: set[str] = set()
    for i, shape in enumerate(shapes):
        if shape.name in names:
            raise problem(
                f"expected a name no other shape has, got {describe(shape.name)}",
                at=f"shapes[{i}].name",
            )
        names.add(shape.name)
    if not any(isinstance(s, Rectangle) and s.emission is not None for s in shapes):
        raise problem("expected at least one rectangle with emission, got none")
    return shapes


# --------------------------------------------------------------------------------------------
# The document


class SceneDocument(Table):
    """A scene file: its top-level keys (docs/SCENE_FILES.md lists each, its unit and default).
    A file without ``name`` takes its file's name without suffix."""

    whole_file: ClassVar[bool] = True

    format: Annotated[int, integer(1, FORMAT_VERSION)] = FORMAT_VERSION
    name: Name = None  # type: ignore[assignment]
    description: Text = ""
    max_depth: Annotated[int, integer(2, MAX_DEPTH)]
    animated: Boolean = True
    camera: Camera
    textures: Annotated[
        dict[str, Annotated[Checker | Felt, Kinds(Checker, Felt)]],
        _named("texture"),
        AfterValidator(_cells),
    ] = {}
    materials: Annotated[dict[str, Material], _named("material")] = {}
    medium: Medium = None  # type: ignore[assignment]
    shapes: Annotated[
        list[Shape],
        BeforeValidator(_shape_list),
        AfterValidator(_distinct_and_lit),
    ]

    @model_validator(mode="after")
    def _references(self) -> SceneDocument:
        """Each texture or material a shape (or a material) names is defined; a texture only on
        a rectangle, directly or through its material."""
        for key, material in self.materials.items():
            _reference(material, f"materials.{key}", self.textures, {}, True)
        for i, shape in enumerate(self.shapes):
            textured = isinstance(shape, Rectangle)
            _reference(shape, f"shapes[{i}]", self.textures, self.materials, textured)
        return self


def _reference(table: Any, at: str, textures: dict, materials: dict, textured: bool) -> None:
    key = next(k for k in MATERIAL_KEYS if k in table.model_fields_set)
    if key == "albedo":
        return
    name = getattr(table, key)
    known = textures if key == "texture" else materials
    if not isinstance(name, str) or name not in known:
        defined = ", ".join(known) or "none defined"
        raise problem(
            f"expected the name of a {key} ({defined}), got {describe(name)}", f"{at}.{key}"
        )
    if key == "texture" and not textured:
        raise problem("expected textures on rectangles only, got one", f"{at}.texture")
    if key == "material" and "texture" in materials[name].model_fields_set and not textured:
        raise problem(f"expected an untextured material, got {name!r}", f"{at}.material")
