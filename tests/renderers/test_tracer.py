"""Tests for renderers.tracer, the driver: buffers, determinism, chunks, batches, threads,
compilation, motion vectors, typed errors (the per-path physics: test_integrator.py)."""

import warnings

import pytest
import torch
import torch.nn.functional as F

from bnerr.errors import DtypeError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.sequences import make_sampler
from renderers import get_scene, integrator, render, tracer
from renderers.camera import camera_frame, generate_rays
from renderers.compare import compare_images
from renderers.geometry import intersect, scene_tensors

pytestmark = pytest.mark.usefixtures("one_thread")


def seeds_for(height: int, width: int, key: int = 0) -> torch.Tensor:
    from bnerr.strategies import pixel_seeds

    return pixel_seeds(height, width, key)


WHITE = make_sampler("white")


def test_frame_buffers():
    scene = get_scene("snooker")
    frame = render(scene, 2, seeds_for(12, 20), WHITE, 4)
    assert frame.color.shape == (3, 12, 20) and frame.color.dtype == torch.float32
    for name, channels in dict(
        albedo=3, normal=3, depth=1, motion=2, object_id=1, variance=3
    ).items():
        assert getattr(frame, name).shape == (channels, 12, 20), name
    assert torch.isfinite(frame.color).all() and (frame.color >= 0).all()
    ids = set(frame.object_id.unique().tolist())
    assert ids <= set(range(-1, len(scene.shapes))) and len(ids) > 2
    escaped = frame.object_id[0] == -1
    assert (frame.depth[0][escaped] == 0).all() and (frame.depth[0][~escaped] > 0).all()
    assert frame.timings["render"] > 0
    assert render(scene, 0, seeds_for(4, 4), WHITE, 1).variance is None


@pytest.mark.parametrize("name", ["cornell", "snooker", "medium"])
def test_same_seeds_give_bit_identical_frames(name):
    scene = get_scene(name)
    seeds = seeds_for(10, 14)
    a = render(scene, 3, seeds, WHITE, 3)
    b = render(scene, 3, seeds.clone(), make_sampler("white"), 3)
    for key, value in a.buffers().items():
        assert torch.equal(value, b.buffers()[key]), key
    c = render(scene, 3, seeds_for(10, 14, key=1), WHITE, 3)
    assert not torch.equal(a.color, c.color)


@pytest.mark.parametrize(
    ("name", "size", "spp", "chunk"),
    [
        ("cornell", (16, 16), 1, 1024),  # 4 frames per chunk: frames aligned to 64 pixels
        ("medium", (16, 16), 3, 4096),
        ("snooker", (13, 7), 1, 1024),  # 91 pixels: each frame cut into chunks on its own
        ("indirect", (13, 7), 16, 64),
    ],
)
def test_a_batch_renders_each_frame_bit_for_bit_as_alone(name, size, spp, chunk):
    # the oracle's candidates are rendered as one batch: the cells of the committed results
    # were measured with one render per candidate, so exact equality, not approx
    scene = get_scene(name)
    seeds = torch.stack([seeds_for(*size, key=k) for k in range(5)])
    batch = tracer.render_batch(scene, 3, seeds, WHITE, spp, chunk=chunk)
    assert len(batch) == 5
    for k, frame in enumerate(batch):
        alone = render(scene, 3, seeds[k], WHITE, spp)
        assert alone.buffers().keys() == frame.buffers().keys()
        for key, value in alone.buffers().items():
            assert torch.equal(value, frame.buffers()[key]), (k, key)
        assert frame.timings["render"] > 0
    batch[0].depth += 1  # every frame owns its buffers
    assert not torch.equal(batch[0].depth, batch[1].depth)
    assert tracer.render_batch(scene, 3, seeds[:0], WHITE, spp) == []
    with pytest.raises(ShapeError):
        tracer.render_batch(scene, 3, seeds[0], WHITE, spp)


def test_chunking_changes_only_rounding():
    scene = get_scene("indirect")
    seeds = seeds_for(8, 8)
    a = render(scene, 0, seeds, WHITE, 16)
    b = render(scene, 0, seeds, WHITE, 16, chunk=40)  # samples of a pixel split across chunks
    torch.testing.assert_close(a.color, b.color, rtol=1e-5, atol=1e-7)
    torch.testing.assert_close(a.variance, b.variance, rtol=1e-3, atol=1e-9)


