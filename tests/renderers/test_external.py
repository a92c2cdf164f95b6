"""renderers.external: the seed file, the renderer manifest and the render callback of a program,
with a Python stand-in renderer (its color is a function of each pixel's seed)."""

from __future__ import annotations

import struct
import sys

import pytest
import torch

from bnerr.errors import ExternalProcessError, FileFormatError, ValueRangeError
from bnerr.external import ManifestError
from bnerr.sequences import make_sampler
from bnerr.strategies import make_strategy, pixel_seeds
from renderers.external import (
    SEED_HEADER,
    ExternalRenderer,
    command_manifest,
    load_renderer_manifest,
    read_seed_file,
    sampler_values,
    write_seed_file,
)

#: The stand-in: color = (seed / 2^32, spp, frame), albedo 0.5; its last argument picks a fault.


def _stand_in(tmp_path) -> str:
    """The stand-in renderer (numpy and OpenEXR only: no torch to import per run)."""
    script = tmp_path / "render.py"
    script.write_text(
        "import os, struct, sys\n"
        "import numpy as np, OpenEXR\n"
        "seeds, spp, frame, out, fault = sys.argv[1:6]\n"
        "data = open(seeds, 'rb').read()\n"
        "_, _, w, h, k, _ = struct.unpack_from('<4s5I', data)\n"
        "images = np.frombuffer(data, '<u4', offset=24).reshape(k, h, w)\n"
        "for i, s in enumerate(images):\n"
        "    r = (s / 2**32).astype(np.float32)\n"
        "    if fault == 'nan': r[0, 0] = np.nan\n"
        "    if fault == 'small': r = r[:, 1:].copy()\n"
        "    if fault == 'exit': sys.exit('the renderer gave up')\n"
        "    c = {'R': r, 'G': r * 0 + int(spp), 'B': r * 0 + int(frame)}\n"
        "    if fault != 'noalbedo': c.update({f'albedo.{x}': r * 0 + 0.5 for x in 'RGB'})\n"
        "    target = os.path.join(out, f'{i}.exr') if os.path.isdir(out) else out\n"
        "    c = {n: np.ascontiguousarray(v, dtype=np.float32) for n, v in c.items()}\n"
        "    OpenEXR.File({'type': OpenEXR.scanlineimage}, c).write(target)\n"
        "    if fault == 'cut': open(target, 'r+b').truncate(os.path.getsize(target) - 8)\n"
    )
    return "render.py"


def _manifest(tmp_path, fault="none", batch=False, extra=""):
    script = _stand_in(tmp_path)
    out = "{out}"
    path = tmp_path / "renderer.toml"
    path.write_text(
        'name = "stand_in"\n'
        f'command = ["{{python}}", "{script}", "{{seeds}}", "{{spp}}", "{{frame}}", "{out}", '
        f'"{fault}"]\n'
        'buffers = ["color", "albedo"]\n'
        f"batch = {'true' if batch else 'false'}\n" + extra
    )
    return load_renderer_manifest(path)


def test_the_seed_file_holds_its_header_then_the_low_32_bits_row_major(tmp_path):
    seeds = torch.tensor([[[1, 2, 3], [4, 5, (1 << 32) + 6]]], dtype=torch.int64)
    write_seed_file(tmp_path / "s.bin", seeds)
    data = (tmp_path / "s.bin").read_bytes()
    assert SEED_HEADER.unpack_from(data) == (b"BNSD", 1, 3, 2, 1, 1)
    assert struct.unpack_from("<6I", data, 24) == (1, 2, 3, 4, 5, 6)
    assert torch.equal(read_seed_file(tmp_path / "s.bin"), seeds & 0xFFFFFFFF)
    (tmp_path / "s.bin").write_bytes(data[:-4])
    with pytest.raises(FileFormatError, match="expected 48 bytes for 1 x 2 x 3 seeds, got 44"):
        read_seed_file(tmp_path / "s.bin")
    (tmp_path / "s.bin").write_bytes(b"XXXX" + data[4:])
    with pytest.raises(FileFormatError, match="expected magic b'BNSD'"):
        read_seed_file(tmp_path / "s.bin")


def test_a_frame_is_one_run_of_the_program_and_its_time_is_the_render_cost(tmp_path):
    renderer = ExternalRenderer(_manifest(tmp_path))
    seeds = pixel_seeds(5, 7, 3)
    frame = renderer.render(2, seeds, make_sampler("owen_sobol"), 4)
    assert torch.equal(frame.color[0], (seeds / 2**32).float())
    assert float(frame.color[1].max()) == 4 and float(frame.color[2].min()) == 2
    assert frame.albedo is not None and frame.timings["render"] > 0


@pytest.mark.parametrize("batch", [False, True])
def test_the_oracles_candidates_are_the_frames_of_one_seed_image_each(tmp_path, batch):
    renderer = ExternalRenderer(_manifest(tmp_path, batch=batch))
    seeds = torch.stack([pixel_seeds(4, 6, k) for k in range(3)])
    frames = renderer.render_batch(0, seeds, make_sampler("owen_sobol"), 1)
    for k, frame in enumerate(frames):
        assert torch.equal(frame.color[0], (seeds[k] / 2**32).float())


