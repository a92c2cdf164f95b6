"""Tests of the frame folder ``bnerr eval`` reads (benchmarks.commands.eval.frame_folder): the
manifest's keys and values, the files it implies checked before any pixel is read (missing, outside
the folder, another size, however large the header claims), non-finite pixels, and the auxiliary
buffers read from layers or sibling files."""

import os
import struct

import pytest
import torch

from benchmarks.commands.eval.frame_folder import (
    MANIFEST_KEYS,
    FrameFolder,
    check_folder,
    frame_name,
    load_manifest,
    parse_manifest,
    reference_frames,
)
from bnerr.errors import (
    FileFormatError,
    NonFiniteError,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
)
from bnerr.io import write_exr
from tests._frame_folders import SYNTHETIC, synthetic_folder, toml_text


def _check(root):
    folder = FrameFolder(root)
    m = folder.manifest
    sets = {k: list(m.seed_sets) for k in m.methods}
    check_folder(folder, sets, range(m.warmup, m.warmup + m.frames))
    return folder


def test_a_manifest_reads_with_its_defaults(tmp_path):
    m = load_manifest(synthetic_folder(tmp_path))
    assert (m.scene, m.spp, m.width, m.height, m.frames) == ("gradient", 1, 8, 8, 2)
    assert (m.methods, m.seed_sets, m.warmup, m.buffers) == (("white", "mine"), ("0", "1"), 0, ())
    assert (m.regions, m.static, m.sampler, m.tuning_seed_set) == (
        ("all",),
        False,
        "owen_sobol",
        None,
    )


def test_unknown_keys_are_refused_with_the_known_ones():
    with pytest.raises(UnknownNameError, match="unknown keys colour, fps") as err:
        parse_manifest({**SYNTHETIC, "colour": 1, "fps": 2})
    assert all(key in str(err.value) for key in MANIFEST_KEYS)


def test_the_white_method_and_the_required_keys_are_required():
    with pytest.raises(ValueRangeError, match="expected the white baseline"):
        parse_manifest({**SYNTHETIC, "methods": ["mine", "theirs"]})
    with pytest.raises(ValueRangeError, match="expected the keys spp, frames"):
        parse_manifest({k: v for k, v in SYNTHETIC.items() if k not in ("spp", "frames")})
    with pytest.raises(ValueRangeError, match="reserved"):
        parse_manifest({**SYNTHETIC, "methods": ["white", "reference"]})


@pytest.mark.parametrize("name", ["..", "/tmp", "a/b", ".hidden", ""])
def test_names_that_leave_the_folder_are_refused(name):
    with pytest.raises(ValueRangeError, match="expected plain folder names"):
        parse_manifest({**SYNTHETIC, "seed_sets": ["0", name]})


def test_a_symbolic_link_out_of_the_folder_is_refused(tmp_path):
    outside = synthetic_folder(tmp_path / "outside")
    root = synthetic_folder(tmp_path / "root")
    os.rename(root / "mine" / "1", tmp_path / "moved")
    os.symlink(outside / "mine" / "1", root / "mine" / "1")
    with pytest.raises(ValueRangeError, match="expected a file inside .* got a symbolic link"):
        _check(root)


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("resolution", [8], "expected \\[width, height\\]"),
        ("resolution", [1 << 14, 1 << 14], "expected at most"),
        ("spp", 0, "spp: expected an integer >= 1"),
        ("buffers", ["alpha"], "buffers: expected names from albedo"),
        ("regions", ["edges"], "expected buffers object_id"),
        ("static", "yes", "static: expected true or false"),
        ("tuning_seed_set", "1", "expected a folder apart from the measured seed sets"),
        ("seed_sets", ["0", "0"], "expected distinct names"),
    ],
)
def test_bad_values_are_one_line_each(key, value, match):
    with pytest.raises((ValueRangeError, UnknownNameError), match=match) as err:
        parse_manifest({**SYNTHETIC, key: value})
    assert "\n" not in str(err.value)


