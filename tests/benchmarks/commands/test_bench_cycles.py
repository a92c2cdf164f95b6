"""``bnerr bench`` on Cycles scenes: docs/CYCLES.md runs as written (a scene built by code, saved
as a ``.blend`` file and measured as a user's file at 32 x 32, with Cycles' own denoiser), and the
Cycles door refuses each bad input in one line, with exit status 2, writing nothing."""

import json
import re
import runpy

import pytest

from renderers.cycles.session import close_sessions
from tests._cli import bnerr_in_process
from tests._cycles import skip_without_bpy
from tests._paths import ROOT

PAGE = ROOT / "docs" / "CYCLES.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", PAGE.read_text(), flags=re.S | re.M)


@pytest.mark.usefixtures("one_thread")
def test_the_page_runs_as_written(tmp_path, capsys, monkeypatch):
    skip_without_bpy()
    (python,) = _blocks("python")
    (commands,) = _blocks("sh")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "save.py").write_text(python)
    runpy.run_path("save.py", run_name="__main__")
    assert (tmp_path / "product.blend").read_bytes()[:2] in (b"BL", b"\x28\xb5")
    for line in commands.strip().splitlines():
        code, _, err = bnerr_in_process(line, capsys, tmp_path)
        assert code == 0, err
    out = tmp_path / "product-results"
    rows = [json.loads(line)["cell"] for line in (out / "cells.jsonl").read_text().splitlines()]
    assert {r["strategy"] for r in rows} == {"white", "blue_noise"}
    assert {r["denoiser"] for r in rows} >= {"cycles_oidn", "gaussian"}
    assert {r["scene"] for r in rows} == {"product"}
    assert "| blue_noise |" in (out / "table.md").read_text()
    record = json.loads((out / "cycles_scenes.json").read_text())  # Blender and what bnerr set
    product = record["scenes"]["product"]
    assert product["blender"].startswith("4.5") and product["camera"] == "camera"
    assert product["settings"]["sampling_pattern"] == "AUTOMATIC"  # the file's, before bnerr's
    assert record["bnerr_sets"]["use_animated_seed"] is False


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        ("--scenes direct --strategies white blue_noise", "expected a Cycles scene"),
        ("--scenes gone.blend", r"gone\.blend: expected a readable \.blend file"),
        ("--scenes text.blend", r"text\.blend: expected a \.blend file"),
        ("--scenes text.blend --strategies white temporal", "per-pixel seeds"),
    ],
)
def test_the_door_refuses_in_one_line_and_writes_nothing(argv, message, tmp_path, capsys):
    (tmp_path / "text.blend").write_text("a text file")
    code, _, err = bnerr_in_process(f"bnerr bench {argv} --out out --quiet", capsys, tmp_path)
    assert code == 2 and re.search(message, err), err
    assert len(err.strip().splitlines()) <= 2  # the note on left-out strategies, and the error
    assert not (tmp_path / "out").exists()


def test_no_bpy_is_refused_in_one_line_and_writes_nothing(tmp_path, capsys, monkeypatch):
    close_sessions()  # a Blender this process started for another test would be reused
    monkeypatch.setenv("BNERR_BPY_PYTHON", str(tmp_path / "no-python"))
    argv = "bnerr bench --scenes cycles_product --strategies white blue_noise --out out"
    code, _, err = bnerr_in_process(argv, capsys, tmp_path)
    assert code == 2 and "expected the optional extra 'cycles'" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "out").exists()
