"""Tests of benchmarks.suites: the named suites as data, their checks, and the CLI overrides."""

import dataclasses

import pytest

from benchmarks.suites import (
    GAP_BEST,
    GAP_SINGLE,
    REGIONS,
    RIVALS,
    SAMPLERS,
    SUITES,
    Condition,
    Suite,
    Sweep,
    get_suite,
    resolve,
)
from benchmarks.sweep.plan import ALWAYS_REGION
from bnerr.errors import DtypeError, UnknownNameError, ValueRangeError


def _cells(suite):
    for sweep in suite.sweeps:
        for scene in sweep.scenes:
            for strategy in sweep.strategies:
                for spp in sweep.spp:
                    for denoiser in sweep.denoisers:
                        for cond in sweep.conditions:
                            yield scene, strategy, spp, denoiser, cond


def test_every_suite_is_named_as_its_key_and_has_work():
    assert sorted(SUITES) == ["cycles", "gap", "quality", "quick", "seed", "speed", "stability"]
    for name, suite in SUITES.items():
        assert suite.name == name and suite.description
        assert bool(suite.sweeps) != bool(suite.scripts), name  # cells or scripts, not both
    assert get_suite("quick") is SUITES["quick"]


def test_cycles_measures_its_default_after_its_own_denoiser_and_the_same_scene_twice():
    cells = list(_cells(get_suite("cycles")))
    scenes = {c[0] for c in cells}
    assert {"cycles_interior", "cycles_product", "cycles_outdoor"} <= scenes
    headline = {(c[1], c[2], c[3]) for c in cells if c[0] == "cycles_product"}
    for spp in (1, 4, 16, 64):
        for denoiser in ("cycles_oidn", "gaussian", "unet", "taa"):
            assert {("white", spp, denoiser), ("blue_noise", spp, denoiser)} <= headline
    assert {c[1] for c in cells} >= {"blue_noise_adaptive", "classic_adaptive", "classic_scrambled"}
    # Cycles' own pattern and bnerr's reproduction of it on the same scenes, at 1 and 4 spp
    same = {(c[0], c[1], c[2]) for c in cells if c[0] in ("direct", "cycles_direct")}
    assert {("direct", "cycles_blue", 1), ("cycles_direct", "blue_noise", 4)} <= same
    assert all(s.reference_spp >= 1024 and s.warmup >= 1 for s in get_suite("cycles").sweeps)


def test_quick_brackets_the_method_with_white_and_oracle():
    cells = list(_cells(get_suite("quick")))
    assert {c[1] for c in cells} >= {"white", "temporal", "oracle"}
    assert {c[0] for c in cells} == {"direct", "indirect"}
    assert all(s.warmup > 0 for s in get_suite("quick").sweeps)


def test_quality_covers_every_scene_adoptable_strategy_and_denoiser_at_1_4_16_spp():
    import denoisers
    import renderers
    from bnerr.strategies import strategy_identity

    cells = list(_cells(get_suite("quality")))
    assert {c[0] for c in cells} == set(renderers.SCENES)
    strategies = {c[1] for c in cells}
    # no bound (the gap suite measures them), every family a renderer could adopt
    assert "white" in strategies and not {"oracle", "vertical"} & strategies
    assert strategies <= {"white", "bnds", "temporal", "temporal_sort"} | set(RIVALS)
    families = {strategy_identity(s).family for s in strategies}
    assert families >= {"baseline", "rival", "temporal", "ldbn"}
    assert {"ldbn128", "openqmc_sobolbn", "openqmc_latticebn", "zsobol"} <= strategies
    assert {c[2] for c in cells} == {1, 4, 16}
    # every denoiser but Cycles' own, which runs on Cycles scenes only (the cycles suite)
    assert {c[3] for c in cells} == set(denoisers.DENOISERS) - {"cycles_oidn"} | {
        "gaussian:own",
        "atrous:own",
        "guided:own",
    }
    # every pixel and away from visible lights, the latter's open verdicts adding seed sets and
    # a settled cell stopping (the coverage study's design)
    suite = get_suite("quality")
    assert {c[4].region for c in cells} == {"all", "unlit"}
    assert suite.resolve == ("unlit",) and suite.stop_settled


