"""Tests of benchmarks.sweep.measure with stand-in parts: the timings come from the frame's own
clock (one stopwatch per render), stateless strategies skip the warmup, crops are sRGB previews, and
the denoisers are tuned once on white noise."""

import dataclasses

import numpy as np
import pytest
import torch

from benchmarks.suites import Condition, Suite, Sweep
from benchmarks.sweep.measure import measure_run
from benchmarks.sweep.parts import Parts
from benchmarks.sweep.plan import plan
from benchmarks.sweep.references import ReferenceCache
from benchmarks.sweep.tuning import TUNING_SEED_SET, tune_denoisers
from bnerr import strategies
from bnerr.color import preview_u8
from bnerr.frame import Frame
from bnerr.metrics import cvvdp as cvvdp_module
from bnerr.sequences import make_sampler

pytestmark = pytest.mark.usefixtures("one_thread")


@dataclasses.dataclass(frozen=True)
class _Scene:
    dimensions: int = 3


@dataclasses.dataclass(frozen=True)
class _Lit(_Scene):
    lights: tuple[int, ...] = ()


class _Render:
    """A render whose colour is a fixed function of the seeds and t; reports 7 ms, records calls."""

    def __init__(self):
        self.calls, self.compiles = [], []

    def __call__(self, scene, t, seeds, sampler, spp, *, compile=None):
        self.calls.append((t, spp))
        self.compiles.append(compile)
        u = ((seeds * 2654435761 + t) % 1000003).float() / 1000003
        color = torch.stack([u, u * u, 1 - u]) * 2.0
        h, w = seeds.shape
        object_id = torch.zeros(1, h, w)
        object_id[:, :, 7:] = 1.0  # two objects: columns 0-6 and 7-9
        return Frame(
            color=color,
            albedo=torch.full((3, h, w), 0.5),
            normal=torch.tensor([0.0, 0.0, 1.0])[:, None, None].expand(3, h, w).clone(),
            depth=torch.full((1, h, w), 2.0),
            object_id=object_id,
            variance=color * 0.01,
            timings={"render": 7.0},
        )


class _Store:
    def __init__(self):
        self.entries, self.puts = {}, []

    def put(self, result, scene, spp):
        self.puts.append((result, scene, spp))
        self.entries.setdefault(result, {}).setdefault(scene, {})[str(spp)] = {"scale": 0.5}

    def params(self, denoiser, scene, spp):
        return self.entries[denoiser][scene][str(spp)]


def _parts(render):
    def make_strategy(name, scene, height, width, seed, sampler, spp):
        return strategies.make_strategy(name, height, width, seed=seed, sampler=sampler, spp=spp)

    def make_denoiser(name, params):
        scale = (params or {}).get("scale", 1.0)
        return lambda frame: frame.color * scale

    return Parts(
        get_scene=lambda name, animated: _Scene(),
        render=render,
        make_strategy=make_strategy,
        make_denoiser=make_denoiser,
        tune_denoiser=lambda name, frames, refs: name if name == "half" else None,
        reference_sampler=lambda: make_sampler("owen_sobol"),
        with_depth=lambda scene, depth: scene,
        code_version="test",
    )


def _run(strategy, crops=True, coherent=False, skips=()):
    sweep = Sweep(scenes=("direct",), strategies=(strategy,), spp=(2,), denoisers=("gaussian",),
                  frames=2, warmup=3, res=(10, 8), reference_spp=4, seed_sets=2)  # fmt: skip
    suite = Suite("t", "t", sweeps=(sweep,), crops=crops, coherent=coherent, coherent_skips=skips)
    (run,) = plan(suite)
    return dataclasses.replace(run, denoisers=("half", "plain"))


def test_timings_are_the_frames_own_and_stateless_strategies_skip_the_warmup(tmp_path):
    render = _Render()
    parts = _parts(render)
    run = _run("white")
    denoisers = {"half": parts.make_denoiser("half", {"scale": 0.5}), "plain": lambda f: f.color}
    ticks = []
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), denoisers,
                          on_frame=lambda: ticks.append(1))  # fmt: skip
    assert len(records) == 2 and len(ticks) == 2 * (3 + 2)
    measured = [c for c in render.calls if c[1] == 2]
    assert measured == [(3, 2), (4, 2)] * 2  # the warmup frames 0..2 are not rendered
    for rec in records:
        assert rec.timings.render_ms == [[7.0, 7.0], [7.0, 7.0]]
        assert all(v >= 0 for row in rec.timings.perm_ms for v in row)
        assert rec.t == [3, 4] and rec.reference.version == "test" and rec.dimensions == 3
        assert rec.reference.floor > 0 and rec.crop is None  # no crops folder given


