"""The tracer's driver: render a frame from a sampler, in chunks of paths, on worker threads,
through the eager, ``torch.compile``d or ahead-of-time packaged vertex stage.

``render(scene, t, seeds, sampler, spp)`` estimates every pixel of frame t as the mean of ``spp``
paths, traced by :func:`renderers.integrator.trace` (the per-path physics: stages, vertex step,
bounce loop, and the order in which a path reads its sampler's dimensions). Nothing here is
random: equal inputs give bit-identical frames. ``render(..., compile=True)`` runs
:func:`~renderers.integrator.vertex_step` through ``torch.compile``, which fuses a whole vertex
into one vectorized C++ kernel: about 8x faster than eager on one core (cornell: 1.8 M against
0.2 M paths per second in :func:`~renderers.integrator.trace`).

Memory stays bounded at any resolution and spp: :func:`render` processes ``chunk`` paths at a
time (whole pixels times a range of sample indices) and keeps only per-pixel sums.

The Frame's buffers: ``color`` is the pixel mean, ``variance`` the variance of that mean (the
per-pixel sample variance over its spp paths divided by spp; None when spp = 1), ``albedo`` and
``normal`` the mean over the pixel's paths of the first surface hit (zero on escape; a medium in
front does not count), and ``depth``, ``object_id`` and ``motion`` come from one extra,
deterministic ray through each pixel's center: distance to the first surface (0 on escape),
object id (-1 on escape), and motion in pixels from frame t-1 to t, computed by moving that hit
point back with its object's motion and projecting it into frame t-1's camera (a ray that
escapes is projected as a direction, so the background follows the camera's rotation; points
that were behind the camera at t-1 get zero motion).

Not for: the light transport itself (:mod:`renderers.integrator`), or packaging the stage ahead
of time (:mod:`renderers.aot`).
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import os
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import torch

from bnerr.errors import DtypeError, ShapeError, check_dtype, check_positive_int, check_shape
from bnerr.frame import Frame
from bnerr.sequences import Sampler
from bnerr.timing import Stopwatch
from renderers.camera import CameraFrame, camera_frame, generate_rays, project
from renderers.geometry import SceneTensors, intersect, scene_tensors, where
from renderers.integrator import PathVertex, VertexStage, trace, vertex_step
from renderers.layout import Layout
from renderers.scene import Scene

__all__ = [
    "COMPILED_CHUNK",
    "DEFAULT_CHUNK",
    "RECOMPILE_LIMIT",
    "StageSource",
    "render",
    "render_batch",
]

#: Paths traced at once by the eager stage. 2^16 keeps a chunk's working set (a few dozen [3, N]
#: tensors plus the [D, N] sample block) in the tens of MB, so memory is flat in resolution and
#: spp.
DEFAULT_CHUNK = 1 << 16
#: Paths traced at once by a compiled or packaged stage: its fused kernels make a few passes over
#: the lanes instead of hundreds, so the chunk's eager part (lanes, camera rays, sums) is what a
#: smaller chunk keeps in cache. Measured on the idle 2-core machine, 256x256 at 32 spp, 7
#: interleaved rounds: 2^15 took 0.92x (direct) and 0.86x (cornell) 2^16's time, 2^14 1.13x and
#: 0.86x; eager renders are slower at 2^15 (1.16-1.23x), so they keep 2^16. The image is the same
#: bit for bit (with spp at most the chunk every pixel's samples share one chunk, and the padded
#: lane count of a compiled chunk is a power of two: every lane runs the kernels' vector loops).
COMPILED_CHUNK = 1 << 15


# --------------------------------------------------------------------------------------------
# Guide buffers from one deterministic ray per pixel center


def _center_buffers(
    st: SceneTensors, cam: CameraFrame, cam_prev: CameraFrame, px: torch.Tensor, py: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``depth [N]``, ``object_id [N]`` (float) and ``motion [2, N]`` through pixel centers."""
    cx, cy = px.to(torch.float32) + 0.5, py.to(torch.float32) + 0.5
    o, d = generate_rays(cam, cx, cy)
    t, obj = intersect(st, o, d)
    hit = obj >= 0
    p = o + where(hit, t, 0.0) * d
    p_prev = p - st.translation[obj.clamp_min(0)].T  # undo the object's own motion
    x_pt, y_pt, front_pt = project(cam_prev, p_prev)
    x_dir, y_dir, front_dir = project(cam_prev, d, directions=True)
    x_prev = where(hit, x_pt, x_dir)
    y_prev = where(hit, y_pt, y_dir)
    valid = where(hit, front_pt, front_dir)
    motion = where(valid, torch.stack([cx - x_prev, cy - y_prev]), 0.0)
    return where(hit, t, 0.0), obj.to(torch.float32), motion


