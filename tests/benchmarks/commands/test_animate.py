"""Tests for ``bnerr animate`` (benchmarks.commands.animate): files written, one-line errors."""

import imageio.v2 as imageio
import imageio.v3 as iio
import pytest

from benchmarks.cli import main
from benchmarks.commands.animate import DEFAULT_PARAMS, params_file
from denoisers.tuning import ParamStore

pytestmark = pytest.mark.usefixtures("one_thread")


def _args(tmp_path, *extra):
    ParamStore().save(tmp_path / "tuned_params.json")  # no entries: the denoiser's defaults
    return [
        "animate",
        "--scene",
        "direct",
        "--strategies",
        "white,temporal",
        "--frames",
        "3",
        "--warmup",
        "1",
        "--res",
        "32x24",
        "--spp",
        "1",
        "--reference-spp",
        "4",
        "--gif-crop",
        "16",
        "--gif-frames",
        "2",
        "--params",
        str(tmp_path),  # a bnerr bench folder holding tuned_params.json
        "--cache",
        str(tmp_path / "cache"),
        *extra,
    ]


def test_writes_mp4_and_gif_per_scene(tmp_path, capsys):
    out = tmp_path / "anim"
    assert main(_args(tmp_path, "--out", str(out), "--threads", "1")) == 0
    printed = capsys.readouterr().out
    assert "direct: " in printed and "1 animation(s) written" in printed
    names = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    assert names == ["README.md", "direct.gif", "direct.mp4"]
    readme = (out / "README.md").read_text()
    # The folder says how it was made: a command that bnerr animate accepts, and each file.
    assert "    bnerr animate --scenes direct --strategies " in readme
    assert "| direct | " in readme and "KiB" in readme
    with imageio.get_reader(out / "direct.mp4", format="FFMPEG") as reader:
        frames = list(reader.iter_data())
    assert len(frames) == 3
    # caption 2 x 13 + header 14 + rows 2 x 24 = 88, padded to 96; 14 + 3 x 32 = 110 -> 112
    assert frames[0].shape == (96, 112, 3)
    gif = iio.imread(out / "direct.gif", index=None)
    assert gif.shape[:3] == (2, 2 * 13 + 14 + 2 * 16, 14 + 3 * 16)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--scene", "nope"], "unknown scene 'nope'"),
        (["--strategies", "white,nope"], "unknown strategy 'nope'"),
        (["--denoiser", "nope"], "unknown denoiser 'nope'"),
        (["--res", "32by24"], "--res: expected WxH"),
        (["--res", "0x24"], "--res: expected width and height >= 1"),
        (["--frames", "0"], "frames: expected an integer >= 1"),
        (["--threads", "0"], "--threads: expected an integer >= 1"),
        (["--params", "typo.json"], "--params typo.json: expected a tuned_params.json or a bnerr"),
        (["--params", "/"], "--params /: expected a tuned_params.json or a bnerr bench folder"),
    ],
)
def test_bad_input_is_one_line(tmp_path, capsys, extra, message):
    assert main(_args(tmp_path, "--out", str(tmp_path / "anim"), *extra)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("bnerr animate: error: ")
    assert message in err
    assert not (tmp_path / "cache").exists()  # refused before any render


def test_unwritable_out_is_one_line(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    for out in (blocker, blocker / "sub", "/proc/bnerr-animate"):
        assert main(_args(tmp_path, "--out", str(out))) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("bnerr animate: error: --out ")
    assert not (tmp_path / "cache").exists()


@pytest.mark.parametrize("garbage", [b"", b'{"format": "bnerr-tun', b'{"format": "other"}'])
def test_a_corrupted_params_file_is_one_line_before_any_render(tmp_path, capsys, garbage):
    bad = tmp_path / "bad.json"
    bad.write_bytes(garbage)
    assert main(_args(tmp_path, "--out", str(tmp_path / "anim"), "--params", str(bad))) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"bnerr animate: error: {bad}: expected")
    assert not (tmp_path / "cache").exists()


def test_params_omitted_is_the_quality_suites_file_or_the_defaults(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert params_file(None) is None
    assert "the denoiser runs with its defaults" in capsys.readouterr().out
    DEFAULT_PARAMS.parent.mkdir(parents=True)
    ParamStore().save(DEFAULT_PARAMS)
    assert params_file(None) == DEFAULT_PARAMS
    assert params_file(DEFAULT_PARAMS.parent) == DEFAULT_PARAMS  # the folder holding it
