"""Tests of denoisers.external: executable denoisers declared by a manifest.

The example (examples/external_denoiser) runs end to end against the same filter in-process;
small scripts written here play every way a program can fail, and a temporal one checks that
frames come in order with the previous output. Every failure is a typed error whose first line
names the denoiser and what was expected; the temporary files are gone afterwards.
"""

from __future__ import annotations

import importlib.util
import json
import pickle
import sys
import tempfile
import time
from pathlib import Path

import pytest
import torch

import denoisers
from bnerr.errors import ExternalProcessError, FileFormatError, UnknownNameError
from bnerr.frame import Frame
from denoisers.base import Denoiser
from denoisers.external import ManifestError, denoiser_class, load_manifest
from denoisers.temporal import SequenceError

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "external_denoiser"
H, W = 12, 16

# One script for every way a program can fail: argv = mode, color, output, delay, pid file.
FAULT = """\
import subprocess, sys, time

mode, color, output, delay, pidfile = sys.argv[1:6]
time.sleep(float(delay))
if mode == "sleep":  # before the imports below: the pid file is written at once
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    with open(pidfile, "w") as f:
        f.write(str(child.pid))
    time.sleep(60)

import numpy as np
import OpenEXR

found = OpenEXR.File(color, separate_channels=True).channels()
p = {c: np.asarray(found[c].pixels, dtype=np.float32) for c in "RGB"}


def write(planes):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, planes).write(output)


if mode == "copy":
    write(p)
elif mode == "half":
    write({c: v.astype(np.float16) for c, v in p.items()})
elif mode == "fail":
    for i in range(30):
        print(f"complaint {i}", file=sys.stderr)
    sys.exit(3)
elif mode == "size":
    write({c: np.ascontiguousarray(v[:-1]) for c, v in p.items()})
elif mode == "channels":
    write({**p, "A": np.ones_like(p["R"])})
elif mode == "nan":
    p["G"][0, 1] = np.nan
    write(p)
elif mode == "uint":
    write({c: v.astype(np.uint32) for c, v in p.items()})
elif mode == "garbage":
    open(output, "wb").write(b"not an exr file")
elif mode == "huge":
    open(output, "wb").write(bytes(10_000_000))
"""

# A temporal program: the mean of the frame and the previous output; logs "frame had_previous".
ACCUMULATE = """\
import sys
import numpy as np
import OpenEXR

color, previous, output, frame, log = sys.argv[1:6]


def read(path):
    found = OpenEXR.File(path, separate_channels=True).channels()
    return {c: np.asarray(found[c].pixels, dtype=np.float32) for c in "RGB"}


now = read(color)
if previous:
    before = read(previous)
    now = {c: np.float32(0.5) * (now[c] + before[c]) for c in "RGB"}
with open(log, "a") as f:
    f.write(f"{frame} {int(bool(previous))}\\n")
header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
OpenEXR.File(header, now).write(output)
"""


