"""Issue 28, item 1: an output's name decides its format, for every command that writes images.

``.png`` writes a PNG, ``.exr`` an EXR, any other suffix is refused before any work in one line
with exit code 2 naming the accepted suffixes, and nothing is written. The rule lives in
:func:`bnerr.io.image_format` / :func:`bnerr.io.write_image`.
"""

import pytest
import torch

from benchmarks.cli import main
from bnerr.errors import FileFormatError
from bnerr.frame import Frame
from bnerr.io import IMAGE_SUFFIXES, image_format, read_frame, write_frame, write_image

pytestmark = pytest.mark.usefixtures("one_thread")

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
EXR_MAGIC = b"\x76\x2f\x31\x01"
MAGIC = {".png": PNG_MAGIC, ".exr": EXR_MAGIC}


def _frame():
    g = torch.Generator().manual_seed(0)
    return Frame(color=torch.rand(3, 6, 8, generator=g), timings={"render": 1.0})


def _frame_file(tmp_path):
    path = tmp_path / "frame.exr"
    write_frame(path, _frame())
    return path


def _one_line_refusal(capsys, code, folder, before):
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert (
        ".exr" in err
        and ".png" in err
        and "expected a name ending in" in err
        or ("expected a folder" in err)
    )
    assert sorted(p.name for p in folder.iterdir()) == before  # nothing written
    return err


def test_image_format_accepts_the_listed_suffixes_and_refuses_the_rest():
    assert IMAGE_SUFFIXES == (".exr", ".png")
    assert image_format("a/b.PNG") == ".png"
    assert image_format("b.exr") == ".exr"
    for bad in ("b.tiff", "b", "b.png.bak", "b.jpg"):
        with pytest.raises(FileFormatError, match=r"expected a name ending in \.exr or \.png"):
            image_format(bad)
    with pytest.raises(FileFormatError, match="--out b: .* got no suffix"):
        image_format("b")
    assert image_format("m.npy", "--out", (".npy", *IMAGE_SUFFIXES)) == ".npy"


@pytest.mark.parametrize("suffix", IMAGE_SUFFIXES)
def test_write_image_writes_the_format_its_name_says(tmp_path, suffix):
    path = tmp_path / f"x{suffix}"
    write_image(path, _frame())
    assert path.read_bytes().startswith(MAGIC[suffix])
    with pytest.raises(FileFormatError):
        write_image(tmp_path / "x.tiff", _frame())
    assert not (tmp_path / "x.tiff").exists()


@pytest.mark.parametrize("suffix", IMAGE_SUFFIXES)
def test_denoise_writes_png_or_exr_by_the_output_name(tmp_path, suffix):
    source = _frame_file(tmp_path)
    out = tmp_path / f"result{suffix}"
    args = ["denoise", "--denoiser", "gaussian", "--in", str(source), "--out", str(out)]
    assert main(args) == 0
    assert out.read_bytes().startswith(MAGIC[suffix])
    if suffix == ".exr":
        assert read_frame(out).width == 8


@pytest.mark.parametrize("name", ["result.tiff", "result", "result.jpg"])
def test_denoise_refuses_other_names_before_any_work(tmp_path, capsys, name):
    source = tmp_path / "missing.exr"  # never read: the name is refused first
    before = sorted(p.name for p in tmp_path.iterdir())
    args = ["denoise", "--denoiser", "gaussian", "--in", str(source), "--out", str(tmp_path / name)]
    err = _one_line_refusal(capsys, main(args), tmp_path, before)
    assert "missing.exr" not in err.split(":")[1]


@pytest.mark.parametrize("suffix", [".png", ".exr", ".npy"])
def test_mask_writes_the_format_its_name_says(tmp_path, suffix):
    out = tmp_path / f"m{suffix}"
    assert main(["mask", "--size", "8", "--out", str(out)]) == 0
    if suffix in MAGIC:
        assert out.read_bytes().startswith(MAGIC[suffix])
    else:
        assert out.read_bytes().startswith(b"\x93NUMPY")


def test_mask_refuses_other_names_before_any_work(tmp_path, capsys):
    before = sorted(p.name for p in tmp_path.iterdir())
    code = main(["mask", "--size", "8", "--out", str(tmp_path / "m.tiff")])
    err = _one_line_refusal(capsys, code, tmp_path, before)
    assert ".npy" in err


@pytest.mark.parametrize("suffix", IMAGE_SUFFIXES)
def test_render_refuses_an_image_name_for_its_output_folder(tmp_path, capsys, suffix):
    before = sorted(p.name for p in tmp_path.iterdir())
    args = ["render", "--scene", "direct", "--res", "4x4", "--spp", "1"]
    code = main([*args, "--out", str(tmp_path / f"frame{suffix}")])
    _one_line_refusal(capsys, code, tmp_path, before)


def test_render_writes_one_exr_and_one_png_per_frame(tmp_path):
    args = ["render", "--scene", "direct", "--res", "4x4", "--spp", "1", "--out", str(tmp_path)]
    assert main(args) == 0
    assert (tmp_path / "direct_0000.exr").read_bytes().startswith(EXR_MAGIC)
    assert (tmp_path / "direct_0000.png").read_bytes().startswith(PNG_MAGIC)
