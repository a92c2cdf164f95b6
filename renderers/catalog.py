"""The catalog of named scenes: each an animation over frames t, with a static variant
(``animated=False``).

===============  ===  =====  ======================================================================
name             D    depth  what it models
===============  ===  =====  ======================================================================
direct           4    2      a sphere on a plane under one rectangular light, direct light only:
                             the low-dimensional case where dithered sampling shines
indirect         8    3      a sphere on a checkerboard floor before a wall, direct and one bounce
                             of indirect light (the talk's teapot-on-checkerboard case)
cornell          20   6      the Cornell box exactly as Mitsuba 3's ``mi.cornell_box()`` builds it
snooker          10   3      a table with a textured felt, rails and rolling balls under two area
                             lights: texture defeats the temporal method (the paper's failure case)
snooker_plain    10   3      the same table with the felt's mean colour instead of its texture
medium           40   9      a box of homogeneous scattering fog above a floor, lit by one area
                             light, up to 8 scattering events: the high-dimensional case
===============  ===  =====  ======================================================================

Depth is Mitsuba's ``max_depth`` (segments of the longest path); D follows from it
(:mod:`renderers.layout`). Motions are slow (a fraction of a degree or about a pixel per frame at
256 pixels wide), the regime the temporal algorithm of Heitz & Belcour 2019 assumes; frame 0 of
every animation equals its static variant, and for ``cornell`` also Mitsuba's own camera.

The issue that asked for the medium scene quoted "24 dimensions" for 8 bounces; with next-event
estimation at every vertex and a free-flight dimension per segment, 8 scattering vertices take
40 here (5 per vertex, see the layout).

**Plug-in scenes** (:mod:`bnerr.plugins`): a function ``() -> Scene`` given as a spec
(``get_scene("mymod:make_scene")``, :func:`load_scene`) or installed as an entry point of the
group ``bnerr.scenes`` joins :data:`SCENES` under its ``name`` attribute (else the spec's or
entry point's name); a path ending in ``.toml`` or ``.json`` is a scene file
(``renderers.scene_file.load_scene_file``), registered under its scene's name; a path ending in
``.xml`` is a Mitsuba 3 scene (``renderers.mitsuba_scene.load_mitsuba_scene``, with its camera
path ``scene.camera.toml`` when it exists), registered under the file's stem: its
:class:`~renderers.mitsuba_scene.MitsubaScene` renders itself through Mitsuba.
:func:`scene_version` is what identifies a registered scene's content for cached references.

Not for: measuring a renderer's speed on realistic geometry: every scene has under 20 primitives.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from pathlib import Path

from bnerr import plugins
from bnerr.errors import PluginError, check_name
from renderers.scene import (
    Box,
    Camera,
    Checker,
    Diffuse,
    Felt,
    Fixed,
    HomogeneousMedium,
    Linear,
    Orbit,
    Rectangle,
    Scene,
    Sphere,
    affine,
)

__all__ = [
    "SCENES",
    "SHIPPED_SCENES",
    "get_scene",
    "is_cycles",
    "load_scene",
    "renders_itself",
    "scene_version",
]

_WHITE = Diffuse((0.8, 0.8, 0.8))


def _floor(name: str, half: float, material: Diffuse, y: float = 0.0) -> Rectangle:
    """A square of side ``2 half`` in the plane y, facing up (+y)."""
    return Rectangle(name, (0.0, y, 0.0), (half, 0.0, 0.0), (0.0, 0.0, -half), material)


def _ceiling_light(
    name: str,
    center: tuple[float, float, float],
    half_x: float,
    half_z: float,
    radiance: tuple[float, float, float],
) -> Rectangle:
    """A horizontal rectangular light facing down (-y)."""
    return Rectangle(name, center, (half_x, 0.0, 0.0), (0.0, 0.0, half_z), _WHITE, radiance)


def direct() -> Scene:
    """Sphere on a plane under one rectangular light, direct lighting only (D = 4)."""
    return Scene(
        name="direct",
        description="a sphere on a plane under one rectangular light, direct lighting only",
        camera=Camera(
            Orbit((0.0, 0.0, 0.0), 6.0, 3.0, 20.0, 0.5),
            Fixed((0.0, 0.8, 0.0)),
            (0.0, 1.0, 0.0),
            40.0,
        ),
        shapes=(
            _floor("floor", 5.0, Diffuse((0.7, 0.7, 0.7))),
            Sphere("sphere", Fixed((0.0, 1.0, 0.0)), 1.0, Diffuse((0.8, 0.35, 0.2))),
            _ceiling_light("light", (1.5, 4.0, 1.0), 0.75, 0.75, (16.0, 15.0, 13.0)),
        ),
        max_depth=2,
    )


def indirect() -> Scene:
    """Sphere on a checkerboard floor before a wall, direct and one indirect bounce (depth 3)."""
    floor = Rectangle(
        "floor",
        (0.0, 0.0, 0.5),
        (5.0, 0.0, 0.0),
        (0.0, 0.0, -4.5),
        Diffuse(Checker((0.8, 0.8, 0.8), (0.1, 0.1, 0.1), 10, 9)),
    )
    wall = Rectangle(
        "wall", (0.0, 2.5, -4.0), (5.0, 0.0, 0.0), (0.0, 2.5, 0.0), Diffuse((0.6, 0.6, 0.65))
    )
    return Scene(
        name="indirect",
        description="a sphere on a checkerboard floor before a wall, "
        "direct and one bounce of indirect light",
        camera=Camera(
            Linear((1.0, 2.5, 6.5), (0.02, 0.0, 0.0)), Fixed((0.0, 0.8, 0.0)), (0.0, 1.0, 0.0), 45.0
        ),
        shapes=(
            floor,
            wall,
            Sphere("sphere", Fixed((0.0, 1.0, 0.0)), 1.0, Diffuse((0.75, 0.75, 0.75))),
            _ceiling_light("light", (-1.0, 4.5, 1.5), 1.0, 1.0, (12.0, 11.5, 10.5)),
        ),
        max_depth=3,
    )


def cornell() -> Scene:
    """Mitsuba 3's ``mi.cornell_box()`` Cornell box (its transforms, BSDFs and light), depth 6."""
    white = Diffuse((0.885809, 0.698859, 0.666422))
    green = Diffuse((0.105421, 0.37798, 0.076425))
    red = Diffuse((0.570068, 0.0430135, 0.0443706))
    x, y = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    rect = Rectangle.from_transform
    return Scene(
        name="cornell",
        description="the Cornell box as Mitsuba 3's mi.cornell_box() builds it, depth 6",
        camera=Camera(
            Orbit((0.0, 0.0, 0.0), 3.9, 0.0, 0.0, 0.25),
            Fixed((0.0, 0.0, 0.0)),
            y,
            39.3077,
            "smaller",
        ),
        shapes=(
            rect(
                "light",
                affine((0.0, 0.99, 0.01), (x, 90.0), (0.23, 0.19, 0.19)),
                white,
                (18.387, 13.9873, 6.75357),
            ),
            rect("floor", affine((0.0, -1.0, 0.0), (x, -90.0)), white),
            rect("ceiling", affine((0.0, 1.0, 0.0), (x, 90.0)), white),
            rect("back", affine((0.0, 0.0, -1.0)), white),
            rect("green-wall", affine((1.0, 0.0, 0.0), (y, -90.0)), green),
            rect("red-wall", affine((-1.0, 0.0, 0.0), (y, 90.0)), red),
            Box("small-box", affine((0.335, -0.7, 0.38), (y, -17.0), 0.3), white),
            Box("large-box", affine((-0.33, -0.4, -0.28), (y, 18.25), (0.3, 0.61, 0.3)), white),
        ),
        max_depth=6,
    )


