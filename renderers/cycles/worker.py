"""The Blender side of bnerr's Cycles back-end: one long-lived process that holds one scene.

This file runs under the Python that has ``bpy`` (Blender as a module), not under bnerr's own:
``bpy`` pins numpy below 2 and bnerr needs numpy 2, so the two cannot share an environment
(``make cycles`` builds ``.venv-cycles`` for it). It imports only the standard library, ``bpy``
and :mod:`builders` beside it; :class:`renderers.cycles.session.CyclesSession` starts it and
speaks to it in JSON lines:

- ``{"op": "open", "blend": PATH}`` opens a ``.blend`` file; ``{"op": "build", "recipe": {...}}``
  builds a scene by code (:mod:`builders`); either answers ``{"ok": true, "info": {...}}``: the
  Blender version, the camera, the frame range, the patterns this Blender has and every setting
  of the file that bnerr's renders will override (``settings``). ``{"op": "save", "blend": PATH}``
  writes the scene held to a ``.blend`` file.
- ``{"op": "render", ...}`` renders one frame (:func:`render`) into a multilayer OpenEXR file and
  answers ``{"ok": true, "render_s": ..., "wall_s": ...}``.
- ``{"op": "quit"}`` ends the process.

A failure answers ``{"ok": false, "error": "<one line>"}`` and the process goes on. Blender's own
progress lines go to stderr: the protocol has stdout to itself (file descriptor 1 is pointed at
stderr once the protocol's copy of it is taken).
"""

from __future__ import annotations

import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bpy
import builders

#: The settings bnerr takes over in every render, recorded from the file before it changes them.
OVERRIDDEN = (
    "samples",
    "seed",
    "use_animated_seed",
    "sampling_pattern",
    "use_adaptive_sampling",
    "adaptive_threshold",
    "scrambling_distance",
    "auto_scrambling_distance",
    "use_denoising",
    "denoiser",
    "denoising_input_passes",
    "denoising_prefilter",
    "device",
)
#: Settings that change the image and that bnerr records but leaves as the file has them.
RECORDED = (
    "max_bounces",
    "diffuse_bounces",
    "glossy_bounces",
    "transmission_bounces",
    "volume_bounces",
    "transparent_max_bounces",
    "sample_clamp_direct",
    "sample_clamp_indirect",
    "caustics_reflective",
    "caustics_refractive",
    "blur_glossy",
    "use_light_tree",
    "light_sampling_threshold",
    "pixel_filter_type",
    "filter_width",
    "film_exposure",
)


def _patterns() -> list[str]:
    """The sampling patterns this Blender accepts (its enum, read by provoking its refusal)."""
    cycles = bpy.context.scene.cycles
    try:
        cycles.sampling_pattern = "__none__"
    except TypeError as err:  # "enum "__none__" not found in ('AUTOMATIC', ...)"
        text = str(err)
        return [p.strip(" '\"") for p in text[text.rfind("(") + 1 : text.rfind(")")].split(",")]
    return []


def _settings(scene: bpy.types.Scene) -> dict:
    cycles = scene.cycles
    found = {}
    for name in OVERRIDDEN + RECORDED:
        value = getattr(cycles, name, None)
        found[name] = (
            value if isinstance(value, (bool, int, float, str)) or value is None else str(value)
        )
    found["motion_blur"] = scene.render.use_motion_blur
    found["resolution_percentage"] = scene.render.resolution_percentage
    found["use_compositing"] = scene.render.use_compositing
    found["view_transform"] = scene.view_settings.view_transform
    return found


def _info() -> dict:
    scene = bpy.context.scene
    if scene.camera is None:
        raise ValueError("expected a scene with an active camera, got none")
    return {
        "blender": bpy.app.version_string,
        "engine": scene.render.engine,
        "camera": scene.camera.name,
        "frame_start": scene.frame_start,
        "frame_end": scene.frame_end,
        "resolution": [scene.render.resolution_x, scene.render.resolution_y],
        "patterns": _patterns(),
        "settings": _settings(scene),
        "objects": len(scene.objects),
    }


