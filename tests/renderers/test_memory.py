"""Tests for renderers.memory: the rough peak bytes of a render grow with the pixel count from a
fixed working set."""

from renderers.memory import RENDER_BYTES_PER_PIXEL, RENDER_FIXED_BYTES, render_bytes


def test_render_bytes_is_the_fixed_set_plus_a_cost_per_pixel():
    assert render_bytes(0, 0) == RENDER_FIXED_BYTES
    assert render_bytes(64, 32) - render_bytes(32, 32) == RENDER_BYTES_PER_PIXEL * 32 * 32
    assert render_bytes(1920, 1080) > render_bytes(1080, 1080)