_FELT = Felt((0.06, 0.36, 0.13), cells_u=144, cells_v=72, grain=0.3, nap=0.12, bands=8, seed=7)
_BALL_RADIUS = 0.05


def _snooker(textured: bool) -> Scene:
    felt = Diffuse(_FELT) if textured else Diffuse(_FELT.mean())
    rail = Diffuse((0.04, 0.25, 0.09))
    r = _BALL_RADIUS

    def ball(name, x, z, albedo, velocity=(0.0, 0.0, 0.0)):
        return Sphere(name, Linear((x, r, z), velocity), r, Diffuse(albedo))

    name = "snooker" if textured else "snooker_plain"
    what = "textured felt" if textured else "plain felt (the mean colour of snooker's texture)"
    return Scene(
        name=name,
        description=f"a snooker table with {what}, rails and rolling balls under two area lights",
        camera=Camera(
            Orbit((0.0, 0.0, 0.0), 2.6, 1.6, 15.0, 0.3),
            Fixed((0.0, 0.0, 0.0)),
            (0.0, 1.0, 0.0),
            45.0,
        ),
        shapes=(
            Rectangle("felt", (0.0, 0.0, 0.0), (1.8, 0.0, 0.0), (0.0, 0.0, -0.9), felt),
            Box("rail-far", affine((0.0, 0.04, -0.95), scale=(1.9, 0.04, 0.05)), rail),
            Box("rail-near", affine((0.0, 0.04, 0.95), scale=(1.9, 0.04, 0.05)), rail),
            Box("rail-left", affine((-1.85, 0.04, 0.0), scale=(0.05, 0.04, 0.9)), rail),
            Box("rail-right", affine((1.85, 0.04, 0.0), scale=(0.05, 0.04, 0.9)), rail),
            ball("cue", -0.9, 0.3, (0.9, 0.88, 0.8), (0.012, 0.0, -0.002)),
            ball("red-1", 0.45, 0.0, (0.7, 0.05, 0.04), (0.0, 0.0, 0.003)),
            ball("red-2", 0.7, 0.06, (0.7, 0.05, 0.04)),
            ball("red-3", 0.7, -0.06, (0.7, 0.05, 0.04)),
            ball("yellow", -0.4, -0.45, (0.85, 0.7, 0.08)),
            ball("blue", 0.0, 0.0, (0.05, 0.15, 0.7)),
            ball("black", 1.3, 0.2, (0.03, 0.03, 0.03)),
            _ceiling_light("lamp-left", (-0.8, 1.3, 0.0), 0.5, 0.25, (24.0, 23.0, 21.5)),
            _ceiling_light("lamp-right", (0.8, 1.3, 0.0), 0.5, 0.25, (24.0, 23.0, 21.5)),
        ),
        max_depth=3,
    )


