"""Tests for renderers.scene_file: every shipped scene survives dump and load bit for bit, the
committed example files match what dump_scene writes, and bad files raise SceneFileError."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from bnerr.errors import BnerrError, DtypeError, SceneFileError
from bnerr.sequences import make_sampler
from bnerr.strategies import pixel_seeds
from renderers import SCENES, render
from renderers.camera import camera_frame
from renderers.geometry import scene_tensors
from renderers.scene import Rectangle, affine
from renderers.scene_file import (
    MAX_FILE_BYTES,
    MAX_SHAPES,
    dump_scene,
    load_camera_path,
    load_scene_file,
    loads_scene,
    scene_dict,
    scene_from_dict,
    write_scene_file,
)

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "scenes"
NAMES = sorted(SCENES)
FRAMES = (0, 5)


def _loaded(name: str, fmt: str = "toml"):
    return loads_scene(dump_scene(SCENES[name](), fmt), fmt)


# --------------------------------------------------------------------------------------------
# Every shipped scene, dumped and loaded, is the built-in one


@pytest.mark.parametrize("fmt", ["toml", "json"])
@pytest.mark.parametrize("name", NAMES)
def test_dump_then_load_gives_the_same_scene(name, fmt):
    scene = SCENES[name]()
    assert _loaded(name, fmt) == scene
    assert loads_scene(dump_scene(scene.static(), fmt), fmt) == scene.static()


@pytest.mark.parametrize("name", NAMES)
def test_the_packed_tensors_and_camera_are_bit_identical_at_every_frame(name):
    built, loaded = SCENES[name](), _loaded(name)
    for t in FRAMES:
        a, b = scene_tensors(built, t), scene_tensors(loaded, t)
        for f in dataclasses.fields(a):
            x, y = getattr(a, f.name), getattr(b, f.name)
            if isinstance(x, torch.Tensor):
                assert torch.equal(x, y) and x.dtype == y.dtype, (name, t, f.name)
            else:
                assert x == y, (name, t, f.name)
        ca, cb = camera_frame(built.camera, t, 24, 16), camera_frame(loaded.camera, t, 24, 16)
        for f in ("origin", "right", "up", "forward"):
            assert torch.equal(getattr(ca, f), getattr(cb, f)), (name, t, f)
        assert (ca.tan_x, ca.tan_y) == (cb.tan_x, cb.tan_y)


@pytest.mark.parametrize("name", NAMES)
def test_renders_are_bit_identical(name):
    built, loaded = SCENES[name](), _loaded(name)
    seeds, sampler = pixel_seeds(16, 16, 3), make_sampler("white")
    for t in FRAMES:
        a, b = render(built, t, seeds, sampler, 2), render(loaded, t, seeds, sampler, 2)
        for buffer in ("color", "variance", "albedo", "normal", "depth", "object_id", "motion"):
            assert torch.equal(getattr(a, buffer), getattr(b, buffer)), (name, t, buffer)


@pytest.mark.parametrize("name", NAMES)
def test_the_committed_example_files_are_what_dump_scene_writes_today(name):
    path = EXAMPLES / f"{name}.toml"
    assert path.read_text(encoding="utf-8") == dump_scene(SCENES[name]()), (
        f"{path} drifted: rewrite it with renderers.scene_file.write_scene_file"
    )
    build = load_scene_file(path)
    assert build() == SCENES[name]() and build.__name__ == name


def test_load_scene_file_reads_json_and_names_a_scene_after_its_file(tmp_path):
    document = scene_dict(SCENES["direct"]())
    del document["name"]
    path = tmp_path / "my_scene.json"
    path.write_text(json.dumps(document))
    scene = load_scene_file(path)()
    assert scene.name == "my_scene"
    assert dataclasses.replace(scene, name="direct") == SCENES["direct"]()


def test_write_scene_file_writes_atomically_what_dump_scene_gives(tmp_path):
    scene = SCENES["snooker"]()
    assert write_scene_file(scene, tmp_path / "s.toml").read_text() == dump_scene(scene)
    assert json.loads((write_scene_file(scene, tmp_path / "s.json")).read_text())["name"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json", "s.toml"]
    with pytest.raises(SceneFileError, match="suffix .toml or .json"):
        write_scene_file(scene, tmp_path / "s.yaml")


def test_dump_scene_refuses_what_the_format_cannot_express():
    scene = dataclasses.replace(SCENES["direct"](), name="has space")
    with pytest.raises(SceneFileError, match="cannot be written.*name"):
        dump_scene(scene)
    with pytest.raises(DtypeError, match="expected a renderers Scene"):
        dump_scene("direct")  # type: ignore[arg-type]


HAND_WRITTEN = """
name = "box"
max_depth = 3

