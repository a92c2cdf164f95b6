"""Tests for renderers.mitsuba_scene: Mitsuba 3 XML scenes with a camera path as sweep scenes.

Loading (the XML checked, the sidecar camera path parsed, the registration in the catalog) needs
no Mitsuba; rendering and the motion vectors need the ``reference`` extra and an LLVM recent
enough for Dr.Jit (>= 19), and skip with the reason otherwise.
"""

import math

import pytest
import torch

from bnerr.errors import FileFormatError, SceneFileError
from bnerr.sequences import make_sampler
from bnerr.strategies import pixel_seeds
from renderers import get_scene, load_scene, renders_itself, scene_version
from renderers import mitsuba_render as mr
from renderers import mitsuba_scene as ms
from renderers.camera import camera_frame, generate_rays, project
from renderers.scene import Camera, Fixed, Orbit
from tests._paths import ROOT

SCENE = ROOT / "examples" / "mitsuba_temporal.xml"
REASON = mr.unavailable_reason("llvm_ad_rgb")
needs_mitsuba = pytest.mark.skipif(
    REASON is not None, reason=f"Mitsuba 3 llvm_ad_rgb unusable here: {REASON}"
)

SKY = """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="2"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world">
            <lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <film type="hdrfilm">
            <integer name="width" value="8"/><integer name="height" value="6"/>
        </film>
    </sensor>
    <shape type="sphere">
        <point name="center" value="0, 0, 40"/><float name="radius" value="0.1"/>
    </shape>
</scene>
"""


# --------------------------------------------------------------------------------------------
# Without Mitsuba


def test_the_example_loads_with_its_camera_path():
    scene = ms.load_mitsuba_scene(SCENE)()
    assert scene.name == "mitsuba_temporal" and scene.animated
    assert scene.camera == ms.CameraPath(Orbit((0.0, 0.0, 0.0), 4.0, 1.6, 0.0, 0.5),
                                         Fixed((0.0, 0.4, 0.0)), (0.0, 1.0, 0.0))  # fmt: skip
    assert scene.pose(2) == scene.camera.pose(2)
    assert scene.version.startswith("mitsuba-") and len(scene.version.split("-")[-1]) == 16
    still = scene.static()
    assert not still.animated and still.pose(7) == scene.pose(0)


