"""Tests of bnerr.plugins and the registries' plug-in hooks: specs ``pkg.mod:attr`` and
``file.py:Name`` resolve, register under their name and are found like shipped entries; every
failure is a one-line PluginError naming the plug-in; the fingerprint follows the source; the
sweep's parts load the specs again (what a fresh worker does)."""

import importlib
import sys
import textwrap

import pytest
import torch

import denoisers
import renderers
from bnerr import plugins, sequences, strategies
from bnerr.errors import FileFormatError, PluginError
from bnerr.frame import Frame
from bnerr.metrics import METRIC_TABLE, FrameMetrics, load_metric

STRATEGY = """
from bnerr.strategies import WhiteStrategy

class Mine(WhiteStrategy):
    name = "{name}"
    family = "experimental"
    stream = {stream}
"""


def _write(path, text):
    path.write_text(textwrap.dedent(text))
    return path


def test_a_strategy_file_registers_under_its_name_with_its_family(tmp_path, forget):
    path = _write(tmp_path / "strat.py", STRATEGY.format(name="plug_a", stream=0x51A7E001))
    forget.append(("bnerr.strategies", "plug_a"))
    strategy = strategies.make_strategy(f"{path}:Mine", 4, 4, seed=1)
    assert strategy.name == "plug_a" and "plug_a" in strategies.STRATEGIES
    assert strategies.STRATEGIES["plug_a"].family == "experimental"
    module = sys.modules[plugins.file_module_name(path)]
    assert str(tmp_path) not in sys.path and module.__name__.startswith("bnerr_plugin_strat_")
    assert plugins.resolve(f"{path}:Mine").obj is strategies.STRATEGIES["plug_a"]


def test_errors_name_the_plugin_and_what_was_expected(tmp_path, forget):
    bad = _write(tmp_path / "bad.py", "import no_such_module_here\n")
    with pytest.raises(PluginError, match=r"plug-in '.*bad.py:X' \(no distribution\).*importable"):
        plugins.resolve(f"{bad}:X")
    good = _write(tmp_path / "good.py", "class Thing:\n    name = 'thing'\n")
    with pytest.raises(PluginError, match="expected an attribute 'Missing'"):
        plugins.resolve(f"{good}:Missing")
    with pytest.raises(PluginError, match="expected a subclass of bnerr.strategies.base.Strategy"):
        strategies.make_strategy(f"{good}:Thing", 4, 4)
    with pytest.raises(PluginError, match="expected a denoisers.Denoiser subclass"):
        denoisers.get_denoiser(f"{good}:Thing.name")
    raising = _write(tmp_path / "raising.py", "def scene():\n    raise RuntimeError('boom')\n")
    forget.append(("bnerr.scenes", "scene"))  # registered, though it cannot build
    with pytest.raises(PluginError, match="raising.py:scene.*expected its scene to build.*boom"):
        renderers.get_scene(f"{raising}:scene")
    with pytest.raises(FileFormatError, match="scene.xml: expected a readable Mitsuba XML scene"):
        renderers.get_scene(str(tmp_path / "scene.xml"))  # XML scenes: renderers.mitsuba_scene


def test_a_function_denoiser_is_wrapped_with_its_kind_and_grid(tmp_path, forget):
    path = _write(
        tmp_path / "den.py",
        """
        def scaled(frame, gain=1.0):
            return frame.color * gain
        scaled.name = "scaled_plug"
        scaled.kind = "filter"
        scaled.grid = {"gain": [1.0, 0.5]}
        """,
    )
    forget.append(("bnerr.denoisers", "scaled_plug"))
    denoiser = denoisers.get_denoiser(f"{path}:scaled", gain=0.5)
    cls = denoisers.DENOISERS["scaled_plug"]
    assert (cls.kind, dict(cls.grid)) == ("filter", {"gain": [1.0, 0.5]})
    frame = Frame(color=torch.ones(3, 2, 2))
    assert torch.equal(denoiser(frame), torch.full((3, 2, 2), 0.5))
    assert denoiser.params() == {"gain": 0.5}


def test_a_manifest_path_dispatches_to_the_external_denoiser(tmp_path, monkeypatch, forget):
    stand_in = type(sys)("denoisers.external")

    class External(denoisers.Denoiser):
        name = "ext_plug"

    stand_in.denoiser_class = lambda path: External
    stand_in.program_file = lambda manifest: None  # the file its command runs: none here
    External.manifest = None
    monkeypatch.setitem(sys.modules, "denoisers.external", stand_in)
    forget.append(("bnerr.denoisers", "ext_plug"))
    manifest = _write(tmp_path / "den.toml", "name = 'ext_plug'\n")
    assert denoisers.load_denoiser(str(manifest)) == "ext_plug"
    assert plugins.loaded("bnerr.denoisers", "ext_plug").fingerprint.startswith("sha256:")