def snooker() -> Scene:
    """Snooker table with a felt texture under two lights, depth 3."""
    return _snooker(True)


def snooker_plain() -> Scene:
    """The snooker table with an untextured felt of the texture's mean colour."""
    return _snooker(False)


def medium() -> Scene:
    """A box of homogeneous fog above a floor, one area light, 8 scattering events (depth 9)."""
    return Scene(
        name="medium",
        description="a box of homogeneous scattering fog above a floor under one area light, "
        "8 bounces",
        camera=Camera(
            Orbit((0.0, 0.0, 0.0), 7.0, 2.5, 30.0, 0.4),
            Fixed((0.0, 1.0, 0.0)),
            (0.0, 1.0, 0.0),
            40.0,
        ),
        shapes=(
            _floor("floor", 4.0, Diffuse((0.6, 0.6, 0.6))),
            Sphere("sphere", Fixed((2.2, 0.6, 0.5)), 0.6, Diffuse((0.3, 0.5, 0.8))),
            _ceiling_light("light", (1.5, 4.5, 0.5), 0.6, 0.6, (30.0, 28.0, 25.0)),
        ),
        max_depth=9,
        medium=HomogeneousMedium((-1.0, 0.3, -1.0), (1.0, 2.3, 1.0), 1.2, (0.9, 0.8, 0.6)),
    )