@pytest.mark.parametrize(
    ("fault", "message"),
    [
        (
            "nan",
            r"expected finite values in color, got 3 NaN and 0 infinite of 72, first at pixel "
            r"\(y, x\) = \(0, 0\)",
        ),
        # width x height, the order of --res and of bnerr eval's messages (issue 54)
        ("small", r"expected a frame of 6 x 4 pixels \(width x height\), got 5 x 4"),
        ("noalbedo", "expected the buffers color, albedo, got no albedo"),
        ("exit", "expected exit status 0, got exit status 1(.|\n)*the renderer gave up"),
    ],
)
def test_a_wrong_frame_is_an_external_process_error_naming_the_renderer(tmp_path, fault, message):
    renderer = ExternalRenderer(_manifest(tmp_path, fault))
    with pytest.raises(ExternalProcessError, match=message) as err:
        renderer.render(0, pixel_seeds(4, 6, 0), make_sampler("owen_sobol"), 1)
    assert str(err.value).startswith("renderer 'stand_in' (renderer.toml): command ")


def test_a_sampler_the_manifest_does_not_list_is_refused(tmp_path):
    renderer = ExternalRenderer(_manifest(tmp_path))
    with pytest.raises(ValueRangeError, match=r"expected a sampler it lists \(owen_sobol\)"):
        renderer.render(0, pixel_seeds(4, 6, 0), make_sampler("white"), 1)


def test_the_manifest_refuses_unknown_keys_and_missing_placeholders(tmp_path):
    with pytest.raises(ManifestError, match="unknown key.s. colour"):
        _manifest(tmp_path, extra="colour = 1\n")
    with pytest.raises(ManifestError, match=r"expected the placeholder.s. \{seeds\}, \{out\}"):
        _manifest(tmp_path, extra='samplers = ["owen_sobol", "ldbn"]\n')
    with pytest.raises(ManifestError, match="samplers: expected distinct names among"):
        _manifest(tmp_path, extra='samplers = ["bnds"]\n')


def test_a_command_template_is_split_without_a_shell_and_named_after_its_program(tmp_path):
    script = _stand_in(tmp_path)
    manifest = command_manifest(
        f"{{python}} {script} {{seeds}} {{spp}} 0 {{out}} 'a b'", None, tmp_path
    )
    assert manifest.command[-1] == "a b" and manifest.samplers == ("owen_sobol",)
    assert manifest.name == "render" and manifest.path is None and manifest.folder == tmp_path
    ldbn = " ".join("{" + p + "}" for p in ("sampler", "ldbn_keys", "ldbn_slice"))
    full = command_manifest(
        f"{sys.executable} {{seeds}} {{spp}} {{out}} {ldbn} {{ldbn_offset_y}} {{ldbn_offset_x}}",
        "mine",
    )
    assert full.samplers == ("owen_sobol", "ldbn") and full.name == "mine"
    with pytest.raises(ManifestError, match="expected a command line, got No closing quotation"):
        command_manifest("tracer 'open")


@pytest.mark.parametrize(
    ("template", "name"),
    [
        ("python3 my_render.py {seeds} {spp} {out}", "my_render"),
        (f"{sys.executable} -u tools/flat.py {{seeds}} {{spp}} {{out}}", "flat"),
        ("env OMP_NUM_THREADS=1 ./pbrt_bridge {seeds} {spp} {out}", "pbrt_bridge"),
        ("bash run.sh {seeds} {spp} {out}", "run"),
        ("./tracer --seeds {seeds} --spp {spp} --out {out}", "tracer"),
    ],
)
def test_a_command_run_through_an_interpreter_is_named_after_its_script(tmp_path, template, name):
    """Issue 54: ``python3 render.py ...`` named the scene ``python`` (only ``{python}`` was
    looked past): the records and reference cache of every Python renderer shared one name."""
    for program in ("pbrt_bridge", "tracer"):
        (tmp_path / program).write_text("#!/bin/sh\n")
        (tmp_path / program).chmod(0o755)
    assert command_manifest(template, None, tmp_path).name == name


def test_an_ldbn_sampler_is_described_by_its_exported_key_set_slice_and_offset(tmp_path):
    strategy = make_strategy("ldbn", 16, 16, seed=1, spp=4)
    manifest = command_manifest(
        f"{sys.executable} {{seeds}} {{spp}} {{out}} {{sampler}} {{ldbn_keys}} {{ldbn_slice}} "
        "{ldbn_offset_y} {ldbn_offset_x}"
    )
    sampler = strategy.sampler(3)
    values = sampler_values(manifest, sampler)
    assert values == {
        "sampler": "ldbn",
        "ldbn_keys": "ldbn_screen_64",
        "ldbn_slice": "2",  # level 2 (4 spp) of the one-frame screen set
        "ldbn_offset_y": str(sampler.offset[0]),
        "ldbn_offset_x": str(sampler.offset[1]),
    }
    st = make_strategy("ldbn_st", 16, 16, seed=1, spp=2).sampler(5)
    assert sampler_values(manifest, st)["ldbn_keys"] == "ldbn_st_64x4"
    assert sampler_values(manifest, st)["ldbn_slice"] == str(1 * 4 + 1)


def test_a_truncated_frame_is_one_error_and_openexr_prints_nothing(tmp_path, capfd):
    """Issue 54: OpenEXR's own lines (its C library's on stderr, its binding's on stdout) came
    before bnerr's one line on a truncated frame; they are quoted in the error instead."""
    renderer = ExternalRenderer(_manifest(tmp_path, "cut"))
    capfd.readouterr()
    with pytest.raises(ExternalProcessError, match="expected an OpenEXR frame") as err:
        renderer.render(0, pixel_seeds(4, 6, 0), make_sampler("owen_sobol"), 1)
    assert capfd.readouterr() == ("", "")
    assert "OpenEXR said: " in str(err.value).splitlines()[0]
