"""The per-path physics of the tracer: the wavefront stages, one vertex of all paths, the bounce
loop (pbrt-v4 keeps its ``PathIntegrator`` apart from the driver the same way).

:func:`trace` traces one path per lane. Path ``i`` of pixel ``p`` uses the sampler's values
``X(seeds[p], i, 0 .. D-1)``, in the fixed order documented in :mod:`renderers.layout`: pixel
jitter (2), then per vertex a light position (2) and, except at the last vertex, a direction (2),
with the one-dimensional decisions (free-flight distances in a medium, light choices when there
are several lights) bundled in pairs after every other vertex so that each 2D decision gets an
aligned (2j, 2j+1) pair. Nothing else is random: the integrator never calls ``torch.rand``, so
equal inputs give bit-identical paths and permuting seeds between pixels permutes exactly which
sequence each pixel integrates with.

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

Wavefront stages, one call each per vertex over all of a chunk's paths (pbrt-v4's
``wavefront/integrator.cpp`` names the same ones): :func:`camera_rays`, ``intersect``
(:func:`renderers.geometry.intersect`), :func:`sample_medium`, :func:`emission`,
:func:`next_event`, :func:`sample_direction`, chained by :func:`vertex_step`, whose result is a
:class:`PathVertex` (the loop state by name). Rays and colours are component-major ``[3, N]``
tensors and per-lane scalars ``[N]`` (see :mod:`renderers.geometry` for why). Dead paths keep
their lanes with zero throughput, so every tensor keeps its shape through the bounce loop.
:func:`vertex_step` is what ``torch.compile`` and :mod:`renderers.aot` compile (one fused kernel
per vertex).

Not for: pixels, chunks, threads, sums over samples, guide buffers or compilation (the driver,
:mod:`renderers.tracer`); glossy or refractive materials, Russian roulette, spectral rendering,
or scenes with more than a few dozen primitives (see :mod:`renderers.geometry`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import torch

from bnerr.errors import ValueRangeError
from renderers.camera import CameraFrame, generate_rays
from renderers.geometry import (
    LIGHT_AREA,
    LIGHT_CENTER,
    LIGHT_HALF_U,
    LIGHT_HALF_V,
    LIGHT_NORMAL,
    LIGHT_RADIANCE,
    MEDIUM_SIGMA_T,
    SceneTensors,
    SurfaceHit,
    dot,
    intersect,
    medium_interval,
    medium_of,
    spawn_offset,
    surface_at,
    where,
)
from renderers.layout import Layout

__all__ = [
    "PathResult",
    "PathVertex",
    "VertexStage",
    "camera_rays",
    "emission",
    "next_event",
    "sample_direction",
    "sample_medium",
    "trace",
    "vertex_step",
]

_INV_PI = 1.0 / math.pi
_INV_4PI = 1.0 / (4.0 * math.pi)


# --------------------------------------------------------------------------------------------
# Stages (component-major: vectors are [3, N], scalars per lane [N])


def camera_rays(
    cam: CameraFrame, px: torch.Tensor, py: torch.Tensor, jitter: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Rays ``[3, N]`` through pixel ``(px, py)`` (int64 ``[N]``) at ``jitter [2, N]`` in [0, 1)."""
    return generate_rays(cam, px.to(jitter.dtype) + jitter[0], py.to(jitter.dtype) + jitter[1])