def test_a_sampler_and_a_metric_plugin(tmp_path, forget):
    _write(
        tmp_path / "plug_extras.py",
        """
        from bnerr.sequences import WhiteSampler

        class Mine(WhiteSampler):
            name = "plug_sampler"

        def maxerr(pred, ref):
            "the largest absolute error"
            return float((pred - ref).abs().max())
        """,
    )
    sys.path.insert(0, str(tmp_path))
    try:
        forget += [("bnerr.samplers", "plug_sampler"), ("bnerr.metrics", "maxerr")]
        assert sequences.load_sampler("plug_extras:Mine") == "plug_sampler"
        assert "plug_sampler" in sequences.per_pixel_samplers()
        assert isinstance(sequences.make_sampler("plug_sampler"), sequences.WhiteSampler)
        assert load_metric("plug_extras:maxerr") == "maxerr"
        assert METRIC_TABLE["maxerr"].description == "the largest absolute error"
        acc = FrameMetrics(["mse", "maxerr"])
        row = acc.update(torch.zeros(3, 4, 4), torch.full((3, 4, 4), 0.25))
        assert row["maxerr"] == pytest.approx(0.25)
        fingerprint = plugins.loaded("bnerr.metrics", "maxerr").fingerprint
        assert fingerprint.startswith("sha256:") and len(fingerprint) == 23
    finally:
        sys.path.remove(str(tmp_path))
        sys.modules.pop("plug_extras", None)


def test_the_fingerprint_follows_the_source(tmp_path):
    path = _write(tmp_path / "fp.py", "def f():\n    return 1\n")
    before = plugins.plugin_fingerprint(plugins.resolve(f"{path}:f").obj)
    path.write_text("def f():\n    return 2\n")
    sys.modules.pop(plugins.file_module_name(path))
    plugins._resolve.cache_clear()
    assert plugins.plugin_fingerprint(plugins.resolve(f"{path}:f").obj) != before


def test_the_parts_load_the_specs_again_in_a_fresh_worker(tmp_path, forget):
    from benchmarks.sweep.parts import real_parts

    path = _write(tmp_path / "again.py", STRATEGY.format(name="plug_b", stream=0x51A7E002))
    spec = f"{path}:Mine"
    forget.append(("bnerr.strategies", "plug_b"))
    assert strategies.REGISTRY.name_of(spec) == "plug_b"
    parts = real_parts((("bnerr.strategies", spec),))
    # what a fresh worker process starts from: neither the module nor the name is known
    strategies.REGISTRY.remove("plug_b")
    plugins._LOADED.pop(("bnerr.strategies", "plug_b"))
    sys.modules.pop(plugins.file_module_name(path))
    plugins._resolve.cache_clear()
    scene = parts.get_scene("direct", True)
    assert parts.make_strategy("plug_b", scene, 4, 4, 0, "owen_sobol", 1).name == "plug_b"


def test_a_file_plugin_is_found_by_its_path_once_registered(tmp_path, forget):
    manifest = _write(tmp_path / "den.toml", "name = 'ext_again'\n")
    assert plugins.registered_file("bnerr.denoisers", manifest) is None
    forget.append(("bnerr.denoisers", "ext_again"))
    files = (str(manifest.resolve()),)
    plugins.record(
        "bnerr.denoisers", "ext_again", plugins.Plugin(str(manifest), object(), None, files)
    )
    assert plugins.registered_file("bnerr.denoisers", tmp_path / "." / "den.toml") == "ext_again"
    assert plugins.registered_file("bnerr.scenes", manifest) is None  # per group


def test_a_strategy_file_also_imported_as_a_module_still_loads_by_its_spec(
    tmp_path, monkeypatch, forget
):
    path = _write(tmp_path / "twice_mod.py", STRATEGY.format(name="plug_twice", stream=0x51A7E0F3))
    forget.append(("bnerr.strategies", "plug_twice"))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "twice_mod", raising=False)
    importlib.import_module("twice_mod")  # an entry point's import: the class registers itself
    assert strategies.REGISTRY.name_of(f"{path}:Mine") == "plug_twice"  # the file's own import
    assert strategies.make_strategy("plug_twice", 4, 4).name == "plug_twice"


def test_an_installed_plugins_fingerprint_follows_its_source_not_only_its_version(
    tmp_path, monkeypatch
):
    """Issue 54: ``--resume`` did not see an edited entry-point module whose version did not
    change (an editable install); the fingerprint is ``name==version+sha256:<its source>``."""
    info = tmp_path / "fpdist54-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fpdist54\nVersion: 1.0\n")
    (info / "top_level.txt").write_text("fpmod54\n")
    source = tmp_path / "fpmod54.py"
    source.write_text("def metric(pred, ref):\n    return 0.0\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    plugins._top_level_distributions.cache_clear()
    try:
        plugin = plugins.resolve("fpmod54:metric")
        assert plugin.distribution == "fpdist54 1.0"
        before = plugin.fingerprint
        assert before.startswith("fpdist54==1.0+sha256:")
        assert plugins.plugin_fingerprint(plugin.obj) == before
        source.write_text("def metric(pred, ref):\n    return 1.0\n")  # same version
        assert plugin.fingerprint != before and plugin.fingerprint.startswith("fpdist54==1.0+")
    finally:
        plugins._top_level_distributions.cache_clear()
        sys.modules.pop("fpmod54", None)