def _adapt(plugin: plugins.Plugin) -> tuple[str, Callable[[], Scene]]:
    """A scene plug-in checked: a function (what it returns is checked when called)."""
    if not callable(plugin.obj) or isinstance(plugin.obj, type):
        raise PluginError(
            f"{plugin.who}: expected a function () -> renderers.scene.Scene, got "
            f"{type(plugin.obj).__name__}"
        )
    return plugins.plugin_name(plugin, "scene"), plugin.obj


_SHIPPED: dict[str, Callable[[], Scene]] = {
    "cornell": cornell,
    "direct": direct,
    "indirect": indirect,
    "medium": medium,
    "snooker": snooker,
    "snooker_plain": snooker_plain,
}
#: Scene name -> builder of its animated version (``get_scene`` makes the static variant); the
#: plug-ins included.
SCENES: dict[str, Callable[[], Scene]] = plugins.PluginRegistry("bnerr.scenes", _adapt, _SHIPPED)
#: The shipped scenes' names (no plug-in among them).
SHIPPED_SCENES: tuple[str, ...] = tuple(_SHIPPED)

#: Scene-file suffixes (``renderers.scene_file``).
SCENE_FILE_SUFFIXES = (".toml", ".json")


def load_scene(name_or_spec: str) -> str:
    """The registered name of ``name_or_spec``: itself when registered (or not a spec), else the
    plug-in it names, loaded and registered: a scene file (``.toml``, ``.json``) through
    ``renderers.scene_file.load_scene_file``, or a spec ``pkg.mod:make`` / ``file.py:make``.

    Raises:
        PluginError: the plug-in cannot be loaded or is not a scene builder.
        SceneFileError, FileFormatError: a scene file or Mitsuba XML scene that is not valid.
    """
    registry = SCENES
    assert isinstance(registry, plugins.PluginRegistry)
    if name_or_spec in registry:
        return name_or_spec
    if name_or_spec.endswith(".xml"):
        path = Path(name_or_spec)
        known = plugins.loaded("bnerr.scenes", path.stem)
        if known is not None and known.files[:1] == (str(path.resolve()),):
            return path.stem  # loaded before (a worker's parts load their specs on every use)
        # renderers.mitsuba_scene, loaded when used (Mitsuba itself only when it renders)
        mitsuba_scene = importlib.import_module("renderers.mitsuba_scene")
        builder = mitsuba_scene.load_mitsuba_scene(name_or_spec)
        return registry.add(plugins.Plugin(builder.__name__, builder, None, builder.files))
    if name_or_spec.endswith(".blend") or name_or_spec in _cycles().BUILT:
        return _load_cycles(name_or_spec)
    if name_or_spec.endswith(SCENE_FILE_SUFFIXES):
        registered = plugins.registered_file("bnerr.scenes", name_or_spec)
        if registered is not None:  # loaded already (the driver, then each unit of work)
            return registered
        # renderers.scene_file, loaded when used (a scene-file run only)
        scene_file = importlib.import_module("renderers.scene_file")
        path = Path(name_or_spec)
        builder = scene_file.load_scene_file(path)
        plugin = plugins.Plugin(name_or_spec, builder, None, files=(str(path.resolve()),))
        scene = plugins.call_plugin(plugin, "scene", builder)
        if _is_shipped(scene, scene_file.scene_dict, path):
            return scene.name  # the shipped scene written as a file (examples/scenes/*.toml)
        setattr(builder, "name", scene.name)  # noqa: B010 - the name it registers under
        return registry.add(plugin)  # its spec the file's path, as the records keep it
    if not plugins.is_spec(name_or_spec):
        return name_or_spec
    return registry.add(plugins.resolve(name_or_spec))


def _cycles():  # renderers.cycles, loaded when used (Blender itself only when it renders)
    return importlib.import_module("renderers.cycles")


