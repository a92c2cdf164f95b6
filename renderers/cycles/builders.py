"""Scenes built in Blender by code (no third-party assets), for bnerr's Cycles back-end.

Runs under the ``bpy`` Python with :mod:`worker` (standard library and ``bpy`` only). A *recipe*
is plain JSON made by :mod:`renderers.cycles.scenes`: ``{"kind": NAME, "frames": N, ...}`` where
``kind`` is one of :data:`KINDS` or ``"shapes"`` (bnerr's own scene description converted to
Blender's axes: spheres, rectangles with constant or checker albedo, rectangle lights, a camera
pose per frame). Every scene has its camera keyframed on frames 1..N, so that Cycles' vector pass
gives the camera's motion and a saved ``.blend`` carries the animation.

The three scenes of the ``cycles`` suite (:data:`KINDS`), each with camera motion:

- ``interior``: a room lit through one window by a sun and the sky (mostly indirect light);
- ``product``: a metal sphere, a glossy Suzanne and a glossy ring on a backdrop under two small,
  bright area lights (glossy paths and small highlights);
- ``outdoor``: a sun and sky over a field of 3,000 thin grass blades and a fence of thin posts
  (sub-pixel geometry).
"""

from __future__ import annotations

import math
import random

import bpy
from mathutils import Matrix, Vector


def _material(name: str, color, *, metallic=0.0, roughness=0.5, emission=None):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    if emission is not None:
        bsdf.inputs["Emission Color"].default_value = (*emission, 1.0)
        bsdf.inputs["Emission Strength"].default_value = 1.0
    return mat


def _diffuse(name: str, color):
    """A Lambertian material (Diffuse BSDF), as bnerr's tracer's."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*color, 1.0)
    tree.links.new(diffuse.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat, diffuse


def _checker(name: str, color0, color1, cells_u: int, cells_v: int):
    """bnerr's checker: cell (iu, iv) of a cells_u x cells_v grid in UV space, nearest texels."""
    mat, diffuse = _diffuse(name, color0)
    image = bpy.data.images.new(name, cells_u, cells_v, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"  # before the pixels: it regenerates the image
    pixels = []
    for iv in range(cells_v):
        for iu in range(cells_u):
            pixels += [*(color1 if (iu + iv) % 2 else color0), 1.0]
    image.pixels = pixels
    image.pack()  # Cycles reads a packed image (a generated one's pixels stay in the viewer)
    texture = mat.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.interpolation = "Closest"
    mat.node_tree.links.new(texture.outputs["Color"], diffuse.inputs["Color"])
    return mat


def _front_emission(name: str, radiance):
    """Emission of ``radiance`` on the front side only (black from behind), as bnerr's lights."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    front = tree.nodes.new("ShaderNodeEmission")
    front.inputs["Color"].default_value = (*radiance, 1.0)
    back = tree.nodes.new("ShaderNodeEmission")
    back.inputs["Strength"].default_value = 0.0
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
    tree.links.new(front.outputs[0], mix.inputs[1])
    tree.links.new(back.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def _mesh(name: str, vertices, faces, material, uvs=None, smooth=False):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in vertices], [], [tuple(f) for f in faces])
    if uvs is not None:
        layer = mesh.uv_layers.new(name="UVMap")
        for loop in mesh.loops:
            layer.data[loop.index].uv = uvs[loop.vertex_index]
    mesh.materials.append(material)
    for polygon in mesh.polygons:
        polygon.use_smooth = smooth
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _rectangle(name: str, center, u, v, material):
    """bnerr's rectangle ``center + a u + b v`` (a, b in [-1, 1]), normal along u x v."""
    c, u, v = Vector(center), Vector(u), Vector(v)
    corners = [c - u - v, c + u - v, c + u + v, c - u + v]
    uvs = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
    return _mesh(name, corners, [(0, 1, 2, 3)], material, uvs)


def _sphere(name: str, center, radius: float, material):
    bpy.ops.mesh.primitive_uv_sphere_add(
        segments=96, ring_count=48, radius=radius, location=tuple(center)
    )
    obj = bpy.context.object
    obj.name = name
    obj.data.materials.append(material)
    bpy.ops.object.shade_smooth()
    return obj


def _box(name: str, center, size, material):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=tuple(center))
    obj = bpy.context.object
    obj.name = name
    obj.scale = tuple(size)
    obj.data.materials.append(material)
    return obj