def test_coherent_records_say_how_much_of_the_image_they_cover(tmp_path):
    render = _Render()
    parts = _parts(render)
    run = _run("white", coherent=True)
    denoisers = {"half": parts.make_denoiser("half", {"scale": 0.5}), "plain": lambda f: f.color}
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), denoisers)
    assert [r.cell.region for r in records] == ["all", "coherent"] * 2
    # 10 x 8 pixels, windows of 5 x 5 inside the image and inside columns 0-6: x in 2..4, y in 2..5
    want = (3 * 4) / (10 * 8)
    for rec in records:
        if rec.cell.region == "all":
            assert rec.coverage is None and "coverage" not in rec.to_json()
        else:
            assert rec.coverage == [[want, want], [want, want]]
    whole, part = records[0].raw["mse"], records[1].raw["mse"]
    assert part != whole  # measured over the coherent pixels only
    # the raw error's spectrum over the coherent pixels too, the same in every cell of the run
    spectra = [r.spectrum["coherent"] for r in records]
    assert spectra[0].freq == records[0].spectrum["raw"].freq and spectra.count(spectra[0]) == 4
    assert spectra[0].power != records[0].spectrum["raw"].power


def test_the_coherent_region_measures_without_the_suites_skipped_metrics(tmp_path):
    render = _Render()
    parts = _parts(render)
    run = _run("white", coherent=True, skips=("ssim",))
    denoisers = {"half": parts.make_denoiser("half", {"scale": 0.5}), "plain": lambda f: f.color}
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), denoisers)
    full = _run("white", coherent=True)
    again = measure_run(full, parts, ReferenceCache(tmp_path, parts), denoisers)
    for rec, whole in zip(records, again, strict=True):
        want = [m for m in run.metrics if rec.cell.region != "coherent" or m != "ssim"]
        assert sorted(rec.raw) == sorted(rec.den) == sorted(want)
        assert {m: rec.den[m] for m in want} == {m: whole.den[m] for m in want}  # the same


@pytest.mark.parametrize("lights", [(1,), ()])
def test_unlit_records_leave_out_the_pixels_next_to_a_visible_light(tmp_path, monkeypatch, lights):
    # object 1 (columns 7-9) is the light: grown by a pixel, columns 6-9 are left out; a scene
    # whose lights are out of view measures every pixel, the whole image's records bit for bit,
    # and its sequences are scored once (a stand-in for ColorVideoVDP counts them)
    monkeypatch.setattr(cvvdp_module, "require_cvvdp", lambda: None)
    scored = []

    def jod(preds, refs, masks=None):
        scored.append(masks)
        shown = [p if m is None else torch.where(m, p, r) for p, r, m in zip(preds, refs, masks)]
        return float(sum(float((p - r).abs().mean()) for p, r in zip(shown, refs, strict=True)))

    monkeypatch.setattr(cvvdp_module, "sequence_jod", jod)
    render = _Render()
    parts = dataclasses.replace(
        _parts(render), get_scene=lambda name, animated: _Lit(lights=lights)
    )
    sweep = Sweep(scenes=("direct",), strategies=("white",), spp=(2,), denoisers=("gaussian",),
                  frames=2, warmup=3, res=(10, 8), reference_spp=4, seed_sets=2,
                  metrics=("mse", "cvvdp"),
                  conditions=(Condition(), Condition(region="unlit")))  # fmt: skip
    (run,) = plan(Suite("t", "t", sweeps=(sweep,), crops=False))
    run = dataclasses.replace(run, denoisers=("plain",))
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), {"plain": lambda f: f.color})
    whole, unlit = records
    assert (whole.cell.region, unlit.cell.region) == ("all", "unlit")
    if lights:
        assert unlit.coverage == [[0.6, 0.6], [0.6, 0.6]]
        assert unlit.raw["mse"] != whole.raw["mse"]
        assert unlit.raw["cvvdp"] != whole.raw["cvvdp"]
        assert len(scored) == 2 * 2 * 2  # seed sets x (raw, plain) x regions
    else:
        assert unlit.coverage == [[1.0, 1.0], [1.0, 1.0]]
        assert unlit.raw == whole.raw and unlit.den == whole.den
        assert len(scored) == 2 * 2 and all(m == [None, None] for m in scored)


