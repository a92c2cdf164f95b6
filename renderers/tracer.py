"""A wavefront path tracer in torch, driven entirely by a sampler (seed image, sample index, dim).

``render(scene, t, seeds, sampler, spp)`` estimates every pixel of frame t as the mean of ``spp``
paths. Path ``i`` of pixel ``p`` uses the sampler's values ``X(seeds[p], i, 0 .. D-1)``, in the
fixed order documented in :mod:`renderers.layout`:: pixel jitter (2), then per vertex an optional
free-flight distance (1, medium scenes), an optional light choice (1, scenes with several
lights), a light position (2) and, except at the last vertex, a direction (2). Nothing else is
random: the tracer never calls ``torch.rand``, so equal inputs give bit-identical frames and
permuting seeds between pixels permutes exactly which sequence each pixel integrates with.

The estimator (pbrt-v4's ``PathIntegrator`` / Mitsuba 3's ``path`` and ``volpath``, without
Russian roulette so that D is fixed):

- camera rays through ``pixel + jitter`` (box pixel filter), pinhole camera;
- at each vertex, next-event estimation to a uniformly chosen rectangular light, with a point
  sampled uniformly on its area, combined with the BSDF (or phase function) sample of the next
  segment by multiple importance sampling with the power heuristic (Veach 1997, ch. 9);
- Lambertian BSDF sampled with cosine-weighted directions (Shirley-Chiu concentric mapping),
  isotropic phase function sampled uniformly on the sphere;
- homogeneous medium: the free-flight distance is sampled exactly, ``-ln(1 - u) / sigma_t`` from
  where the segment enters the medium box; passing through it has probability equal to the
  transmittance, so the throughput is unchanged, and a scattering event multiplies it by the
  albedo. Shadow rays use the analytic transmittance ``exp(-sigma_t * length inside the box)``;
- the last vertex samples no direction: its light sample carries the full weight.

Wavefront stages, one call each per vertex over all of a chunk's paths (flat ``[N]``/``[N, 3]``
tensors; pbrt-v4 ``wavefront/integrator.cpp`` names the same ones): :func:`camera_rays`,
``intersect`` (:func:`renderers.geometry.intersect`), :func:`sample_medium`, :func:`emission`,
:func:`next_event`, :func:`sample_direction`. Dead paths keep their lanes with zero throughput, so
every tensor keeps its shape through the bounce loop (that is what lets ``torch.compile`` fuse the
stages into a handful of loops).

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

Not for: glossy or refractive materials, Russian roulette, spectral rendering, or scenes with more
than a few dozen primitives (see :mod:`renderers.geometry`).
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass

import torch

from bnerr.errors import DtypeError, ShapeError, check_dtype, check_positive_int, check_shape
from bnerr.frame import Frame
from bnerr.sequences import Sampler
from renderers.camera import CameraFrame, camera_frame, generate_rays, project
from renderers.geometry import (
    SceneTensors,
    intersect,
    medium_interval,
    scene_tensors,
    spawn_offset,
    surface_at,
)
from renderers.layout import Layout
from renderers.scene import Scene

__all__ = ["DEFAULT_CHUNK", "render", "trace"]

#: Paths traced at once. 2^16 keeps a chunk's working set (a few dozen [N, 3] tensors plus the
#: [N, D] sample block and [N, primitives] hit tensors) in the tens of MB, so memory is flat in
#: resolution and spp.
DEFAULT_CHUNK = 1 << 16

_INV_PI = 1.0 / math.pi
_INV_4PI = 1.0 / (4.0 * math.pi)


# --------------------------------------------------------------------------------------------
# Stages


def camera_rays(cam: CameraFrame, px: torch.Tensor, py: torch.Tensor, jitter: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
    """Rays through pixel ``(px, py)`` (int64 ``[N]``) at offset ``jitter [N, 2]`` (x, y) in [0, 1)."""
    return generate_rays(cam, px.to(jitter.dtype) + jitter[:, 0], py.to(jitter.dtype) + jitter[:, 1])


def sample_medium(st: SceneTensors, o: torch.Tensor, d: torch.Tensor, t_surface: torch.Tensor,
                  u: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Free-flight sampling on the segment ``o + s d``, ``0 < s < t_surface``.

    Returns ``scatter [N]`` (bool: a scattering event happens before the surface) and its
    distance ``s [N]``. ``u [N]`` in [0, 1).
    """
    t0, t1 = medium_interval(st, o, d)
    t1 = torch.minimum(t1, t_surface)
    s = t0 - torch.log1p(-u) / st.sigma_t
    return (t0 < t1) & (s < t1), s


