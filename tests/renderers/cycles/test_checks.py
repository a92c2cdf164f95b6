"""The Cycles door's checks: each bad pairing or file refused in one line, before anything runs."""

import subprocess

import pytest

import renderers
from bnerr.errors import ExternalProcessError, FileFormatError, ValueRangeError
from renderers.cycles import checks
from renderers.cycles.checks import check_cells, is_cycles_name
from renderers.cycles.session import bpy_python
from tests._cycles import skip_without_bpy


def test_cycles_scenes_are_blend_files_and_the_built_ones():
    assert is_cycles_name("a/b.blend") and is_cycles_name("cycles_product")
    assert not is_cycles_name("direct") and not is_cycles_name("scene.xml")


def test_cycles_own_patterns_are_refused_on_bnerr_s_scenes_and_white_is_not():
    check_cells("direct", ["white", "temporal"])
    with pytest.raises(ValueRangeError, match=r"^--strategies blue_noise: expected a Cycles scene"):
        check_cells("direct", ["white", "blue_noise"])


def test_bnerr_s_strategies_are_refused_on_a_cycles_scene_before_blender_starts():
    with pytest.raises(ValueRangeError, match=r"^--strategies ldbn: .*per-pixel seeds"):
        check_cells("missing.blend", ["white", "ldbn"])


def test_a_missing_blend_is_refused(tmp_path):
    with pytest.raises(FileFormatError, match=r"expected a readable \.blend file"):
        check_cells(str(tmp_path / "gone.blend"), ["white"])


def test_a_blender_without_the_blue_noise_pattern_is_refused(monkeypatch):
    class Old:
        info = {"blender": "4.1.0", "patterns": ["SOBOL_BURLEY", "TABULATED_SOBOL"]}

    monkeypatch.setattr(checks, "CyclesScene", Old)
    monkeypatch.setattr(renderers.catalog, "get_scene", lambda name: Old())
    check_cells("cycles_product", ["white"])
    with pytest.raises(
        ValueRangeError,
        match=r"^--strategies blue_noise: expected a Blender whose "
        r"Cycles has the BLUE_NOISE sampling pattern \(4\.4 or later\), got "
        r"Blender 4\.1\.0 with SOBOL_BURLEY, TABULATED_SOBOL$",
    ):
        check_cells("cycles_product", ["white", "blue_noise"])


def test_a_blend_without_a_camera_or_that_blender_cannot_read_is_refused(tmp_path):
    skip_without_bpy()
    empty = tmp_path / "empty.blend"
    code = (
        "import bpy; bpy.ops.wm.read_factory_settings(use_empty=True); "
        f"bpy.ops.wm.save_as_mainfile(filepath={str(empty)!r})"
    )
    subprocess.run([str(bpy_python()), "-c", code], capture_output=True, check=True, timeout=120)
    with pytest.raises(
        ExternalProcessError,
        match=r"^Cycles scene empty: Cycles: expected a scene "
        r"with an active camera, got none$",
    ):
        check_cells(str(empty), ["white"])
    corrupt = tmp_path / "corrupt.blend"
    corrupt.write_bytes(b"BLENDER-v405REND" + bytes(40))
    with pytest.raises(ExternalProcessError, match=r"^Cycles scene corrupt: Cycles: .*corrupt"):
        check_cells(str(corrupt), ["white", "blue_noise"])