# --------------------------------------------------------------------------------------------
# The public entry point


def _use_compile(compile: bool | StageSource | None) -> bool:
    """``compile`` if given, else True only when the environment sets ``BNERR_COMPILE=1``.

    Compiling is opt-in: a compiled render may differ from the eager one in the last bits
    (fused kernels round differently), and each new process spends 10 s to a minute compiling
    before its first frame, so the default is the eager stage, which is bit-identical everywhere.
    """
    if compile is not None:
        return bool(compile)
    return os.environ.get("BNERR_COMPILE", "") == "1"


class _CompiledStep:
    """:func:`vertex_step` through ``torch.compile``, falling back to eager if compiling fails.

    Dynamo specializes on the scene's static layout and on the lane count (and would on which
    arguments are None: :func:`trace` gives this stage the same types at every vertex), so a
    process that renders several scenes needs more than dynamo's default 8 variants of one
    function: :func:`render` raises that limit while it runs (:data:`RECOMPILE_LIMIT`). Lane
    counts are padded to a power of two, so a render compiles at most two lane counts.
    """

    #: :func:`trace` passes the same argument types at every vertex: one variant per scene.
    uniform = True

    def __init__(self) -> None:
        self._fn = torch.compile(vertex_step, dynamic=False)
        self.failed = False

    def __call__(self, *args: Any) -> PathVertex:  # vertex_step's own arguments
        if not self.failed:
            try:
                return self._fn(*args)
            except Exception as err:  # any compiler failure: inductor, C++ toolchain, dynamo
                warnings.warn(
                    "renderers: torch.compile failed, tracing in eager mode "
                    f"({type(err).__name__}: {err})",
                    RuntimeWarning,
                    stacklevel=2,
                )
                self.failed = True
        return vertex_step(*args)


_COMPILED: _CompiledStep | None = None

#: Variants of the compiled stage dynamo may keep while :func:`render` runs (3 per scene and lane
#: count; its default of 8 would silently fall back to eager after three scenes).
RECOMPILE_LIMIT = 256


def _compiled_step() -> _CompiledStep:
    """The process-wide compiled stage (built lazily, once)."""
    global _COMPILED
    if _COMPILED is None:
        _COMPILED = _CompiledStep()
    return _COMPILED


#: What :func:`render`'s ``compile`` may be besides a bool or None: a callable
#: ``(scene tensors, layout, workers) -> stage or None`` that gives the frame's vertex stage
#: (:func:`renderers.aot.stage`, the ahead-of-time compiled one); None from it means eager.
StageSource = Callable[[SceneTensors, Layout, int], VertexStage | None]


def _stage(
    compile: bool | StageSource | None, st: SceneTensors, layout: Layout, workers: int
) -> VertexStage:
    """The vertex stage :func:`render` runs (see its ``compile``)."""
    if callable(compile):
        return compile(st, layout, workers) or vertex_step
    return _compiled_step() if _use_compile(compile) else vertex_step


def _padded(n: int) -> int:
    """Lane count for the compiled stage: the next power of two (at least 1024)."""
    return max(1024, 1 << (n - 1).bit_length())


@contextlib.contextmanager
def _intra_op_threads(n: int) -> Iterator[None]:
    """Set torch's intra-op thread count for the duration of the block, then restore it."""
    before = torch.get_num_threads()
    if n != before:
        torch.set_num_threads(n)
    try:
        yield
    finally:
        if n != before:
            torch.set_num_threads(before)