def test_the_sidecar_is_named_after_the_xml_and_enters_the_version(tmp_path):
    xml = tmp_path / "room.xml"
    xml.write_text(SKY)
    assert ms.camera_path_file(xml) == tmp_path / "room.camera.toml"
    still = ms.load_mitsuba_scene(xml)
    assert still().camera is None and still.files == (str(xml.resolve()),)
    (tmp_path / "room.camera.toml").write_text(
        'origin = { type = "linear", start = [0, 0, 5], velocity = [0.1, 0, 0] }\n'
        "target = [0, 0, 0]\n"
    )
    moving = ms.load_mitsuba_scene(xml)
    assert moving().camera.pose(3) == ((0.1 * 3, 0.0, 5.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    assert len(moving.files) == 2 and moving().version != still().version


@pytest.mark.parametrize(
    ("sidecar", "words"),
    [
        ("origin = [0, 0, 5]\n", ["expected key 'target'"]),
        ("origin = [0, 0, 5]\ntarget = [0, 0, 0]\nfov = 3\n", ["unknown key 'fov'"]),
        ("origin = [0, 0, 0]\ntarget = [0, 0, 0]\n", ["origin and target apart"]),
        ("origin = [0, 0, 5]\ntarget = [0, 0, 0]\nup = [0, 0, 1]\n", ["not parallel"]),
        ("origin = [0, 0\n", ["expected TOML"]),
    ],
)
def test_a_bad_camera_path_is_refused_naming_the_file(tmp_path, sidecar, words):
    (tmp_path / "room.xml").write_text(SKY)
    (tmp_path / "room.camera.toml").write_text(sidecar)
    with pytest.raises(SceneFileError) as err:
        ms.load_mitsuba_scene(tmp_path / "room.xml")
    assert "room.camera.toml" in str(err.value)
    assert all(w in str(err.value) for w in words)


@pytest.mark.parametrize(
    ("text", "words"),
    [("<scene><shape type='sphere'/></scene>", "<sensor>"), ("<scene>", "Mitsuba XML")],
)
def test_an_xml_that_is_no_scene_is_refused(tmp_path, text, words):
    (tmp_path / "bad.xml").write_text(text)
    with pytest.raises(FileFormatError, match=words):
        ms.load_mitsuba_scene(tmp_path / "bad.xml")
    with pytest.raises(FileFormatError, match="readable"):
        ms.load_mitsuba_scene(tmp_path / "missing.xml")


def test_the_catalog_registers_an_xml_scene_once_under_its_stem(forget):
    forget.append(("bnerr.scenes", "mitsuba_temporal"))  # the registry is process-wide
    assert load_scene(str(SCENE)) == "mitsuba_temporal"
    assert load_scene(str(SCENE)) == "mitsuba_temporal"  # again: a worker reloads its specs
    scene = get_scene(str(SCENE), animated=False)
    assert isinstance(scene, ms.MitsubaScene) and not scene.animated and renders_itself(scene)
    assert not renders_itself(get_scene("direct"))
    assert scene_version("mitsuba_temporal") == scene.version and scene_version("direct") == ""


# --------------------------------------------------------------------------------------------
# With Mitsuba


@needs_mitsuba
def test_render_is_deterministic_and_gives_every_buffer():
    scene = ms.load_mitsuba_scene(SCENE)()
    seeds = pixel_seeds(12, 10, 3)
    one = scene.render(2, seeds, make_sampler("owen_sobol"), 2)
    two = scene.render(2, seeds, make_sampler("owen_sobol"), 2)
    for name in ("color", "albedo", "normal", "depth", "object_id", "motion"):
        assert torch.equal(getattr(one, name), getattr(two, name)), name
    assert one.color.shape == (3, 12, 10) and one.motion.shape == (2, 12, 10)
    assert one.motion.abs().max() > 0.01  # the orbit moves the camera
    assert scene.static().render(2, seeds, None, 1).motion.abs().max() < 1e-3
    assert scene.dimensions == 2 + 6 * 3  # pixel 2, then 6 per vertex for max_depth 3


@needs_mitsuba
def test_the_same_pose_gives_zero_motion():
    scene = ms.load_mitsuba_scene(SCENE)()
    scene.render(5, pixel_seeds(8, 8, 0), None, 1)  # poses the sensor at frame 5
    render = ms._renderer(scene.path, 1, None, 8, 8)
    assert ms.camera_motion(render, scene.pose(5)).abs().max() < 1e-3


@needs_mitsuba
def test_motion_of_escaping_rays_matches_the_tracers_camera(tmp_path):
    """Rays that escape are projected as directions: for a camera orbiting its target, the
    motion must equal the tracer's own reprojection (renderers.camera) of the same rays."""
    (tmp_path / "sky.xml").write_text(SKY)
    (tmp_path / "sky.camera.toml").write_text(
        'origin = { type = "orbit", radius = 5.0, step = 2.0 }\ntarget = [0, 0, 0]\n'
    )
    scene = ms.load_mitsuba_scene(tmp_path / "sky.xml")()
    frame = scene.render(4, pixel_seeds(6, 8, 1), None, 1)
    camera = Camera(scene.camera.origin, scene.camera.target, scene.camera.up, 50.0)
    now, then = camera_frame(camera, 4, 8, 6), camera_frame(camera, 3, 8, 6)
    cy, cx = torch.meshgrid(torch.arange(6) + 0.5, torch.arange(8) + 0.5, indexing="ij")
    _, direction = generate_rays(now, cx.reshape(-1), cy.reshape(-1))
    x, y, _ = project(then, direction, directions=True)
    expected = torch.stack([cx.reshape(-1) - x, cy.reshape(-1) - y]).reshape(2, 6, 8)
    assert frame.object_id.max() < 0  # nothing hit
    assert torch.allclose(frame.motion, expected, atol=1e-3)
    assert math.isclose(float(expected[0].mean()), float(frame.motion[0].mean()), abs_tol=1e-3)


@needs_mitsuba
def test_motion_of_surface_hits_matches_an_independent_reprojection(tmp_path):
    """Issue 54: only escaping rays were compared with an independent reprojection. Here a
    sphere fills most of the view of an orbiting camera: each hit pixel's motion must equal the
    analytic hit of its ray (ray-sphere, not Mitsuba's) projected into the previous frame's
    camera by the tracer's own projection (renderers.camera)."""
    xml = SKY.replace('value="0, 0, 40"/><float name="radius" value="0.1"/>',
                      'value="0, 0, 0"/><float name="radius" value="1.5"/>')  # fmt: skip
    xml = xml.replace('"width" value="8"', '"width" value="16"').replace(
        '"height" value="6"', '"height" value="12"'
    )
    (tmp_path / "ball.xml").write_text(xml)
    (tmp_path / "ball.camera.toml").write_text(
        'origin = { type = "orbit", radius = 5.0, step = 4.0 }\ntarget = [0, 0, 0]\n'
    )
    scene = ms.load_mitsuba_scene(tmp_path / "ball.xml")()
    frame = scene.render(4, pixel_seeds(12, 16, 1), None, 1)
    camera = Camera(scene.camera.origin, scene.camera.target, scene.camera.up, 50.0)
    now, then = camera_frame(camera, 4, 16, 12), camera_frame(camera, 3, 16, 12)
    cy, cx = torch.meshgrid(torch.arange(12) + 0.5, torch.arange(16) + 0.5, indexing="ij")
    origin, direction = generate_rays(now, cx.reshape(-1), cy.reshape(-1))
    origin, direction = origin.double(), direction.double()  # [3, N], component-major
    b = (origin * direction).sum(0)  # |o + s d| = 1.5: the sphere at the origin
    disc = b**2 - ((origin**2).sum(0) - 1.5**2)
    hit = disc > 1e-6
    s = -b - disc.clamp(min=0).sqrt()
    point = origin + s[None] * direction
    x, y, _ = project(then, point.float())
    expected = torch.stack([cx.reshape(-1) - x, cy.reshape(-1) - y]).reshape(2, 12, 16)
    hit = hit.reshape(12, 16)
    # the same sphere (the id buffer's one jittered sample differs at the silhouette only)
    assert float((frame.object_id[0] >= 0).eq(hit).float().mean()) > 0.9
    both = hit & (frame.object_id[0] >= 0)
    assert int(both.sum()) > 60 and float(expected[:, both].abs().max()) > 0.1  # it moves
    assert torch.allclose(frame.motion[:, both], expected[:, both], atol=2e-3)
