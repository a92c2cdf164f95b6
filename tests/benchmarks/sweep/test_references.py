"""Tests of benchmarks.sweep.references: reference seeds, the cache's round trip, and a cache key
that follows every input of a reference (the tracer's and the samplers' code among them)."""

import dataclasses
import re
import shutil

import pytest
import torch

import renderers
from benchmarks.suites import Suite, Sweep
from benchmarks.sweep import version
from benchmarks.sweep.parts import real_parts
from benchmarks.sweep.plan import plan
from benchmarks.sweep.references import (
    REFERENCE_COMPILE_PATHS,
    ReferenceCache,
    reference_compile,
    reference_seeds,
)
from benchmarks.sweep.version import code_version, reference_sources, source_hash
from bnerr import plugins
from bnerr.frame import Frame
from bnerr.io import read_frame, write_frame

pytestmark = pytest.mark.usefixtures("one_thread")


class _Counting:
    def __init__(self, render):
        self.render, self.calls = render, 0

    def __call__(self, *args, **kwargs):
        self.calls += 1
        return self.render(*args, **kwargs)


def _run():
    sweep = Sweep(
        scenes=("direct",),
        strategies=("white",),
        spp=(1,),
        denoisers=("gaussian",),
        frames=2,
        warmup=1,
        res=(16, 12),
        reference_spp=16,
        seed_sets=1,
    )
    return plan(Suite("tiny", "test", sweeps=(sweep,)))[0]


def _mix32_twin(x: int) -> int:
    """The 0x45d9f3b mix on one Python int, written out (the slow twin of the seeds' hash)."""
    for _ in range(2):
        x = (((x >> 16) ^ x) * 0x45D9F3B) & 0xFFFFFFFF
    return (x >> 16) ^ x


def test_reference_seeds_are_deterministic_distinct_and_32_bit():
    a = reference_seeds(32, 32, 3)
    assert a.dtype == torch.int64 and a.shape == (32, 32)
    assert torch.equal(a, reference_seeds(32, 32, 3))
    assert a.unique().numel() == 32 * 32
    assert int(a.min()) >= 0 and int(a.max()) < 2**32
    assert not torch.equal(a, reference_seeds(32, 32, 4))


@pytest.mark.parametrize("t", [0, 7, 2**32 + 5])
def test_reference_seeds_are_bit_identical_to_the_written_out_hash(t):
    # The committed references (and every result measured against them) depend on these bits.
    want = [_mix32_twin(_mix32_twin(i ^ 0x5EEDBA5E) ^ (t & 0xFFFFFFFF)) for i in range(9 * 7)]
    assert reference_seeds(9, 7, t).reshape(-1).tolist() == want


def test_references_are_rendered_once_and_read_back_bit_exact(tmp_path):
    counting = _Counting(real_parts().render)
    parts = dataclasses.replace(real_parts(), render=counting)
    run = _run()
    scene = parts.get_scene("direct", True)
    first = ReferenceCache(tmp_path, parts).get(run, scene, 5)
    assert counting.calls == 1
    again = ReferenceCache(tmp_path, parts).get(run, scene, 5)  # a new cache object: from disk
    assert counting.calls == 1
    assert torch.equal(first.color, again.color) and torch.equal(first.object_id, again.object_id)
    (path,) = tmp_path.rglob("*.exr")
    assert path.name.startswith("direct_m1_d_t5_16x12_spp16_owen_sobol_s5eedba5e_")
    assert parts.code_version in path.name
    path.write_bytes(b"torn")  # a corrupt cache file is rendered again, not trusted
    assert torch.equal(ReferenceCache(tmp_path, parts).get(run, scene, 5).color, first.color)
    assert counting.calls == 2
    assert torch.equal(read_frame(path).color, first.color)


def test_sources_cover_the_renderer_the_samplers_and_the_hash():
    labels = set(reference_sources())
    assert "renderers/tracer.py" in labels and "bnerr/hashing.py" in labels
    assert any(label.startswith("bnerr/sequences") for label in labels)
    assert all(label.endswith(".py") for label in labels)
    version = code_version()
    assert version == real_parts().code_version and len(version.split("-")[-1]) == 12


def test_changing_a_samplers_code_invalidates_the_cache(tmp_path, monkeypatch):
    sources = reference_sources()
    sampler_label = next(label for label in sorted(sources) if label.startswith("bnerr/sequences"))
    copy = tmp_path / "copy.py"
    shutil.copy(sources[sampler_label], copy)
    monkeypatch.setattr(version, "reference_sources", lambda: {**sources, sampler_label: copy})
    before = real_parts()
    assert before.code_version == code_version(sources)  # same bytes, same key
    with copy.open("a") as handle:
        handle.write("\n# a change to the sampler\n")
    after = real_parts()
    assert after.code_version != before.code_version
    counting = _Counting(before.render)
    run, cache = _run(), tmp_path / "cache"
    scene = before.get_scene("direct", True)
    ReferenceCache(cache, dataclasses.replace(before, render=counting)).get(run, scene, 1)
    ReferenceCache(cache, dataclasses.replace(after, render=counting)).get(run, scene, 1)
    assert counting.calls == 2 and len(list(cache.rglob("*.exr"))) == 2


def test_source_hash_follows_labels_and_bytes(tmp_path):
    a, b = tmp_path / "a.py", tmp_path / "b.py"
    a.write_text("x = 1\n")
    b.write_text("x = 1\n")
    assert source_hash({"a.py": a}) == source_hash({"a.py": b})
    assert source_hash({"a.py": a}) != source_hash({"b.py": a})
    b.write_text("x = 2\n")
    assert source_hash({"a.py": a}) != source_hash({"a.py": b})


