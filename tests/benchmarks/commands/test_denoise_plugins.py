"""``bnerr denoise`` with plug-in denoisers: a plain function from ``file.py:name`` (wrapped as a
Denoiser), in a subprocess, and the shipped example executable denoiser by its manifest, with a
parameter of the manifest's on the command line."""

import textwrap

import torch
import torch.nn.functional as F

from benchmarks.cli import main
from bnerr.io import read_frame, write_frame
from tests._images import random_frame
from tests._paths import EXAMPLES, bnerr_cli

BOX = '''
import torch.nn.functional as F


def box(frame):
    """A 3x3 box filter."""
    return F.avg_pool2d(frame.color[None], 3, 1, 1, count_include_pad=False)[0]


box.kind = "filter"
'''


def _frame_file(tmp_path):
    frame = random_frame(10, 12, scale=2.0, drop=("motion", "object_id"))
    write_frame(tmp_path / "frame.exr", frame)
    return tmp_path / "frame.exr", read_frame(tmp_path / "frame.exr")


def test_denoise_takes_a_function_from_a_file(tmp_path):
    source, frame = _frame_file(tmp_path)
    (tmp_path / "mine.py").write_text(textwrap.dedent(BOX))
    out = tmp_path / "out.exr"
    args = ["--denoiser", f"{tmp_path / 'mine.py'}:box", "--in", str(source), "--out", str(out)]
    done = bnerr_cli("denoise", *args)
    assert done.returncode == 0, done.stderr
    assert "12x10" in done.stdout
    expected = F.avg_pool2d(frame.color[None], 3, 1, 1, count_include_pad=False)[0]
    assert torch.equal(read_frame(out).color, expected)


def test_denoise_takes_an_executable_denoisers_manifest(tmp_path, capsys, forget):
    forget.append(("bnerr.denoisers", "example_joint_bilateral"))
    source, frame = _frame_file(tmp_path)
    manifest = str(EXAMPLES / "external_denoiser" / "manifest.toml")
    out = tmp_path / "out.exr"
    args = ["denoise", "--denoiser", manifest, "--in", str(source), "--out", str(out)]
    assert main([*args, "--params", "sigma_space=2.0"]) == 0
    assert "sigma_space=2.0" in capsys.readouterr().out
    color = read_frame(out).color
    assert color.shape == frame.color.shape and not torch.equal(color, frame.color)
    assert read_frame(out).timings["denoise"] > 0
