"""One frame of a scene as tensors, and the vectorized ray queries the tracer's stages use.

:func:`scene_tensors` resolves a :class:`~renderers.scene.Scene` at frame t into a
:class:`SceneTensors`: per primitive type the parameters stacked into small tensors (``S`` spheres,
``R`` rectangles, ``B`` boxes), plus per-object tables indexed by object id ``P = S + R + B``
(the shape's index in ``scene.shapes``). Rays are flat tensors ``origin [N, 3]``,
``direction [N, 3]`` (unit length). Every query tests all rays against all primitives of a type
at once (an ``[N, K]`` tensor of hit distances): the scenes have a handful of primitives, for
which this beats any acceleration structure in a tensor framework.

Intersection tests:
- spheres: the quadratic with ``b = (o - c) . d``, nearer root first;
- rectangles: plane distance, then the local coordinates ``a``, ``b`` in [-1, 1] along the dual
  basis of the half edges (exact for parallelograms);
- boxes: the slab test in the box's local frame (the inverse affine of ``to_world``), as for an
  oriented bounding box (pbrt-v4, ``Bounds3::IntersectP``, after the transform).

Hits need ``t > 0``; callers offset ray origins off surfaces (``spawn_offset``) instead of using a
``t_min``, like Mitsuba's ``spawn_ray``.

Not for: more than a few dozen primitives (the cost is linear in their number), or meshes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from renderers.scene import Box, Rectangle, Scene, Sphere

__all__ = [
    "SceneTensors",
    "SurfaceHit",
    "intersect",
    "medium_interval",
    "scene_tensors",
    "spawn_offset",
    "surface_at",
]

KIND_SPHERE, KIND_RECTANGLE, KIND_BOX = 0, 1, 2


@dataclass
class SceneTensors:
    """Tensors of one frame, float32 / int64 on one device (see the module docstring for sizes).

    Per type: ``sph_center [S, 3]``, ``sph_radius2 [S]``; ``rect_basis [3R, 3]`` (rows: R
    normals, R dual vectors of u, R dual vectors of v) and ``rect_offset [3R]`` (the same rows
    dotted with each center); ``box_linv [3B, 3]`` (the B inverse linear parts stacked),
    ``box_loff [3B]`` (``-linv @ translation``). ``columns [S + R + B]`` maps the column of a
    concatenated ``[N, S + R + B]`` hit tensor to its object id.

    Per object id (``[P, ...]``): ``kind`` (0 sphere, 1 rectangle, 2 box), ``albedo [P, 3]``,
    ``emission [P, 3]`` (zero if not a light), ``light_pdf_area [P]`` (1 / (area * lights) for a
    light, else 0), ``center [P, 3]`` (sphere or rectangle center), ``inv_radius [P]``,
    ``normal [P, 3]`` (rectangle), ``dual_u``, ``dual_v [P, 3]`` (rectangle), ``linv [P, 3, 3]``,
    ``loff [P, 3]`` (box); textures: ``tex_offset``, ``tex_nu``, ``tex_nv [P]`` int64 into
    ``texels [T, 3]``, ``textured [P]`` bool.

    Lights (``L``): ``light_center``, ``light_u``, ``light_v``, ``light_normal [L, 3]``,
    ``light_radiance [L, 3]``, ``light_area [L]``. Medium: ``medium_min``, ``medium_max [3]``,
    ``sigma_t`` (float), ``medium_albedo [3]``, or None.
    """

    sph_center: torch.Tensor
    sph_radius2: torch.Tensor
    rect_basis: torch.Tensor
    rect_offset: torch.Tensor
    box_linv: torch.Tensor
    box_loff: torch.Tensor
    columns: torch.Tensor
    kind: torch.Tensor
    albedo: torch.Tensor
    emission: torch.Tensor
    light_pdf_area: torch.Tensor
    center: torch.Tensor
    inv_radius: torch.Tensor
    normal: torch.Tensor
    dual_u: torch.Tensor
    dual_v: torch.Tensor
    linv: torch.Tensor
    loff: torch.Tensor
    tex_offset: torch.Tensor
    tex_nu: torch.Tensor
    tex_nv: torch.Tensor
    texels: torch.Tensor
    textured: torch.Tensor
    light_center: torch.Tensor
    light_u: torch.Tensor
    light_v: torch.Tensor
    light_normal: torch.Tensor
    light_radiance: torch.Tensor
    light_area: torch.Tensor
    medium_min: torch.Tensor | None
    medium_max: torch.Tensor | None
    sigma_t: float
    medium_albedo: torch.Tensor | None
    sphere_centers_prev: torch.Tensor  # [P, 3] sphere centers at t - 1 (object motion), else center

    @property
    def num_lights(self) -> int:
        return self.light_area.shape[0]


def _rect_frame(shape: Rectangle) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Center, unit normal and the dual vectors of the half edges (a = (p - c) . dual_u)."""
    c, u, v = (np.asarray(x, dtype=np.float64) for x in (shape.center, shape.u, shape.v))
    n = np.cross(u, v)
    n /= np.linalg.norm(n)
    basis = np.stack([u, v, n], axis=1)  # columns u, v, n
    dual = np.linalg.inv(basis)  # rows: dual_u, dual_v, n
    return c, n, dual[0], dual[1]


