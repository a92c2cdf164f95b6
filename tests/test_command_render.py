"""Tests for ``bnerr render`` (benchmarks.commands.render)."""

import pytest
import torch

from benchmarks.cli import main
from benchmarks.commands.render import parse_resolution
from bnerr.errors import DtypeError, ValueRangeError
from bnerr.io import read_frame

pytestmark = pytest.mark.usefixtures("one_thread")


def test_writes_one_exr_and_png_per_frame(tmp_path, capsys):
    code = main(
        [
            "render",
            "--scene",
            "snooker",
            "--res",
            "12x8",
            "--spp",
            "2",
            "--frames",
            "2",
            "--start",
            "3",
            "--sampler",
            "owen_sobol",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 0
    names = sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("."))
    assert names == ["snooker_0003.exr", "snooker_0003.png", "snooker_0004.exr", "snooker_0004.png"]
    frame = read_frame(tmp_path / "snooker_0004.exr")
    assert frame.color.shape == (3, 8, 12)
    for name in ("albedo", "normal", "depth", "motion", "object_id", "variance"):
        assert getattr(frame, name) is not None, name
    assert frame.timings["render"] > 0
    assert "M samples/s" in capsys.readouterr().out
    a, b = read_frame(tmp_path / "snooker_0003.exr"), frame
    assert not torch.equal(a.color, b.color)  # every frame has its own seeds


def test_static_frames_do_not_move(tmp_path):
    assert (
        main(
            [
                "render",
                "--scene",
                "direct",
                "--res",
                "8x8",
                "--spp",
                "1",
                "--frames",
                "2",
                "--static",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    assert read_frame(tmp_path / "direct_0001.exr").motion.abs().max() < 1e-3


def test_bad_arguments_are_reported(tmp_path, capsys):
    assert main(["render", "--scene", "teapot", "--out", str(tmp_path)]) == 2
    assert "unknown scene 'teapot'" in capsys.readouterr().err
    assert main(["render", "--scene", "direct", "--res", "0x4", "--out", str(tmp_path)]) == 2
    assert "--res: expected width and height >= 1, got 0x4" in capsys.readouterr().err
    assert main(["render", "--scene", "direct", "--spp", "-1", "--out", str(tmp_path)]) == 2
    assert "--spp: expected an integer >= 1, got -1" in capsys.readouterr().err


def test_parse_resolution():
    assert parse_resolution("320x240") == (320, 240)
    assert parse_resolution("64X32") == (64, 32)
    with pytest.raises(DtypeError, match="--res: expected WxH with integers"):
        parse_resolution("320")
    with pytest.raises(DtypeError, match="--res: expected WxH with integers"):
        parse_resolution("ax3")
    with pytest.raises(ValueRangeError, match="--res: expected width and height >= 1"):
        parse_resolution("4x-2")


# -- issue 18: sizes and output paths checked before any work; one writer --------------------------


def test_an_absurd_resolution_is_refused_before_allocating(tmp_path, capsys, monkeypatch):
    import renderers

    monkeypatch.setattr(renderers, "render", lambda *a, **k: pytest.fail("rendered"))
    args = ["render", "--scene", "direct", "--res", "40000x40000", "--out", str(tmp_path / "o")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "--res 40000x40000: expected a size that fits in memory" in err
    assert "GiB available), got an estimate of" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("file", "expected a folder, got an existing file"),
        ("file/sub", "an existing file"),
        ("/proc/bnerr-render", "expected a folder that can be created"),
        ("/proc/self", "expected a writable folder"),
    ],
)
def test_bad_output_folders_fail_before_rendering_in_one_line(tmp_path, capsys, out, message):
    (tmp_path / "file").write_text("x")
    path = out if out.startswith("/") else str(tmp_path / out)
    assert main(["render", "--scene", "direct", "--res", "4x4", "--out", path]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_a_second_render_into_the_same_folder_refuses(tmp_path, capsys):
    from bnerr.outputs import output_lock

    with output_lock(tmp_path, "bnerr render"):
        args = ["render", "--scene", "direct", "--res", "4x4", "--spp", "1", "--out", str(tmp_path)]
        assert main(args) == 2
    assert "another bnerr render holds its lock" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.exr"))
