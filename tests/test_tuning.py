"""Tests of denoisers/tuning.py: the grid search and the stored-parameters file."""

import functools
import json

import pytest
import torch

from bnerr.errors import (
    DtypeError,
    FileFormatError,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
)
from bnerr.frame import Frame
from denoisers import DENOISERS, get_denoiser, tuning
from denoisers.filters import Gaussian, Median
from denoisers.temporal import TAA, SequenceError
from denoisers.tuning import (
    GRIDS,
    PARAMS_FORMAT,
    STATEFUL_SKIP,
    ParamStore,
    grid_points,
    tune,
    tuned_denoiser,
)
from tests._scene_renders import SCENES, mse, scene_renders

SPATIAL = sorted(name for name in GRIDS if not DENOISERS[name].stateful)


def _noisy_frames(count, noise, seed=0, size=32):
    """A smooth image and ``count`` noisy copies (Gaussian noise of std ``noise``)."""
    g = torch.Generator().manual_seed(seed)
    yy, xx = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    clean = torch.stack([0.5 + 0.3 * xx, 0.4 + 0.2 * yy, 0.3 + 0.1 * xx * yy])
    frames = [
        Frame(color=clean + noise * torch.randn(3, size, size, generator=g)) for _ in range(count)
    ]
    return frames, [clean] * count


def test_grid_points_are_the_sorted_product():
    points = grid_points({"b": (1, 2), "a": ("x", "y", "z")})
    assert points[0] == {"a": "x", "b": 1} and points[1] == {"a": "x", "b": 2}
    assert len(points) == 6 and len({tuple(p.items()) for p in points}) == 6
    for name, grid in GRIDS.items():
        assert 2 <= len(grid_points(grid)) <= 20, name  # "a small grid"


def test_tune_returns_the_minimum_of_its_table():
    frames, refs = _noisy_frames(2, noise=0.2)
    result = tune("gaussian", frames, refs)
    assert len(result.table) == len(GRIDS["gaussian"]["sigma"])
    assert result.mse == min(mse for _, mse in result.table)
    assert result.mse < result.noisy_mse
    # The table's MSE is the denoiser's MSE, recomputed independently here.
    d = Gaussian(**result.params)
    again = sum(float((d(f) - r).double().square().mean()) for f, r in zip(frames, refs)) / 2
    assert result.mse == pytest.approx(again, rel=1e-12)


def test_more_noise_picks_a_wider_gaussian():
    # On a smooth image the best blur widens as the noise grows: a property of the MSE trade-off.
    low = tune("gaussian", *_noisy_frames(2, noise=0.02))
    high = tune("gaussian", *_noisy_frames(2, noise=0.5))
    assert high.params["sigma"] > low.params["sigma"]


def test_tune_with_grid_override_and_deterministic():
    frames, refs = _noisy_frames(1, noise=0.3)
    a = tune("median", frames, refs, grid={"kernel_size": (3, 5)})
    b = tune("median", frames, refs, grid={"kernel_size": (3, 5)})
    assert a == b and [p for p, _ in a.table] == [{"kernel_size": 3}, {"kernel_size": 5}]


def test_tune_rejects_bad_input():
    frames, refs = _noisy_frames(2, noise=0.1)
    with pytest.raises(UnknownNameError, match="unknown tunable denoiser 'unet'"):
        tune("unet", frames, refs)
    with pytest.raises(ValueRangeError, match="got 2 frames and 1 references"):
        tune("gaussian", frames, refs[:1])
    with pytest.raises(ShapeError, match=r"tune: references\[1\]"):
        tune("gaussian", frames, [refs[0], refs[1][:, :8]])


