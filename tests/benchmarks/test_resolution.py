"""Tests of benchmarks.resolution: the one ``WxH`` parser."""

from __future__ import annotations

import pytest

from benchmarks.commands import _args
from benchmarks.resolution import parse_resolution
from bnerr.errors import DtypeError, ValueRangeError


def test_parse_resolution():
    assert parse_resolution("320x240") == (320, 240)
    assert parse_resolution("64X32") == (64, 32)
    with pytest.raises(DtypeError, match="--res: expected WxH with integers"):
        parse_resolution("320")
    with pytest.raises(DtypeError, match="--res: expected WxH with integers"):
        parse_resolution("ax3")
    with pytest.raises(ValueRangeError, match="--res: expected width and height >= 1"):
        parse_resolution("4x-2")


def test_the_flag_is_named_in_the_message():
    with pytest.raises(DtypeError, match="--size: expected WxH"):
        parse_resolution("big", flag="--size")


def test_the_commands_use_this_one_definition():
    assert _args.parse_resolution is parse_resolution
