"""Tests of benchmarks.sweep.plan: runs shared between denoisers, regions and sweeps; pending
cells."""

import dataclasses
import json

from benchmarks.suites import Condition, Suite, Sweep, get_suite
from benchmarks.sweep.plan import Cell, pending, plan


def _suite() -> Suite:
    sweep = Sweep(
        scenes=("direct",),
        strategies=("white",),
        spp=(1, 4),
        denoisers=("gaussian",),
        conditions=(Condition(), Condition(region="edges"), Condition(motion=0)),
    )
    other = dataclasses.replace(sweep, denoisers=("atrous",), conditions=(Condition(),))
    return Suite("s", "d", sweeps=(sweep, other))


def test_plan_shares_renders_between_denoisers_regions_and_sweeps():
    runs = plan(_suite())
    assert len(runs) == 4  # 2 spp x (moving, static); the second sweep adds no render
    moving = [r for r in runs if r.motion == 1]
    assert all(
        r.denoisers == ("gaussian", "atrous") and r.regions == ("all", "edges") for r in moving
    )
    assert sum(len(r.cells()) for r in runs) == 2 * 2 * 2 + 2 * 1
    assert [r.crops for r in runs] == [True, False, True, False]  # crops at the lowest spp only
    every = plan(dataclasses.replace(_suite(), crops_every_spp=True))
    assert [r.crops for r in every] == [True] * 4  # the seed suite's figures show every spp


def test_a_coherent_suite_measures_the_coherent_region_in_every_run_after_its_own():
    suite = dataclasses.replace(_suite(), coherent=True)
    runs = plan(suite)
    assert [r.regions for r in runs] == [
        (("all", "edges", "coherent") if r.motion == 1 else ("all", "coherent")) for r in runs
    ]
    bare = [dataclasses.replace(r, regions=()) for r in runs]  # the same renders as without
    assert bare == [dataclasses.replace(r, regions=()) for r in plan(_suite())]
    named = [get_suite(n) for n in ("quick", "quality", "gap", "stability")]
    assert all(r.regions[-1] == "coherent" for s in named for r in plan(s))


def test_the_coherent_region_leaves_out_the_suites_skipped_metrics_only():
    suite = dataclasses.replace(_suite(), coherent=True, coherent_skips=("ssim", "cvvdp"))
    for run in plan(suite):
        assert run.metrics_of("coherent") == tuple(m for m in run.metrics if m != "ssim")
        assert run.metrics_of("all") == run.metrics_of("edges") == run.metrics
    assert all(r.metrics_of("coherent") == r.metrics for r in plan(_suite()))


def test_cell_key_is_its_fields_as_sorted_json():
    cell = plan(_suite())[0].cells()[0]
    assert json.loads(cell.key()) == dataclasses.asdict(cell)
    assert Cell(**json.loads(cell.key())) == cell


def test_pending_narrows_runs_to_their_missing_cells():
    runs = plan(_suite())
    cells = [c for r in runs for c in r.cells()]
    missing = [c for c in cells if (c.spp, c.denoiser, c.region) == (1, "atrous", "edges")]
    todo = pending(_suite(), {c.key() for c in cells if c not in missing})
    assert [(r.spp, r.motion, r.denoisers, r.regions) for r in todo] == [
        (1, 1, ("atrous",), ("edges",))
    ]
    assert [c.key() for r in todo for c in r.cells()] == [c.key() for c in missing]
    assert pending(_suite(), {c.key() for c in cells}) == []
    assert pending(_suite(), set()) == runs