def test_store_round_trip_and_lookup(tmp_path):
    frames, refs = _noisy_frames(1, noise=0.3)
    store = ParamStore()
    store.put(tune("median", frames, refs), "cornell", 4)
    store.put(tune("gaussian", frames, refs), "cornell", 4)
    path = tmp_path / "sub" / "params.json"
    store.save(path)
    loaded = ParamStore.load(path)
    assert loaded.entries == store.entries
    assert json.loads(path.read_text())["format"] == PARAMS_FORMAT
    assert loaded.entries["median"]["cornell"]["4"]["sampler"] == "white"
    d = tuned_denoiser("median", "cornell", 4, loaded)
    assert isinstance(d, Median) and d.params() == loaded.params("median", "cornell", 4)
    # Equal stores give equal files (sorted keys), so the file diffs cleanly in git.
    again = tmp_path / "again.json"
    loaded.save(again)
    assert again.read_text() == path.read_text()
    assert not list(tmp_path.glob("**/.*tmp*"))  # the atomic write leaves no temporary behind


def test_untunable_denoiser_needs_no_stored_entry():
    assert tuned_denoiser("unet", "snooker", 4, ParamStore()).name == "unet"  # nothing to tune


def test_store_errors(tmp_path):
    store = ParamStore()
    with pytest.raises(
        UnknownNameError, match="expected an entry for gaussian/snooker/4 spp, got none"
    ):
        store.params("gaussian", "snooker", 4)
    with pytest.raises(UnknownNameError, match="expected an entry"):
        tuned_denoiser("gaussian", "snooker", 4, store)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(FileFormatError, match="bad.json: expected a tuned-parameters JSON file"):
        ParamStore.load(bad)
    bad.write_text(json.dumps({"format": "other"}))
    with pytest.raises(
        FileFormatError, match="expected format 'bnerr-tuned-params-v1', got 'other'"
    ):
        ParamStore.load(bad)
    with pytest.raises(FileFormatError, match="got no such file"):
        ParamStore.load(tmp_path / "missing.json")


@functools.cache
def _tuned(scene, name):
    tune_frame, _, reference = scene_renders(scene)
    return tune(name, [tune_frame], [reference])


@pytest.mark.parametrize("name", SPATIAL)
@pytest.mark.parametrize("scene", SCENES)
def test_tuned_filters_lower_mse_on_every_scene_at_4spp(scene, name, request):
    """Tuned on one white-noise frame, measured on an independent one (64 x 64, 4 spp)."""
    if (scene, name) == ("cornell", "median"):
        request.applymarker(
            pytest.mark.xfail(
                strict=True,
                reason=(
                    "a median erodes the corners of the Cornell box's light (radiance 17 next to "
                    "0.5); those few pixels cost more than all the noise the median removes"
                ),
            )
        )
    _, frame, reference = scene_renders(scene)
    denoised = get_denoiser(name, **_tuned(scene, name).params)(frame)
    assert mse(denoised, reference) < mse(frame.color, reference)


def test_resolve_accepts_the_scene_name_alone_when_one_key_matches():
    from bnerr.errors import UnknownNameError
    from denoisers.tuning import ParamStore, TuneResult

    store = ParamStore()
    for key, spp in [("direct/m1/owen_sobol/128x128", 4), ("cornell/a", 4), ("cornell/b", 4)]:
        store.put(TuneResult("gaussian", {"sigma": 1.0}, 0.1, 0.2, 1), key, spp)
    assert store.resolve("gaussian", "direct") == ("direct/m1/owen_sobol/128x128", 4)
    assert store.resolve("gaussian", "direct", 8) == ("direct/m1/owen_sobol/128x128", 8)
    assert store.resolve("gaussian", "cornell/a") == ("cornell/a", 4)
    assert store.resolve("unet", "direct") == ("direct", 0)
    with pytest.raises(UnknownNameError, match="got 2: cornell/a, cornell/b"):
        store.resolve("gaussian", "cornell")
    with pytest.raises(UnknownNameError, match="got 0: cornell/a, cornell/b, direct/m1"):
        store.resolve("gaussian", "teapot")


# -- stateful denoisers: tuned on a sequence, reset per candidate, measured after a warm-up -------


