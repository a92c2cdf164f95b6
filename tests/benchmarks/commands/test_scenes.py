"""Tests for ``bnerr scenes`` (benchmarks.commands.scenes)."""

from benchmarks.cli import main
from benchmarks.commands.scenes import table
from renderers import SCENES, get_scene


def test_table_lists_every_scene_with_its_dimensions():
    rows = table()
    assert [r["name"] for r in rows] == list(SCENES)
    for row in rows:
        scene = get_scene(row["name"])
        assert (row["D"], row["depth"], row["lights"]) == (
            scene.dimensions,
            scene.max_depth,
            len(scene.lights),
        )


def test_prints_the_table_and_a_layout(capsys):
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    assert "direct" in out and "medium" in out and "what it models" in out
    assert main(["scenes", "--layout", "medium"]) == 0
    out = capsys.readouterr().out
    assert "D = 40" in out and "39: vertex 7 light v" in out
    assert main(["scenes", "--layout", "nope"]) == 2
