"""Tests of benchmarks.runner: planning, cached references, tuning, timings, resume, end to end.

Everything renders with the real path tracer and denoisers at 16x16 so that the whole file runs
in seconds.
"""

import dataclasses
import json

import pytest
import torch

from benchmarks import runner
from benchmarks.runner import Cell, ReferenceCache, load_records, plan, real_parts, reference_seeds, run_suite
from benchmarks.suites import Condition, Suite, Sweep
from bnerr.errors import FileFormatError
from bnerr.io import read_frame


pytestmark = pytest.mark.usefixtures("one_thread")


class _Counting:
    """Wraps the renderer: counts calls and can fail after a number of them (an interruption)."""

    def __init__(self, render, fail_after=None):
        self.render, self.calls, self.fail_after = render, 0, fail_after

    def __call__(self, *args, **kwargs):
        if self.fail_after is not None and self.calls >= self.fail_after:
            raise KeyboardInterrupt("simulated interruption")
        self.calls += 1
        return self.render(*args, **kwargs)


def _parts(**changes):
    return dataclasses.replace(real_parts(), **changes)


def _suite(**sweep):
    base = dict(scenes=("direct",), strategies=("white", "temporal"), spp=(1,), denoisers=("gaussian", "median"),
                frames=2, warmup=1, res=(16, 12), reference_spp=16, seed_sets=2)
    base.update(sweep)
    return Suite(name="tiny", description="test", sweeps=(Sweep(**base),))


# -- planning ---------------------------------------------------------------------------------------


def test_plan_shares_renders_between_denoisers_regions_and_sweeps():
    sweep = Sweep(scenes=("direct",), strategies=("white",), spp=(1, 4), denoisers=("gaussian",),
                  conditions=(Condition(), Condition(region="edges"), Condition(motion=0)))
    other = dataclasses.replace(sweep, denoisers=("atrous",), conditions=(Condition(),))
    runs = plan(Suite("s", "d", sweeps=(sweep, other)))
    assert len(runs) == 4  # 2 spp x (moving, static); the second sweep adds no render
    moving = [r for r in runs if r.motion == 1]
    assert all(r.denoisers == ("gaussian", "atrous") and r.regions == ("all", "edges") for r in moving)
    assert sum(len(r.cells()) for r in runs) == 2 * 2 * 2 + 2 * 1
    assert [r.crops for r in runs] == [True, False, True, False]  # crops at the lowest spp only


def test_reference_seeds_are_deterministic_distinct_and_32_bit():
    a = reference_seeds(32, 32, 3)
    assert a.dtype == torch.int64 and a.shape == (32, 32)
    assert torch.equal(a, reference_seeds(32, 32, 3))
    assert a.unique().numel() == 32 * 32
    assert int(a.min()) >= 0 and int(a.max()) < 2**32
    assert not torch.equal(a, reference_seeds(32, 32, 4))


# -- references -------------------------------------------------------------------------------------


def test_references_are_rendered_once_and_read_back_bit_exact(tmp_path):
    counting = _Counting(real_parts().render)
    parts = _parts(render=counting)
    run = plan(_suite())[0]
    scene = parts.get_scene("direct", True)
    first = ReferenceCache(tmp_path, parts).get(run, scene, 5)
    assert counting.calls == 1
    again = ReferenceCache(tmp_path, parts).get(run, scene, 5)  # a new cache object: from disk
    assert counting.calls == 1
    assert torch.equal(first.color, again.color) and torch.equal(first.object_id, again.object_id)
    (path,) = tmp_path.rglob("*.exr")
    assert "direct_m1_d_t5_16x12_spp16_" in path.name and parts.renderer_version in path.name
    path.write_bytes(b"torn")  # a corrupt cache file is rendered again, not trusted
    assert torch.equal(ReferenceCache(tmp_path, parts).get(run, scene, 5).color, first.color)
    assert counting.calls == 2
    assert torch.equal(read_frame(path).color, first.color)


def test_renderer_version_follows_the_renderer_sources():
    assert real_parts().renderer_version == real_parts().renderer_version
    assert len(real_parts().renderer_version.split("-")[-1]) == 12


# -- end to end -------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """One uninterrupted run of the tiny suite: (output dir, cache dir, records, render count)."""
    out = tmp_path_factory.mktemp("out")
    cache = tmp_path_factory.mktemp("cache")
    counting = _Counting(real_parts().render)
    records = run_suite(_suite(), out, parts=_parts(render=counting), cache_dir=cache, progress=False)
    return out, cache, records, counting.calls


def test_every_cell_gets_a_record_with_per_frame_pairs(tiny):
    out, _, records, _ = tiny
    assert len(records) == 2 * 2  # strategies x denoisers
    assert load_records(out) == records
    for rec in records:
        cell = Cell(**rec["cell"])
        assert rec["key"] == cell.key()
        assert rec["t"] == [1, 2]  # warmup frame 0 is rendered, not measured
        assert set(rec["raw"]) == set(rec["den"]) == set(_suite().sweeps[0].metrics)
        s = torch.tensor(rec["raw"]["mse"])
        assert s.shape == (2, 2, 2) and torch.all(s[..., 1] == 3 * 16 * 12)  # [seed sets, frames, 2]
        assert rec["dimensions"] == 4
        assert rec["reference"]["spp"] == 16 and rec["reference"]["floor"] > 0