def _object_indices(scene: bpy.types.Scene) -> None:
    """Every object a distinct ``pass_index`` 1, 2, ... (sorted by name), so that the object
    index pass separates objects (0 stays the background)."""
    for index, obj in enumerate(sorted(scene.objects, key=lambda o: o.name), start=1):
        obj.pass_index = index


def _passes(scene: bpy.types.Scene) -> None:
    layer = bpy.context.view_layer
    layer.use_pass_z = True
    layer.use_pass_normal = True
    layer.use_pass_object_index = True
    layer.use_pass_vector = True
    layer.cycles.denoising_store_passes = True
    scene.render.use_motion_blur = False  # Cycles writes the vector pass only without it
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.render.resolution_percentage = 100
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"


def prepare() -> dict:
    """The scene held, checked and set up for bnerr's renders: Cycles on the CPU, the passes
    bnerr reads, distinct object indices. Returns :func:`_info` of the file *before* that."""
    info = _info()
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    _object_indices(scene)
    _passes(scene)
    return info


def render(request: dict) -> dict:
    """One frame: ``frame`` (the scene's frame number), ``width``, ``height``, ``spp``, ``seed``,
    ``pattern`` (a ``sampling_pattern``), ``scrambling_distance`` (None: off), ``adaptive``,
    ``denoise`` (Cycles' OIDN on, its Noisy Image kept), ``threads`` (0: Blender's choice) and
    ``out`` (the EXR path). Answers the render's time as Cycles reports it and the wall time."""
    scene = bpy.context.scene
    cycles = scene.cycles
    scene.frame_set(int(request["frame"]))
    scene.render.resolution_x = int(request["width"])
    scene.render.resolution_y = int(request["height"])
    cycles.samples = int(request["spp"])
    cycles.seed = int(request["seed"])
    cycles.use_animated_seed = False
    cycles.sampling_pattern = request["pattern"]
    cycles.use_adaptive_sampling = bool(request["adaptive"])
    cycles.adaptive_threshold = 0.01
    cycles.adaptive_min_samples = 0
    distance = request.get("scrambling_distance")
    cycles.auto_scrambling_distance = False
    cycles.scrambling_distance = 1.0 if distance is None else float(distance)
    cycles.use_denoising = bool(request["denoise"])
    cycles.denoiser = "OPENIMAGEDENOISE"
    cycles.denoising_input_passes = "RGB_ALBEDO_NORMAL"
    cycles.denoising_prefilter = "ACCURATE"
    threads = int(request.get("threads", 0))
    scene.render.threads_mode = "FIXED" if threads else "AUTO"
    if threads:
        scene.render.threads = threads
    scene.render.filepath = request["out"]
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    wall = time.perf_counter() - start
    if not os.path.exists(request["out"]):
        raise RuntimeError("Cycles wrote no image (the render failed inside Blender)")
    return {"wall_s": wall}


def _serve(request: dict) -> dict:
    op = request.get("op")
    if op == "open":
        bpy.ops.wm.open_mainfile(filepath=request["blend"])
        return {"info": prepare()}
    if op == "build":
        bpy.ops.wm.read_factory_settings(use_empty=True)
        builders.build(request["recipe"])
        return {"info": prepare()}
    if op == "save":
        bpy.ops.wm.save_as_mainfile(filepath=request["blend"], check_existing=False)
        return {}
    if op == "render":
        return render(request)
    raise ValueError(f"op: expected open, build, save, render or quit, got {op!r}")


def main() -> None:
    protocol = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)  # Blender's progress lines (and any print) go to stderr from now on
    protocol.write(json.dumps({"ok": True, "ready": bpy.app.version_string}) + "\n")
    for line in sys.stdin:
        request = json.loads(line)
        if request.get("op") == "quit":
            break
        try:
            answer = {"ok": True, **_serve(request)}
        except Exception as err:  # every failure answered as one line; the process goes on
            message = " ".join(str(err).split()) or type(err).__name__
            answer = {"ok": False, "error": message[:500]}
        protocol.write(json.dumps(answer) + "\n")


if __name__ == "__main__":
    main()
