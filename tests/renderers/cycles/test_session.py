"""The Blender process behind a Cycles scene: found, started, asked, refused in one line, ended."""

import sys

import pytest

from bnerr.errors import ExternalProcessError, MissingExtraError
from renderers.cycles import session as cycles_session
from renderers.cycles.session import CyclesSession, bpy_python
from tests._cycles import skip_without_bpy

_TINY = {"op": "build", "recipe": {"kind": "outdoor", "frames": 2}}


def test_no_python_with_bpy_is_refused_naming_the_extra(monkeypatch, tmp_path):
    monkeypatch.setenv("BNERR_BPY_PYTHON", str(tmp_path / "none" / "python"))
    with pytest.raises(
        MissingExtraError,
        match=r"^Cycles scenes: expected the optional extra "
        r"'cycles'.*make cycles.*got no Python at BNERR_BPY_PYTHON=",
    ):
        bpy_python()


def test_a_python_without_bpy_is_refused_with_its_own_last_words(monkeypatch):
    monkeypatch.setenv("BNERR_BPY_PYTHON", sys.executable)  # bnerr's Python: numpy 2, no bpy
    with pytest.raises(MissingExtraError, match=r"bpy under .*got .*(ModuleNotFoundError|bpy)"):
        CyclesSession(_TINY, "test")


def test_a_failure_inside_blender_is_one_line_and_the_process_goes_on():
    skip_without_bpy()
    held = CyclesSession(_TINY, "test scene")
    try:
        assert held.blender.startswith("4.") and held.info["camera"] == "camera"
        with pytest.raises(ExternalProcessError, match=r"^test scene: Cycles: op: expected open"):
            held.ask({"op": "nonsense"})
        with pytest.raises(ExternalProcessError, match=r"^test scene: Cycles: .*(No such|not)"):
            held.ask({"op": "open", "blend": "/nowhere/at/all.blend"})
        assert held.ask({"op": "build", "recipe": _TINY["recipe"]})["ok"]
    finally:
        held.close()
    assert held.process.poll() is not None and not held.log.exists()
    with pytest.raises(ExternalProcessError, match="expected a running Blender"):
        held.ask({"op": "render"})


def test_one_session_per_scene_and_all_closed_together():
    skip_without_bpy()
    first = cycles_session.session("k", _TINY, "t")
    assert cycles_session.session("k", _TINY, "t") is first
    cycles_session.close_sessions()
    assert first.process.poll() is not None
    assert cycles_session.session("k", _TINY, "t") is not first
    cycles_session.close_sessions()
