"""Tests for renderers.mitsuba: the export matches Mitsuba's own Cornell box, and Mitsuba 3's
scalar_rgb renders every scene to the same expected image as our tracer (the cross-check)."""

import numpy as np
import pytest
import torch

from bnerr.errors import DtypeError, ValueRangeError
from bnerr.sequences import make_sampler
from bnerr.strategies import pixel_seeds
from renderers import SCENES, get_scene, render
from renderers.compare import compare_images
from renderers.mitsuba import mitsuba_available, render_mitsuba, to_mitsuba

mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is optional: pip install 'bnerr[reference]'")
pytestmark = pytest.mark.reference


@pytest.fixture(autouse=True, scope="module")
def scalar_variant():
    mi.set_variant("scalar_rgb")
    before = torch.get_num_threads()
    torch.set_num_threads(1)  # two OpenMP threads stall on a loaded two-core machine
    yield
    torch.set_num_threads(before)


def matrix(transform) -> np.ndarray:
    return np.array(transform.matrix, dtype=np.float64)


def test_available():
    assert mitsuba_available()


def test_cornell_export_is_mitsubas_cornell_box():
    theirs = mi.cornell_box()
    ours = to_mitsuba(get_scene("cornell", animated=False), 0, width=8, height=8, spp=1)
    assert ours["integrator"]["max_depth"] == 6
    np.testing.assert_allclose(
        matrix(ours["sensor"]["to_world"]), matrix(theirs["sensor"]["to_world"]), atol=1e-6
    )
    assert ours["sensor"]["fov"] == theirs["sensor"]["fov"]
    assert ours["sensor"]["fov_axis"] == theirs["sensor"]["fov_axis"]
    for name in (
        "light",
        "floor",
        "ceiling",
        "back",
        "green-wall",
        "red-wall",
        "small-box",
        "large-box",
    ):
        a, b = matrix(ours[name]["to_world"]), matrix(theirs[name]["to_world"])
        assert ours[name]["type"] == theirs[name]["type"], name
        if ours[name]["type"] == "rectangle":
            # A rectangle is flat: its edges, center and facing matter, not the z column's length.
            np.testing.assert_allclose(a[:3, [0, 1, 3]], b[:3, [0, 1, 3]], atol=1e-6, err_msg=name)
            n = b[:3, 2] / np.linalg.norm(b[:3, 2])
            np.testing.assert_allclose(a[:3, 2], n, atol=1e-6, err_msg=name)
        else:
            np.testing.assert_allclose(a, b, atol=1e-6, err_msg=name)
        ref = theirs[name]["bsdf"]["id"]
        np.testing.assert_allclose(
            ours[name]["bsdf"]["reflectance"]["value"],
            theirs[ref]["reflectance"]["value"],
            err_msg=name,
        )
    np.testing.assert_allclose(
        ours["light"]["emitter"]["radiance"]["value"],
        theirs["light"]["emitter"]["radiance"]["value"],
    )


@pytest.mark.parametrize("name", sorted(SCENES))
def test_every_scene_loads(name):
    ours = get_scene(name)
    scene = mi.load_dict(to_mitsuba(ours, 3, width=6, height=4, spp=1))
    assert len(scene.emitters()) == len(ours.lights)  # (Mitsuba merges meshes: no shape count)
    assert np.array(mi.render(scene)).shape == (4, 6, 3)


def test_bad_input():
    with pytest.raises(DtypeError, match="scene: expected a renderers Scene, got str"):
        to_mitsuba("cornell", width=4, height=4, spp=1)
    with pytest.raises(ValueRangeError, match="width: expected an integer >= 1, got 0"):
        to_mitsuba(get_scene("direct"), width=0, height=4, spp=1)
    with pytest.raises(ValueRangeError, match="passes: expected a divisor of spp = 8, got 3"):
        render_mitsuba(get_scene("direct"), width=4, height=4, spp=8, passes=3)


CROSS_CHECK = dict(width=24, height=24, spp=1024)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SCENES))
def test_cross_check_with_mitsuba(name):
    """Our image and Mitsuba scalar_rgb's agree within their statistical error.

    Same resolution, depth (Mitsuba's max_depth convention is ours), box filter and spp. Our
    variance is the Frame's (per-pixel sample variance / spp); Mitsuba's comes from ``spp``
    renders of one sample each, i.e. the same estimator of its own. The thresholds are derived
    in renderers.compare (max |z| by Bonferroni at alpha = 1e-3, about 5 at 24 x 24 x 3 values
    and never below 4; the count of pixels beyond 3 sigma; the per-channel mean of z). The medium
    scene runs through Mitsuba's volpath, whose model (null-BSDF box with a homogeneous interior,
    isotropic phase, depth counted by scattering events) is ours.
    """
    scene = get_scene(name, animated=False)
    w, h, spp = CROSS_CHECK["width"], CROSS_CHECK["height"], CROSS_CHECK["spp"]
    ours = render(scene, 0, pixel_seeds(h, w, 0), make_sampler("white"), spp)
    theirs, theirs_var = render_mitsuba(scene, 0, width=w, height=h, spp=spp, seed=1, passes=spp)
    result = compare_images(ours.color, ours.variance, theirs, theirs_var, alpha=1e-3)
    print(f"{name}: {result.summary()}")
    assert result.passed, f"{name}: {result.summary()}"