def _camera(poses, fov_x_degrees: float, frame_start: int = 1):
    """A pinhole camera keyframed at ``look_at(origin, target, up)`` on frames 1, 2, ...
    (Blender's axes), with the horizontal field of view ``fov_x_degrees``."""
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "HORIZONTAL"
    data.angle = math.radians(fov_x_degrees)
    data.clip_start = 0.01
    obj = bpy.data.objects.new("camera", data)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = obj
    previous = None
    for k, (origin, target, up) in enumerate(poses):
        forward = (Vector(target) - Vector(origin)).normalized()
        right = forward.cross(Vector(up)).normalized()
        camera_up = right.cross(forward)
        rotation = Matrix((right, camera_up, -forward)).transposed()
        euler = rotation.to_euler("XYZ", previous) if previous else rotation.to_euler("XYZ")
        previous = euler
        obj.location = Vector(origin)
        obj.rotation_euler = euler
        obj.keyframe_insert("location", frame=frame_start + k)
        obj.keyframe_insert("rotation_euler", frame=frame_start + k)
    for curve in obj.animation_data.action.fcurves:
        for point in curve.keyframe_points:
            point.interpolation = "LINEAR"
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = frame_start, frame_start + len(poses) - 1
    return obj


def _world(color, strength: float) -> None:
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*color, 1.0)
    background.inputs["Strength"].default_value = strength
    bpy.context.scene.world = world


def _sun(strength: float, direction_degrees, angle_degrees: float = 0.53):
    data = bpy.data.lights.new("sun", "SUN")
    data.energy = strength
    data.angle = math.radians(angle_degrees)
    obj = bpy.data.objects.new("sun", data)
    obj.rotation_euler = tuple(math.radians(a) for a in direction_degrees)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _area(name: str, location, size: float, power: float, rotation_degrees):
    data = bpy.data.lights.new(name, "AREA")
    data.energy = power
    data.size = size
    obj = bpy.data.objects.new(name, data)
    obj.location = tuple(location)
    obj.rotation_euler = tuple(math.radians(a) for a in rotation_degrees)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def _orbit(center, radius, height, start_deg, step_deg, frames, target):
    poses = []
    for t in range(frames):
        a = math.radians(start_deg + step_deg * t)
        origin = (center[0] + radius * math.sin(a), center[1] - radius * math.cos(a), height)
        poses.append((origin, target, (0.0, 0.0, 1.0)))
    return poses


def interior(frames: int) -> None:
    """A 6 x 6 x 3 m room lit through a window in its back wall by a low sun and the sky."""
    wall = _material("plaster", (0.8, 0.78, 0.72), roughness=0.9)
    floor = _material("wood", (0.45, 0.3, 0.18), roughness=0.6)
    _box("floor", (0, 0, -0.05), (6.2, 6.2, 0.1), floor)
    _box("ceiling", (0, 0, 3.05), (6.2, 6.2, 0.1), wall)
    _box("wall_left", (-3.05, 0, 1.5), (0.1, 6.2, 3.0), wall)
    _box("wall_right", (3.05, 0, 1.5), (0.1, 6.2, 3.0), wall)
    _box("wall_front", (0, -3.05, 1.5), (6.2, 0.1, 3.0), wall)
    # the back wall (y = 3) around a 2 x 1.4 m window from x -1..1, z 0.9..2.3
    _box("wall_back_left", (-2.0, 3.05, 1.5), (2.0, 0.1, 3.0), wall)
    _box("wall_back_right", (2.0, 3.05, 1.5), (2.0, 0.1, 3.0), wall)
    _box("wall_back_low", (0, 3.05, 0.45), (2.0, 0.1, 0.9), wall)
    _box("wall_back_high", (0, 3.05, 2.65), (2.0, 0.1, 0.7), wall)
    table = _material("table", (0.6, 0.15, 0.1), roughness=0.4)
    _box("table_top", (0.3, 0.8, 0.75), (1.6, 0.9, 0.06), table)
    for i, (x, y) in enumerate(((-0.4, 0.45), (1.0, 0.45), (-0.4, 1.15), (1.0, 1.15))):
        _box(f"table_leg_{i}", (x, y, 0.36), (0.06, 0.06, 0.72), table)
    _sphere("vase", (0.1, 0.8, 0.98), 0.2, _material("vase", (0.2, 0.35, 0.7), roughness=0.3))
    _box("sofa", (-1.8, -0.6, 0.35), (0.9, 2.2, 0.7), _material("sofa", (0.3, 0.5, 0.3)))
    _world((0.45, 0.6, 1.0), 1.5)
    _sun(4.0, (60.0, 0.0, 170.0))
    poses = [
        ((1.6 - 0.02 * t, -2.6, 1.5), (-0.2 + 0.01 * t, 1.5, 1.2), (0.0, 0.0, 1.0))
        for t in range(frames)
    ]
    _camera(poses, 70.0)