def test_records_hold_the_error_correlation_between_consecutive_measured_frames(tmp_path):
    render = _Render()
    parts = _parts(render)
    run = _run("white")
    denoisers = {"half": parts.make_denoiser("half", {"scale": 0.5}), "plain": lambda f: f.color}
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), denoisers)
    for rec in records:  # 2 seed sets x (2 measured frames - 1) pairs, each a correlation
        assert len(rec.tcorr) == 2 and all(len(row) == 1 for row in rec.tcorr)
        assert all(-1.0 <= v <= 1.0 for row in rec.tcorr for v in row)
    assert records[0].tcorr == records[1].tcorr  # a property of the raw frames, not the denoiser


def test_temporal_renders_its_warmup_and_crops_are_srgb_previews(tmp_path):
    render = _Render()
    parts = _parts(render)
    run = _run("temporal")
    refs = ReferenceCache(tmp_path / "refs", parts)
    denoisers = {"half": parts.make_denoiser("half", {"scale": 0.5}), "plain": lambda f: f.color}
    records = measure_run(run, parts, refs, denoisers, crops_dir=tmp_path / "crops")
    assert len([c for c in render.calls if c[1] == 2]) == 2 * (3 + 2)
    assert records[0].crop == "crops/direct_temporal_2spp_m1_owen_sobol.npz"
    with np.load(tmp_path / records[0].crop) as data:
        ref = refs.get(run, _Scene(), 3).color
        np.testing.assert_array_equal(data["reference"], preview_u8(ref))
        assert set(data.files) == {"reference", "raw", "denoised__half", "denoised__plain"}


def test_denoisers_are_tuned_once_on_the_white_tuning_seed_set(tmp_path):
    render = _Render()
    parts = _parts(render)
    made = []
    parts = dataclasses.replace(
        parts,
        make_strategy=lambda name, scene, h, w, seed, sampler, spp: (
            made.append((name, seed))
            or strategies.make_strategy(name, h, w, seed=seed, sampler=sampler, spp=spp)
        ),
    )
    store = _Store()
    run = _run("temporal")
    refs = ReferenceCache(tmp_path, parts)
    denoisers = tune_denoisers(run, parts, refs, store)
    assert made == [("white", TUNING_SEED_SET)]
    assert [p[1:] for p in store.puts] == [("direct/m1/owen_sobol/10x8", 2)]
    frame = Frame(color=torch.ones(3, 8, 10))
    assert (
        float(denoisers["half"](frame).mean()) == 0.5
        and float(denoisers["plain"](frame).mean()) == 1
    )
    tune_denoisers(dataclasses.replace(run, denoisers=("half",)), parts, refs, store)
    # already stored: nothing rendered or tuned again
    assert made == [("white", TUNING_SEED_SET)] and len(store.puts) == 1


_RENDERED_WITH = [
    ("white", "owen_sobol"),
    ("zsobol", "zsobol"),
    ("temporal_zsobol", "zsobol"),
    ("bnds_st", "bnds"),
]


@pytest.mark.parametrize(("strategy", "want"), _RENDERED_WITH)
def test_records_keep_the_sampler_the_strategy_rendered_with(tmp_path, strategy, want):
    render = _Render()
    parts = _parts(render)
    run = _run(strategy, crops=False)
    denoisers = {"half": parts.make_denoiser("half", {"scale": 0.5}), "plain": lambda f: f.color}
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), denoisers)
    assert {r.render_sampler for r in records} == {want}
    assert {r.cell.sampler for r in records} == {"owen_sobol"}  # the condition, paired with white


class _Accumulating:
    """A stand-in stateful denoiser: the running mean of the colours it was fed since reset;
    logs resets and frame indices."""

    stateful = True

    def __init__(self):
        self.log, self.total, self.count = [], None, 0

    def reset(self):
        self.log.append("reset")
        self.total, self.count = None, 0

    def __call__(self, frame, t=None):
        self.log.append(t)
        self.total = frame.color if self.total is None else self.total + frame.color
        self.count += 1
        return self.total / self.count