def test_references_compile_exactly_from_2_22_paths_as_the_committed_results_did(monkeypatch):
    # The tracer's former automatic rule (compiled from 2^22 paths), independent of BNERR_COMPILE.
    assert REFERENCE_COMPILE_PATHS == 1 << 22
    monkeypatch.setenv("BNERR_COMPILE", "1")
    assert reference_compile(128, 128, 1024) and reference_compile(128, 128, 512)
    assert reference_compile(64, 64, 1024)  # exactly 2^22
    assert not reference_compile(64, 64, 1023) and not reference_compile(16, 12, 16)
    assert not reference_compile(128, 128, 255) and reference_compile(128, 128, 256)


class _Recording:
    """A stand-in render that records the compile flag it is given (and returns a tiny frame)."""

    def __init__(self):
        self.compiles = []

    def __call__(self, scene, t, seeds, sampler, spp, *, compile=None):
        self.compiles.append(compile)
        return Frame(color=torch.zeros(3, *seeds.shape))


@pytest.mark.parametrize(("res", "spp", "want"), [((16, 12), 16, False), ((64, 64), 1024, True)])
def test_the_cache_passes_the_compile_rule_to_the_renderer(tmp_path, res, spp, want):
    recording = _Recording()
    parts = dataclasses.replace(real_parts(), render=recording)
    run = dataclasses.replace(_run(), width=res[0], height=res[1], reference_spp=spp)
    ReferenceCache(tmp_path, parts).get(run, parts.get_scene("direct", True), 0)
    assert recording.compiles == [want]


def test_the_progress_text_names_each_reference_render_and_the_first_compile(tmp_path):
    parts = dataclasses.replace(real_parts(), render=_Recording())
    run = dataclasses.replace(_run(), width=64, height=64, reference_spp=1024)
    cache = ReferenceCache(tmp_path, parts)
    told = []
    cache.on_render = told.append
    scene = parts.get_scene("direct", True)
    cache.get(run, scene, 0)
    cache.get(run, scene, 0)  # in memory: nothing rendered, nothing told
    cache.get(run, scene, 1)
    assert told == [
        "reference t=0 at 1024 spp, compiling the tracer first (up to a minute)",
        "",
        "reference t=1 at 1024 spp",
        "",
    ]


def _ref_plug():
    """A plug-in scene: ``direct`` under another name."""
    return dataclasses.replace(renderers.get_scene("direct"), name="ref_plug")


_ref_plug.name = "ref_plug"  # type: ignore[attr-defined]  # the name it registers under


def test_a_plugin_scene_keys_its_references_by_its_fingerprint(tmp_path, forget):
    run = dataclasses.replace(_run(), scene="ref_plug")
    cache = ReferenceCache(tmp_path, real_parts())
    forget.append(("bnerr.scenes", "ref_plug"))
    keys = []
    for content in (b"one scene", b"the same scene, edited"):
        (tmp_path / "s.toml").write_bytes(content)  # a scene file's fingerprint: its bytes
        files = (str(tmp_path / "s.toml"),)
        renderers.SCENES.add(plugins.Plugin("s.toml", _ref_plug, None, files))  # type: ignore[attr-defined]
        keys.append(cache.path(run, 0).name)
    assert re.match(r"ref_plug_m1_.*_sha256-[0-9a-f]{16}\.exr$", keys[0]) and keys[0] != keys[1]
    assert cache.path(_run(), 0).name.startswith("direct_m1_")  # a shipped scene: as before


def test_a_sweep_off_the_cpu_keys_its_references_apart_and_the_cpu_keys_stay(tmp_path):
    cpu = ReferenceCache(tmp_path, real_parts())
    cuda = ReferenceCache(tmp_path, dataclasses.replace(real_parts(), device="cuda:1"))
    on_cpu, on_cuda = cpu.path(_run(), 0), cuda.path(_run(), 0)
    assert on_cuda.name == on_cpu.name.removesuffix(".exr") + "_cuda.exr"
    assert on_cpu.name.endswith(f"_{code_version()}.exr")  # the CPU's names as they were


def test_a_cached_reference_is_moved_to_the_sweeps_device(tmp_path, monkeypatch):
    parts = dataclasses.replace(real_parts(), device="cuda")
    cache = ReferenceCache(tmp_path, parts)
    cache.path(_run(), 0).parent.mkdir(parents=True)
    frame = real_parts().render(renderers.get_scene("direct"), 0, torch.zeros(12, 16).long(),
                                real_parts().reference_sampler(), 1)  # fmt: skip
    write_frame(cache.path(_run(), 0), frame)
    moved = []
    monkeypatch.setattr(Frame, "to", lambda self, device: moved.append(device) or self)
    assert torch.equal(cache.get(_run(), None, 0).color, frame.color)
    assert moved == ["cuda"]


def test_device_info_is_none_on_the_cpu_and_names_a_gpu_and_torch(monkeypatch):
    assert version.device_info("cpu") is None
    monkeypatch.setattr(torch.cuda, "current_device", lambda: 0)
    monkeypatch.setattr(torch.cuda, "get_device_name", lambda where: f"GPU {where}")
    info = version.device_info("cuda")
    assert info == {
        "device": "cuda:0",
        "name": "GPU cuda:0",
        "torch": torch.__version__,
        "cuda": torch.version.cuda or "",
    }