@pytest.mark.parametrize("name", ["direct", "medium"])
def test_chunks_of_whole_pixels_in_multiples_of_64_lanes_change_no_bit(name):
    # Why DEFAULT_CHUNK may change without regenerating results: with every pixel's samples in
    # one chunk and chunks of 64 k lanes, each lane keeps its place modulo the SIMD loops.
    scene = get_scene(name)
    seeds = seeds_for(40, 24)
    a = render(scene, 0, seeds, WHITE, 4, chunk=1 << 16)
    b = render(scene, 0, seeds, WHITE, 4, chunk=256)  # 64 pixels a chunk, 15 chunks
    for field in ("color", "variance", "albedo", "normal", "depth", "motion", "object_id"):
        assert torch.equal(getattr(a, field), getattr(b, field)), field


def test_the_tracer_draws_no_random_numbers(monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("the tracer must take every random number from the sampler")

    for name in (
        "rand",
        "randn",
        "randint",
        "rand_like",
        "randn_like",
        "randperm",
        "bernoulli",
        "multinomial",
    ):
        monkeypatch.setattr(torch, name, forbidden)
    monkeypatch.setattr(torch.Tensor, "uniform_", forbidden)
    for name in ("direct", "medium", "snooker"):
        render(get_scene(name), 0, seeds_for(4, 4), WHITE, 2)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["direct", "snooker"])
def test_white_and_owen_sobol_converge_to_the_same_image(name):
    scene = get_scene(name, animated=False)
    white = render(scene, 0, seeds_for(16, 16, 1), WHITE, 256)
    sobol = render(scene, 0, seeds_for(16, 16, 2), make_sampler("owen_sobol"), 256)
    # Owen-Sobol's sample variance overestimates the error of its mean (QMC converges faster),
    # which only makes the test conservative; compare_images states the thresholds.
    result = compare_images(white.color, white.variance, sobol.color, sobol.variance)
    assert result.passed, result.summary()


def center_hits(scene, t, width, height):
    """World point, object id and hit mask of the ray through each pixel center at frame t."""
    st = scene_tensors(scene, t)
    cam = camera_frame(scene.camera, t, width, height)
    ys, xs = torch.meshgrid(torch.arange(height), torch.arange(width), indexing="ij")
    o, d = generate_rays(cam, xs.flatten() + 0.5, ys.flatten() + 0.5)
    dist, obj = intersect(st, o, d)
    hit = obj >= 0
    p = o + torch.where(hit, dist, 0.0) * d
    return p.view(3, height, width), obj.view(height, width), st.translation


def motion_setup(name):
    scene = get_scene(name)
    width, height, t = 96, 64, 12
    frame = render(scene, t, seeds_for(height, width), WHITE, 1)
    p_now, obj_now, translation = center_hits(scene, t, width, height)
    # Frame t's points moved back to where they were at t-1 (balls roll: undo their motion).
    p_back = p_now - translation[obj_now.clamp_min(0)].permute(2, 0, 1)
    ys, xs = torch.meshgrid(torch.arange(height) + 0.5, torch.arange(width) + 0.5, indexing="ij")
    src_x, src_y = xs - frame.motion[0], ys - frame.motion[1]  # where pixel (x, y) was at t-1
    cam = camera_frame(scene.camera, t, width, height)
    footprint = (p_now - cam.origin[:, None, None]).norm(dim=0) * 2 * cam.tan_x / width
    assert frame.motion.abs().max() > 0.2  # the scene does move
    return scene, t, (width, height), p_back, obj_now, src_x, src_y, footprint


@pytest.mark.parametrize("name", ["snooker", "direct"])
def test_motion_vectors_point_to_the_same_surface_point_at_t_minus_1(name):
    """The ray of frame t-1 through ``pixel - motion`` hits the very point that frame t sees at
    the pixel center (moved back with its object), wherever it is not occluded at t-1."""
    scene, t, (width, height), p_back, obj_now, src_x, src_y, footprint = motion_setup(name)
    cam_prev = camera_frame(scene.camera, t - 1, width, height)
    o, d = generate_rays(cam_prev, src_x.flatten(), src_y.flatten())
    dist, obj = intersect(scene_tensors(scene, t - 1), o, d)
    p_then = (o + torch.where(obj >= 0, dist, 0.0) * d).view(3, height, width)
    visible = (obj.view(height, width) == obj_now) & (obj_now >= 0)  # else occluded at t-1
    assert visible.sum() > 0.95 * (obj_now >= 0).sum()
    error = (p_then - p_back).norm(dim=0) / footprint
    assert torch.quantile(error[visible], 0.99) < 1e-3  # float rounding, a thousandth of a pixel
    for i in obj_now[visible].unique().tolist():  # every object, however small (rolling balls)
        assert error[visible & (obj_now == i)].median() < 1e-3, scene.shapes[i].name