def _frame(seed: int = 0) -> tuple[Frame, torch.Tensor]:
    """A noisy frame of two flat surfaces (albedo and normal mark the edge) and its clean image."""
    g = torch.Generator().manual_seed(seed)
    clean = torch.full((3, H, W), 0.2)
    clean[:, :, W // 2 :] = 0.9
    albedo = clean.clone()
    normal = torch.zeros(3, H, W)
    normal[2] = 1.0
    noisy = clean + 0.3 * torch.randn(3, H, W, generator=g)
    return Frame(color=noisy, albedo=albedo, normal=normal), clean


def _write(folder: Path, manifest: dict, script: str = FAULT, name: str = "fault") -> Path:
    """A JSON manifest in ``folder`` beside its script ``<name>.py``."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.py").write_text(script)
    path = folder / f"{name}.json"
    path.write_text(json.dumps(manifest))
    return path


def _fault_manifest(**changes: object) -> dict:
    base = {
        "name": "fault",
        "command": [
            "{python}",
            "fault.py",
            "{mode}",
            "{color}",
            "{output}",
            "{delay}",
            "{pidfile}",
        ],
        "params": {"mode": "copy", "delay": 0.0, "pidfile": ""},
        "timeout_s": 60,
    }
    base.update(changes)
    return base


@pytest.fixture
def scratch(tmp_path, monkeypatch) -> Path:
    """The folder the denoisers' temporary folders go to (to check that they are removed)."""
    folder = tmp_path / "scratch"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


# -- the example --------------------------------------------------------------------------------


def _example_module():
    spec = importlib.util.spec_from_file_location("example_denoise", EXAMPLE / "denoise.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_example_matches_its_filter_run_in_process_and_lowers_the_error(scratch):
    cls = denoiser_class(EXAMPLE / "manifest.toml")
    assert issubclass(cls, Denoiser) and cls.name == "example_joint_bilateral"
    assert cls.requires == frozenset({"albedo", "normal"}) and not cls.stateful
    assert cls.kind == "filter" and dict(cls.grid)["sigma_space"] == (1.0, 1.5, 2.5)
    frame, clean = _frame()
    denoiser = cls(sigma_space=2)  # an int for a float parameter
    assert denoiser.params() == {"sigma_space": 2.0, "sigma_albedo": 0.1, "sigma_normal": 0.3}
    out = denoiser(frame)
    assert out.dtype == torch.float32 and out.shape == (3, H, W)
    assert out.device == frame.color.device
    inside = _example_module().joint_bilateral(
        frame.color.numpy(), frame.albedo.numpy(), frame.normal.numpy(), 2.0, 0.1, 0.3
    )
    assert torch.equal(out, torch.from_numpy(inside))  # the EXR round trip is exact
    noisy_mse = float((frame.color - clean).square().mean())
    assert float((out - clean).square().mean()) < 0.2 * noisy_mse
    assert not any(scratch.iterdir())


def test_registered_it_is_built_by_name_and_survives_pickling(monkeypatch):
    cls = denoiser_class(EXAMPLE / "manifest.toml")
    monkeypatch.setitem(denoisers.DENOISERS, cls.name, cls)
    built = denoisers.get_denoiser(cls.name, sigma_albedo=0.2)
    assert type(built) is cls and built.params()["sigma_albedo"] == 0.2
    with pytest.raises(UnknownNameError, match="unknown parameter.*sigma: expected one of"):
        denoisers.get_denoiser(cls.name, sigma=1.0)
    again = pickle.loads(pickle.dumps(built))
    assert again.params() == built.params() and again.name == cls.name


# -- temporal -----------------------------------------------------------------------------------


def test_a_temporal_program_gets_frames_in_order_with_the_previous_output(tmp_path, scratch):
    log = tmp_path / "order.log"
    path = _write(
        tmp_path / "acc",
        {
            "name": "accumulate",
            "command": [
                "{python}",
                "accumulate.py",
                "{color}",
                "{previous_output}",
                "{output}",
                "{frame}",
                "{log}",
            ],
            "temporal": True,
            "params": {"log": str(log)},
        },
        ACCUMULATE,
        "accumulate",
    )
    cls = denoiser_class(path)
    assert cls.stateful and cls.kind == "temporal"
    denoiser = cls()
    frames = [_frame(seed)[0] for seed in range(3)]
    outs = [denoiser(frame, t=t) for t, frame in enumerate(frames)]
    assert torch.equal(outs[0], frames[0].color)
    assert torch.equal(outs[1], 0.5 * (frames[1].color + outs[0]))
    assert torch.equal(outs[2], 0.5 * (frames[2].color + outs[1]))
    with pytest.raises(SequenceError, match="expected frame 3 after frame 2, got frame 5"):
        denoiser(frames[0], t=5)
    denoiser.reset()
    assert torch.equal(denoiser(frames[2], t=0), frames[2].color)
    assert log.read_text().split("\n") == ["0 0", "1 1", "2 1", "0 0", ""]
    assert not any(scratch.iterdir())


# -- failures of the program --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("mode", "expected"),
    [
        ("fail", "expected exit status 0, got exit status 3"),
        ("nothing", "expected an output EXR at {output} (output.exr), got no such file"),
        # width x height, the order of --res and bnerr eval (issue 54)
        ("size", f"expected an output of {W} x {H} pixels (width x height), got {W} x {H - 1}"),
        ("channels", "expected the output channels R, G, B only, got A, B, G, R"),
        ("nan", f"expected finite output values, got 1 NaN or infinite of {3 * H * W}"),
        ("uint", "expected FLOAT or HALF output channels, got uint32"),
        ("garbage", "expected an OpenEXR output, got ValueError: no EXR magic number"),
        ("huge", "bytes, got 10000000 bytes"),
    ],
)
def test_a_failing_program_raises_a_typed_error_naming_it(tmp_path, scratch, mode, expected):
    path = _write(tmp_path / "p", _fault_manifest())
    frame, _ = _frame()
    with pytest.raises(ExternalProcessError) as caught:
        denoiser_class(path)(mode=mode)(frame)
    first = str(caught.value).splitlines()[0]
    assert first.startswith("denoiser 'fault' (fault.json): command ")
    assert "fault.py" in first and expected in first
    assert not any(scratch.iterdir())


def test_the_error_quotes_the_last_lines_of_stderr(tmp_path):
    path = _write(tmp_path / "p", _fault_manifest())
    with pytest.raises(ExternalProcessError) as caught:
        denoiser_class(path)(mode="fail")(_frame()[0])
    lines = str(caught.value).splitlines()
    assert lines[1].strip() == "last 20 line(s) of the program's stderr:"
    assert [line.strip() for line in lines[2:]] == [f"complaint {i}" for i in range(10, 30)]


def test_a_half_output_is_read_as_float32(tmp_path):
    path = _write(tmp_path / "p", _fault_manifest())
    frame, _ = _frame()
    out = denoiser_class(path)(mode="half")(frame)
    assert out.dtype == torch.float32
    assert torch.equal(out, frame.color.half().float())


def _gone_or_zombie(pid: int) -> bool:
    stat = Path(f"/proc/{pid}/stat")
    try:
        return stat.read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except (FileNotFoundError, ProcessLookupError):
        return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_timeout_kills_the_whole_process_group(tmp_path, scratch):
    pidfile = tmp_path / "child.pid"
    path = _write(tmp_path / "p", _fault_manifest(timeout_s=3))
    start = time.perf_counter()
    with pytest.raises(ExternalProcessError, match=r"expected an exit within timeout_s = 3 s"):
        denoiser_class(path)(mode="sleep", pidfile=str(pidfile))(_frame()[0])
    assert time.perf_counter() - start < 30
    child = int(pidfile.read_text())  # the program's own child, in its process group
    deadline = time.perf_counter() + 5
    while not _gone_or_zombie(child) and time.perf_counter() < deadline:
        time.sleep(0.05)
    assert _gone_or_zombie(child)
    assert not any(scratch.iterdir())


def test_a_program_that_cannot_start_is_reported(tmp_path):
    script = tmp_path / "not_executable.sh"
    script.write_text("#!/bin/sh\n")
    script.chmod(0o644)
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"name": "x", "command": [str(script), "{color}", "{output}"]}))
    with pytest.raises(ExternalProcessError, match="expected a program that starts, got Perm"):
        denoiser_class(path)()(_frame()[0])