def test_coherent_needs_its_buffers_and_the_reference_before_the_first_frame():
    aux = ["albedo", "normal", "depth", "object_id"]
    assert parse_manifest({**SYNTHETIC, "buffers": aux, "warmup": 1}).regions == ("all", "coherent")
    assert parse_manifest({**SYNTHETIC, "buffers": aux}).regions == ("all",)  # no frame before
    assert parse_manifest({**SYNTHETIC, "buffers": aux, "static": True}).regions[-1] == "coherent"
    with pytest.raises(ValueRangeError, match="expected warmup >= 1 or static = true"):
        parse_manifest({**SYNTHETIC, "buffers": aux, "regions": ["coherent"]})
    moving = parse_manifest({**SYNTHETIC, "buffers": aux, "warmup": 2})
    assert reference_frames(moving) == range(1, 4)


def test_missing_frames_and_references_are_one_line_each(tmp_path):
    root = synthetic_folder(tmp_path)
    (root / "mine" / "1" / frame_name(1)).unlink()
    (root / "mine" / "0" / frame_name(0)).unlink()
    with pytest.raises(FileFormatError, match="mine/0/0000.exr: expected a frame .* 1 more"):
        _check(root)
    (root / "reference" / frame_name(1)).unlink()
    with pytest.raises(FileFormatError, match="reference/0001.exr: expected a reference"):
        _check(root)
    with pytest.raises(FileFormatError, match="expected the frame folder's manifest"):
        FrameFolder(root / "mine")
    with pytest.raises(FileFormatError, match="expected a frame folder, got no such folder"):
        FrameFolder(tmp_path / "nowhere")


def test_a_frame_of_another_size_is_refused(tmp_path):
    root = synthetic_folder(tmp_path)
    write_exr(root / "white" / "1" / frame_name(1), {"color": torch.zeros(3, 9, 8)})
    with pytest.raises(ShapeError, match="expected 8 x 8 .* got 8 x 9 in its header"):
        _check(root)


def test_a_huge_claimed_size_is_refused_before_reading(tmp_path):
    root = synthetic_folder(tmp_path)
    path = root / "white" / "0" / frame_name(0)
    data = bytearray(path.read_bytes())
    at = data.index(b"dataWindow\x00box2i\x00") + len(b"dataWindow\x00box2i\x00") + 4
    data[at : at + 16] = struct.pack("<4i", 0, 0, 1 << 30, 1 << 30)  # a 2^60-pixel claim
    path.write_bytes(bytes(data))
    with pytest.raises(ShapeError, match="got 1073741825 x 1073741825 .* refused before reading"):
        _check(root)


def test_non_finite_pixels_are_refused_naming_the_file(tmp_path):
    root = synthetic_folder(tmp_path)
    color = torch.ones(3, 8, 8)
    color[1, 2, 3] = float("nan")
    write_exr(root / "mine" / "1" / frame_name(0), {"color": color})
    folder = _check(root)
    with pytest.raises(NonFiniteError, match="mine/1/0000.exr: color: .* 1 NaN .*\\(2, 3\\)"):
        folder.frame("mine", "1", 0)


def test_buffers_come_from_layers_or_sibling_files(tmp_path):
    albedo = torch.full((3, 8, 8), 0.5)
    root = synthetic_folder(tmp_path, layers={"albedo": albedo})
    (root / "manifest.toml").write_text(
        toml_text({**SYNTHETIC, "buffers": ["albedo", "depth", "motion"]})
    )
    folder = FrameFolder(root)
    with pytest.raises(FileFormatError, match="expected buffer 'depth' .* 0000.depth.exr"):
        folder.frame("white", "0", 0)
    for t in range(2):
        for where in ("white/0", "reference"):
            write_exr(root / where / f"{t:04d}.depth.exr", {"Z": torch.ones(1, 8, 8)})
            motion = {"R": torch.ones(1, 8, 8), "G": 2 * torch.ones(1, 8, 8)}
            write_exr(root / where / f"{t:04d}.motion.exr", motion)
    frame = folder.frame("white", "0", 1)
    assert torch.equal(frame.albedo, albedo) and torch.equal(frame.depth, torch.ones(1, 8, 8))
    assert frame.motion[:, 0, 0].tolist() == [1.0, 2.0] and frame.normal is None
    assert folder.reference(0).depth is not None


def test_a_static_folder_has_one_reference_and_the_reference_variance_is_kept(tmp_path):
    root = synthetic_folder(tmp_path, static=True, layers={"variance": torch.ones(3, 8, 8)})
    (root / "reference" / frame_name(1)).unlink()
    folder = _check(root)
    assert folder.reference_path(1).name == frame_name(0)
    assert folder.reference(1).variance is not None
    assert folder.frame("white", "0", 1).variance is None  # not in buffers: not read