def _transmittance(st: SceneTensors, o: torch.Tensor, d: torch.Tensor, dist: torch.Tensor) -> torch.Tensor:
    """``[N]`` transmittance of the medium along ``o + s d``, ``0 < s < dist``."""
    t0, t1 = medium_interval(st, o, d)
    inside = (torch.minimum(t1, dist) - t0).clamp_min(0.0)
    return torch.exp(-st.sigma_t * inside)


def _power_heuristic(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """``a^2 / (a^2 + b^2)``, 0 where both vanish (Veach 1997, eq. 9.13 with beta = 2)."""
    a2, b2 = a * a, b * b
    s = a2 + b2
    return torch.where(s > 0, a2 / torch.where(s > 0, s, 1.0), 0.0)


def emission(hit_emission: torch.Tensor, front: torch.Tensor, t: torch.Tensor,
             cos_light: torch.Tensor, light_pdf_area: torch.Tensor, prev_pdf: torch.Tensor | None
             ) -> torch.Tensor:
    """``[N, 3]`` emitted radiance reaching the previous vertex, MIS-weighted against NEE.

    ``prev_pdf [N]`` is the solid-angle density with which the previous vertex sampled this
    segment's direction, or None for camera rays (weight 1). The light-sampling density of the
    same point is ``light_pdf_area * t^2 / cos_light``.
    """
    le = torch.where(front[:, None], hit_emission, 0.0)
    if prev_pdf is None:
        return le
    t = torch.where(front, t, 0.0)
    p_light = light_pdf_area * t * t / cos_light.clamp_min(1e-12)
    return le * _power_heuristic(prev_pdf, p_light)[:, None]


def next_event(st: SceneTensors, x: torch.Tensor, normal: torch.Tensor, on_surface: torch.Tensor,
               f: torch.Tensor, u_choice: torch.Tensor | None, u_light: torch.Tensor, mis: bool
               ) -> torch.Tensor:
    """Next-event estimation: ``[N, 3]`` radiance from one light sample, per unit throughput.

    Args:
        x: ``[N, 3]`` shading points (surface points already pushed off the surface).
        normal: ``[N, 3]`` surface normals (ignored where not ``on_surface``).
        on_surface: ``[N]`` True for a surface vertex, False for a medium vertex.
        f: ``[N, 3]`` BSDF or phase value (albedo / pi, or albedo / (4 pi) in a medium).
        u_choice: ``[N]`` light choice or None (one light); ``u_light [N, 2]`` point on it.
        mis: weight against the density of the direction sample (False at the last vertex).
    """
    n_lights = st.num_lights
    if u_choice is None:
        j = torch.zeros(x.shape[0], dtype=torch.int64, device=x.device)
    else:
        j = (u_choice * n_lights).long().clamp_max(n_lights - 1)
    y = st.light_center[j] + (2.0 * u_light[:, :1] - 1.0) * st.light_u[j] + (2.0 * u_light[:, 1:] - 1.0) * st.light_v[j]
    w = y - x
    dist2 = (w * w).sum(-1)
    dist = dist2.sqrt()
    w = w / dist[:, None]
    cos_light = -(w * st.light_normal[j]).sum(-1)
    cos_surface = torch.where(on_surface, (w * normal).sum(-1), 1.0)
    ok = (cos_light > 0) & (cos_surface > 0)
    p_light = dist2 / (cos_light.clamp_min(1e-12) * st.light_area[j] / n_lights)
    weight = cos_surface / p_light
    if mis:
        p_dir = torch.where(on_surface, cos_surface * _INV_PI, _INV_4PI)
        weight = weight * _power_heuristic(p_light, p_dir)
    t_block, _ = intersect(st, x, w)
    ok = ok & (t_block >= dist * (1.0 - 1e-4))
    if st.medium_min is not None:
        weight = weight * _transmittance(st, x, w, dist)
    return torch.where(ok[:, None], f * st.light_radiance[j] * weight[:, None], 0.0)


def _orthonormal(n: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Two tangents completing ``n [N, 3]`` to an orthonormal basis (Duff et al. 2017, JCGT 6(1))."""
    nx, ny, nz = n.unbind(-1)
    sign = torch.where(nz >= 0, 1.0, -1.0)
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    t1 = torch.stack([1.0 + sign * nx * nx * a, sign * b, -sign * nx], dim=-1)
    t2 = torch.stack([b, sign + ny * ny * a, -ny], dim=-1)
    return t1, t2


def sample_direction(normal: torch.Tensor, on_surface: torch.Tensor, u: torch.Tensor
                     ) -> tuple[torch.Tensor, torch.Tensor]:
    """Next direction and its solid-angle density.

    Surface: cosine-weighted around ``normal`` via the concentric disk mapping (Shirley & Chiu
    1997), density ``cos / pi``. Medium: uniform on the sphere, density ``1 / (4 pi)``.
    ``u [N, 2]`` in [0, 1). Returns ``direction [N, 3]`` and ``pdf [N]``.
    """
    a = 2.0 * u[:, 0] - 1.0
    b = 2.0 * u[:, 1] - 1.0
    use_a = a.abs() > b.abs()
    r = torch.where(use_a, a, b)
    ratio = torch.where(use_a, b / torch.where(a == 0, 1.0, a), a / torch.where(b == 0, 1.0, b))
    phi = torch.where(use_a, (math.pi / 4) * ratio, (math.pi / 2) - (math.pi / 4) * ratio)
    dx, dy = r * torch.cos(phi), r * torch.sin(phi)
    dz = (1.0 - dx * dx - dy * dy).clamp_min(0.0).sqrt()
    t1, t2 = _orthonormal(normal)
    d_surface = dx[:, None] * t1 + dy[:, None] * t2 + dz[:, None] * normal
    # Uniform sphere: z = 1 - 2 u0, phi = 2 pi u1.
    z = 1.0 - 2.0 * u[:, 0]
    s = (1.0 - z * z).clamp_min(0.0).sqrt()
    phi_s = 2.0 * math.pi * u[:, 1]
    d_sphere = torch.stack([s * torch.cos(phi_s), s * torch.sin(phi_s), z], dim=-1)
    d = torch.where(on_surface[:, None], d_surface, d_sphere)
    pdf = torch.where(on_surface, dz * _INV_PI, _INV_4PI)
    return d, pdf


# --------------------------------------------------------------------------------------------
# One chunk of paths


@dataclass
class PathResult:
    """Per path: ``radiance [N, 3]``, first-hit ``albedo [N, 3]`` and ``normal [N, 3]``."""

    radiance: torch.Tensor
    albedo: torch.Tensor
    normal: torch.Tensor


def trace(st: SceneTensors, cam: CameraFrame, layout: Layout, px: torch.Tensor, py: torch.Tensor,
          u: torch.Tensor) -> PathResult:
    """Trace one path per lane.

    Args:
        st: the frame's scene tensors; cam: its camera; layout: the dimension layout.
        px, py: ``[N]`` int64 pixel coordinates of each lane.
        u: ``[N, D]`` the lane's sampler values, D = ``layout.dimensions``.

    Returns:
        :class:`PathResult`.
    """
    o, d = camera_rays(cam, px, py, u[:, 0:2])
    n_paths = o.shape[0]
    beta = torch.ones(n_paths, 3, dtype=u.dtype, device=u.device)  # path throughput
    radiance = torch.zeros_like(beta)  # L, the estimate so far
    alive = torch.ones(n_paths, dtype=torch.bool, device=u.device)  # live lanes
    prev_pdf = None  # density of the direction that produced the current segment
    first_albedo = first_normal = None
    has_medium = st.medium_min is not None
    for k in range(layout.vertices):
        last = k == layout.vertices - 1
        # -- intersect: nearest surface along the segment
        t, obj = intersect(st, o, d)
        hit = surface_at(st, o, d, t, obj)
        if k == 0:
            first_albedo, first_normal = hit.albedo, hit.normal
        # -- medium: a scattering event before the surface replaces it
        if has_medium:
            scatter, s = sample_medium(st, o, d, t, u[:, layout.distance(k)])
            scatter = scatter & alive
            beta = torch.where(scatter[:, None], beta * st.medium_albedo, beta)
        else:
            scatter, s = torch.zeros_like(alive), torch.zeros_like(t)
        cos_hit = -(d * hit.normal).sum(-1)
        front = (obj >= 0) & (cos_hit > 0) & alive & ~scatter
        # -- emission: light reached by the previous direction sample (MIS against NEE)
        le = emission(hit.emission, front, t, cos_hit, hit.light_pdf_area, prev_pdf)
        radiance = radiance + beta * le
        alive = front | scatter
        beta = torch.where(alive[:, None], beta, 0.0)
        # -- shade: the new vertex, on a surface (pushed off it) or in the medium
        on_surface = ~scatter
        p_surface = hit.position + spawn_offset(hit.position)[:, None] * hit.normal
        x = torch.where(scatter[:, None], o + torch.where(scatter, s, 0.0)[:, None] * d, p_surface)
        f = torch.where(on_surface[:, None], hit.albedo * _INV_PI, _INV_4PI)  # BSDF or phase
        # -- next-event estimation
        c = layout.light_choice(k)
        lo = layout.light(k)
        nee = next_event(st, x, hit.normal, on_surface, f, None if c is None else u[:, c],
                         u[:, lo:lo + 2], mis=not last)
        radiance = radiance + torch.where(alive[:, None], beta * nee, 0.0)
        if last:
            break
        # -- sample the next direction (BSDF or phase function)
        w = layout.direction(k)
        d, prev_pdf = sample_direction(hit.normal, on_surface, u[:, w:w + 2])
        beta = torch.where(on_surface[:, None], beta * hit.albedo, beta)
        o = x
    return PathResult(radiance, first_albedo, first_normal)


# --------------------------------------------------------------------------------------------
# Guide buffers from one deterministic ray per pixel center


def _center_buffers(st: SceneTensors, cam: CameraFrame, cam_prev: CameraFrame, px: torch.Tensor,
                    py: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``depth [N]``, ``object_id [N]`` (float) and ``motion [N, 2]`` through pixel centers."""
    cx, cy = px.to(torch.float32) + 0.5, py.to(torch.float32) + 0.5
    o, d = generate_rays(cam, cx, cy)
    t, obj = intersect(st, o, d)
    hit = obj >= 0
    i = obj.clamp_min(0)
    p = o + torch.where(hit, t, 0.0)[:, None] * d
    p_prev = p - (st.center[i] - st.sphere_centers_prev[i])  # undo the object's translation
    x_pt, y_pt, front_pt = project(cam_prev, p_prev)
    x_dir, y_dir, front_dir = project(cam_prev, d, directions=True)
    x_prev = torch.where(hit, x_pt, x_dir)
    y_prev = torch.where(hit, y_pt, y_dir)
    valid = torch.where(hit, front_pt, front_dir)
    motion = torch.stack([cx - x_prev, cy - y_prev], dim=-1)
    motion = torch.where(valid[:, None], motion, 0.0)
    depth = torch.where(hit, t, 0.0)
    return depth, obj.to(torch.float32), motion


# --------------------------------------------------------------------------------------------
# The public entry point


def _compile_default() -> bool:
    return os.environ.get("BNERR_COMPILE", "0") not in ("", "0", "false", "False")


def render(scene: Scene, t: int, seeds: torch.Tensor, sampler: Sampler, spp: int, *,
           chunk: int = DEFAULT_CHUNK) -> Frame:
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
            float rounding in the per-pixel sums).

    Returns:
        A :class:`bnerr.frame.Frame` with color, variance (None if spp = 1), albedo, normal,
        depth, motion, object_id and ``timings["render"]`` in ms.

    Raises:
        DtypeError: scene, sampler, seeds or spp of the wrong type or dtype.
        ShapeError: seeds not ``[H, W]`` or empty.
        ValueRangeError: spp or chunk < 1.
    """
    start = time.perf_counter()
    if not isinstance(scene, Scene):
        raise DtypeError(f"scene: expected a renderers Scene, got {type(scene).__name__}")
    if not isinstance(sampler, Sampler):
        raise DtypeError(f"sampler: expected a bnerr.sequences.Sampler, got {type(sampler).__name__}")
    if isinstance(t, bool) or not isinstance(t, int):
        raise DtypeError(f"t: expected an integer frame index, got {type(t).__name__} {t!r}")
    size = check_shape(seeds, "H W", "seeds")
    check_dtype(seeds, torch.int64, "seeds")
    if size["H"] < 1 or size["W"] < 1:
        raise ShapeError(f"seeds: expected H >= 1 and W >= 1, got shape {list(seeds.shape)}")
    check_positive_int(spp, "spp")
    check_positive_int(chunk, "chunk")

    height, width = size["H"], size["W"]
    device = seeds.device
    st = scene_tensors(scene, t, device)
    cam = camera_frame(scene.camera, t, width, height, device)
    layout = scene.layout
    n_pixels = height * width
    seeds_flat = seeds.reshape(-1)
    f32 = dict(dtype=torch.float32, device=device)
    mean = torch.zeros(n_pixels, 3, **f32)
    m2 = torch.zeros(n_pixels, 3, **f32)
    albedo = torch.zeros(n_pixels, 3, **f32)
    normal = torch.zeros(n_pixels, 3, **f32)

    per_chunk = min(spp, chunk)  # sample indices per chunk
    pixels_per_chunk = max(1, chunk // per_chunk)
    for p0 in range(0, n_pixels, pixels_per_chunk):
        p1 = min(n_pixels, p0 + pixels_per_chunk)
        pix = torch.arange(p0, p1, device=device)
        done = 0
        for s0 in range(0, spp, per_chunk):
            ns = min(spp, s0 + per_chunk) - s0
            lane_pix = pix.repeat_interleave(ns)
            lane_index = torch.arange(s0, s0 + ns, device=device).repeat(p1 - p0)
            py, px = lane_pix // width, lane_pix % width
            u = sampler.sample(seeds_flat[lane_pix], lane_index, 0, layout.dimensions,
                               torch.stack([py, px], dim=1))
            paths = trace(st, cam, layout, px, py, u)
            _merge(mean[p0:p1], m2[p0:p1], done, paths.radiance.view(p1 - p0, ns, 3))
            albedo[p0:p1] += paths.albedo.view(p1 - p0, ns, 3).sum(1)
            normal[p0:p1] += paths.normal.view(p1 - p0, ns, 3).sum(1)
            done += ns

    cam_prev = camera_frame(scene.camera, t - 1, width, height, device)
    depth = torch.empty(n_pixels, **f32)
    object_id = torch.empty(n_pixels, **f32)
    motion = torch.empty(n_pixels, 2, **f32)
    for p0 in range(0, n_pixels, chunk):
        p1 = min(n_pixels, p0 + chunk)
        pix = torch.arange(p0, p1, device=device)
        depth[p0:p1], object_id[p0:p1], motion[p0:p1] = _center_buffers(
            st, cam, cam_prev, pix % width, pix // width)

    def image(x: torch.Tensor) -> torch.Tensor:
        return x.reshape(height, width, -1).permute(2, 0, 1).contiguous()

    variance = image(m2 / ((spp - 1) * spp)) if spp > 1 else None
    elapsed = (time.perf_counter() - start) * 1e3
    return Frame(color=image(mean), albedo=image(albedo / spp), normal=image(normal / spp),
                 depth=image(depth), motion=image(motion), object_id=image(object_id),
                 variance=variance, timings={"render": elapsed})


def _merge(mean: torch.Tensor, m2: torch.Tensor, n_a: int, x: torch.Tensor) -> None:
    """Fold samples ``x [P, n, 3]`` into running ``mean``, ``m2 [P, 3]`` over ``n_a`` samples, in place.

    Chan, Golub & LeVeque's pairwise update, so the variance does not suffer the cancellation of
    ``E[x^2] - E[x]^2`` in float32.
    """
    n_b = x.shape[1]
    mean_b = x.mean(1)
    m2_b = ((x - mean_b[:, None]) ** 2).sum(1)
    if n_a == 0:
        mean.copy_(mean_b)
        m2.copy_(m2_b)
        return
    n = n_a + n_b
    delta = mean_b - mean
    mean.add_(delta * (n_b / n))
    m2.add_(m2_b + delta * delta * (n_a * n_b / n))
