"""denoisers.identity: a denoiser's kind and tuning grid read by name alone."""

from __future__ import annotations

import denoisers
from denoisers.identity import OTHER_KIND, identity_in, of_kind


def test_a_registered_denoiser_is_its_class():
    gaussian = denoisers.DENOISERS["gaussian"]
    found = denoisers.denoiser_identity("gaussian")
    assert found.kind == "filter" and dict(found.grid) == dict(gaussian.grid)
    assert denoisers.denoiser_identity("oidn").kind == "reference"
    assert denoisers.denoiser_identity("unet").kind == "learned"


def test_own_tuning_takes_the_base_and_an_unknown_name_is_neutral():
    assert denoisers.denoiser_identity("gaussian:own").kind == "filter"
    found = identity_in({}, "retired")
    assert (found.kind, dict(found.grid)) == (OTHER_KIND, {})


def test_the_grid_cannot_be_changed_through_the_identity():
    grid = denoisers.denoiser_identity("gaussian").grid
    try:
        grid["sigma"] = (9.0,)  # type: ignore[index]
    except TypeError:
        pass
    assert denoisers.DENOISERS["gaussian"].grid["sigma"] != (9.0,)


def test_of_kind_lists_the_kind_sorted():
    assert of_kind(denoisers.DENOISERS, "temporal") == ("svgf", "taa")
    assert denoisers.denoisers_of_kind("learned") == ("unet", "unet_blue")