def scene_tensors(scene: Scene, t: int, device: torch.device | str = "cpu") -> SceneTensors:
    """Resolve ``scene`` at frame ``t`` into :class:`SceneTensors` on ``device``."""
    P = len(scene.shapes)
    kind = np.zeros(P, np.int64)
    albedo = np.zeros((P, 3))
    emission = np.zeros((P, 3))
    center = np.zeros((P, 3))
    center_prev = np.zeros((P, 3))
    inv_radius = np.zeros(P)
    normal = np.zeros((P, 3))
    dual_u = np.zeros((P, 3))
    dual_v = np.zeros((P, 3))
    linv = np.tile(np.eye(3), (P, 1, 1))
    loff = np.zeros((P, 3))
    tex_offset = np.zeros(P, np.int64)
    tex_nu = np.ones(P, np.int64)
    tex_nv = np.ones(P, np.int64)
    textured = np.zeros(P, bool)
    texels = [np.zeros((1, 3), np.float32)]  # row 0: a dummy texel for untextured objects
    n_texels = 1
    spheres, rects, boxes = [], [], []

    for i, shape in enumerate(scene.shapes):
        material = shape.material
        if material.textured:
            tex = material.albedo.texels()
            tex_offset[i], tex_nv[i], tex_nu[i] = n_texels, tex.shape[0], tex.shape[1]
            textured[i] = True
            texels.append(tex.reshape(-1, 3))
            n_texels += tex.shape[0] * tex.shape[1]
            albedo[i] = tex.reshape(-1, 3).mean(0)
        else:
            albedo[i] = material.albedo
        if isinstance(shape, Sphere):
            kind[i] = KIND_SPHERE
            center[i] = shape.center.at(t)
            center_prev[i] = shape.center.at(t - 1)
            inv_radius[i] = 1.0 / shape.radius
            spheres.append(i)
        elif isinstance(shape, Rectangle):
            kind[i] = KIND_RECTANGLE
            center[i], normal[i], dual_u[i], dual_v[i] = _rect_frame(shape)
            center_prev[i] = center[i]
            if shape.emission is not None:
                emission[i] = shape.emission
            rects.append(i)
        else:
            kind[i] = KIND_BOX
            m = np.asarray(shape.to_world, dtype=np.float64)
            linv[i] = np.linalg.inv(m[:, :3])
            loff[i] = -linv[i] @ m[:, 3]
            center[i] = center_prev[i] = m[:, 3]
            boxes.append(i)

    lights = list(scene.lights)
    light_area = np.array([scene.shapes[i].area for i in lights])
    light_pdf_area = np.zeros(P)
    light_pdf_area[lights] = 1.0 / (light_area * len(lights))

    f32 = dict(dtype=torch.float32, device=device)
    i64 = dict(dtype=torch.int64, device=device)

    def f(x) -> torch.Tensor:
        return torch.tensor(np.asarray(x, dtype=np.float64), **f32)

    sph = np.asarray(spheres, np.int64)
    rec = np.asarray(rects, np.int64)
    box = np.asarray(boxes, np.int64)
    rect_basis = np.concatenate([normal[rec], dual_u[rec], dual_v[rec]]).reshape(-1, 3)
    rect_offset = (rect_basis * np.concatenate([center[rec]] * 3).reshape(-1, 3)).sum(-1)
    medium = scene.medium
    return SceneTensors(
        sph_center=f(center[sph].reshape(-1, 3)),
        sph_radius2=f((1.0 / inv_radius[sph]) ** 2 if len(sph) else np.zeros(0)),
        rect_basis=f(rect_basis.reshape(-1, 3)),
        rect_offset=f(rect_offset),
        box_linv=f(linv[box].reshape(-1, 3)),
        box_loff=f(loff[box].reshape(-1)),
        columns=torch.tensor(np.concatenate([sph, rec, box]), **i64),
        kind=torch.tensor(kind, **i64),
        albedo=f(albedo),
        emission=f(emission),
        light_pdf_area=f(light_pdf_area),
        center=f(center),
        inv_radius=f(inv_radius),
        normal=f(normal),
        dual_u=f(dual_u),
        dual_v=f(dual_v),
        linv=f(linv),
        loff=f(loff),
        tex_offset=torch.tensor(tex_offset, **i64),
        tex_nu=torch.tensor(tex_nu, **i64),
        tex_nv=torch.tensor(tex_nv, **i64),
        texels=torch.tensor(np.concatenate(texels), **f32),
        textured=torch.tensor(textured, dtype=torch.bool, device=device),
        light_center=f(center[lights]),
        light_u=f([scene.shapes[i].u for i in lights]),
        light_v=f([scene.shapes[i].v for i in lights]),
        light_normal=f(normal[lights]),
        light_radiance=f(emission[lights]),
        light_area=f(light_area),
        medium_min=f(medium.bounds_min) if medium else None,
        medium_max=f(medium.bounds_max) if medium else None,
        sigma_t=float(medium.sigma_t) if medium else 0.0,
        medium_albedo=f(medium.albedo) if medium else None,
        sphere_centers_prev=f(center_prev),
    )