def _sequence(count, noise, drift=0.0, seed=0, size=16):
    """Noisy frames of a smooth image that brightens by ``drift`` per frame (no motion)."""
    g = torch.Generator().manual_seed(seed)
    yy, xx = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    clean = torch.stack([0.5 + 0.3 * xx, 0.4 + 0.2 * yy, 0.3 + 0.1 * xx * yy])
    normal = torch.zeros(3, size, size)
    normal[2] = 1.0
    frames, refs = [], []
    for t in range(count):
        ref = clean + drift * t
        frames.append(
            Frame(
                color=ref + noise * torch.randn(3, size, size, generator=g),
                normal=normal,
                depth=torch.ones(1, size, size),
                motion=torch.zeros(2, size, size),
                object_id=torch.zeros(1, size, size),
            )
        )
        refs.append(ref)
    return frames, refs


def test_stateful_tune_feeds_the_sequence_and_measures_after_the_warm_up():
    frames, refs = _sequence(5, noise=0.2)
    result = tune("taa", frames, refs)
    assert result.skipped == STATEFUL_SKIP and result.frames == 5 - STATEFUL_SKIP
    noisy = sum(mse(f.color, r) for f, r in zip(frames[2:], refs[2:])) / 3
    assert result.noisy_mse == pytest.approx(noisy, rel=1e-12)
    # Each table row is a fresh denoiser fed the whole sequence in order, measured on frames 2-4.
    for params, value in result.table:
        taa = TAA(**params)
        outs = [taa(f, t=t) for t, f in enumerate(frames)]
        again = sum(mse(o, r) for o, r in zip(outs[2:], refs[2:])) / 3
        assert value == pytest.approx(again, rel=1e-12)
    assert result.mse < result.noisy_mse


def test_stateful_tune_resets_before_each_candidate(monkeypatch):
    frames, refs = _sequence(4, noise=0.2)
    shared = TAA(alpha=0.3)  # one instance for every candidate: only reset() separates them
    monkeypatch.setattr(tuning, "get_denoiser", lambda name, **params: shared)
    result = tune("taa", frames, refs, grid={"alpha": (0.3, 0.3, 0.3)})
    assert len({value for _, value in result.table}) == 1


def test_static_noise_picks_a_slow_blend_and_changing_content_a_fast_one():
    # A property of the MSE trade-off: history helps while the image stands still, lags when
    # it changes faster than the noise hides.
    still = tune("taa", *_sequence(30, noise=0.2))
    moving = tune("taa", *_sequence(12, noise=0.01, drift=0.2))
    assert still.params["alpha"] == min(GRIDS["taa"]["alpha"])
    assert moving.params["alpha"] == max(GRIDS["taa"]["alpha"])
    still_mse, moving_mse = [v for _, v in still.table], [v for _, v in moving.table]
    assert still_mse == sorted(still_mse) and moving_mse == sorted(moving_mse, reverse=True)


def test_svgf_tunes_on_a_sequence():
    frames, refs = _sequence(5, noise=0.2, size=12)
    result = tune("svgf", frames, refs)
    assert len(result.table) == len(grid_points(GRIDS["svgf"]))
    assert result.mse < result.noisy_mse


def test_skip_is_checked_and_stateless_filters_skip_frames_unseen():
    frames, refs = _sequence(3, noise=0.2)
    with pytest.raises(ValueRangeError, match=r"tune: skip: expected a value in \[0, 2\], got 3"):
        tune("taa", frames, refs, skip=3)
    with pytest.raises(DtypeError, match="tune: skip: expected an int"):
        tune("gaussian", frames, refs, skip=1.0)
    skipped = tune("gaussian", frames, refs, skip=1)
    plain = tune("gaussian", frames[1:], refs[1:])
    assert skipped.table == plain.table and (skipped.frames, skipped.skipped) == (2, 1)
    assert tune("taa", frames[:1], refs[:1]).skipped == 0  # one frame: nothing left to skip


def test_stateful_tune_refuses_frames_of_two_sizes():
    frames, refs = _sequence(2, noise=0.2)
    other, other_refs = _sequence(1, noise=0.2, size=8)
    with pytest.raises(SequenceError, match="call reset"):
        tune("taa", frames + other, refs + other_refs)