def test_the_bounds_are_measured_where_shares_are_computed():
    cells = list(_cells(get_suite("gap")))
    for bound in ("oracle", "vertical"):
        assert any(c[1] == bound for c in cells)
    vertical = {(c[0], c[2], c[3], c[4]) for c in cells if c[1] == "vertical"}
    for strategy in ("white", "oracle"):  # the vertical bound's share needs both
        assert vertical <= {(c[0], c[2], c[3], c[4]) for c in cells if c[1] == strategy}


def test_stability_varies_each_failure_axis():
    import renderers

    suite = get_suite("stability")
    cells = list(_cells(suite))
    scenes = {c[0] for c in cells}
    assert {"snooker", "snooker_plain"} <= scenes <= set(renderers.SCENES)
    conds = {c[4] for c in cells}
    # the coherent region needs no condition: every planned run measures it; the unlit region
    # differs from every pixel only where the camera sees a light (the Cornell box)
    assert {c.region for c in conds} | {ALWAYS_REGION, "unlit"} == set(REGIONS)
    assert {c.sampler for c in conds} == set(SAMPLERS)
    assert {0, 1} < {c.motion for c in conds} and max(c.motion for c in conds) > 1
    depths = sorted(c.depth for c in conds if c.depth is not None)
    assert depths[0] == 2 and depths[-1] == 9  # 1 to 8 bounces
    assert min(c[2] for c in cells) == 1 and max(c[2] for c in cells) == 64
    assert all("white" in s.strategies for s in suite.sweeps)  # every ratio has its baseline


def test_speed_names_existing_scripts():
    import importlib

    for script in get_suite("speed").scripts:
        importlib.import_module(f"benchmarks.{script}")


def test_resolve_overrides_every_sweep():
    suite = resolve(
        get_suite("stability"), scenes=["direct"], spp=[2], frames=3, warmup=0, res=(16, 8)
    )
    for sweep in suite.sweeps:
        assert sweep.scenes == ("direct",) and sweep.spp == (2,)
        assert (sweep.frames, sweep.warmup, sweep.res) == (3, 0, (16, 8))
    original = get_suite("stability")
    assert resolve(original) == original
    assert original.sweeps[0].scenes != ("direct",)  # the registry itself is untouched


def test_resolve_checks_names_against_the_registries():
    with pytest.raises(UnknownNameError, match="unknown scene 'nope': expected one of a, b"):
        resolve(get_suite("quick"), scenes=["a", "nope"], known_scenes=["a", "b"])
    with pytest.raises(UnknownNameError, match="unknown suite 'fast'"):
        get_suite("fast")


def test_bad_configurations_raise_typed_errors():
    sweep = get_suite("quick").sweeps[0]
    with pytest.raises(ValueRangeError, match="Sweep.strategies: expected at least one entry"):
        dataclasses.replace(sweep, strategies=())
    with pytest.raises(ValueRangeError, match="Sweep.spp: expected an integer >= 1, got 0"):
        dataclasses.replace(sweep, spp=(1, 0))
    with pytest.raises(DtypeError, match="Sweep.frames: expected an integer"):
        dataclasses.replace(sweep, frames=2.5)
    with pytest.raises(UnknownNameError, match="unknown region 'rim'"):
        Condition(region="rim")
    with pytest.raises(ValueRangeError, match="Condition.depth: expected an integer >= 2, got 1"):
        Condition(depth=1)
    with pytest.raises(ValueRangeError, match="Condition.motion: expected an integer >= 0"):
        Condition(motion=-1)
    with pytest.raises(UnknownNameError, match="unknown per-pixel sampler 'sobol'"):
        Condition(sampler="sobol")
    with pytest.raises(UnknownNameError, match="unknown coherent_skips metric 'jod'"):
        Suite("s", "d", coherent_skips=("jod",))


def test_runs_count_renders_not_denoisers_or_regions():
    sweep = Sweep(
        scenes=("a", "b"),
        strategies=("white", "temporal"),
        spp=(1, 4),
        denoisers=("x", "y", "z"),
        seed_sets=2,
        conditions=(Condition(), Condition(region="edges"), Condition(motion=0)),
    )
    assert sweep.runs == 2 * 2 * 2 * 2 * 2