# -- the manifest -------------------------------------------------------------------------------


def _cmd(*extra: str) -> list[str]:
    return ["{python}", "fault.py", "{color}", "{output}", *extra]


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"colour": 1}, "unknown key(s) colour: expected only name, command, inputs, params"),
        ({"name": None}, "expected the key(s) name, got none"),
        ({"name": "9lives"}, "name: expected a letter then"),
        ({"command": "python fault.py {color} {output}"}, "command: expected a list of arg"),
        ({"command": []}, "command: expected a non-empty list of non-empty strings"),
        ({"command": _cmd("{colour}")}, "expected placeholders among {albedo}, {color}"),
        ({"command": _cmd("{color!r}")}, "got {color}"),
        ({"command": _cmd("{")}, "argument '{': Single '{' encountered"),
        ({"command": _cmd("{previous_output}")}, "got {previous_output}"),
        ({"command": _cmd("{albedo}")}, "a placeholder for each of inputs = color and no"),
        ({"inputs": ["color", "normal"]}, "a placeholder for each of inputs = color, normal"),
        ({"command": ["{python}", "fault.py", "{color}"]}, "expected an {output} placeholder"),
        ({"inputs": ["albedo"]}, "inputs: expected 'color' and no name twice, got albedo"),
        ({"inputs": ["color", "colour"]}, "inputs: expected buffer names among color"),
        ({"inputs": "color"}, "inputs: expected a list of buffer names, got str 'color'"),
        ({"timeout_s": "10"}, "timeout_s: expected a number of seconds, got str '10'"),
        ({"timeout_s": 0}, "timeout_s: expected a number > 0, got 0"),
        ({"temporal": 1}, "temporal: expected true or false, got int 1"),
        ({"kind": 3}, "kind: expected a string, got int 3"),
        ({"params": {"s": [1]}}, "params.s: expected an int, a float or a string, got list"),
        ({"params": {"color": 1}}, "params: expected identifiers other than python"),
        ({"params": {"s": True}}, "params.s: expected an int, a float or a string, got bool"),
        ({"grid": {"s": [1.0]}}, "grid.s: expected a parameter of [params] (none declared)"),
        ({"params": {"s": 1}, "grid": {"s": [1, 2.5]}}, "grid.s: expected int like its default"),
        ({"params": {"s": 1}, "grid": {"s": []}}, "grid.s: expected a non-empty list, got list"),
    ],
)
def test_a_bad_manifest_is_refused_in_one_line_naming_the_file(tmp_path, changes, expected):
    manifest = {"name": "m", "command": _cmd()}
    manifest.update(changes)
    manifest = {k: v for k, v in manifest.items() if v is not None}
    path = _write(tmp_path, manifest)
    with pytest.raises(ManifestError) as caught:
        denoiser_class(path)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{path}: ")
    assert expected in message
    assert isinstance(caught.value, FileFormatError)