@pytest.mark.parametrize("name", ["snooker", "direct"])
def test_motion_vectors_warp_the_previous_frame_onto_the_current(name):
    """Warp frame t-1's first-hit positions along the motion vectors (bilinear): they match frame
    t's where the four taps see the pixel's own object (no occlusion, no edge)."""
    scene, t, (width, height), p_back, obj_now, src_x, src_y, footprint = motion_setup(name)
    p_prev, obj_prev, _ = center_hits(scene, t - 1, width, height)
    grid = torch.stack([src_x / width * 2 - 1, src_y / height * 2 - 1], dim=-1)[None]
    warped = F.grid_sample(p_prev[None], grid, mode="bilinear", align_corners=False)[0]
    x0, y0 = (src_x - 0.5).floor().long(), (src_y - 0.5).floor().long()
    same = (x0 >= 0) & (y0 >= 0) & (x0 + 1 < width) & (y0 + 1 < height) & (obj_now >= 0)
    x0, y0 = x0.clamp(0, width - 2), y0.clamp(0, height - 2)
    for dy in (0, 1):
        for dx in (0, 1):
            same &= obj_prev[y0 + dy, x0 + dx] == obj_now
    assert same.sum() > 0.8 * (obj_now >= 0).sum()
    error = ((warped - p_back).norm(dim=0) / footprint)[same]
    # Bilinear interpolation of curved or foreshortened surfaces is not exact, but the typical
    # pixel lands within a hundredth of its footprint (a wrong vector is off by its own length).
    assert error.median() < 0.01


def test_static_scene_has_zero_motion():
    frame = render(get_scene("cornell", animated=False), 5, seeds_for(8, 8), WHITE, 1)
    assert frame.motion.abs().max() < 1e-3


def test_bad_input():
    scene = get_scene("direct")
    seeds = seeds_for(4, 4)
    with pytest.raises(UnknownNameError, match="unknown scene 'teapot'"):
        get_scene("teapot")
    with pytest.raises(DtypeError, match="seeds: expected dtype int64, got int32"):
        render(scene, 0, seeds.int(), WHITE, 1)
    with pytest.raises(ShapeError, match="seeds: expected 2 dimensions"):
        render(scene, 0, seeds[None], WHITE, 1)
    with pytest.raises(ShapeError, match="seeds: expected H >= 1 and W >= 1"):
        render(scene, 0, seeds[:0], WHITE, 1)
    with pytest.raises(DtypeError, match="seeds: expected a torch.Tensor"):
        render(scene, 0, seeds.numpy(), WHITE, 1)
    with pytest.raises(ValueRangeError, match="spp: expected an integer >= 1, got 0"):
        render(scene, 0, seeds, WHITE, 0)
    with pytest.raises(ValueRangeError, match="spp: expected an integer >= 1, got -3"):
        render(scene, 0, seeds, WHITE, -3)
    with pytest.raises(DtypeError, match="spp: expected an integer, got float"):
        render(scene, 0, seeds, WHITE, 2.0)
    with pytest.raises(DtypeError, match="sampler: expected a bnerr.sequences.Sampler, got str"):
        render(scene, 0, seeds, "white", 1)
    with pytest.raises(DtypeError, match="scene: expected a renderers Scene, got str"):
        render("direct", 0, seeds, WHITE, 1)
    with pytest.raises(DtypeError, match="t: expected an integer frame index"):
        render(scene, 0.5, seeds, WHITE, 1)
    with pytest.raises(ValueRangeError, match="chunk: expected an integer >= 1"):
        render(scene, 0, seeds, WHITE, 1, chunk=0)


