"""The Mitsuba XML scene door's probe (issue 41): bad XML scenes and camera-path sidecars, and
files named in the XML that escape its folder (``..``, an absolute path, a symlink), each
refused as a one-line typed error naming the file and what was expected (tests/_probes.py);
entity expansion is refused by the parser, never tried. Mitsuba is not needed: the files are
checked when the scene is loaded."""

from __future__ import annotations

import pytest

from bnerr.errors import FileFormatError, SceneFileError
from renderers.mitsuba_scene import load_mitsuba_scene
from tests._probes import Bad, check, ids

SCENE = """<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
    </sensor>
    {body}
</scene>
"""


def _xml(text: str, sidecar: str | None = None):
    def run(tmp_path):
        (tmp_path / "scene.xml").write_text(text)
        if sidecar is not None:
            (tmp_path / "scene.camera.toml").write_text(sidecar)
        return load_mitsuba_scene(tmp_path / "scene.xml")

    return run


def _mesh(filename: str):
    body = f'<shape type="ply"><string name="filename" value="{filename}"/></shape>'
    return _xml(SCENE.format(body=body))


def _linked(tmp_path):
    (tmp_path / "outside.ply").write_text("ply\n")
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "mesh.ply").symlink_to(tmp_path / "outside.ply")
    body = '<shape type="ply"><string name="filename" value="mesh.ply"/></shape>'
    (tmp_path / "in" / "scene.xml").write_text(SCENE.format(body=body))
    return load_mitsuba_scene(tmp_path / "in" / "scene.xml")


LAUGHS = (
    '<?xml version="1.0"?>\n<!DOCTYPE scene [\n<!ENTITY a "aaaaaaaaaa">\n'
    + "".join(f'<!ENTITY {c} "{("&" + p + ";") * 10}">\n' for p, c in zip("abcdefgh", "bcdefghi"))
    + ']>\n<scene version="3.0.0"><sensor type="perspective"/><x>&i;</x></scene>\n'
)
EXTERNAL = (
    '<?xml version="1.0"?>\n<!DOCTYPE scene [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
    '<scene version="3.0.0"><sensor type="perspective"/><x>&x;</x></scene>\n'
)
PATH = "origin = [0.0, 1.0, 5.0]\ntarget = [0.0, 1.0, 0.0]\n"

CASES = [
    Bad("missing file", lambda p: load_mitsuba_scene(p / "none.xml"), FileFormatError,
        r"none\.xml: expected a readable Mitsuba XML scene"),
    Bad("malformed XML", _xml('<scene version="3.0.0">\n<sensor>\n</scene>\n'), FileFormatError,
        r"scene\.xml: expected a Mitsuba XML scene, got mismatched tag: line 3"),
    Bad("not XML", _xml("name = 'a toml file'\n"), FileFormatError,
        r"scene\.xml: expected a Mitsuba XML scene, got syntax error: line 1"),
    Bad("no sensor", _xml('<scene version="3.0.0"><shape type="sphere"/></scene>'),
        FileFormatError, r"scene\.xml: expected a <scene> with a <sensor>"),
    Bad("another root", _xml("<sensor/>"), FileFormatError,
        r"scene\.xml: expected a <scene> with a <sensor>, got <sensor>"),
    Bad("entity expansion", _xml(LAUGHS), FileFormatError,
        r"scene\.xml: expected a Mitsuba XML scene, got"),
    Bad("external entity", _xml(EXTERNAL), FileFormatError,
        r"scene\.xml: expected a Mitsuba XML scene, got"),
    Bad("file escaping with ..", _mesh("../meshes/bunny.ply"), FileFormatError,
        r"scene\.xml: .*filename.*expected a path inside.*got '\.\./meshes/bunny\.ply'"),
    Bad("absolute file", _mesh("/etc/passwd"), FileFormatError,
        r"scene\.xml: .*filename.*expected a path inside.*got '/etc/passwd'"),
    Bad("file escaping by a symlink", _linked, FileFormatError,
        r"scene\.xml: .*filename.*expected a path inside.*got 'mesh\.ply'"),
    Bad("include escaping", _xml(SCENE.format(body='<include filename="../other.xml"/>')),
        FileFormatError, r"scene\.xml: .*include.*expected a path inside.*'\.\./other\.xml'"),
    Bad("sidecar malformed", _xml(SCENE.format(body=""), "origin = [0.0, 1.0\n"),
        SceneFileError, r"scene\.camera\.toml.*line"),
    Bad("sidecar unknown key", _xml(SCENE.format(body=""), PATH + "fov = 40\n"),
        SceneFileError, r"scene\.camera\.toml.*fov.*origin, target, up"),
    Bad("sidecar missing target", _xml(SCENE.format(body=""), "origin = [0.0, 1.0, 5.0]\n"),
        SceneFileError, r"scene\.camera\.toml.*target"),
    Bad("sidecar degenerate pose", _xml(SCENE.format(body=""),
        "origin = [0.0, 1.0, 0.0]\ntarget = [0.0, 1.0, 0.0]\n"), SceneFileError,
        r"scene\.camera\.toml.*origin"),
    Bad("sidecar NaN", _xml(SCENE.format(body=""), "origin = [nan, 1.0, 5.0]\n"
        "target = [0.0, 1.0, 0.0]\n"), SceneFileError, r"scene\.camera\.toml.*origin.*nan"),
]  # fmt: skip


@pytest.mark.parametrize("case", CASES, ids=ids(CASES))
def test_a_bad_mitsuba_scene_is_refused_in_one_line_naming_it(case, tmp_path):
    check(case, tmp_path)


def test_files_inside_the_folder_are_accepted(tmp_path):
    (tmp_path / "meshes").mkdir()
    body = '<shape type="ply"><string name="filename" value="meshes/bunny.ply"/></shape>'
    (tmp_path / "scene.xml").write_text(SCENE.format(body=body))
    assert load_mitsuba_scene(tmp_path / "scene.xml")().name == "scene"
