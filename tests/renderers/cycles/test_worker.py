"""The Blender side: what it records of a scene before bnerr changes it, what a render sets, and
its protocol kept apart from Blender's own output."""

import ast
from pathlib import Path

import OpenEXR
import pytest

from renderers.cycles.session import CyclesSession
from tests._cycles import skip_without_bpy

WORKER = Path(__file__).parents[3] / "renderers" / "cycles" / "worker.py"


def _constant(name: str) -> tuple:
    """A module-level tuple of worker.py (which imports bpy, so it is read, not imported)."""
    for node in ast.parse(WORKER.read_text()).body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == name:
            return ast.literal_eval(node.value)
    raise AssertionError(name)


OVERRIDDEN, RECORDED = _constant("OVERRIDDEN"), _constant("RECORDED")


@pytest.fixture(scope="module")
def held():
    skip_without_bpy()
    session = CyclesSession({"op": "build", "recipe": {"kind": "outdoor", "frames": 3}}, "t")
    yield session
    session.close()


def test_the_scene_s_own_settings_are_recorded_before_bnerr_overrides_them(held):
    info = held.info
    assert info["blender"].startswith("4.5") and info["engine"] == "CYCLES"
    assert {"AUTOMATIC", "TABULATED_SOBOL", "BLUE_NOISE"} <= set(info["patterns"])
    assert set(OVERRIDDEN) | set(RECORDED) <= set(info["settings"])
    # a factory scene: Blender's own defaults, which the renders then override
    assert info["settings"]["sampling_pattern"] == "AUTOMATIC"
    assert info["settings"]["use_adaptive_sampling"] is True
    assert (info["frame_start"], info["frame_end"]) == (1, 3)


def test_a_render_writes_every_pass_at_the_size_asked(held, tmp_path):
    out = tmp_path / "f.exr"
    answer = held.ask(
        {
            "op": "render",
            "frame": 2,
            "width": 12,
            "height": 8,
            "spp": 2,
            "seed": 9,
            "pattern": "BLUE_NOISE",
            "scrambling_distance": None,
            "adaptive": False,
            "denoise": True,
            "out": str(out),
        }
    )
    assert answer["ok"] and answer["wall_s"] > 0
    with OpenEXR.File(str(out)) as exr:
        channels = exr.parts[0].channels
        assert channels["ViewLayer.Noisy Image"].pixels.shape == (8, 12, 4)
        names = {k.split(".")[1] for k in channels}
    assert {
        "Combined",
        "Noisy Image",
        "Denoising Albedo",
        "Normal",
        "Depth",
        "IndexOB",
        "Vector",
    } <= names


def test_a_pattern_blender_does_not_have_is_one_line(held, tmp_path):
    from bnerr.errors import ExternalProcessError

    with pytest.raises(ExternalProcessError, match=r"Cycles: .*BLUE_NOISE_FIRST.*not found"):
        held.ask(
            {
                "op": "render",
                "frame": 1,
                "width": 4,
                "height": 4,
                "spp": 1,
                "seed": 0,
                "pattern": "BLUE_NOISE_FIRST",
                "adaptive": False,
                "denoise": False,
                "out": str(tmp_path / "x.exr"),
            }
        )