def sample_medium(
    st: SceneTensors, o: torch.Tensor, d: torch.Tensor, t_surface: torch.Tensor, u: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Free-flight sampling on the segment ``o + s d``, ``0 < s < t_surface`` (``[3, N]`` rays).

    Returns ``scatter [N]`` (bool: a scattering event happens before the surface) and its
    distance ``s [N]``. ``u [N]`` in [0, 1).
    """
    t0, t1 = medium_interval(st, o, d)
    t1 = torch.minimum(t1, t_surface)
    medium, _ = medium_of(st)
    s = t0 - torch.log1p(-u) / medium[MEDIUM_SIGMA_T]
    return (t0 < t1) & (s < t1), s


def _transmittance(
    st: SceneTensors, o: torch.Tensor, d: torch.Tensor, dist: torch.Tensor
) -> torch.Tensor:
    """``[N]`` transmittance of the medium along ``o + s d``, ``0 < s < dist``."""
    t0, t1 = medium_interval(st, o, d)
    medium, _ = medium_of(st)
    return torch.exp(-medium[MEDIUM_SIGMA_T] * (torch.minimum(t1, dist) - t0).clamp_min(0.0))


def _power_heuristic(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """``a^2 / (a^2 + b^2)``, 0 where both vanish (Veach 1997, eq. 9.13 with beta = 2)."""
    a2, b2 = a * a, b * b
    s = a2 + b2
    return where(s > 0, a2 / where(s > 0, s, 1.0), 0.0)


def emission(
    hit_emission: torch.Tensor,
    front: torch.Tensor,
    t: torch.Tensor,
    cos_light: torch.Tensor,
    light_pdf_area: torch.Tensor,
    prev_pdf: torch.Tensor | None,
    camera: torch.Tensor | None = None,
) -> torch.Tensor:
    """``[3, N]`` emitted radiance reaching the previous vertex, MIS-weighted against NEE.

    ``prev_pdf [N]`` is the solid-angle density with which the previous vertex sampled this
    segment's direction, or None for camera rays (weight 1). The light-sampling density of the
    same point is ``light_pdf_area * t^2 / cos_light``. ``camera``: a bool tensor that says the
    same as a None ``prev_pdf`` (weight 1 where it holds), for a compiled stage that must not
    change its arguments' types between vertices.
    """
    le = where(front, hit_emission, 0.0)
    if prev_pdf is None:
        return le
    t = where(front, t, 0.0)
    p_light = light_pdf_area * t * t / cos_light.clamp_min(1e-12)
    weight = _power_heuristic(prev_pdf, p_light)
    if camera is not None:
        weight = where(camera, 1.0, weight)
    return le * weight


def _pick_light(st: SceneTensors, u_choice: torch.Tensor | None, n: int) -> torch.Tensor:
    """Per lane, the chosen light's row and radiance, ``[16, N]`` (``[16, 1]`` with one light)."""
    rows = torch.cat([st.lights, st.light_radiance], dim=1)  # [L, 16]
    if u_choice is None:
        return rows[0][:, None]
    j = (u_choice * st.num_lights).floor().clamp_max(st.num_lights - 1)
    picked = rows[0][:, None].expand(-1, n)
    for light in range(1, st.num_lights):
        picked = where(j == light, rows[light][:, None], picked)
    return picked


def next_event(
    st: SceneTensors,
    x: torch.Tensor,
    normal: torch.Tensor,
    on_surface: torch.Tensor | None,
    f: torch.Tensor,
    u_choice: torch.Tensor | None,
    u_light: torch.Tensor,
    mis: bool | torch.Tensor,
) -> torch.Tensor:
    """Next-event estimation: ``[3, N]`` radiance from one light sample, per unit throughput.

    Args:
        x: ``[3, N]`` shading points (surface points already pushed off the surface).
        normal: ``[3, N]`` surface normals (ignored where not ``on_surface``).
        on_surface: ``[N]`` True for a surface vertex, False for a medium vertex; None: all
            on surfaces (a scene without a medium).
        f: ``[3, N]`` BSDF or phase value (albedo / pi, or 1 / (4 pi) in the medium).
        u_choice: ``[N]`` light choice or None (one light); ``u_light [2, N]`` point on it.
        mis: weight against the density of the direction sample (False at the last vertex);
            a bool tensor says the same per lane (for the compiled stage, see :func:`trace`).
    """
    light = _pick_light(st, u_choice, x.shape[1])
    half_u, half_v = light[LIGHT_HALF_U], light[LIGHT_HALF_V]
    y = light[LIGHT_CENTER] + (2.0 * u_light[0] - 1.0) * half_u
    y = y + (2.0 * u_light[1] - 1.0) * half_v
    w = y - x
    dist2 = dot(w, w)
    dist = dist2.sqrt()
    w = w / dist
    cos_light = -dot(w, light[LIGHT_NORMAL])
    cos_surface = dot(w, normal)
    if on_surface is not None:
        cos_surface = where(on_surface, cos_surface, 1.0)
    ok = (cos_light > 0) & (cos_surface > 0)
    # (1/L)(1/A) d^2/cos
    p_light = dist2 / (st.num_lights * cos_light.clamp_min(1e-12) * light[LIGHT_AREA])
    weight = cos_surface / p_light
    if isinstance(mis, torch.Tensor) or mis:
        p_dir = cos_surface * _INV_PI
        if on_surface is not None:
            p_dir = where(on_surface, p_dir, _INV_4PI)
        weighted = weight * _power_heuristic(p_light, p_dir)
        weight = where(mis, weighted, weight) if isinstance(mis, torch.Tensor) else weighted
    t_block, _ = intersect(st, x, w, with_object=False)
    ok = ok & (t_block >= dist * (1.0 - 1e-4))
    if st.medium is not None:
        weight = weight * _transmittance(st, x, w, dist)
    return where(ok, f * light[LIGHT_RADIANCE] * weight, 0.0)


def _orthonormal(n: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Two tangents completing ``n [3, N]`` to an orthonormal basis (Duff et al. 2017, JCGT 6)."""
    nx, ny, nz = n[0], n[1], n[2]
    sign = where(nz >= 0, 1.0, -1.0)
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    t1 = torch.stack([1.0 + sign * nx * nx * a, sign * b, -sign * nx])
    t2 = torch.stack([b, sign + ny * ny * a, -ny])
    return t1, t2


def sample_direction(
    normal: torch.Tensor, on_surface: torch.Tensor | None, u: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Next direction ``[3, N]`` and its solid-angle density ``[N]``; ``u [2, N]`` in [0, 1).

    Surface: cosine-weighted around ``normal`` via the concentric disk mapping (Shirley & Chiu
    1997), density ``cos / pi``. Medium: uniform on the sphere, density ``1 / (4 pi)``.
    ``on_surface [N]`` chooses between them per lane; None: surface everywhere.
    """
    a = 2.0 * u[0] - 1.0
    b = 2.0 * u[1] - 1.0
    use_a = a.abs() > b.abs()
    r = where(use_a, a, b)
    ratio = where(use_a, b / where(a == 0, 1.0, a), a / where(b == 0, 1.0, b))
    phi = where(use_a, (math.pi / 4) * ratio, (math.pi / 2) - (math.pi / 4) * ratio)
    dx, dy = r * torch.cos(phi), r * torch.sin(phi)
    dz = (1.0 - dx * dx - dy * dy).clamp_min(0.0).sqrt()
    t1, t2 = _orthonormal(normal)
    d_surface = dx * t1 + dy * t2 + dz * normal
    if on_surface is None:
        return d_surface, dz * _INV_PI
    # Uniform sphere: z = 1 - 2 u0, phi = 2 pi u1.
    z = 1.0 - 2.0 * u[0]
    s = (1.0 - z * z).clamp_min(0.0).sqrt()
    phi_s = 2.0 * math.pi * u[1]
    d_sphere = torch.stack([s * torch.cos(phi_s), s * torch.sin(phi_s), z])
    d = where(on_surface, d_surface, d_sphere)
    pdf = where(on_surface, dz * _INV_PI, _INV_4PI)
    return d, pdf


# --------------------------------------------------------------------------------------------
# One vertex of all paths, and the bounce loop


def _shading_point(
    o: torch.Tensor,
    d: torch.Tensor,
    hit: SurfaceHit,
    scatter: torch.Tensor | None,
    s: torch.Tensor | None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """The new vertex ``x [3, N]`` (a surface point pushed off the surface, or the scattering
    point ``o + s d`` where ``scatter [N]``; None: no medium) and its BSDF or phase value
    ``f [3, N]``."""
    p_surface = hit.position + spawn_offset(hit.position) * hit.normal
    if scatter is None or s is None:  # both None together (no medium)
        return p_surface, hit.albedo * _INV_PI
    x = where(scatter, o + where(scatter, s, 0.0) * d, p_surface)
    return x, where(~scatter, hit.albedo * _INV_PI, _INV_4PI)


def _medium_event(
    st: SceneTensors,
    o: torch.Tensor,
    d: torch.Tensor,
    t: torch.Tensor,
    u_distance: torch.Tensor | None,
    alive: torch.Tensor,
    beta: torch.Tensor,
) -> tuple[torch.Tensor | None, torch.Tensor | None, torch.Tensor]:
    """A scattering event before the surface at ``t``: ``(scatter [N], s [N], beta)`` with the
    throughput scaled by the medium's albedo where it scatters; ``(None, None, beta)`` without a
    medium (every vertex on a surface, and the selects between the two cases skipped)."""
    if st.medium is None:
        return None, None, beta
    if u_distance is None:
        raise ValueRangeError(
            "vertex_step: u_distance: expected the free-flight sample of a scene with a medium, "
            "got None"
        )
    _, medium_albedo = medium_of(st)
    scatter, s = sample_medium(st, o, d, t, u_distance)
    scatter = scatter & alive
    return scatter, s, where(scatter, beta * medium_albedo[:, None], beta)


class PathVertex(NamedTuple):
    """The bounce loop's state after a vertex, by name (:func:`vertex_step`'s result; a pytree
    node, so ``torch.compile`` and ``torch.export`` pass it through as its eight tensors in this
    order): the next segment and the path's running estimate (component-major), and the
    vertex's surface buffers."""

    o: torch.Tensor  # [3, N] origin of the next segment
    d: torch.Tensor  # [3, N] its unit direction
    beta: torch.Tensor  # [3, N] path throughput
    radiance: torch.Tensor  # [3, N] the estimate so far
    alive: torch.Tensor  # [N] bool, live lanes
    pdf: torch.Tensor | None  # [N] solid-angle density of d (None: camera rays, eager stage)
    albedo: torch.Tensor  # [3, N] this vertex's surface albedo (zero on escape)
    normal: torch.Tensor  # [3, N] and its normal (the first vertex's feed the guide buffers)


def vertex_step(
    st: SceneTensors,
    o: torch.Tensor,
    d: torch.Tensor,
    beta: torch.Tensor,
    radiance: torch.Tensor,
    alive: torch.Tensor,
    prev_pdf: torch.Tensor | None,
    u_distance: torch.Tensor | None,
    u_choice: torch.Tensor | None,
    u_light: torch.Tensor,
    u_direction: torch.Tensor | None,
    ends: tuple[torch.Tensor, torch.Tensor] | None = None,
) -> PathVertex:
    """Trace the segment ``(o, d)`` to the next vertex, shade it and sample the next segment.

    State (``[3, N]`` / ``[N]``): ``beta`` path throughput, ``radiance`` the estimate so far,
    ``alive`` live lanes, ``prev_pdf`` density of the direction that produced this segment (None
    for camera rays). ``u_*`` are this vertex's sampler rows (``u_direction`` None at the last
    vertex, which samples no direction).

    ``ends``: bool scalar tensors ``(first, last)`` that replace the None arguments for the
    compiled stage (one variant per scene; see :func:`trace`): the flags select the camera
    ray's emission weight and the last vertex's unweighted next-event estimate, and the last
    vertex samples a direction nobody reads.

    Returns a :class:`PathVertex`: the next segment, the updated state and the vertex's surface
    albedo and normal.
    """
    # -- intersect: nearest surface along the segment
    t, obj = intersect(st, o, d)
    hit = surface_at(st, o, d, t, obj)
    # -- medium: a scattering event before the surface replaces it (scatter None: no medium,
    # every vertex lies on a surface, and the selects between the two cases are skipped)
    scatter, s, beta = _medium_event(st, o, d, t, u_distance, alive, beta)
    cos_hit = -dot(d, hit.normal)
    front = (obj >= 0) & (cos_hit > 0) & alive
    if scatter is not None:
        front = front & ~scatter
    # -- emission: a light reached by the previous direction sample (MIS against NEE)
    first, last = (None, u_direction is None) if ends is None else ends
    radiance = radiance + beta * emission(
        hit.emission, front, t, cos_hit, hit.light_pdf_area, prev_pdf, first
    )
    alive = front if scatter is None else front | scatter
    beta = where(alive, beta, 0.0)
    # -- shade: the new vertex, on a surface (pushed off it) or in the medium
    on_surface = None if scatter is None else ~scatter
    x, f = _shading_point(o, d, hit, scatter, s)
    # -- next-event estimation (full weight at the last vertex)
    mis = ~last if isinstance(last, torch.Tensor) else not last
    nee = next_event(st, x, hit.normal, on_surface, f, u_choice, u_light, mis=mis)
    radiance = radiance + where(alive, beta * nee, 0.0)
    if u_direction is None:
        return PathVertex(o, d, beta, radiance, alive, prev_pdf, hit.albedo, hit.normal)
    # -- sample the next direction (BSDF or phase function)
    d, pdf = sample_direction(hit.normal, on_surface, u_direction)
    beta = beta * hit.albedo if on_surface is None else where(on_surface, beta * hit.albedo, beta)
    return PathVertex(x, d, beta, radiance, alive, pdf, hit.albedo, hit.normal)


#: What :func:`trace` calls per vertex: :func:`vertex_step` or a compiled version of it (the
#: same arguments, a :class:`PathVertex` back).
VertexStage = Callable[..., PathVertex]


@dataclass
class PathResult:
    """Per path, component-major: ``radiance [3, N]``, first-hit ``albedo``, ``normal [3, N]``."""

    radiance: torch.Tensor
    albedo: torch.Tensor
    normal: torch.Tensor


def trace(
    st: SceneTensors,
    cam: CameraFrame,
    layout: Layout,
    px: torch.Tensor,
    py: torch.Tensor,
    u: torch.Tensor,
    step: VertexStage = vertex_step,
) -> PathResult:
    """Trace one path per lane.

    Args:
        st: the frame's scene tensors; cam: its camera; layout: the dimension layout.
        px, py: ``[N]`` int64 pixel coordinates of each lane.
        u: ``[D, N]`` the lanes' sampler values, one row per dimension (D = layout.dimensions).
        step: :func:`vertex_step` or a compiled version of it (:data:`VertexStage`). A step
            with a true attribute ``uniform`` gets the same argument types at every vertex (see
            ``ends`` in :func:`vertex_step`): one compiled variant per scene instead of three.

    Returns:
        :class:`PathResult`.
    """
    o, d = camera_rays(cam, px, py, u[0:2])
    uniform = getattr(step, "uniform", False)
    alive = torch.ones_like(px, dtype=torch.bool)
    pdf = torch.zeros_like(d[0]) if uniform else None
    # No vertex yet: unit throughput, nothing gathered, no surface buffers (stand-ins, unread).
    path = PathVertex(o, d, torch.ones_like(d), torch.zeros_like(d), alive, pdf, d, d)
    first = path
    # Distinct tensors for the two flags: the same tensor passed twice is a guard of its own.
    firsts, lasts = ([torch.tensor(v, device=d.device) for v in (False, True)] for _ in "fl")

    def row(i: int | None) -> torch.Tensor | None:
        return None if i is None else u[i]

    def pair(i: int | None) -> torch.Tensor | None:
        return None if i is None else u[i : i + 2]

    for k in range(layout.vertices):
        args: list[torch.Tensor | tuple[torch.Tensor, torch.Tensor] | None]
        args = [row(layout.distance(k)), row(layout.light_choice(k)), pair(layout.light(k))]
        o = path.o
        if uniform:  # contiguous o, a stand-in direction sample at the last vertex, the flags
            o, last = o.contiguous(), k == layout.vertices - 1
            args += [pair(layout.light(k) if last else layout.direction(k))]
            args += [(firsts[k == 0], lasts[last])]
        else:
            args += [pair(layout.direction(k))]
        state = (o, path.d, path.beta, path.radiance, path.alive, path.pdf)
        path = step(st, *state, *args)
        if k == 0:
            first = path
    return PathResult(path.radiance, first.albedo, first.normal)