def _load_cycles(name_or_spec: str) -> str:
    """Register a ``.blend`` file (under its stem) or a built Cycles scene (under its name)."""
    cycles = _cycles()
    if name_or_spec in cycles.BUILT:
        # shipped with bnerr, not a plug-in: no plug-in identity in the records (whose resume
        # check would then follow edits of renderers/cycles/scene.py); its content is its
        # version, which keys its references (scene_version)
        if not dict.__contains__(SCENES, name_or_spec):
            dict.__setitem__(SCENES, name_or_spec, cycles.built_scene(name_or_spec))
        return name_or_spec
    path = Path(name_or_spec)
    known = plugins.loaded("bnerr.scenes", path.stem)
    if known is not None and known.files[:1] == (str(path.resolve()),):
        return path.stem  # loaded before (a worker's parts load their specs on every use)
    builder = cycles.load_blend(name_or_spec)
    return SCENES.add(plugins.Plugin(builder.__name__, builder, None, builder.files))  # type: ignore[attr-defined]


def _is_shipped(scene: Scene, describe: Callable[[Scene], dict], path: Path) -> bool:
    """Whether a scene file's ``scene`` is the shipped scene of its name, key for key (what
    ``describe``, ``renderers.scene_file.scene_dict``, says of both): then it is that scene,
    its references and cells shared. A different scene under a shipped name is refused.

    Raises:
        PluginError: ``scene`` takes a shipped scene's name but differs from it.
    """
    if scene.name not in SHIPPED_SCENES:
        return False
    if describe(scene) == describe(SCENES[scene.name]()):
        return True
    raise PluginError(
        f"scene file {path}: expected a name other than a shipped scene's for a scene that "
        f'differs from it, got {scene.name!r} (give it its own: name = "..." in the file)'
    )


def get_scene(name: str, animated: bool = True) -> Scene:
    """The named scene; ``animated=False`` gives its static variant (every pose frozen at t = 0).

    ``name`` may be a plug-in spec or scene file (:func:`load_scene`).

    Raises:
        UnknownNameError: ``name`` is not in :data:`SCENES`.
        PluginError: a plug-in that cannot be loaded, raises, or returns no Scene.
    """
    name = check_name(load_scene(name), list(SCENES), "scene")
    plugin = plugins.loaded("bnerr.scenes", name)
    if plugin is None:
        scene = SCENES[name]()
    else:
        scene = plugins.call_plugin(plugin, "scene", SCENES[name])
        if not isinstance(scene, Scene) and not renders_itself(scene):
            raise PluginError(
                f"{plugin.who}: expected a renderers.scene.Scene, got {type(scene).__name__}"
            )
    return scene if animated else scene.static()


def renders_itself(scene: object) -> bool:
    """Whether ``scene`` renders itself: a Mitsuba XML scene's
    :class:`renderers.mitsuba_scene.MitsubaScene`, whose ``render(t, seeds, sampler, spp)`` the
    sweep and ``bnerr render`` call instead of the tracer (and whose time the tracer's budget
    does not model). That module is imported only once an XML scene was loaded."""
    module = sys.modules.get("renderers.mitsuba_scene")
    if module is not None and isinstance(scene, module.MitsubaScene):
        return True
    return is_cycles(scene)


def is_cycles(scene: object) -> bool:
    """Whether ``scene`` is a Cycles scene (:class:`renderers.cycles.CyclesScene`), whose
    strategies are Cycles' own patterns (:mod:`renderers.cycles.patterns`)."""
    module = sys.modules.get("renderers.cycles.scene")
    return module is not None and isinstance(scene, module.CyclesScene)


def scene_version(name: str) -> str:
    """What identifies the content of the registered scene ``name`` beyond the code: "" for a
    shipped scene (the code version covers it), a Mitsuba scene's ``version`` (Mitsuba's version
    and its files' hash), else the plug-in's fingerprint (a scene file's hash, a distribution's
    version; a Cycles scene built by code its ``version``). Keys the sweep's cached references."""
    plugin = plugins.loaded("bnerr.scenes", name)
    if name in _cycles().BUILT:
        return str(get_scene(name).version)  # type: ignore[attr-defined]
    if plugin is None:
        return ""
    version = getattr(get_scene(name), "version", None)
    return version if isinstance(version, str) else plugin.fingerprint
