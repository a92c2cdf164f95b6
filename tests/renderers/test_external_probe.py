"""The executable-renderer door's probe (issue 41): bad renderer manifests, ``--renderer-cmd``
templates, seed files and programs that fail every way through the seed protocol, each refused
as a typed error whose first line names the manifest or renderer, its command and what was
expected (tests/_probes.py); its temporary folder is gone afterwards. The programs are shell
scripts handing back EXR files the test wrote (no interpreter's start-up per case)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
import torch

from bnerr.errors import ExternalProcessError, FileFormatError, ValueRangeError
from bnerr.external import ManifestError
from bnerr.io import write_exr
from bnerr.sequences import make_sampler
from renderers.external import (
    SEED_HEADER,
    ExternalRenderer,
    command_manifest,
    load_renderer_manifest,
    read_seed_file,
)
from tests._probes import Bad, assert_ended, check, ids

H, W = 8, 8
GOOD = {
    "name": "probe_renderer",
    "command": ["./prog.sh", "{seeds}", "{spp}", "{out}"],
    "timeout_s": 20,
}


def _folder(tmp_path: Path, script: str, manifest: dict | str, suffix: str = ".json") -> Path:
    """A renderer folder: ``prog.sh`` (``script``; ``$1`` the seed file, ``$3`` the output) and
    its manifest ``renderer<suffix>`` (a dict as JSON, or the text itself)."""
    folder = tmp_path / "renderer"
    folder.mkdir(exist_ok=True)
    program = folder / "prog.sh"
    program.write_text("#!/bin/sh\n" + script)
    program.chmod(0o755)
    path = folder / f"renderer{suffix}"
    path.write_text(manifest if isinstance(manifest, str) else json.dumps(manifest))
    return path


def _load(manifest: dict | str, suffix: str = ".json"):
    return lambda tmp_path: load_renderer_manifest(_folder(tmp_path, "", manifest, suffix))


def _render(script: str, ready: dict | None = None, sampler: str = "owen_sobol", **changes):
    """A case's run: render one 8x8 frame with ``script``; ``ready`` written as ``ready.exr``."""

    def run(tmp_path: Path) -> object:
        path = _folder(tmp_path, script, {**GOOD, **changes})
        if ready is not None:
            write_exr(path.parent / "ready.exr", ready)
        renderer = ExternalRenderer(load_renderer_manifest(path))
        seeds = torch.arange(H * W, dtype=torch.int64).view(H, W)
        return renderer.render(0, seeds, make_sampler(sampler), 1)

    return run


def _frame(h: int = H, w: int = W, value: float = 0.5, **more: torch.Tensor) -> dict:
    return {"color": torch.full((3, h, w), value), **more}


def _seed_file(data: bytes):
    def run(tmp_path: Path) -> object:
        (tmp_path / "seeds.bin").write_bytes(data)
        return read_seed_file(tmp_path / "seeds.bin")

    return run


def _symlinked(tmp_path: Path, manifest: dict) -> object:
    """Load ``manifest`` with ``link.sh`` beside it, a symlink to a program outside its folder."""
    (tmp_path / "outside.sh").write_text("#!/bin/sh\n")
    (tmp_path / "outside.sh").chmod(0o755)
    (tmp_path / "renderer").mkdir()
    (tmp_path / "renderer" / "link.sh").symlink_to(tmp_path / "outside.sh")
    return _load(manifest)(tmp_path)


_HEAD = SEED_HEADER.pack(b"BNSD", 1, 2, 2, 1, 1)
COPY = 'cp ready.exr "$3"\n'