[camera]
origin = [0, 0, 3.9]
target = [0, 0, 0]
fov = 39.3077
fov_axis = "smaller"

[materials.white]
albedo = [0.885809, 0.698859, 0.666422]

[[shapes]]
type = "rectangle"
name = "light"
material = "white"
emission = [18.387, 13.9873, 6.75357]

[shapes.transform]
translate = [0, 0.99, 0.01]
rotate = { axis = [1, 0, 0], degrees = 90 }
scale = [0.23, 0.19, 0.19]

[[shapes]]
type = "box"
name = "small-box"
transform.translate = [0.335, -0.7, 0.38]
transform.rotate = { axis = [0, 1, 0], degrees = -17 }
transform.scale = 0.3
material = "white"
"""


def test_materials_and_transforms_build_what_the_python_helpers_build():
    scene = loads_scene(HAND_WRITTEN)
    cornell = SCENES["cornell"]()
    assert scene.shapes[0] == cornell.shapes[0]  # Rectangle.from_transform(affine(...))
    assert scene.shapes[1] == cornell.shapes[6]
    assert scene.camera.pose(7) == cornell.camera.pose(0) and scene.camera.up == (0, 1, 0)
    assert scene.description == "" and scene.medium is None and scene.animated
    assert isinstance(scene.shapes[0], Rectangle) and scene.shapes[1].to_world == affine(
        (0.335, -0.7, 0.38), ((0, 1, 0), -17.0), 0.3
    )


# --------------------------------------------------------------------------------------------
# Bad files: one typed error, naming the line or the key


def _edit(name: str, change) -> dict:
    document = scene_dict(SCENES[name]())
    change(document)
    return document


def _set(path: tuple, value):
    def change(document):
        target = document
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value

    return change


BAD = {
    "negative radius": ("direct", ("shapes", 1, "radius"), -1.0, r"shapes\[1\]\.radius"),
    "zero radius": ("direct", ("shapes", 1, "radius"), 0, r"shapes\[1\]\.radius"),
    "nan": ("direct", ("shapes", 1, "center", 0), float("nan"), r"center\[0\].*finite"),
    "inf": ("direct", ("camera", "fov"), float("inf"), r"camera\.fov.*finite"),
    "huge": ("direct", ("medium",), {"bounds_min": [0, 0, 0]}, r"medium.*bounds_max"),
    "zero fov": ("direct", ("camera", "fov"), 0.0, r"camera\.fov"),
    "up along view": ("indirect", ("camera", "up"), [-1.0, -1.7, -6.5], r"camera\.up.*parallel"),
    "zero up": ("indirect", ("camera", "up"), [0, 0, 0], r"camera\.up"),
    "eye on target": ("direct", ("camera", "target"), [0.0, 3.0, 6.0], r"origin and target apart"),
    "degenerate light": ("direct", ("shapes", 2, "u"), [0.0, 0.0, 1.0], r"shapes\[2\].*area"),
    "point light": ("direct", ("shapes", 2, "v"), [0.0, 0.0, 0.0], r"shapes\[2\].*area"),
    "dark light": ("direct", ("shapes", 2, "emission"), [0, 0, 0], r"emission.*above 0"),
    "unknown key": ("direct", ("shapes", 1, "colour"), [1, 1, 1], r"unknown key 'colour'.*radius"),
    "unknown top key": ("direct", ("lights",), [], r"unknown key 'lights'.*max_depth"),
    "wrong type": ("direct", ("shapes", 1, "type"), "cone", r"type.*sphere, rectangle, box"),
    "bool number": ("direct", ("shapes", 1, "radius"), True, r"radius.*a number.*bool"),
    "big integer": ("direct", ("shapes", 1, "radius"), 10**400, r"radius"),
    "albedo over 1": ("direct", ("shapes", 1, "albedo"), [2, 0, 0], r"albedo\[0\]"),
    "depth": ("direct", ("max_depth",), 1000, r"max_depth.*\[2, 64\]"),
    "format": ("direct", ("format",), 2, r"format.*\[1, 1\]"),
    "duplicate name": ("direct", ("shapes", 1, "name"), "floor", r"shapes\[1\]\.name"),
    "reserved name": ("direct", ("shapes", 1, "name"), "sensor", r"other than"),
    "bad name": ("direct", ("name",), "../x", r"name: expected a name"),
    "texture on sphere": ("snooker", ("shapes", 5, "texture"), "felt", r"exactly one of"),
    "unknown texture": ("snooker", ("shapes", 0, "texture"), "silk", r"texture.*felt"),
    "huge texture": ("snooker", ("textures", "felt", "cells_u"), 1 << 16, r"texture cells"),
    "no light": ("direct", ("shapes",), [], r"shapes.*non-empty"),
    "flat box": ("cornell", ("shapes", 6, "to_world", 1), [0, 0, 0, 1], r"to_world.*invertible"),
    "mirrored rectangle": (
        "cornell",
        ("shapes", 1),
        {"type": "rectangle", "name": "f", "albedo": [1, 1, 1], "transform": {"scale": [1, 1, -1]}},
        r"determinant > 0",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_values_are_refused_naming_the_key(case):
    name, path, value, message = BAD[case]
    document = _edit(name, _set(path, value))
    with pytest.raises(SceneFileError, match=message):
        loads_scene(json.dumps(document), "json", source="bad.json")


def test_the_error_names_the_source_file():
    with pytest.raises(SceneFileError, match=r"^bad\.json: shapes\[1\]\.radius"):
        loads_scene(
            json.dumps(_edit("direct", _set(("shapes", 1, "radius"), -1))), "json", "bad.json"
        )


def test_too_many_shapes_are_refused_before_any_is_read():
    document = _edit("direct", lambda d: d.update(shapes=[None] * (MAX_SHAPES + 1)))
    with pytest.raises(SceneFileError, match=f"at most {MAX_SHAPES} shapes, got {MAX_SHAPES + 1}"):
        scene_from_dict(document)


def test_a_scene_without_light_is_refused():
    document = _edit("direct", lambda d: d["shapes"][2].pop("emission"))
    with pytest.raises(SceneFileError, match="at least one rectangle with emission"):
        scene_from_dict(document)


@pytest.mark.parametrize(
    "text, fmt, message",
    [
        ('name = "x"\nmax_depth = \n', "toml", r"line 2"),
        ('name = "x"\nname = "y"\n', "toml", r"line 2"),
        ('{\n  "name": "x",\n  "max_depth": 3,,\n}', "json", r"line 3, column 18"),
        ('{"name": "x", "name": "y"}', "json", r"key 'name' given twice"),
        ("[" * 100_000, "json", r"expected a JSON document"),
        (b'name = "\xff"', "toml", r"line 1: expected UTF-8"),
        ("max_depth = nan", "toml", r"max_depth: expected an integer"),
        ('{"max_depth": 3, "camera": {"fov": NaN}}', "json", r"camera"),
        ("[1, 2]", "json", r"scene: expected a table"),
    ],
)
def test_malformed_text_is_reported_with_its_line(text, fmt, message):
    with pytest.raises(SceneFileError, match=message):
        loads_scene(text, fmt, "scene." + fmt)


def test_file_checks_come_before_parsing(tmp_path):
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * (MAX_FILE_BYTES + 1))
    with pytest.raises(SceneFileError, match=f"at most {MAX_FILE_BYTES} bytes"):
        load_scene_file(big)
    folder = tmp_path / "folder.toml"
    folder.mkdir()
    with pytest.raises(SceneFileError, match="regular file"):
        load_scene_file(folder)
    with pytest.raises(SceneFileError, match="readable file"):
        load_scene_file(tmp_path / "missing.toml")
    with pytest.raises(SceneFileError, match="suffix .toml or .json"):
        load_scene_file(tmp_path / "scene.xml")
    with pytest.raises(DtypeError):
        load_scene_file(3)  # type: ignore[arg-type]
    assert issubclass(SceneFileError, BnerrError) and issubclass(SceneFileError, OSError)


# --------------------------------------------------------------------------------------------
# Properties: whatever the bytes, a scene or a SceneFileError


def _loads_or_refuses(data: bytes | str, fmt: str) -> None:
    try:
        loads_scene(data, fmt)
    except SceneFileError:
        pass


@given(st.binary(max_size=400), st.sampled_from(["toml", "json"]))
def test_any_bytes_load_or_raise_scene_file_error(data, fmt):
    _loads_or_refuses(data, fmt)


_TOKENS = st.sampled_from(
    ["nan", "-inf", "0", "-1", "1e400", "1e-300", "true", '"x"', "[]", "{}", "[1, 2]", "9" * 30]
)


@given(st.sampled_from(NAMES), st.integers(0, 10_000), _TOKENS)
def test_any_value_swapped_into_a_shipped_file_loads_or_raises_scene_file_error(name, at, token):
    lines = dump_scene(SCENES[name]()).splitlines()
    values = [i for i, line in enumerate(lines) if " = " in line]
    i = values[at % len(values)]
    lines[i] = lines[i].split(" = ")[0] + " = " + token
    _loads_or_refuses("\n".join(lines), "toml")


_JSON = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=20,
)


@given(st.sampled_from(NAMES), st.integers(0, 10_000), _JSON)
def test_any_subtree_swapped_into_a_shipped_document_is_loaded_or_refused(name, at, value):
    document = scene_dict(SCENES[name]())
    slots = []

    def walk(node):
        items = node.items() if isinstance(node, dict) else enumerate(node)
        for key, child in items:
            slots.append((node, key))
            if isinstance(child, (dict, list)):
                walk(child)

    walk(document)
    node, key = slots[at % len(slots)]
    node[key] = value
    try:
        scene_from_dict(document)
    except SceneFileError:
        pass


def test_the_example_of_the_documentation_loads_and_its_light_faces_down():
    doc = (ROOT / "docs" / "SCENE_FILES.md").read_text(encoding="utf-8")
    example = doc.split("```toml\n")[1].split("```")[0]
    scene = loads_scene(example, source="docs/SCENE_FILES.md")
    assert [s.name for s in scene.shapes] == ["floor", "ball", "light"]
    assert scene.lights == (2,) and scene.shapes[2].normal == pytest.approx((0, -1, 0), abs=1e-12)
    assert scene.shapes[0].material.albedo == (0.7, 0.7, 0.7) and scene.camera.up == (0, 1, 0)


def test_the_documented_messages_are_the_real_ones():
    with pytest.raises(SceneFileError) as syntax:
        loads_scene('name = "x"\n\n[camera]\nfov = *\n', source="my.toml")
    assert str(syntax.value) == "my.toml: expected TOML, got Invalid value (at line 4, column 7)"
    document = _edit("direct", _set(("shapes", 1, "radius"), -1.0))
    with pytest.raises(SceneFileError) as meaning:
        loads_scene(json.dumps(document), "json", "my.toml")
    assert str(meaning.value) == (
        "my.toml: shapes[1].radius: expected a finite number in [1e-06, 1000000.0], got float -1.0"
    )


def test_a_camera_path_file_reads_motions_like_a_scene_files_camera(tmp_path):
    path = tmp_path / "x.camera.toml"
    path.write_text('target = [0, 1, 0]\n[origin]\ntype = "orbit"\nradius = 2\nstep = 90\n')
    origin, target, up = load_camera_path(path)
    assert target.at(9) == (0.0, 1.0, 0.0) and up == (0.0, 1.0, 0.0)
    assert origin.at(1) == pytest.approx((2.0, 0.0, 0.0), abs=1e-12)
    path.write_text("origin = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = 40\n")
    with pytest.raises(SceneFileError, match="x.camera.toml: camera path: unknown key 'fov'"):
        load_camera_path(path)