def test_compile_failure_falls_back_to_eager(monkeypatch):
    def broken_compile(fn, **kwargs):
        def call(*args):
            raise RuntimeError("no C++ compiler")

        return call

    monkeypatch.setattr(tracer.torch, "compile", broken_compile)
    monkeypatch.setattr(tracer, "_COMPILED", None)
    scene = get_scene("direct")
    with pytest.warns(RuntimeWarning, match="torch.compile failed, tracing in eager mode"):
        compiled = render(scene, 0, seeds_for(6, 6), WHITE, 2, compile=True)
    eager = render(scene, 0, seeds_for(6, 6), WHITE, 2, compile=False)
    assert torch.equal(compiled.color, eager.color)
    monkeypatch.setattr(tracer, "_COMPILED", None)


@pytest.mark.slow
def test_compiled_matches_eager_and_is_deterministic():
    scene = get_scene("direct")
    seeds = seeds_for(16, 16)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # a silent fallback would not test compile
        a = render(scene, 1, seeds, WHITE, 8, compile=True)
        b = render(scene, 1, seeds, WHITE, 8, compile=True)
    eager = render(scene, 1, seeds, WHITE, 8, compile=False)
    assert torch.equal(a.color, b.color)
    torch.testing.assert_close(a.color, eager.color, rtol=1e-4, atol=1e-5)
    torch.testing.assert_close(a.albedo, eager.albedo, rtol=1e-4, atol=1e-5)


def test_compile_is_opt_in(monkeypatch):
    monkeypatch.delenv("BNERR_COMPILE", raising=False)
    assert not tracer._use_compile(None)
    assert not tracer._use_compile(False) and tracer._use_compile(True)
    for value in ("0", "", "true", "yes", "2"):
        monkeypatch.setenv("BNERR_COMPILE", value)
        assert not tracer._use_compile(None), value
    monkeypatch.setenv("BNERR_COMPILE", "1")
    assert tracer._use_compile(None)
    assert not tracer._use_compile(False)


def test_default_render_never_compiles(monkeypatch):
    """Whatever its size, a render with ``compile=None`` runs the eager stage (no compiler)."""
    monkeypatch.delenv("BNERR_COMPILE", raising=False)

    def forbidden():
        raise AssertionError("render compiled without being asked to")

    monkeypatch.setattr(tracer, "_compiled_step", forbidden)
    scene = get_scene("direct")
    seeds = seeds_for(6, 5)
    default = render(scene, 0, seeds, WHITE, 2)
    eager = render(scene, 0, seeds, WHITE, 2, compile=False)
    for key, value in default.buffers().items():
        assert torch.equal(value, eager.buffers()[key]), key


def test_render_is_the_per_pixel_mean_of_trace():
    """The slow twin of render's chunking and accumulation: every lane of the frame traced at once
    in pixel-major order, then averaged per pixel. With one chunk both see the same lanes in the
    same order, so the colour agrees bit for bit."""
    scene = get_scene("medium")
    height, width, spp, t = 5, 7, 3, 2
    seeds = seeds_for(height, width, 4)
    frame = render(scene, t, seeds, WHITE, spp)
    st = scene_tensors(scene, t)
    cam = camera_frame(scene.camera, t, width, height)
    pix = torch.arange(height * width).repeat_interleave(spp)
    index = torch.arange(spp).repeat(height * width)
    py, px = pix // width, pix % width
    u = WHITE.sample(seeds.flatten()[pix], index, 0, scene.dimensions, torch.stack([py, px], 1))
    paths = integrator.trace(st, cam, scene.layout, px, py, u.T.contiguous())
    radiance = paths.radiance.view(3, height, width, spp)
    assert torch.equal(frame.color, radiance.mean(-1))
    torch.testing.assert_close(frame.variance, radiance.var(-1) / spp, rtol=1e-4, atol=1e-9)
    albedo = paths.albedo.view(3, height, width, spp).mean(-1)
    torch.testing.assert_close(frame.albedo, albedo, rtol=1e-6, atol=1e-7)
    normal = paths.normal.view(3, height, width, spp).mean(-1)
    torch.testing.assert_close(frame.normal, normal, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("name", ["cornell", "medium"])
def test_result_does_not_depend_on_the_thread_count(name):
    scene = get_scene(name)
    seeds = seeds_for(16, 16)
    serial = render(scene, 0, seeds, WHITE, 4, chunk=128)
    torch.set_num_threads(3)  # chunk-parallel: 8 ranges over 3 worker threads
    try:
        parallel = render(scene, 0, seeds, WHITE, 4, chunk=128)
    finally:
        torch.set_num_threads(1)
    assert torch.get_num_threads() == 1
    for key, value in serial.buffers().items():
        assert torch.equal(value, parallel.buffers()[key]), key