def product(frames: int) -> None:
    """A metal sphere, a glossy Suzanne and a glossy ring on a backdrop, two small bright lights."""
    _rectangle("backdrop_floor", (0, 0, 0), (4, 0, 0), (0, 4, 0), _material("paper", (0.8,) * 3))
    _rectangle("backdrop_wall", (0, 3, 2), (4, 0, 0), (0, 0, 2), _material("paper2", (0.8,) * 3))
    _sphere(
        "chrome",
        (-0.9, 0.3, 0.5),
        0.5,
        _material("chrome", (0.9,) * 3, metallic=1.0, roughness=0.05),
    )
    bpy.ops.mesh.primitive_monkey_add(size=0.9, location=(0.5, 0.2, 0.5), rotation=(0.3, 0, 0.4))
    monkey = bpy.context.object
    monkey.name = "suzanne"
    monkey.data.materials.append(_material("lacquer", (0.7, 0.05, 0.05), roughness=0.15))
    modifier = monkey.modifiers.new("subdivision", "SUBSURF")
    modifier.levels = modifier.render_levels = 2
    bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_torus_add(
        location=(0.0, -0.6, 0.12), major_radius=0.35, minor_radius=0.08
    )
    ring = bpy.context.object
    ring.name = "ring"
    ring.data.materials.append(_material("gold", (1.0, 0.75, 0.3), metallic=1.0, roughness=0.2))
    bpy.ops.object.shade_smooth()
    _area("key", (2.0, -2.0, 3.0), 0.25, 300.0, (45.0, 0.0, 45.0))
    _area("rim", (-2.5, 1.5, 2.5), 0.15, 150.0, (-45.0, 0.0, -60.0))
    _world((0.05, 0.05, 0.06), 1.0)
    _camera(_orbit((0, 0, 0), 4.0, 1.8, -20.0, 0.6, frames, (0.0, 0.0, 0.45)), 40.0)


def outdoor(frames: int) -> None:
    """A sun and sky over 3,000 thin grass blades and a fence of thin posts."""
    rng = random.Random(7)
    _rectangle("ground", (0, 0, 0), (30, 0, 0), (0, 30, 0), _material("soil", (0.3, 0.22, 0.12)))
    vertices, faces = [], []
    for _ in range(3000):
        x, y = rng.uniform(-4, 4), rng.uniform(-2, 6)
        height, width, lean = (
            rng.uniform(0.15, 0.45),
            rng.uniform(0.004, 0.012),
            rng.uniform(0, 6.3),
        )
        tip = (x + 0.1 * height * math.cos(lean), y + 0.1 * height * math.sin(lean), height)
        base = len(vertices)
        vertices += [(x - width, y, 0.0), (x + width, y, 0.0), tip]
        faces.append((base, base + 1, base + 2))
    _mesh("grass", vertices, faces, _material("grass", (0.15, 0.45, 0.08), roughness=0.7))
    wood = _material("fence", (0.55, 0.45, 0.35), roughness=0.8)
    for i in range(25):
        bpy.ops.mesh.primitive_cylinder_add(
            radius=0.025, depth=1.2, location=(-3 + 0.25 * i, 3.0, 0.6)
        )
        bpy.context.object.name = f"post_{i:02d}"
        bpy.context.object.data.materials.append(wood)
    for k, z in enumerate((0.5, 1.0)):
        _box(f"rail_{k}", (0.0, 3.0, z), (6.2, 0.03, 0.03), wood)
    _world((0.5, 0.7, 1.0), 1.0)
    _sun(5.0, (50.0, 0.0, 30.0))
    poses = [
        ((-0.5 + 0.015 * t, -2.5 + 0.02 * t, 0.9), (0.2 + 0.015 * t, 3.0, 0.5), (0.0, 0.0, 1.0))
        for t in range(frames)
    ]
    _camera(poses, 60.0)


def shapes(recipe: dict) -> None:
    """bnerr's own scene description (already in Blender's axes): ``spheres``, ``rectangles``
    (``albedo`` a colour or ``checker``), ``lights`` (front-emitting rectangles), ``poses`` per
    frame and ``fov``; a black world; Cycles' box pixel filter and bounce count as bnerr's."""
    for s in recipe["spheres"]:
        mat, _ = _diffuse(s["name"], s["albedo"])
        _sphere(s["name"], s["center"], s["radius"], mat)
    for r in recipe["rectangles"]:
        if "checker" in r:
            c = r["checker"]
            mat = _checker(r["name"], c["color0"], c["color1"], c["cells_u"], c["cells_v"])
        elif "radiance" in r:
            mat = _front_emission(r["name"], r["radiance"])
        else:
            mat, _ = _diffuse(r["name"], r["albedo"])
        _rectangle(r["name"], r["center"], r["u"], r["v"], mat)
    _world((0.0, 0.0, 0.0), 0.0)
    _camera(recipe["poses"], recipe["fov"])
    cycles = bpy.context.scene.cycles
    cycles.max_bounces = recipe["max_bounces"]
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    cycles.sample_clamp_indirect = 0.0
    cycles.caustics_reflective = cycles.caustics_refractive = False


#: The scenes built by code for the ``cycles`` suite, by recipe kind.
KINDS = {"interior": interior, "product": product, "outdoor": outdoor}


def build(recipe: dict) -> None:
    """Build ``recipe`` into the (empty) current scene and set Cycles as its engine."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    kind = recipe["kind"]
    if kind == "shapes":
        shapes(recipe)
    elif kind in KINDS:
        KINDS[kind](int(recipe["frames"]))
    else:
        raise ValueError(f"recipe kind: expected shapes or one of {sorted(KINDS)}, got {kind!r}")
