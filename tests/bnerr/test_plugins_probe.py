"""The plug-in door's probe (issue 41): bad plug-ins of every group, each refused as a one-line
typed error naming the plug-in and what was expected (tests/_probes.py), never a traceback,
SystemExit or a silently converted output; a denoiser plug-in that raises mid-run ends
``bnerr bench`` in one line, keeps the records written, and ``--resume`` completes once fixed."""

from __future__ import annotations

import json
import re
import textwrap
from pathlib import Path

import pytest
import torch

import denoisers
import renderers
from bnerr import plugins, sequences, strategies
from bnerr.errors import DtypeError, NonFiniteError, PluginError, ShapeError
from bnerr.frame import Frame
from bnerr.metrics import FrameMetrics, load_metric
from tests._probes import Bad, check, ids, refused_on_the_command_line


def _file(tmp_path: Path, text: str, name: str = "plug.py") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def _spec(text: str, attr: str):
    """A case's run: write ``text`` as a plug-in file, return the spec ``file.py:attr``."""
    return lambda tmp_path: f"{_file(tmp_path, text)}:{attr}"


def _denoise(text: str, attr: str = "den"):
    """A case's run: load the function denoiser ``attr`` of ``text`` and denoise an 8x8 frame."""

    def run(tmp_path: Path) -> object:
        denoiser = denoisers.get_denoiser(_spec(text, attr)(tmp_path))
        return denoiser(Frame(color=torch.rand(3, 8, 8, generator=torch.Generator())), 0)

    return run


def _strategy(text: str, attr: str = "Mine"):
    return lambda tmp_path: strategies.make_strategy(_spec(text, attr)(tmp_path), 4, 4, seed=1)


def _with_name(name: str, body: str) -> str:
    return f"{body}\n{name}.name = 'probe_{name}'\n"