def _run_ranges(
    work: Callable[[tuple[int, int]], None],
    ranges: list[tuple[int, int]],
    workers: int,
    warm_alone: bool = False,
) -> None:
    """Run ``work`` on every pixel range, ``workers`` ranges at a time (caller: one op thread).

    Torch's own intra-op parallelism opens an OpenMP region per op, whose barrier waits for the
    slowest thread: a few hundred regions per chunk, so on a loaded machine every descheduled
    thread stalls all of them (measured: 2 threads 6x slower than 1 on cornell). Chunks are
    independent, so :func:`render` runs its ops single-threaded and lets each of ``workers``
    Python threads trace whole chunks (the kernels release the GIL), like Mitsuba's block
    scheduler. Every range writes its own pixels, in a fixed order within the range, so the
    result does not depend on the thread count or the scheduling. With ``warm_alone`` (a
    ``torch.compile`` stage) the first and the last range run alone first, so that it sees every
    lane count before threads share it; eager and packaged stages start every range in the pool
    (a 256x256, 32 spp render has 32 ranges: two alone then 30 on two threads take the time of
    17 ranges, all 32 on two threads that of 16).
    """
    if workers == 1 or len(ranges) <= 2:
        for pixel_range in ranges:
            work(pixel_range)
        return
    if warm_alone:
        work(ranges[0])
        work(ranges[-1])
        ranges = ranges[1:-1]
    # OpenMP keeps its thread count per thread: a fresh worker would open regions of the
    # machine's default size inside compiled kernels unless told otherwise.
    with concurrent.futures.ThreadPoolExecutor(
        workers, initializer=torch.set_num_threads, initargs=(1,)
    ) as pool:
        for _ in pool.map(work, ranges):
            pass


def render(
    scene: Scene,
    t: int,
    seeds: torch.Tensor,
    sampler: Sampler,
    spp: int,
    *,
    chunk: int | None = None,
    compile: bool | StageSource | None = None,
) -> Frame:
    """Render frame ``t`` of ``scene``: the mean of ``spp`` paths per pixel.

    Args:
        scene: a :class:`~renderers.scene.Scene` (``renderers.get_scene(name)``).
        t: frame index (any int; the animation is defined for every t, and motion vectors
            compare with t - 1).
        seeds: ``[H, W]`` int64 seed image; the resolution is its shape, its device is the device
            of every output.
        sampler: a :class:`bnerr.sequences.Sampler`; path i of pixel (y, x) uses
            ``sampler.sample(seeds[y, x], i, 0, D, (y, x))``.
        spp: samples (paths) per pixel, >= 1.
        chunk: paths traced at once (memory bound; results do not depend on it except for
            float rounding in the per-pixel sums when spp exceeds it). None (the default):
            :data:`DEFAULT_CHUNK` for the eager stage, :data:`COMPILED_CHUNK` for a compiled or
            packaged one.
        compile: run the per-vertex stage through ``torch.compile`` (about 8x faster on CPU
            once compiled; the first call of a process compiles three variants per scene, about
            a minute, or 10 to 25 s from inductor's on-disk cache). None (the default): eager,
            unless the environment sets ``BNERR_COMPILE=1``. If compilation fails the eager
            stage is used, with a warning. A compiled render may differ from the eager one in
            the last bits (measured: up to 3.6e-7 at 960x540, 16 spp, in 16 % of the values),
            since the fused kernels round differently; each mode is bit-identical between runs.
            A callable (:data:`StageSource`, e.g. :func:`renderers.aot.stage`) gives the stage
            instead: the ahead-of-time compiled package, loaded in milliseconds in a new process.

    Threads: ``torch.get_num_threads()`` chunks are traced at once, each by single-threaded ops
    (torch's thread count is 1 while ``render`` runs and is restored after). Torch's per-op
    OpenMP parallelism stalls at every op's barrier on a loaded machine (measured 6x slower with
    2 threads on a shared 2-core machine); whole chunks per thread do not (see ``_run_ranges``).
    The result does not depend on the thread count.

    Returns:
        A :class:`bnerr.frame.Frame` with color, variance (None if spp = 1), albedo, normal,
        depth, motion, object_id and ``timings["render"]`` in ms.

    Raises:
        DtypeError: scene, sampler, seeds or spp of the wrong type or dtype.
        ShapeError: seeds not ``[H, W]`` or empty.
        ValueRangeError: spp or chunk < 1.
    """
    watch = Stopwatch()
    _check_render_args(scene, t, seeds, sampler, spp, chunk)
    workers = torch.get_num_threads() if seeds.device.type == "cpu" else 1
    with _intra_op_threads(1):
        (frame,) = _render(scene, t, seeds[None], sampler, spp, chunk, compile, workers)
    frame.timings["render"] = watch.ms(frame.color)  # waits for the device's queued work
    return frame