CASES = [
    Bad("malformed TOML", _load('name = "x"\nbatch = maybe\n', ".toml"), ManifestError,
        r"renderer\.toml: expected valid TOML.*line 2"),
    Bad("malformed JSON", _load('{"name": "x",,}', ".json"), ManifestError,
        r"renderer\.json: expected valid JSON.*line 1"),
    Bad("unknown key", _load({**GOOD, "shell": "bash"}), ManifestError,
        r"renderer\.json: unknown key\(s\) shell: expected only .*command"),
    Bad("a shell string", _load({**GOOD, "command": "./prog.sh {seeds} {spp} {out}"}),
        ManifestError, r"renderer\.json: command: expected a list of arguments"),
    Bad("no seeds placeholder", _load({**GOOD, "command": ["./prog.sh", "{spp}", "{out}"]}),
        ManifestError, r"renderer\.json: command: expected the placeholder\(s\).*none for seeds"),
    Bad("unknown sampler", _load({**GOOD, "samplers": ["sobol9"]}), ManifestError,
        r"renderer\.json: samplers: expected distinct names among owen_sobol"),
    Bad("no color buffer", _load({**GOOD, "buffers": ["albedo"]}), ManifestError,
        r"renderer\.json: buffers: expected 'color' among them"),
    Bad("zero dimensions", _load({**GOOD, "dimensions": 0}), ManifestError,
        r"renderer\.json: expected dimensions >= 1 .*got 0"),
    Bad("batch as text", _load({**GOOD, "batch": "yes"}), ManifestError,
        r"renderer\.json: batch: expected true or false, got str"),
    Bad("program escaping by a symlink",
        lambda p: _symlinked(p, {**GOOD, "command": ["./link.sh", "{seeds}", "{spp}", "{out}"]}),
        ManifestError, r"renderer\.json: command\[0\]: expected a path inside the manifest's"),
    Bad("template that does not split", lambda p: command_manifest("./r 'open", folder=p),
        ManifestError, r"--renderer-cmd .*expected a command line"),
    Bad("template without out", lambda p: command_manifest("sh {seeds} {spp}", folder=p),
        ManifestError, r"command: expected the placeholder\(s\).*none for out"),
    Bad("seed file too short", _seed_file(b"BNSD"), FileFormatError,
        r"seeds\.bin: expected a 24-byte header, got 4"),
    Bad("seed file of another magic", _seed_file(b"XXXX" + _HEAD[4:] + bytes(16)),
        FileFormatError, r"seeds\.bin: expected magic b'BNSD'"),
    Bad("seed file claiming huge sizes", _seed_file(SEED_HEADER.pack(
        b"BNSD", 1, 1 << 30, 1 << 30, 1 << 20, 1) + bytes(16)), FileFormatError,
        r"seeds\.bin: expected \d+ bytes for 1048576 x 1073741824 x 1073741824 seeds, got 40"),
    Bad("sampler not listed", _render(COPY, _frame(), sampler="white"), ValueRangeError,
        r"renderer 'probe_renderer'.*white"),
    Bad("exit status", _render("echo gave up >&2\nexit 5\n"), ExternalProcessError,
        r"renderer 'probe_renderer' \(renderer\.json\).*expected exit status 0, got exit status 5"),
    Bad("time limit", _render("sleep 30\n", timeout_s=0.3), ExternalProcessError,
        r"renderer 'probe_renderer'.*expected an exit within timeout_s = 0\.3 s"),
    Bad("no frame", _render("exit 0\n"), ExternalProcessError,
        r"renderer 'probe_renderer'.*expected a frame EXR at out\.exr, got no such file"),
    Bad("partial frame", _render('head -c 200 ready.exr > "$3"\n', _frame()),
        ExternalProcessError, r"renderer 'probe_renderer'.*expected an OpenEXR frame"),
    Bad("wrong size", _render(COPY, _frame(H + 1, W)), ExternalProcessError,
        r"renderer 'probe_renderer'.*a frame of 8 x 8 pixels \(width x height\), got 8 x 9"),
    Bad("missing buffer", _render(COPY, _frame(), buffers=["color", "albedo"]),
        ExternalProcessError, r"renderer 'probe_renderer'.*expected the buffers color, albedo"),
    Bad("wrong channels", _render(COPY, {"albedo": torch.ones(3, H, W)}), ExternalProcessError,
        r"renderer 'probe_renderer'.*expected an OpenEXR frame"),
    Bad("NaN color", _render(COPY, _frame(value=float("nan"))), ExternalProcessError,
        r"renderer 'probe_renderer'.*expected finite values in color"),
    Bad("inf depth", _render(COPY, _frame(depth=torch.full((1, H, W), float("inf")))),
        ExternalProcessError, r"renderer 'probe_renderer'.*expected finite values in depth"),
    Bad("huge frame", _render('truncate -s 300M "$3"\n'), ExternalProcessError,
        r"renderer 'probe_renderer'.*expected at most \d+ bytes, got 314572800"),
    Bad("missing batch frame", _render('cp ready.exr "$3/1.exr"\n', _frame(), batch=True),
        ExternalProcessError, r"renderer 'probe_renderer'.*expected a frame EXR at 0\.exr"),
]  # fmt: skip


@pytest.fixture
def private_tmp(tmp_path, monkeypatch):
    """The temporary folders the door makes go under ``tmp_path/tmp``: checked empty after."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    yield folder
    assert list(folder.iterdir()) == [], "the door left temporary files behind"


@pytest.mark.parametrize("case", CASES, ids=ids(CASES))
def test_a_bad_renderer_input_is_refused_naming_it(case, tmp_path, private_tmp):
    check(case, tmp_path)


def test_a_background_child_of_the_renderer_is_not_left_running(tmp_path, private_tmp):
    pids = tmp_path / "pids"
    run = _render(f"sleep 60 &\necho $! > {pids}\n" + COPY, _frame())
    assert run(tmp_path).color.shape == (3, H, W)
    assert_ended(int(pids.read_text()), "the renderer's background child")