CASES = [
    Bad("missing file", lambda p: plugins.resolve(f"{p}/none.py:X"), PluginError,
        r"none\.py:X.*expected an existing Python file"),
    Bad("syntax error", lambda p: plugins.resolve(_spec("def (:\n", "X")(p)), PluginError,
        r"plug\.py:X.*expected an importable module.*SyntaxError"),
    Bad("import error", lambda p: plugins.resolve(_spec("import no_such_mod_41\n", "X")(p)),
        PluginError, r"plug\.py:X.*no distribution.*importable.*no_such_mod_41"),
    Bad("raises at import", lambda p: plugins.resolve(_spec("raise KeyError('k')\n", "X")(p)),
        PluginError, r"plug\.py:X.*expected an importable module.*KeyError"),
    Bad("sys.exit at import", lambda p: plugins.resolve(_spec("import sys\nsys.exit(3)\n", "X")(p)),
        PluginError, r"plug\.py:X.*expected an importable module.*SystemExit"),
    Bad("module not importable", lambda p: plugins.resolve("no_such_pkg_41.mod:X"), PluginError,
        r"no_such_pkg_41\.mod:X.*expected an importable module"),
    Bad("missing attribute", lambda p: plugins.resolve(_spec("x = 1\n", "Missing")(p)),
        PluginError, r"plug\.py:Missing.*expected an attribute 'Missing'"),
    Bad("missing nested attribute", lambda p: plugins.resolve(_spec("class A: pass\n", "A.b")(p)),
        PluginError, r"plug\.py:A\.b.*expected an attribute 'A\.b'"),
    Bad("not a spec", lambda p: plugins.resolve("no colon here"), PluginError,
        r"expected 'pkg\.module:attr'.*got 'no colon here'"),
    Bad("strategy of the wrong kind", _strategy("class Mine:\n    name = 'm'\n"), PluginError,
        r"plug\.py:Mine.*expected a subclass of bnerr\.strategies\.base\.Strategy"),
    Bad("strategy constructor raises",
        _strategy("from bnerr.strategies import WhiteStrategy\nclass Mine(WhiteStrategy):\n"
                  "    name = 'probe_raising'\n    family = 'experimental'\n"
                  "    stream = 0x51A7E0F9\n    def __init__(self, *a, **k):\n"
                  "        raise RuntimeError('no strategy today')\n"),
        PluginError, r"plug\.py:Mine.*expected.*build.*RuntimeError: no strategy today"),
    Bad("denoiser of the wrong kind",
        lambda p: denoisers.get_denoiser(_spec("den = 42\n", "den")(p)),
        PluginError, r"plug\.py:den.*expected a denoisers\.Denoiser subclass"),
    Bad("denoiser constructor raises",
        lambda p: denoisers.get_denoiser(_spec(
            "from denoisers import Denoiser\nclass Den(Denoiser):\n    name = 'probe_ctor'\n"
            "    def __init__(self):\n        raise ValueError('bad weights')\n", "Den")(p)),
        PluginError, r"plug\.py:Den.*expected its denoiser to build.*ValueError: bad weights"),
    Bad("denoiser of the wrong shape",
        _denoise(_with_name("den", "def den(frame):\n    return frame.color[:1]\n")),
        ShapeError, r"denoiser 'probe_den' output.*expected"),
    Bad("denoiser returning NaN",
        _denoise(_with_name("den", "def den(frame):\n    return frame.color * float('nan')\n")),
        NonFiniteError, r"denoiser 'probe_den' output.*NaN"),
    Bad("denoiser returning text",
        _denoise(_with_name("den", "def den(frame):\n    return 'image'\n")),
        DtypeError, r"denoiser 'probe_den'.*expected a tensor, got str"),
    Bad("denoiser returning integers",
        _denoise(_with_name("den", "def den(frame):\n    return (frame.color * 9).long()\n")),
        DtypeError, r"denoiser 'probe_den'.*expected a floating.*got torch\.int64"),
    Bad("denoiser returning another device",
        _denoise(_with_name("den", "def den(frame):\n    return frame.color.to('meta')\n")),
        DtypeError, r"denoiser 'probe_den'.*expected.*device cpu.*on meta"),
    Bad("denoiser subclass returning float64",
        lambda p: denoisers.get_denoiser(_spec(
            "from denoisers import Denoiser\nclass Den(Denoiser):\n    name = 'probe_f64'\n"
            "    def denoise(self, frame):\n        return frame.color.double()\n", "Den")(p))(
            Frame(color=torch.ones(3, 8, 8))),
        DtypeError, r"denoiser 'probe_f64' output.*expected.*float32.*got float64"),
    Bad("denoiser raising mid-run",
        _denoise(_with_name("den", "def den(frame):\n    raise ZeroDivisionError('oops')\n")),
        PluginError, r"plug\.py:den.*expected.*denoise.*ZeroDivisionError: oops"),
    Bad("scene factory raises",
        lambda p: renderers.get_scene(
            _spec("def scene():\n    raise OSError('gone')\n", "scene")(p)),
        PluginError, r"plug\.py:scene.*expected its scene to build.*OSError: gone"),
    Bad("scene of the wrong kind",
        lambda p: renderers.get_scene(_spec("def scene():\n    return 7\n", "scene")(p)),
        PluginError, r"plug\.py:scene.*expected"),
    Bad("sampler of the wrong kind",
        lambda p: sequences.load_sampler(_spec("class S: pass\n", "S")(p)),
        PluginError, r"plug\.py:S.*expected"),
    Bad("metric that is not callable", lambda p: load_metric(_spec("maxerr = 3\n", "maxerr")(p)),
        PluginError, r"plug\.py:maxerr.*expected"),
    Bad("metric returning text",
        lambda p: FrameMetrics(["mse", load_metric(_spec(
            "def probe_txt(pred, ref):\n    return 'big'\n", "probe_txt")(p))]).update(
            torch.zeros(3, 4, 4), torch.ones(3, 4, 4)),
        PluginError, r"plug\.py:probe_txt.*expected the metric to return a finite.*got 'big'"),
    Bad("metric raising",
        lambda p: FrameMetrics(["mse", load_metric(_spec(
            "def probe_raise(pred, ref):\n    raise IndexError('x')\n", "probe_raise")(p))]).update(
            torch.zeros(3, 4, 4), torch.ones(3, 4, 4)),
        PluginError, r"plug\.py:probe_raise.*IndexError"),
    Bad("name with a slash",
        lambda p: denoisers.get_denoiser(_spec(
            "def den(frame):\n    return frame.color\nden.name = 'a/b'\n", "den")(p)),
        PluginError, r"plug\.py:den.*expected a denoiser name without ':' or '/', got 'a/b'"),
    Bad("name of a shipped strategy",
        _strategy("from bnerr.strategies import WhiteStrategy\nclass Mine(WhiteStrategy):\n"
                  "    name = 'temporal'\n    stream = 0x51A7E0FA\n"),
        PluginError, r"plug\.py:Mine.*expected a name no other strategy has, got 'temporal'"),
]  # fmt: skip

_REGISTERED = [
    ("bnerr.denoisers", "probe_den"), ("bnerr.denoisers", "probe_ctor"),
    ("bnerr.denoisers", "probe_f64"), ("bnerr.denoisers", "a/b"),
    ("bnerr.strategies", "probe_raising"), ("bnerr.metrics", "probe_txt"),
    ("bnerr.metrics", "probe_raise"), ("bnerr.scenes", "scene"), ("bnerr.metrics", "maxerr"),
]  # fmt: skip


@pytest.fixture
def clean(forget):
    """Forget every plug-in the cases registered, and their cached imports (each case writes its
    own plug.py in its own folder)."""
    yield
    for group, name in _REGISTERED:
        if plugins.loaded(group, name) is not None or name in _registry(group):
            forget.append((group, name))


def _registry(group: str):
    from bnerr.metrics import METRIC_TABLE

    return {
        "bnerr.strategies": strategies.STRATEGIES,
        "bnerr.denoisers": denoisers.DENOISERS,
        "bnerr.scenes": renderers.SCENES,
        "bnerr.metrics": METRIC_TABLE,
    }.get(group, {})