@pytest.mark.parametrize("strategy", ["white", "temporal"])
def test_stateful_denoisers_see_every_frame_in_order_and_reset_per_seed_set(tmp_path, strategy):
    render = _Render()
    parts = _parts(render)
    run = dataclasses.replace(_run(strategy, crops=False), denoisers=("acc", "plain"))
    acc = _Accumulating()
    denoisers = {"acc": acc, "plain": lambda f: f.color}
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), denoisers)
    assert acc.log == ["reset", 0, 1, 2, 3, 4] * 2  # warmup frames 0..2 included
    assert [c for c in render.calls if c[1] == 2] == [(t, 2) for t in range(5)] * 2
    by_name = {r.cell.denoiser: r for r in records}
    assert by_name["acc"].den["mse"] != by_name["plain"].den["mse"]
    assert by_name["acc"].raw == by_name["plain"].raw
    assert len(by_name["acc"].timings.denoise_ms[0]) == 2  # measured frames only


def test_own_tuning_tunes_on_the_strategys_held_out_frames_and_stores_its_own_name(tmp_path):
    from denoisers.tuning import ParamStore, TuneResult

    render = _Render()
    made, tuned = [], []

    def tune_denoiser(name, frames, refs):
        tuned.append((name, len(frames)))
        scale = 0.5 if len(made) == 1 else 0.25  # white's frames first, then temporal's
        return TuneResult(denoiser=name, params={"scale": scale}, mse=1.0, noisy_mse=2.0, frames=2)

    base = _parts(render)
    parts = dataclasses.replace(
        base,
        make_strategy=lambda *a: made.append((a[0], a[4])) or base.make_strategy(*a),
        tune_denoiser=tune_denoiser,
    )
    run = dataclasses.replace(_run("temporal", crops=False), denoisers=("half", "half:own"))
    store = ParamStore()
    denoisers = tune_denoisers(run, parts, ReferenceCache(tmp_path, parts), store)
    assert made == [("white", TUNING_SEED_SET), ("temporal", TUNING_SEED_SET)]
    assert tuned == [("half", 2), ("half", 2)]  # the base name, min(frames, 4) frames each
    # temporal rendered its warmup (frames 0..2) before the 2 tuning frames
    assert [c[0] for c in render.calls if c[1] == 2][-5:] == [0, 1, 2, 3, 4]
    assert store.params("half", "direct/m1/owen_sobol/10x8", 2) == {"scale": 0.5}
    assert store.params("half:own", "direct/m1/owen_sobol/10x8/temporal", 2) == {"scale": 0.25}
    frame = Frame(color=torch.ones(3, 8, 10))
    assert float(denoisers["half"](frame).mean()) == 0.5
    assert float(denoisers["half:own"](frame).mean()) == 0.25
    records = measure_run(run, parts, ReferenceCache(tmp_path, parts), denoisers)
    assert [r.cell.denoiser for r in records] == ["half", "half:own"]


def test_on_white_the_fair_and_own_tunings_are_one_search_stored_under_both_names(tmp_path):
    from denoisers.tuning import ParamStore, TuneResult

    tuned = []

    def tune_denoiser(name, frames, refs):
        tuned.append(name)
        return TuneResult(denoiser=name, params={"scale": 0.5}, mse=1.0, noisy_mse=2.0, frames=2)

    parts = dataclasses.replace(_parts(_Render()), tune_denoiser=tune_denoiser)
    run = dataclasses.replace(_run("white", crops=False), denoisers=("half", "half:own"))
    store = ParamStore()
    tune_denoisers(run, parts, ReferenceCache(tmp_path, parts), store)
    assert tuned == ["half"]  # white's own frames are the fair tuning's frames
    assert store.params("half", "direct/m1/owen_sobol/10x8", 2) == {"scale": 0.5}
    assert store.params("half:own", "direct/m1/owen_sobol/10x8/white", 2) == {"scale": 0.5}


def test_split_own_names():
    from benchmarks.sweep.tuning import split_own, tuning_source

    assert split_own("gaussian:own") == ("gaussian", True)
    assert split_own("gaussian") == ("gaussian", False)
    run = _run("temporal")
    assert tuning_source(run, "gaussian:own") == "temporal"
    assert tuning_source(run, "gaussian") == "white"