# --------------------------------------------------------------------------------------------
# Ray queries


def _hits_spheres(st: SceneTensors, o: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """``[N, S]`` distance to each sphere (inf: miss)."""
    oc = o[:, None, :] - st.sph_center  # [N, S, 3]
    b = (oc * d[:, None, :]).sum(-1)
    c = (oc * oc).sum(-1) - st.sph_radius2
    disc = b * b - c
    root = disc.clamp_min(0.0).sqrt()
    near, far = -b - root, -b + root
    t = torch.where(near > 0, near, far)
    return torch.where((disc >= 0) & (t > 0), t, torch.full_like(t, torch.inf))


def _hits_rects(st: SceneTensors, o: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """``[N, R]`` distance to each rectangle (inf: miss)."""
    R = st.rect_offset.shape[0] // 3
    op = o @ st.rect_basis.T - st.rect_offset  # [N, 3R]: (o - c) . (n | dual_u | dual_v)
    dp = d @ st.rect_basis.T
    t = -op[:, :R] / dp[:, :R]
    a = op[:, R:2 * R] + t * dp[:, R:2 * R]
    b = op[:, 2 * R:] + t * dp[:, 2 * R:]
    hit = (t > 0) & (a.abs() <= 1) & (b.abs() <= 1)
    return torch.where(hit, t, torch.full_like(t, torch.inf))


def _hits_boxes(st: SceneTensors, o: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """``[N, B]`` distance to each box (entry, or exit from inside; inf: miss)."""
    N = o.shape[0]
    ol = (o @ st.box_linv.T + st.box_loff).view(N, -1, 3)  # [N, B, 3] origin in box space
    inv = 1.0 / (d @ st.box_linv.T).view(N, -1, 3)
    ta = (-1.0 - ol) * inv
    tb = (1.0 - ol) * inv
    t_near = torch.minimum(ta, tb).amax(-1)
    t_far = torch.maximum(ta, tb).amin(-1)
    t = torch.where(t_near > 0, t_near, t_far)
    return torch.where((t_near <= t_far) & (t > 0), t, torch.full_like(t, torch.inf))


def intersect(st: SceneTensors, o: torch.Tensor, d: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Nearest hit of each ray.

    Args:
        st: the frame's tensors.
        o, d: ``[N, 3]`` ray origins and unit directions.

    Returns:
        ``t [N]`` (inf where the ray escapes) and ``obj [N]`` int64 object id (-1 where it escapes).
    """
    parts = []
    if st.sph_center.shape[0]:
        parts.append(_hits_spheres(st, o, d))
    if st.rect_offset.shape[0]:
        parts.append(_hits_rects(st, o, d))
    if st.box_loff.shape[0]:
        parts.append(_hits_boxes(st, o, d))
    t, col = torch.cat(parts, dim=1).min(dim=1)
    obj = torch.where(torch.isinf(t), -1, st.columns[col])
    return t, obj


@dataclass
class SurfaceHit:
    """What the shading stages need at a hit: ``position``, ``normal`` (unit, the shape's front
    side), ``albedo``, ``emission`` (all ``[N, 3]``) and ``light_pdf_area [N]``. Rows of rays that
    escaped hold zeros."""

    position: torch.Tensor
    normal: torch.Tensor
    albedo: torch.Tensor
    emission: torch.Tensor
    light_pdf_area: torch.Tensor


def surface_at(st: SceneTensors, o: torch.Tensor, d: torch.Tensor, t: torch.Tensor,
               obj: torch.Tensor) -> SurfaceHit:
    """Position, normal and material of the hits ``(t, obj)`` of :func:`intersect`."""
    hit = obj >= 0
    i = obj.clamp_min(0)
    p = o + torch.where(hit, t, 0.0)[:, None] * d
    kind = st.kind[i]
    # Sphere: radial; rectangle: constant; box: the face whose local coordinate is +-1.
    n_sphere = (p - st.center[i]) * st.inv_radius[i, None]
    linv = st.linv[i]  # [N, 3, 3]
    local = (linv @ p[:, :, None]).squeeze(-1) + st.loff[i]
    axis = local.abs().argmax(dim=-1, keepdim=True)
    sign = torch.sign(local.gather(1, axis))
    n_box = linv.gather(1, axis[:, :, None].expand(-1, 1, 3)).squeeze(1) * sign
    n_box = n_box / n_box.norm(dim=-1, keepdim=True)
    normal = torch.where((kind == KIND_SPHERE)[:, None], n_sphere,
                         torch.where((kind == KIND_RECTANGLE)[:, None], st.normal[i], n_box))
    albedo = st.albedo[i]
    if bool(st.textured.any()):
        albedo = torch.where(st.textured[i, None], _texture(st, p, i), albedo)
    zero = torch.zeros_like(p)
    return SurfaceHit(
        position=torch.where(hit[:, None], p, zero),
        normal=torch.where(hit[:, None], normal, zero),
        albedo=torch.where(hit[:, None], albedo, zero),
        emission=torch.where(hit[:, None], st.emission[i], zero),
        light_pdf_area=torch.where(hit, st.light_pdf_area[i], 0.0),
    )


def _texture(st: SceneTensors, p: torch.Tensor, i: torch.Tensor) -> torch.Tensor:
    """Cell-texture albedo at rectangle points ``p [N, 3]`` of objects ``i [N]`` (nearest cell)."""
    rel = p - st.center[i]
    u = ((rel * st.dual_u[i]).sum(-1) + 1.0) * 0.5
    v = ((rel * st.dual_v[i]).sum(-1) + 1.0) * 0.5
    nu, nv = st.tex_nu[i], st.tex_nv[i]
    iu = torch.minimum(torch.floor(u * nu).long().clamp_min(0), nu - 1)
    iv = torch.minimum(torch.floor(v * nv).long().clamp_min(0), nv - 1)
    return st.texels[st.tex_offset[i] + iv * nu + iu]


def spawn_offset(p: torch.Tensor) -> torch.Tensor:
    """``[N]`` distance to push a new ray's origin off the surface at ``p`` (relative epsilon)."""
    return 1e-4 * (1.0 + p.abs().amax(dim=-1))


def medium_interval(st: SceneTensors, o: torch.Tensor, d: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``[N]`` entry and exit distances of the rays in the medium box (entry >= 0; empty if >= exit)."""
    inv = 1.0 / d
    ta = (st.medium_min - o) * inv
    tb = (st.medium_max - o) * inv
    t0 = torch.minimum(ta, tb).amax(-1).clamp_min(0.0)
    t1 = torch.maximum(ta, tb).amin(-1)
    return t0, t1
