"""The scene-file door's probe (issue 41): bad TOML/JSON scene files, each refused as a one-line
:class:`~bnerr.errors.SceneFileError` naming the file and the line (syntax) or the key (meaning),
what was expected and what came (tests/_probes.py); sizes are refused before anything is
allocated; the command line ends in one line, never a traceback."""

from __future__ import annotations

import json
import os
import tomllib

import pytest

from bnerr.errors import SceneFileError
from renderers.scene_file import load_scene_file
from tests._paths import EXAMPLES
from tests._probes import Bad, check, ids, refused_on_the_command_line

DIRECT = (EXAMPLES / "scenes" / "direct.toml").read_text()


def _toml(text: str, name: str = "bad.toml"):
    def run(tmp_path):
        (tmp_path / name).write_text(text)
        return load_scene_file(tmp_path / name)

    return run


def _edited(edit):
    """A case's run: the shipped direct scene as JSON, changed by ``edit(document)``."""

    def run(tmp_path):
        document = tomllib.loads(DIRECT)
        edit(document)
        (tmp_path / "bad.json").write_text(json.dumps(document))
        return load_scene_file(tmp_path / "bad.json")

    return run


def _set(*path_and_value):
    *path, value = path_and_value

    def edit(document):
        at = document
        for key in path[:-1]:
            at = at[key]
        at[path[-1]] = value

    return _edited(edit)


def _fifo(tmp_path):
    os.mkfifo(tmp_path / "pipe.toml")
    return load_scene_file(tmp_path / "pipe.toml")


def _texture(cells: int):
    """The scene with a checker texture of ``cells x cells`` cells on its first rectangle, in the
    keys SCENE_FILES.md names (``cells_u``, ``cells_v``; issue 54: the case wrote an unknown key
    ``cells`` and so never reached the size limit)."""

    def edit(document):
        document["textures"] = {
            "huge": {
                "type": "checker",
                "cells_u": cells,
                "cells_v": cells,
                "color0": [0.1, 0.1, 0.1],
                "color1": [0.9, 0.9, 0.9],
            }
        }
        rectangle = next(s for s in document["shapes"] if s.get("type") == "rectangle")
        for key in ("albedo", "material"):
            rectangle.pop(key, None)
        rectangle["texture"] = "huge"

    return _edited(edit)