@pytest.mark.parametrize("case", CASES, ids=ids(CASES))
def test_a_bad_plugin_is_refused_in_one_line_naming_it(case, tmp_path, clean):
    check(case, tmp_path)


def _broken_distribution(folder: Path) -> Path:
    """A distribution ``brokenden 0.3`` whose ``bnerr.denoisers`` entry point ``broken`` names a
    module that does not exist."""
    info = folder / "brokenden-0.3.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: brokenden\nVersion: 0.3\n")
    (info / "entry_points.txt").write_text("[bnerr.denoisers]\nbroken = no_such_mod_41:den\n")
    return folder


def test_an_entry_point_that_cannot_load_is_left_out_once_and_named_when_used(
    tmp_path, monkeypatch
):
    """Issue 54: one broken installed plug-in stopped every bench, even one that did not use it.
    It is left out with one warning naming it and its distribution; looking it up by name gives
    that error."""
    monkeypatch.syspath_prepend(str(_broken_distribution(tmp_path)))
    monkeypatch.setattr(plugins, "_BROKEN", {})
    plugins.installed.cache_clear()
    try:
        with pytest.warns(UserWarning, match=r"entry point broken.*brokenden 0\.3.*no_such_mod"):
            found = plugins.installed("bnerr.denoisers")
        assert "entry point broken" not in [p.spec for p in found]
        error = plugins.broken("bnerr.denoisers", "broken")
        assert isinstance(error, PluginError) and "brokenden 0.3" in str(error)
        registry = plugins.PluginRegistry("bnerr.denoisers", lambda p: ("x", p), {"box": 1})
        assert registry["box"] == 1 and "broken" not in registry
        with pytest.raises(PluginError, match=r"entry point broken.*brokenden 0\.3"):
            registry["broken"]
    finally:
        plugins.installed.cache_clear()


def test_a_broken_entry_point_stops_no_bench_that_does_not_name_it(tmp_path):
    from tests._paths import bnerr_cli

    site = _broken_distribution(tmp_path / "site")
    common = [
        "--suite", "quick", "--scenes", "direct", "--strategies", "white", "--spp", "1",
        "--frames", "1", "--warmup", "0", "--res", "8x8", "--reference-spp", "2",
        "--seed-sets", "1", "--metrics", "mse", "--cache", str(tmp_path / "cache"),
        "--quiet", "--no-charts",
    ]  # fmt: skip
    done = bnerr_cli(
        "bench", *common, "--denoisers", "gaussian", "--out", str(tmp_path / "o"), path=[site]
    )
    assert done.returncode == 0, done.stderr
    warned = [line for line in done.stderr.splitlines() if "brokenden" in line]
    assert len(warned) == 1 and warned[0].startswith("bnerr bench: warning: plug-in 'entry")
    named = bnerr_cli(
        "bench", *common, "--denoisers", "broken", "--out", str(tmp_path / "n"), path=[site]
    )
    assert named.returncode == 2 and "Traceback" not in named.stderr
    assert re.search(r"bnerr bench: error: plug-in 'entry point broken' \(brokenden 0\.3\)",
                     named.stderr), named.stderr  # fmt: skip


FLAKY = '''
import os

HERE = os.path.dirname(__file__)


def den(frame):
    """Raises from its second call on while the file 'broken' lies beside it."""
    calls = os.path.join(HERE, "calls")
    with open(calls, "a") as f:
        f.write("x")
    if os.path.exists(os.path.join(HERE, "broken")) and os.path.getsize(calls) > 1:
        raise RuntimeError("the plug-in broke")
    return frame.color


den.name = "probe_flaky"
'''


def _bench(tmp_path: Path, *extra: str) -> list[str]:
    return [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white", "temporal",
        "--denoisers", "gaussian", f"{tmp_path / 'flaky.py'}:den", "--metrics", "mse",
        "--spp", "1", "--frames", "1", "--warmup", "0", "--res", "8x8", "--reference-spp", "2",
        "--seed-sets", "1", "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache"),
        "--quiet", "--no-charts", *extra,
    ]  # fmt: skip


def test_a_plugin_raising_mid_run_keeps_the_records_and_resume_completes(tmp_path, capsys, forget):
    forget.append(("bnerr.denoisers", "probe_flaky"))
    (tmp_path / "flaky.py").write_text(FLAKY)
    (tmp_path / "broken").write_text("")
    refused_on_the_command_line(
        _bench(tmp_path), capsys, r"flaky\.py:den.*expected.*denoise.*the plug-in broke"
    )
    records = (tmp_path / "out" / "cells.jsonl").read_text().splitlines()
    assert {json.loads(line)["cell"]["strategy"] for line in records} == {"white"}
    (tmp_path / "broken").unlink()
    from benchmarks.cli import main

    assert main(_bench(tmp_path, "--resume")) == 0, capsys.readouterr().err
    lines = (tmp_path / "out" / "cells.jsonl").read_text().splitlines()
    assert lines[: len(records)] == records
    assert {json.loads(line)["cell"]["strategy"] for line in lines} == {"white", "temporal"}