#: A batch's chunks may hold several frames' pixels only when a frame's pixel count is a multiple
#: of this: every lane then keeps its place modulo the widest SIMD loop (2 x 16 float32 lanes,
#: rounded up), so each elementwise kernel computes it with the same instructions as alone.
_BATCH_ALIGN = 64


def render_batch(
    scene: Scene,
    t: int,
    seeds: torch.Tensor,
    sampler: Sampler,
    spp: int,
    *,
    chunk: int | None = None,
    compile: bool | StageSource | None = None,
) -> list[Frame]:
    """``[render(scene, t, seeds[k], sampler, spp) for k in range(K)]``, bit for bit, faster.

    The K frames share the frame's scene tensors, cameras and guide buffers (depth, object id
    and motion depend on the camera, not the seeds: computed once), and at low spp several
    frames' pixels share a chunk (a 128 x 128 frame at 1 spp fills a quarter of one), so the
    per-operation overhead is paid once per chunk instead of once per frame. Every lane still
    runs the same elementwise operations on the same values at the same SIMD position, so each
    frame is bit-identical to its own :func:`render` (tests/renderers/test_tracer.py). A
    compiled stage (``compile``, ``BNERR_COMPILE``) renders the frames one by one: its kernels
    are specialised on the lane count.

    Args:
        seeds: ``[K, H, W]`` int64, one seed image per frame; the rest as :func:`render`.

    Returns:
        K frames; each one's ``timings["render"]`` is the batch's time divided by K, so that
        their sum is the batch's time.
    """
    check_shape(seeds, "K H W", "seeds")
    if _use_compile(compile) or seeds.shape[0] == 0:
        return [render(scene, t, s, sampler, spp, chunk=chunk, compile=compile) for s in seeds]
    watch = Stopwatch()
    _check_render_args(scene, t, seeds[0], sampler, spp, chunk)
    workers = torch.get_num_threads() if seeds.device.type == "cpu" else 1
    with _intra_op_threads(1):
        frames = _render(scene, t, seeds, sampler, spp, chunk, compile, workers)
    ms = watch.ms(frames[-1].color) / len(frames)
    for frame in frames:
        frame.timings["render"] = ms
    return frames


def _pixel_ranges(frames: int, n_pixels: int, per_range: int) -> list[tuple[int, int]]:
    """Ranges of at most ``per_range`` pixels over ``frames`` frames of ``n_pixels`` each: across
    frame boundaries when a frame's pixels align (:data:`_BATCH_ALIGN`), else within each
    frame, exactly as that frame alone would be cut (a single frame: the same either way)."""
    if frames == 1 or n_pixels % _BATCH_ALIGN == 0:
        total = frames * n_pixels
        return [(p0, min(total, p0 + per_range)) for p0 in range(0, total, per_range)]
    return [
        (f * n_pixels + p0, f * n_pixels + min(n_pixels, p0 + per_range))
        for f in range(frames)
        for p0 in range(0, n_pixels, per_range)
    ]


def _check_render_args(
    scene: object, t: object, seeds: torch.Tensor, sampler: object, spp: object, chunk: object
) -> None:
    """:func:`render`'s argument checks, in the order it reports them."""
    if not isinstance(scene, Scene):
        raise DtypeError(f"scene: expected a renderers Scene, got {type(scene).__name__}")
    if not isinstance(sampler, Sampler):
        raise DtypeError(
            f"sampler: expected a bnerr.sequences.Sampler, got {type(sampler).__name__}"
        )
    if isinstance(t, bool) or not isinstance(t, int):
        raise DtypeError(f"t: expected an integer frame index, got {type(t).__name__} {t!r}")
    size = check_shape(seeds, "H W", "seeds")
    check_dtype(seeds, torch.int64, "seeds")
    if size["H"] < 1 or size["W"] < 1:
        raise ShapeError(f"seeds: expected H >= 1 and W >= 1, got shape {list(seeds.shape)}")
    check_positive_int(spp, "spp")
    if chunk is not None:
        check_positive_int(chunk, "chunk")