def test_raw_metrics_are_shared_by_the_cells_of_a_run_and_denoisers_differ(tiny):
    _, _, records, _ = tiny
    white = [r for r in records if r["cell"]["strategy"] == "white"]
    assert white[0]["raw"] == white[1]["raw"]
    assert white[0]["den"]["mse"] != white[1]["den"]["mse"]


def test_timings_cover_render_permutation_and_denoise(tiny):
    _, _, records, _ = tiny
    for rec in records:
        for name in ("render_ms", "perm_ms", "denoise_ms"):
            values = torch.tensor(rec["timings"][name])
            assert values.shape == (2, 2) and bool((values >= 0).all())
        assert min(min(row) for row in rec["timings"]["render_ms"]) > 0


def test_denoisers_are_tuned_once_on_white_noise_and_shared(tiny):
    out, _, records, _ = tiny
    stored = json.loads((out / runner.TUNED_PARAMS_FILE).read_text())["entries"]
    key = "direct/m1/owen_sobol/16x12"
    for name in ("gaussian", "median"):
        params = stored[name][key]["1"]["params"]
        assert all(r["denoiser_params"] == params for r in records if r["cell"]["denoiser"] == name)


def test_references_are_cached_per_measured_frame(tiny):
    _, cache, _, renders = tiny
    assert len(list(cache.rglob("*.exr"))) == 2  # frames 1 and 2; the warmup frame needs none
    # 2 references + 2 white tuning frames + per seed set: white's 2 measured frames (stateless:
    # its warmup is skipped) and temporal's warmup and 2 measured frames
    assert renders == 2 + 2 + 2 * (2 + 3)


def test_rerun_with_resume_measures_nothing(tiny):
    out, cache, records, _ = tiny
    counting = _Counting(real_parts().render)
    again = run_suite(_suite(), out, parts=_parts(render=counting), cache_dir=cache, resume=True, progress=False)
    assert counting.calls == 0 and again == records


def test_an_interrupted_run_resumes_to_the_same_results(tiny, tmp_path):
    _, cache, records, _ = tiny
    # References are cached: 2 tuning frames + 2 x 2 white frames, then the temporal run dies.
    parts = _parts(render=_Counting(real_parts().render, fail_after=6))
    with pytest.raises(KeyboardInterrupt):
        run_suite(_suite(), tmp_path, parts=parts, cache_dir=cache, progress=False)
    partial = load_records(tmp_path)
    assert len(partial) == 2 and {r["cell"]["strategy"] for r in partial} == {"white"}
    done = run_suite(_suite(), tmp_path, parts=_parts(), cache_dir=cache, resume=True, progress=False)
    strip = lambda recs: sorted((r["key"], r["raw"], r["den"], r["denoiser_params"]) for r in recs)  # noqa: E731
    assert strip(done) == strip(records)  # bit-identical metrics: renders and seeds are deterministic


def test_a_corrupt_results_file_is_reported(tmp_path):
    (tmp_path / runner.RESULTS_FILE).write_text('{"key": 1}\nnot json\n')
    with pytest.raises(FileFormatError, match="bad line 2"):
        load_records(tmp_path)


def test_static_scenes_share_one_reference_and_edges_restrict_pixels(tmp_path):
    cache = tmp_path / "cache"
    suite = _suite(strategies=("white",), denoisers=("gaussian",),
                   conditions=(Condition(motion=0), Condition(motion=0, region="edges")))
    records = run_suite(suite, tmp_path / "out", parts=_parts(), cache_dir=cache, progress=False)
    assert len(list(cache.rglob("*.exr"))) == 1
    counts = {r["cell"]["region"]: torch.tensor(r["raw"]["mse"])[..., 1] for r in records}
    assert bool((counts["edges"] < counts["all"]).all()) and bool((counts["edges"] > 0).all())


def test_speed_suite_stores_each_scripts_figures(tmp_path, monkeypatch):
    # The speed scripts time 1080p work for minutes; their own tests cover them. Here only the
    # plumbing: every script's measure() is called and its nested figures land in JSON and Markdown.
    import benchmarks.speed_masks as speed_masks

    def measure():
        """Seconds per
        mask.

        Not in the report."""
        return {"scalar_64": {"seconds": 0.5, "low": torch.tensor(0.01)}}

    monkeypatch.setattr(speed_masks, "measure", measure)
    text = runner.run_speed(Suite("speed", "timings", scripts=("speed_masks",)), tmp_path, progress=False)
    assert "## speed_masks\n\nSeconds per mask.\n\n| figure | value |" in text  # its first paragraph, one line
    stored = json.loads((tmp_path / "speed.json").read_text())
    assert stored == {"speed_masks": {"scalar_64": {"seconds": 0.5, "low": pytest.approx(0.01)}}}
    assert "| scalar_64/seconds | 0.5 |" in text and (tmp_path / "speed.md").read_text() == text