CASES = [
    Bad("malformed TOML", _toml(DIRECT.replace("radius = 1.0", "radius = = 1.0")), SceneFileError,
        r"bad\.toml.*line 3\d"),
    Bad("malformed JSON", lambda p: (p / "bad.json").write_text('{"format": 1,\n "name": }')
        and load_scene_file(p / "bad.json"), SceneFileError, r"bad\.json.*line 2"),
    Bad("unknown top key", _set("colour", 1), SceneFileError, r"bad\.json.*colour.*format, name"),
    Bad("unknown shape key", _set("shapes", 1, "radiu", 2.0), SceneFileError,
        r"bad\.json.*shapes\[1\].*radiu.*radius"),
    Bad("negative radius", _set("shapes", 1, "radius", -1.0), SceneFileError,
        r"bad\.json: shapes\[1\]\.radius: expected a finite number in .*got float -1"),
    Bad("zero-area light", _set("shapes", 2, "u", [0.0, 0.0, 0.0]), SceneFileError,
        r"bad\.json.*shapes\[2\]"),
    Bad("NaN coordinate", _toml(DIRECT.replace("radius = 1.0", "radius = nan")), SceneFileError,
        r"bad\.toml.*shapes\[1\]\.radius.*nan"),
    Bad("infinite coordinate", _set("shapes", 1, "center", [0.0, 1e300, 0.0]), SceneFileError,
        r"bad\.json.*shapes\[1\]\.center"),
    Bad("camera looking at itself", _set("camera", "origin", [0.0, 0.8, 0.0]), SceneFileError,
        r"bad\.json.*camera.*origin"),
    Bad("up along the view", _set("camera", "up", [0.0, 0.0, 0.0]), SceneFileError,
        r"bad\.json.*up"),
    Bad("format 2", _set("format", 2), SceneFileError,
        r"bad\.json: format: expected an integer in \[1, 1\], got int 2"),
    Bad("max_depth 10^6", _set("max_depth", 10**6), SceneFileError,
        r"bad\.json: max_depth: expected an integer in \[2, 64\], got int 1000000"),
    Bad("reserved shape name", _set("shapes", 0, "name", "integrator"), SceneFileError,
        r"bad\.json.*shapes\[0\]\.name.*integrator"),
    Bad("unknown material", _edited(lambda d: d["shapes"][0].pop("albedo") and
        d["shapes"][0].update(material="gold")), SceneFileError,
        r"bad\.json.*shapes\[0\]\.material.*gold"),
    Bad("too many shapes", _edited(lambda d: d["shapes"].extend([d["shapes"][1]] * 300)),
        SceneFileError, r"bad\.json.*shapes.*256"),
    Bad("10^6 x 10^6 texture cells", _texture(10**6), SceneFileError,
        r"bad\.json: textures\.huge\.cells_u: expected an integer in \[1, 65536\], got int 10+$"),
    Bad("65536 x 65536 texture cells", _texture(65536), SceneFileError,
        r"bad\.json: textures\.huge: expected at most 4194304 texture cells.*got 4294967296"),
    Bad("file over 1 MiB", _toml(DIRECT + "#" * (1 << 20)), SceneFileError,
        r"bad\.toml.*1048576 bytes"),
    Bad("not UTF-8", lambda p: (p / "bad.toml").write_bytes(b"name = '\xff\xfe'\n")
        and load_scene_file(p / "bad.toml"), SceneFileError, r"bad\.toml.*UTF-8"),
    Bad("another suffix", _toml(DIRECT, "bad.yaml"), SceneFileError,
        r"bad\.yaml.*expected.*\.toml.*\.json"),
    Bad("missing file", lambda p: load_scene_file(p / "none.toml"), SceneFileError,
        r"none\.toml"),
    Bad("a named pipe", _fifo, SceneFileError, r"pipe\.toml.*regular file"),
    Bad("a folder", lambda p: (p / "dir.toml").mkdir() or load_scene_file(p / "dir.toml"),
        SceneFileError, r"dir\.toml.*regular file"),
]  # fmt: skip


def test_the_texture_cases_edit_a_scene_that_loads_at_a_small_size(tmp_path):
    """The control of the two texture-size cases: the same edit at 64 x 64 cells loads, so what
    they refuse is the size."""
    scene = _texture(64)(tmp_path)()  # load_scene_file gives the scene's builder
    albedo = scene.shapes[0].material.albedo
    assert (type(albedo).__name__, albedo.cells_u, albedo.cells_v) == ("Checker", 64, 64)


@pytest.mark.parametrize("case", CASES, ids=ids(CASES))
def test_a_bad_scene_file_is_refused_in_one_line_naming_it(case, tmp_path):
    check(case, tmp_path)


@pytest.mark.parametrize(
    "extra, words",
    [
        ([], r"bad\.toml.*shapes\[1\]\.radius"),
        (["--res", "1000000x1000000"], r"1000000"),
    ],
    ids=["bad file", "10^6 x 10^6 pixels"],
)
def test_the_command_line_refuses_in_one_line(tmp_path, capsys, extra, words):
    """``bnerr render`` with a bad scene file, or a good one at 10^6 x 10^6 pixels: refused in
    one line before anything is allocated, nothing written."""
    good = DIRECT if extra else DIRECT.replace("radius = 1.0", "radius = -1.0")
    (tmp_path / "bad.toml").write_text(good)
    argv = ["render", "--scene", str(tmp_path / "bad.toml"), "--spp", "1", "--res", "8x8"]
    argv += [*extra, "--no-compile", "--no-progress", "--out", str(tmp_path / "out")]
    refused_on_the_command_line(argv, capsys, words)
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").rglob("*.exr"))