def _render(
    scene: Scene,
    t: int,
    seeds: torch.Tensor,
    sampler: Sampler,
    spp: int,
    chunk: int | None,
    compile: bool | StageSource | None,
    workers: int,
) -> list[Frame]:
    """:func:`render` of each seed image of ``seeds [K, H, W]`` after the checks, with torch's
    ops on one thread."""
    frames, height, width = seeds.shape
    device = seeds.device
    st = scene_tensors(scene, t, device)
    cam = camera_frame(scene.camera, t, width, height, device)
    step = _stage(compile, st, scene.layout, workers)
    if chunk is None:
        chunk = DEFAULT_CHUNK if step is vertex_step else COMPILED_CHUNK
    job = _PathJob(st, cam, scene.layout, seeds.reshape(-1), width, height, sampler, spp, step)
    n_pixels = height * width
    sums = _PixelSums.zeros(frames * n_pixels, device)
    per_chunk = min(spp, chunk)  # sample indices per chunk
    ranges = _pixel_ranges(frames, n_pixels, max(1, chunk // per_chunk))

    def work(pixel_range: tuple[int, int]) -> None:
        _trace_range(job, sums, pixel_range, per_chunk)

    if not isinstance(step, _CompiledStep):
        _run_ranges(work, ranges, workers)
    else:
        with torch._dynamo.config.patch(recompile_limit=RECOMPILE_LIMIT):
            _run_ranges(work, ranges, workers, warm_alone=True)
    cam_prev = camera_frame(scene.camera, t - 1, width, height, device)
    depth, object_id, motion = _guide_buffers(st, cam, cam_prev, n_pixels, width, chunk)

    def image(x: torch.Tensor, f: int) -> torch.Tensor:
        return x[..., f * n_pixels : (f + 1) * n_pixels].reshape(-1, height, width).contiguous()

    def guide(x: torch.Tensor) -> torch.Tensor:  # one per frame, however many share it
        shared = x.reshape(-1, height, width).contiguous()
        return shared if frames == 1 else shared.clone()

    return [
        Frame(
            color=image(sums.mean, f),
            albedo=image(sums.albedo / spp, f),
            normal=image(sums.normal / spp, f),
            depth=guide(depth),
            motion=guide(motion),
            object_id=guide(object_id),
            variance=image(sums.m2 / ((spp - 1) * spp), f) if spp > 1 else None,
        )
        for f in range(frames)
    ]


@dataclass
class _PathJob:
    """What every chunk of one render shares: the frame's scene and camera, the seeds
    (``seeds_flat [K*H*W]``: K frames' seed images), the image size, the sampler, spp and the
    vertex stage to run."""

    st: SceneTensors
    cam: CameraFrame
    layout: Layout
    seeds_flat: torch.Tensor
    width: int
    height: int
    sampler: Sampler
    spp: int
    step: VertexStage


@dataclass
class _PixelSums:
    """Per-pixel accumulators ``[3, H*W]`` float32: running ``mean`` and ``m2`` of the radiance
    (:func:`_merge`), and the sums of the first-hit ``albedo`` and ``normal``."""

    mean: torch.Tensor
    m2: torch.Tensor
    albedo: torch.Tensor
    normal: torch.Tensor

    @classmethod
    def zeros(cls, n_pixels: int, device: torch.device) -> _PixelSums:
        return cls(
            *(torch.zeros(3, n_pixels, dtype=torch.float32, device=device) for _ in range(4))
        )


def _trace_range(
    job: _PathJob, sums: _PixelSums, pixel_range: tuple[int, int], per_chunk: int
) -> None:
    """Trace all ``spp`` paths of the pixels ``[p0, p1)``, ``per_chunk`` sample indices at a
    time, and fold them into ``sums`` (only these pixels' columns are written)."""
    p0, p1 = pixel_range
    device = job.seeds_flat.device
    pix = torch.arange(p0, p1, device=device)
    done = 0
    for s0 in range(0, job.spp, per_chunk):
        ns = min(job.spp, s0 + per_chunk) - s0
        px, py, u, n = _lanes(job, pix, s0, ns)
        paths = trace(job.st, job.cam, job.layout, px, py, u, job.step)
        _merge(
            sums.mean[:, p0:p1], sums.m2[:, p0:p1], done, paths.radiance[:, :n].view(3, p1 - p0, ns)
        )
        sums.albedo[:, p0:p1] += paths.albedo[:, :n].view(3, p1 - p0, ns).sum(-1)
        sums.normal[:, p0:p1] += paths.normal[:, :n].view(3, p1 - p0, ns).sum(-1)
        done += ns


def _lanes(
    job: _PathJob, pix: torch.Tensor, s0: int, ns: int
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, int]:
    """One lane per (pixel of ``pix [P]``, sample index in ``[s0, s0 + ns)``), pixel-major.

    Returns ``(px, py, u, n)``: int64 pixel coordinates ``[N']``, the sampler's values
    ``[D, N']`` and ``n = P * ns`` real lanes. For a compiled stage the lanes are padded to
    :func:`_padded` by repeating the first one (so one render compiles one shape); ``N' = n``
    otherwise.
    """
    device = pix.device
    lane_index = torch.arange(s0, s0 + ns, device=device).repeat(pix.shape[0])
    # Per pixel first, then repeated per sample: the same integers, ns times fewer divisions
    # and gathers (a sixth of direct's lane set-up).
    py, px = ((pix // job.width) % job.height).repeat_interleave(ns), (pix % job.width)
    px = px.repeat_interleave(ns)  # frame k's pixel
    u = job.sampler.sample(
        job.seeds_flat[pix].repeat_interleave(ns),
        lane_index,
        0,
        job.layout.dimensions,
        torch.stack([py, px], dim=1),
    ).T.contiguous()
    n = u.shape[1]
    if isinstance(job.step, _CompiledStep) and _padded(n) != n:  # one compiled shape per render
        pad = _padded(n) - n
        u = torch.cat([u, u[:, :1].expand(-1, pad)], dim=1)
        px = torch.cat([px, px[:1].expand(pad)])
        py = torch.cat([py, py[:1].expand(pad)])
    return px, py, u, n


def _guide_buffers(
    st: SceneTensors,
    cam: CameraFrame,
    cam_prev: CameraFrame,
    n_pixels: int,
    width: int,
    chunk: int,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``depth [H*W]``, ``object_id [H*W]`` and ``motion [2, H*W]`` by :func:`_center_buffers`,
    ``chunk`` pixels at a time."""
    device = cam.origin.device
    depth = torch.empty(n_pixels, dtype=torch.float32, device=device)
    object_id = torch.empty(n_pixels, dtype=torch.float32, device=device)
    motion = torch.empty(2, n_pixels, dtype=torch.float32, device=device)
    for p0 in range(0, n_pixels, chunk):
        p1 = min(n_pixels, p0 + chunk)
        pix = torch.arange(p0, p1, device=cam.origin.device)
        depth[p0:p1], object_id[p0:p1], motion[:, p0:p1] = _center_buffers(
            st, cam, cam_prev, pix % width, pix // width
        )
    return depth, object_id, motion


def _merge(mean: torch.Tensor, m2: torch.Tensor, n_a: int, x: torch.Tensor) -> None:
    """Fold samples ``x [3, P, n]`` into the running ``mean``, ``m2 [3, P]`` of ``n_a``, in place.

    Chan, Golub & LeVeque's pairwise update, so the variance does not suffer the cancellation of
    ``E[x^2] - E[x]^2`` in float32.
    """
    n_b = x.shape[-1]
    mean_b = x.mean(-1)
    m2_b = ((x - mean_b[..., None]) ** 2).sum(-1)
    if n_a == 0:
        mean.copy_(mean_b)
        m2.copy_(m2_b)
        return
    n = n_a + n_b
    delta = mean_b - mean
    mean.add_(delta * (n_b / n))
    m2.add_(m2_b + delta * delta * (n_a * n_b / n))