def test_the_rivals_are_in_every_stability_sweep_but_the_per_pixel_sequences_one():
    from bnerr.strategies import OWN_SAMPLERS, STRATEGIES

    assert set(RIVALS) <= set(STRATEGIES) and set(RIVALS) <= set(OWN_SAMPLERS)
    for sweep in get_suite("stability").sweeps:
        varies_sampler = len({c.sampler for c in sweep.conditions}) > 1
        assert set(RIVALS).isdisjoint(sweep.strategies) == varies_sampler, sweep.scenes


@pytest.mark.parametrize("name", ["quality", "stability", "gap"])
def test_every_planned_run_builds_its_strategy(name):
    # The suites' plans still work with the rivals: every run's strategy can be built for its
    # scene, depth and spp (the Z-order ones need spp a power of two), and no run is planned twice.
    import renderers
    from benchmarks.sweep.parts import real_parts
    from benchmarks.sweep.plan import plan

    parts = real_parts()
    runs = plan(get_suite(name))
    renders = {
        (r.scene, r.strategy, r.spp, r.motion, r.depth, r.sampler, r.reference_spp) for r in runs
    }
    assert len(renders) == len(runs)
    built = set()
    for run in runs:
        key = (run.scene, run.strategy, run.spp, run.depth)
        if key in built:
            continue
        built.add(key)
        scene = renderers.get_scene(run.scene, animated=run.motion != 0)
        if run.depth is not None:
            scene = parts.with_depth(scene, run.depth)
        strategy = parts.make_strategy(run.strategy, scene, 8, 8, 0, run.sampler, run.spp)
        assert strategy.name == run.strategy


def test_gap_is_an_ablation_bracketed_by_white_and_the_oracle_on_every_condition():
    import renderers
    from bnerr.strategies import parse_variant

    suite = get_suite("gap")
    cells = list(_cells(suite))
    assert {c[0] for c in cells} == set(renderers.SCENES)
    assert {c[2] for c in cells} == {1, 4, 16, 64}
    # 64 spp: the a-priori samplers on the goal scenes, bracketed by white and the oracle
    at_64 = {(c[0], c[1]) for c in cells if c[2] == 64}
    assert {scene for scene, _ in at_64} == {"direct", "indirect"}
    assert {s for _, s in at_64} >= {
        "white",
        "oracle",
        "ldbn_zorder",
        "zsobol",
        "openqmc_latticebn",
    }
    conds = {c[4] for c in cells}
    # the coherent region needs no condition: every planned run measures it; the unlit region
    # differs from every pixel only where the camera sees a light (the Cornell box)
    assert {c.region for c in conds} | {ALWAYS_REGION, "unlit"} == set(REGIONS)
    assert {c.sampler for c in conds} == set(SAMPLERS)
    assert {c.motion for c in conds} == {0, 1, 8}
    vertical = {(c[0], c[2], c[4]) for c in cells if c[1] == "vertical"}
    assert vertical and vertical <= {(c[0], c[2], c[4]) for c in cells if c[1] == "oracle"}
    for sweep in suite.sweeps:  # every share has its two bounds and its baseline
        if sweep.strategies == ("vertical",):  # beside the oracle's cells, checked above
            continue
        assert {"white", "oracle"} <= set(sweep.strategies)
        assert {"mse", "mse_blur1", "mse_blur2"} <= set(sweep.metrics)
        if sweep.spp == (64,):  # the a-priori samplers only: the temporal ones stop at 16
            assert sweep.reference_spp == 1024 and "temporal" not in sweep.strategies
            continue
        assert {"temporal", *GAP_BEST[::2]} <= set(sweep.strategies)
        if sweep.spp != (16,):  # the single options everywhere but at 16 spp
            assert set(GAP_SINGLE) | set(GAP_BEST) <= set(sweep.strategies)
    # one option each, and every option group is covered alone
    options = [parse_variant(name)[1] for name in GAP_SINGLE]
    assert all(len(o.suffix.split("+")) == 2 for o in options)
    assert {o.key for o in options} >= {"residual", "relative"}
    assert any(o.demodulate for o in options) and any(o.reproject for o in options)
    assert any(o.groups for o in options) and any(o.shift for o in options)
    assert {parse_variant(name)[0] for name in GAP_BEST} == {"temporal", "temporal_zsobol"}


