"""``bnerr render`` with plug-ins on its command line, in a subprocess: a scene file, a strategy
from ``file.py:Name`` and a sampler from ``file.py:Name`` (``--sampler`` takes plug-ins beside
white and owen_sobol); the shipped ``examples/scenes/direct.toml`` renders as ``direct`` bit for
bit; an unknown ``--sampler`` is a one-line error naming the samplers it takes."""

import textwrap

import torch

from benchmarks.cli import main
from bnerr.io import read_frame
from tests._paths import EXAMPLES, bnerr_cli
from tests._plugin_sources import SAMPLER, STRATEGY

TINY = ("--res", "16x12", "--spp", "1", "--no-progress")


def test_render_takes_a_scene_file_a_strategy_file_and_a_sampler_file(tmp_path):
    (tmp_path / "strat.py").write_text(textwrap.dedent(STRATEGY))
    (tmp_path / "samp.py").write_text(textwrap.dedent(SAMPLER))
    scene = (EXAMPLES / "scenes" / "direct.toml").read_text()
    (tmp_path / "mine.toml").write_text(scene.replace('name = "direct"', 'name = "mine_scene"'))
    done = bnerr_cli(
        "render", "--scene", str(tmp_path / "mine.toml"), "--strategy",
        f"{tmp_path / 'strat.py'}:Mine", "--sampler", f"{tmp_path / 'samp.py'}:Hashy",
        "--frames", "2", "--out", str(tmp_path / "out"), *TINY,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    names = sorted(p.name for p in (tmp_path / "out").glob("*.exr"))
    assert names == ["mine_scene_0000.exr", "mine_scene_0001.exr"]
    frame = read_frame(tmp_path / "out" / names[0])
    assert frame.color.shape == (3, 12, 16) and bool(frame.color.isfinite().all())


def test_the_shipped_scene_file_renders_as_the_shipped_scene(tmp_path):
    scene_file = str(EXAMPLES / "scenes" / "direct.toml")
    assert main(["render", "--scene", scene_file, "--out", str(tmp_path / "file"), *TINY]) == 0
    assert main(["render", "--scene", "direct", "--out", str(tmp_path / "name"), *TINY]) == 0
    from_file = read_frame(tmp_path / "file" / "direct_0000.exr")
    shipped = read_frame(tmp_path / "name" / "direct_0000.exr")
    for name, value in shipped.buffers().items():
        assert torch.equal(from_file.buffers()[name], value), name


def test_an_unknown_sampler_names_the_samplers_it_takes(tmp_path, capsys):
    args = ["render", "--scene", "direct", "--sampler", "zsobol", "--out", str(tmp_path), *TINY]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert "unknown --sampler 'zsobol': expected one of owen_sobol, white" in err
    assert not list(tmp_path.iterdir())
