"""The frame-folder door's probe (issue 41): broken folders fed to ``bnerr eval`` in-process, each
refused in one line (exit code 2, no traceback) naming the file or key, what was expected and
what came (tests/_probes.py); what is refused before any pixel is read writes nothing."""

from __future__ import annotations

import os
import shutil
import struct
from pathlib import Path

import pytest
import torch

from benchmarks.commands.eval.frame_folder import MANIFEST, frame_name
from bnerr.io import write_exr
from tests._frame_folders import SYNTHETIC, synthetic_folder, toml_text
from tests._probes import refused_on_the_command_line

pytestmark = pytest.mark.usefixtures("one_thread")

INF = float("inf")


def _manifest(**changes):
    def edit(root: Path) -> None:
        table = {k: v for k, v in {**SYNTHETIC, **changes}.items() if v is not None}
        (root / MANIFEST).write_text(toml_text(table))

    return edit


def _frame_file(write):
    """An edit: ``write(path)`` on white's frame 1 of seed set 0."""
    return lambda root: write(root / "white" / "0" / frame_name(1))


def _huge_window(path: Path) -> None:
    data = bytearray(path.read_bytes())
    key = b"dataWindow\x00box2i\x00"
    at = data.index(key) + len(key) + 4
    data[at : at + 16] = struct.pack("<4i", 0, 0, 999_999, 999_999)  # 10^6 x 10^6 claimed
    path.write_bytes(bytes(data))


def _symlink_out(root: Path) -> None:
    outside = root.parent / "outside.exr"
    target = root / "mine" / "1" / frame_name(0)
    outside.write_bytes(target.read_bytes())
    target.unlink()
    os.symlink(outside, target)


def _nan(path: Path) -> None:
    color = torch.full((3, 8, 8), 0.5)
    color[1, 2, 3] = float("nan")
    write_exr(path, {"color": color})


CASES = {
    "missing manifest": (lambda root: (root / MANIFEST).unlink(),
                         r"manifest\.toml: expected the frame folder's manifest, got no such"),
    "malformed manifest": (lambda root: (root / MANIFEST).write_text('scene = "a"\nspp = [\n'),
                           r"manifest\.toml: expected a TOML manifest, got .*line"),
    "unknown key": (_manifest(fps=24), r"unknown keys fps; expected keys from scene"),
    "no white method": (_manifest(methods=["mine"]), r"methods: expected the white baseline"),
    "method escaping": (_manifest(methods=["white", ".."]),
                        r"methods: expected plain folder names inside the folder"),
    "absolute seed set": (_manifest(seed_sets=["0", "/etc"]),
                          r"seed_sets: expected plain folder names"),
    "negative frames": (_manifest(frames=-1), r"frames.*got -1"),
    "10^6 x 10^6 resolution": (_manifest(resolution=[1_000_000, 1_000_000]),
                               r"resolution.*1000000"),
    "unknown buffer": (_manifest(buffers=["alpha"]), r"buffers.*alpha"),
    "missing frame": (lambda root: (root / "mine" / "1" / frame_name(1)).unlink(),
                      r"mine/1/0001\.exr: expected a frame the manifest implies, got no such"),
    "missing reference": (lambda root: (root / "reference" / frame_name(0)).unlink(),
                          r"reference/0000\.exr: expected a reference the manifest implies"),
    "missing buffer": (_manifest(buffers=["albedo"]), r"0000.*albedo"),
    "frame of another size": (_frame_file(lambda p: write_exr(p, {"color": torch.ones(3, 4, 8)})),
                              r"white/0/0001\.exr: expected 8 x 8 .*got 8 x 4"),
    "huge data window": (_frame_file(_huge_window),
                         r"white/0/0001\.exr: expected 8 x 8 .*got 1000000 x 1000000"),
    "wrong channels": (_frame_file(lambda p: write_exr(p, {"albedo": torch.ones(3, 8, 8)})),
                       r"white/0/0001\.exr.*color"),
    "not an EXR": (_frame_file(lambda p: p.write_bytes(b"P6\n8 8\n255\n" + bytes(192))),
                   r"white/0/0001\.exr"),
    "empty file": (_frame_file(lambda p: p.write_bytes(b"")), r"white/0/0001\.exr"),
    "truncated EXR": (_frame_file(lambda p: p.write_bytes(p.read_bytes()[:400])),
                      r"white/0/0001\.exr"),
    "a folder for a frame": (_frame_file(lambda p: p.unlink() or p.mkdir()),
                             r"white/0/0001\.exr"),
    "symlink out of the folder": (_symlink_out, r"mine/1/0000\.exr: expected a file inside"),
    "NaN pixel": (_frame_file(_nan), r"white/0/0001\.exr: color: expected finite values"),
    # issue 54
    "infinite pixel": (_frame_file(lambda p: write_exr(p, {"color": torch.full((3, 8, 8), INF)})),
                       r"white/0/0001\.exr: color: expected finite values, got 0 NaN and 192"),
    "NaN in the last frame read": (lambda root: _nan(root / "mine" / "1" / frame_name(1)),
                                   r"mine/1/0001\.exr: color: expected finite values"),
    "manifest alone": (lambda root: [shutil.rmtree(c) for c in root.iterdir() if c.is_dir()],
                       r"reference/0000\.exr: expected a reference the manifest implies"),
    "text file named .exr": (_frame_file(lambda p: p.write_text("hello\n")),
                             r"white/0/0001\.exr: expected an OpenEXR file"),
}  # fmt: skip


@pytest.mark.parametrize("what", list(CASES))
def test_a_broken_folder_is_refused_in_one_line(tmp_path, capsys, what):
    edit, words = CASES[what]
    root = synthetic_folder(tmp_path / "f")
    edit(root)
    out = tmp_path / "out"
    refused_on_the_command_line(
        ["eval", str(root), "--out", str(out), "--quiet", "--no-charts"], capsys, words
    )
    # docs/EVAL.md: found before anything is written, the NaN pixel too (issue 54: it was
    # exempted, and every case left the lock file): no results folder at all
    assert not out.exists()


def test_a_folder_that_is_not_one(tmp_path, capsys):
    (tmp_path / "file").write_text("")
    refused_on_the_command_line(["eval", str(tmp_path / "file"), "--quiet"], capsys, r"file")