# Render cost of one 128x128 frame at 4 spp per scene, seconds: the white runs' mean render time
# per measured frame in the committed gap results (results/gap, two Ray workers on the 2-core
# machine; 1 spp costs 0.2-0.7x of it, 16 spp 2.1-3.2x, so the spp / 4 below overestimates).
_RENDER_S = {
    "direct": 0.041,
    "indirect": 0.097,
    "cornell": 0.37,
    "medium": 0.33,
    "snooker": 0.18,
    "snooker_plain": 0.15,
}
#: The gap suite's cap on seed sets (bnerr bench --suite gap --until-resolved --seed-set-cap 4,
#: docs/USAGE.md): the model below takes every run to it, the design's worst case.
_GAP_CAP = 4


def test_gap_renders_fit_in_an_hour():
    # Renders dominate (the oracle's 32 per frame among them); references at 256 spp count once
    # per scene, condition and frame. The budget leaves 10 minutes of the hour for the denoisers'
    # tuning and the metrics: the committed run's denoising took 1.1 minutes in all (its records'
    # denoise_ms), tuning the two cheap filters on white frames and the MSE measures less. Two
    # workers share the renders: the committed run took 37.5 minutes of wall time (the first
    # run, then the resumed one with zsobol and OpenQMC's samplers).
    from benchmarks.sweep.plan import plan
    from bnerr.strategies import make_strategy

    seconds = 0.0
    for run in plan(get_suite("gap")):
        per_frame = 32 if run.strategy in ("oracle", "vertical") else 1
        stateful = make_strategy(run.strategy, 8, 8, spp=run.spp).stateful  # renders its warmup
        frames = run.frames + (run.warmup if stateful else 0)
        scale = max(0.3, run.spp / 4)
        seconds += _GAP_CAP * frames * per_frame * scale * _RENDER_S[run.scene]
        if run.strategy == "vertical":  # its greedy search, about 3.6 s a 128x128 frame
            seconds += _GAP_CAP * run.frames * 3.6
    references = {(r.scene, r.motion, r.sampler) for r in plan(get_suite("gap"))}
    seconds += sum(2 * (256 / 4) * _RENDER_S[s] for s, _, _ in references)
    seconds /= 2  # two workers
    assert seconds < 50 * 60, seconds / 60


def test_resolve_accepts_well_formed_temporal_variants():
    known = ["white", "temporal"]
    suite = resolve(
        get_suite("quick"), strategies=["white", "temporal+groups+shift"], known_strategies=known
    )
    assert suite.sweeps[0].strategies == ("white", "temporal+groups+shift")
    with pytest.raises(ValueRangeError, match="expected options in the order"):
        resolve(get_suite("quick"), strategies=["temporal+shift+groups"], known_strategies=known)
    with pytest.raises(UnknownNameError, match="unknown strategy 'oracle'"):
        resolve(get_suite("quick"), strategies=["oracle"], known_strategies=known)


def test_seed_reproduces_the_talks_conditions():
    suite = get_suite("seed")
    cells = list(_cells(suite))
    assert {c[0] for c in cells} == {"indirect", "medium"}
    assert {c[2] for c in cells if c[0] == "indirect"} == {1, 4, 16, 32, 64}
    conds = {c[4] for c in cells}
    assert {c.sampler for c in conds} == set(SAMPLERS) and {c.motion for c in conds} == {0, 1}
    assert {c[1] for c in cells} >= {"white", "temporal", GAP_BEST[0], "oracle", "vertical"}
    assert suite.coherent and suite.crops_every_spp  # its figures show every spp
    # the vertical bound, most of the suite's time, only where the claim is made
    vertical = {(c[2], c[4].motion) for c in cells if c[1] == "vertical"}
    assert vertical == {(16, 1), (64, 1)}
