"""Tests of bnerr.io: exact EXR round trips and channel names, frames, PNG previews, atomic
writes, and the errors for missing, corrupt and malformed files and bad arguments."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
import torch
from skimage.io import imread

from bnerr.errors import DtypeError, FileFormatError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.frame import Frame
from bnerr.io import (
    CHANNELS,
    atomic_write,
    exr_size,
    read_exr,
    read_frame,
    write_exr,
    write_frame,
    write_png,
)
from bnerr.outputs import OutputPathError

H, W = 6, 9


def _rand(c: int, seed: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.randn(c, H, W, generator=g) * 10.0**seed


def _frame() -> Frame:
    return Frame(
        color=_rand(3, 0),
        albedo=_rand(3, 1),
        normal=_rand(3, 2),
        depth=_rand(1, 3),
        motion=_rand(2, 4),
        object_id=torch.arange(H * W, dtype=torch.float32).reshape(1, H, W) - 1,
        variance=_rand(3, 5),
        timings={"render": 12.25, "permute": 0.5},
    )


def _bits(t: torch.Tensor) -> torch.Tensor:
    return t.contiguous().view(torch.int32)


def _special() -> torch.Tensor:
    """Values a float format can get wrong: signed zero, infinities, NaN, denormals, extremes."""
    values = [0.0, -0.0, float("inf"), -float("inf"), float("nan"), 1e-45, -1e-40, 3.4e38, 1 / 3]
    flat = torch.tensor(values * (2 * H * W // len(values) + 1), dtype=torch.float32)
    return flat[: 2 * H * W].reshape(2, H, W)


def test_exr_round_trip_is_bit_exact(tmp_path):
    buffers = {name: _rand(len(channels), i) for i, (name, channels) in enumerate(CHANNELS.items())}
    buffers["special"] = _special()
    buffers["transposed"] = _rand(4, 7).transpose(1, 2).contiguous().transpose(1, 2)  # strided
    write_exr(tmp_path / "a.exr", buffers)
    back = read_exr(tmp_path / "a.exr")
    assert sorted(back) == sorted(buffers)
    for name, tensor in buffers.items():
        assert back[name].dtype == torch.float32 and back[name].shape == tensor.shape
        assert torch.equal(_bits(back[name]), _bits(tensor)), name


def test_exr_channel_names_follow_the_documented_layers(tmp_path):
    buffers = {"color": _rand(3, 0), "normal": _rand(3, 1), "depth": _rand(1, 2)}
    buffers["extra"] = _rand(2, 3)
    write_exr(tmp_path / "a.exr", buffers)
    names = set(OpenEXR.File(str(tmp_path / "a.exr"), separate_channels=True).channels())
    assert names == {
        "R", "G", "B", "normal.X", "normal.Y", "normal.Z", "depth.Z", "extra.0", "extra.1"
    }  # fmt: skip
    # the planes land in the documented channels, in tensor order
    raw = OpenEXR.File(str(tmp_path / "a.exr"), separate_channels=True).channels()
    assert np.array_equal(raw["normal.Y"].pixels, buffers["normal"][1].numpy())
    assert np.array_equal(raw["extra.1"].pixels, buffers["extra"][1].numpy())


def test_read_exr_orders_channels_of_files_written_elsewhere(tmp_path):
    g = np.random.default_rng(0)
    planes = {
        name: g.random((H, W)).astype(np.float32)
        for name in ["A", "B", "G", "R", "Y", "diffuse.B", "diffuse.G", "diffuse.R", "aov.10",
                     "aov.2", "uv.V", "uv.U", "misc.b", "misc.a"]
    }  # fmt: skip
    planes["half.X"] = g.random((H, W)).astype(np.float16)
    OpenEXR.File({}, dict(planes)).write(str(tmp_path / "foreign.exr"))
    back = read_exr(tmp_path / "foreign.exr")
    expect = {
        "color": ["R", "G", "B"], "A": ["A"], "Y": ["Y"], "diffuse": ["diffuse.R", "diffuse.G",
        "diffuse.B"], "aov": ["aov.2", "aov.10"], "uv": ["uv.U", "uv.V"], "misc": ["misc.a",
        "misc.b"], "half": ["half.X"],
    }  # fmt: skip
    assert sorted(back) == sorted(expect)
    for name, channels in expect.items():
        want = np.stack([planes[c].astype(np.float32) for c in channels])
        assert back[name].dtype == torch.float32 and np.array_equal(back[name].numpy(), want)


def test_frame_round_trip_keeps_every_buffer_and_the_timings(tmp_path):
    frame = _frame()
    write_frame(tmp_path / "f.exr", frame)
    back = read_frame(tmp_path / "f.exr")
    assert back.timings == frame.timings
    for name, tensor in frame.buffers().items():
        assert torch.equal(_bits(getattr(back, name)), _bits(tensor)), name


def test_read_frame_accepts_a_plain_rgb_file_and_ignores_foreign_layers(tmp_path):
    write_exr(tmp_path / "c.exr", {"color": _rand(3, 0), "extra": _rand(5, 1)})
    frame = read_frame(tmp_path / "c.exr")
    assert torch.equal(frame.color, _rand(3, 0)) and frame.albedo is None and frame.timings == {}


# ------------------------------------------------------------------------------------------------
# Missing, corrupt and malformed files


def test_missing_file_is_a_file_format_error(tmp_path):
    with pytest.raises(FileFormatError, match=r"nope\.exr: no such file"):
        read_exr(tmp_path / "nope.exr")
    with pytest.raises(FileFormatError, match=r"nope\.exr: no such file"):
        read_frame(tmp_path / "nope.exr")


@pytest.mark.parametrize("payload", [b"", b"garbage bytes " * 50, b"\x76\x2f\x31\x01" + b"\0" * 64])
def test_non_exr_bytes_are_a_file_format_error(tmp_path, payload):
    path = tmp_path / "bad.exr"
    path.write_bytes(payload)
    with pytest.raises(FileFormatError, match=r"bad\.exr: (not an OpenEXR file|corrupt)"):
        read_exr(path)


@pytest.mark.parametrize("keep", [0.99, 0.75, 0.5, 0.1])
def test_truncated_exr_is_a_file_format_error(tmp_path, keep):
    path = tmp_path / "cut.exr"
    write_exr(path, {"color": _rand(3, 0), "depth": _rand(1, 1)})
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])
    with pytest.raises(FileFormatError, match=r"cut\.exr: corrupt or truncated OpenEXR file"):
        read_exr(path)


def test_frame_without_rgb_is_a_file_format_error(tmp_path):
    write_exr(tmp_path / "d.exr", {"depth": _rand(1, 0), "albedo": _rand(3, 1)})
    with pytest.raises(
        FileFormatError, match=r"d\.exr: expected channels R, G, B .* got layers albedo, depth"
    ):
        read_frame(tmp_path / "d.exr")
    # an incomplete RGB is not a color either
    OpenEXR.File({}, {"R": np.zeros((H, W), np.float32), "G": np.zeros((H, W), np.float32)}).write(
        str(tmp_path / "rg.exr")
    )
    assert sorted(read_exr(tmp_path / "rg.exr")) == ["G", "R"]
    with pytest.raises(FileFormatError, match=r"rg\.exr: expected channels R, G, B"):
        read_frame(tmp_path / "rg.exr")


def test_known_layer_with_wrong_channels_and_bad_timings_are_file_format_errors(tmp_path):
    planes = {c: np.zeros((H, W), np.float32) for c in ["R", "G", "B", "normal.X", "normal.Y"]}
    OpenEXR.File({}, planes).write(str(tmp_path / "n.exr"))
    with pytest.raises(
        FileFormatError, match=r"n\.exr: layer 'normal' expected channels X, Y, Z, got X, Y"
    ):
        read_exr(tmp_path / "n.exr")
    write_exr(tmp_path / "t.exr", {"color": _rand(3, 0)}, {"bnerr_timings": json.dumps([1, 2])})
    with pytest.raises(FileFormatError, match=r"t\.exr: header attribute bnerr_timings"):
        read_frame(tmp_path / "t.exr")


# ------------------------------------------------------------------------------------------------
# Atomic writes


def test_atomic_write_replaces_on_success_and_leaves_nothing_on_failure(tmp_path):
    path = tmp_path / "out.txt"
    path.write_text("old")
    with atomic_write(path) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".txt" and tmp != path
        tmp.write_text("new")
        assert path.read_text() == "old"  # not visible until the block ends
    assert path.read_text() == "new"
    with pytest.raises(RuntimeError, match="boom"):
        with atomic_write(path) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert path.read_text() == "new" and sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_atomic_write_errors(tmp_path):
    with pytest.raises(FileFormatError, match=r"out\.txt: the writer created nothing"):
        with atomic_write(tmp_path / "out.txt"):
            pass
    with pytest.raises(FileFormatError, match=r"x\.exr: cannot write, folder .*missing"):
        with atomic_write(tmp_path / "missing" / "x.exr"):
            pass
    with pytest.raises(DtypeError, match="path: expected a str or os.PathLike, got int"):
        with atomic_write(3):
            pass


def test_failed_exr_write_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "keep.exr"
    write_exr(path, {"color": _rand(3, 0)})
    before = path.read_bytes()

    def broken_write(self, name):  # OpenEXR's own words on a full disk
        with open(name, "wb") as f:
            f.write(b"partial")
        raise RuntimeError(
            f'Failed to write pixel data to image file "{name}". No space left on device.'
        )

    monkeypatch.setattr(OpenEXR.File, "write", broken_write)
    # one line naming the file the caller asked for (not the temporary), an OSError the CLI prints
    with pytest.raises(OutputPathError) as err:
        write_exr(path, {"color": _rand(3, 1)})
    assert str(err.value) == f"{path}: expected a writable file, got No space left on device"
    assert path.read_bytes() == before and len(list(tmp_path.iterdir())) == 1


# ------------------------------------------------------------------------------------------------
# Bad arguments to the writers


def test_write_exr_rejects_bad_buffers(tmp_path):
    path = tmp_path / "x.exr"
    with pytest.raises(ShapeError, match=r"buffers\['color'\]: expected 3 dimensions \[3, H, W\]"):
        write_exr(path, {"color": torch.zeros(H, W)})
    with pytest.raises(ShapeError, match=r"buffers\['depth'\]: expected shape \[1, H, W\]"):
        write_exr(path, {"depth": torch.zeros(2, H, W)})
    with pytest.raises(ShapeError, match=r"buffers\['b'\]: expected H x W = 6 x 9 like the first"):
        write_exr(path, {"a": torch.zeros(1, H, W), "b": torch.zeros(1, H, W + 1)})
    with pytest.raises(ShapeError, match=r"buffers\['a'\]: expected H, W >= 1"):
        write_exr(path, {"a": torch.zeros(1, 0, W)})
    with pytest.raises(DtypeError, match=r"buffers\['a'\]: expected dtype float32, got float64"):
        write_exr(path, {"a": torch.zeros(1, H, W, dtype=torch.float64)})
    with pytest.raises(DtypeError, match="buffers: expected a non-empty dict"):
        write_exr(path, {})
    with pytest.raises(DtypeError, match="buffers: expected non-empty str names, got 3"):
        write_exr(path, {3: torch.zeros(1, H, W)})
    with pytest.raises(DtypeError, match="attributes: expected str -> str"):
        write_exr(path, {"a": torch.zeros(1, H, W)}, {"k": 1})
    with pytest.raises(DtypeError, match="frame: expected a bnerr.frame.Frame, got dict"):
        write_frame(path, {"color": torch.zeros(3, H, W)})
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------------------------
# PNG previews


def _srgb8(linear: float) -> int:
    v = 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055
    return round(v * 255)


def test_write_png_tone_maps_exposes_and_encodes_srgb(tmp_path):
    values = torch.tensor([0.0, 0.25, 0.5, 1.0, 4.0, -1.0, float("nan"), float("inf")])
    color = values.reshape(1, 1, -1).expand(3, 2, -1).contiguous()
    for tonemap, exposure, curve in (
        ("clamp", 0.0, lambda x: min(max(x, 0.0), 1.0)),
        ("clamp", 1.0, lambda x: min(max(2 * x, 0.0), 1.0)),
        ("reinhard", 0.0, lambda x: max(x, 0.0) / (1 + max(x, 0.0))),
    ):
        write_png(tmp_path / "p.png", color, exposure=exposure, tonemap=tonemap)
        image = imread(tmp_path / "p.png")
        assert image.shape == (2, values.numel(), 3) and image.dtype == np.uint8
        want = [_srgb8(curve(v)) for v in values[:6].tolist()] + [0, 255]  # NaN -> 0, inf -> 255
        assert image[0, :, 0].tolist() == want, tonemap
    write_png(tmp_path / "aces.png", color)
    aces = imread(tmp_path / "aces.png")[0, :6, 1].astype(int).tolist()
    assert aces[0] == 0 and aces[5] == 0 and aces == sorted(aces[:5]) + [0] and aces[4] < 255


def test_write_png_bytes_are_those_scikit_image_wrote(tmp_path):
    """The encoder moved from scikit-image's imsave to Pillow (a faster import): the files of a
    given image stay byte-identical."""
    from skimage.io import imsave

    color = torch.rand(3, 37, 53, generator=torch.Generator().manual_seed(5)) * 3
    write_png(tmp_path / "new.png", color)
    imsave(tmp_path / "old.png", imread(tmp_path / "new.png"), check_contrast=False)
    assert (tmp_path / "new.png").read_bytes() == (tmp_path / "old.png").read_bytes()


def test_write_png_rejects_bad_arguments(tmp_path):
    path = tmp_path / "p.png"
    with pytest.raises(ShapeError, match=r"color: expected shape \[3, H, W\] with size 3"):
        write_png(path, torch.zeros(4, H, W))
    with pytest.raises(DtypeError, match="color: expected dtype float32, got float16"):
        write_png(path, torch.zeros(3, H, W, dtype=torch.float16))
    with pytest.raises(UnknownNameError, match="unknown tonemap 'filmic': expected one of aces"):
        write_png(path, torch.zeros(3, H, W), tonemap="filmic")
    with pytest.raises(ValueRangeError, match=r"exposure: expected a value in \[-64.0, 64.0\]"):
        write_png(path, torch.zeros(3, H, W), exposure=100)
    assert list(tmp_path.iterdir()) == []


# -- atomic writes: errors are the writer's, temporaries are recognisable -------------------------


def test_atomic_write_cleanup_never_masks_the_original_error(tmp_path, monkeypatch):
    # issue 18: on a read-only file system the cleanup's own error hid the real one.
    def refuse(self, missing_ok=False):
        raise OSError(30, "Read-only file system")

    monkeypatch.setattr(Path, "unlink", refuse)
    with pytest.raises(ValueError, match="the writer's own error"):
        with atomic_write(tmp_path / "a.exr") as tmp:
            tmp.write_bytes(b"partial")
            raise ValueError("the writer's own error")


def test_atomic_write_turns_an_os_error_into_one_line_naming_the_file(tmp_path):
    with pytest.raises(OutputPathError, match=r"a\.exr: expected a writable file, got Permission"):
        with atomic_write(tmp_path / "a.exr"):
            raise PermissionError(13, "Permission denied")
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_temporaries_carry_the_writer_pid(tmp_path):
    with atomic_write(tmp_path / "w.pt") as tmp:
        assert tmp.name.startswith(f".w.pt.bnerr-tmp-{os.getpid()}-")
        assert tmp.suffix == ".pt"
        tmp.write_bytes(b"x")
    assert [p.name for p in tmp_path.iterdir()] == ["w.pt"]


def test_exr_size_reads_the_header_alone(tmp_path):
    write_exr(tmp_path / "a.exr", {"color": torch.zeros(3, 5, 7)}, {"note": "x" * 300})
    assert exr_size(tmp_path / "a.exr") == (7, 5)
    (tmp_path / "b.exr").write_bytes(b"not an exr at all")
    with pytest.raises(FileFormatError, match="no EXR magic number"):
        exr_size(tmp_path / "b.exr")
    (tmp_path / "c.exr").write_bytes((tmp_path / "a.exr").read_bytes()[:30])
    with pytest.raises(FileFormatError, match="expected an OpenEXR header"):
        exr_size(tmp_path / "c.exr")


def test_openexrs_own_lines_on_a_truncated_file_are_folded_into_the_one_error(tmp_path, capfd):
    """Issue 54: OpenEXR printed its own lines (the C library's to stderr, the binding's
    "Warning: Exception raised reading pixel data" to stdout) before bnerr's one line; they are
    caught and quoted in the error instead, and nothing reaches the process's stdout or stderr."""
    path = tmp_path / "cut.exr"
    write_exr(path, {"color": _rand(3, 0)})
    path.write_bytes(path.read_bytes()[:400])
    capfd.readouterr()
    with pytest.raises(FileFormatError) as caught:
        read_exr(path)
    out, err = capfd.readouterr()
    assert (out, err) == ("", "")
    message = str(caught.value)
    assert "\n" not in message and "OpenEXR said: " in message
    assert message.startswith(f"{path}: corrupt or truncated OpenEXR file")
    print("after")  # the process's own streams work again
    assert capfd.readouterr().out == "after\n"


def test_a_clean_read_prints_nothing_and_warns_nothing(tmp_path, capfd, recwarn):
    path = tmp_path / "fine.exr"
    write_exr(path, {"color": _rand(3, 0)})
    capfd.readouterr()
    assert read_exr(path)["color"].shape == (3, H, W)
    assert capfd.readouterr() == ("", "") and not recwarn.list