@pytest.mark.parametrize(
    ("name", "text", "expected"),
    [
        ("m.toml", 'name = "x"\ncommand = [\n', "expected valid TOML, got"),
        ("m.toml", 'name = "x"\ncommand = [\n', "at the end of the document, after line 2"),
        ("m.toml", 'name = "x"\ncommand = [1,,]\nkind = 2\n', "(at line 2, column"),
        ("m.json", '{"name": "x",\n "command": [}', "expected valid JSON, got"),
        ("m.json", '{"name": "x",\n "command": [}', "at line 2, column"),
        ("m.json", "[1, 2]", "expected a table of keys, got list [1, 2]"),
        ("m.yaml", "name: x", "expected a manifest named *.toml or *.json, got '.yaml'"),
    ],
)
def test_a_malformed_manifest_is_reported_with_its_line(tmp_path, name, text, expected):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ManifestError, match="^[^\n]*$") as caught:
        load_manifest(path)
    assert expected in str(caught.value)


def test_a_missing_manifest_is_refused(tmp_path):
    with pytest.raises(ManifestError, match="expected a denoiser manifest file, got no such"):
        load_manifest(tmp_path / "none.toml")


def test_a_relative_program_must_stay_inside_the_manifest_folder(tmp_path):
    outside = tmp_path / "outside.py"
    outside.write_text(FAULT)
    folder = tmp_path / "m"
    folder.mkdir()
    (folder / "link.py").symlink_to(outside)
    for program, expected in [
        ("../outside.py", "expected a path inside the manifest's folder"),
        ("link.py", "(through '..' or a symlink)"),
        ("missing.py", "expected an existing file, got 'missing.py': no such file"),
        ("{color}", "expected the program's path, got a placeholder"),
    ]:
        path = folder / "m.json"
        path.write_text(json.dumps({"name": "m", "command": _cmd()[:1] + [program] + _cmd()[2:]}))
        with pytest.raises(ManifestError, match="command\\[1\\]") as caught:
            load_manifest(path)
        assert expected in str(caught.value)
    # an absolute path is the user's choice; a relative one inside resolves to an absolute path
    path.write_text(json.dumps({"name": "m", "command": ["{python}", str(outside), *_cmd()[2:]]}))
    assert load_manifest(path).command[1] == str(outside)
    (folder / "sub").mkdir()
    (folder / "sub" / "ok.py").write_text(FAULT)
    path.write_text(
        json.dumps({"name": "m", "command": ["{python}", "sub/../sub/ok.py"] + _cmd()[2:]})
    )
    assert load_manifest(path).command[1] == str((folder / "sub" / "ok.py").resolve())


def test_a_bare_program_is_looked_up_on_path(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(
        json.dumps({"name": "m", "command": ["no-such-program-here", "{color}", "{output}"]})
    )
    with pytest.raises(ManifestError, match="expected a program on PATH, got 'no-such-program"):
        load_manifest(path)


# -- in the sweep -------------------------------------------------------------------------------


@pytest.mark.slow
def test_the_sweep_runs_it_and_records_the_program_time_as_its_cost(tmp_path, monkeypatch):
    from benchmarks.sweep.runner import run_suite
    from tests._suites import tiny_suite

    slow = denoiser_class(
        _write(
            tmp_path / "p", _fault_manifest(params={"mode": "copy", "delay": 0.3, "pidfile": ""})
        )
    )
    example = denoiser_class(EXAMPLE / "manifest.toml")
    for cls in (slow, example):
        monkeypatch.setitem(denoisers.DENOISERS, cls.name, cls)
    suite = tiny_suite(strategies=("white",), denoisers=("fault", example.name), seed_sets=1)
    records = run_suite(suite, tmp_path / "out", cache_dir=tmp_path / "cache", progress=False)
    by_name = {rec.cell.denoiser: rec for rec in records}
    assert set(by_name) == {"fault", example.name}
    assert min(by_name["fault"].timings.denoise_ms[0]) >= 300  # the program's sleep is inside
    copy, smoothed = (torch.tensor(by_name[n].den["mse"]) for n in ("fault", example.name))
    raw = torch.tensor(by_name["fault"].raw["mse"])
    assert torch.equal(copy, raw)  # a copy of the frame has the frame's error
    assert bool((smoothed[..., 0] < raw[..., 0]).all())


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_the_output_comes_back_on_the_frames_device():
    frame, _ = _frame()
    on_gpu = frame.to("cuda")
    cls = denoiser_class(EXAMPLE / "manifest.toml")
    out = cls()(on_gpu)
    assert out.device == on_gpu.color.device
    assert torch.equal(out.cpu(), cls()(frame))
