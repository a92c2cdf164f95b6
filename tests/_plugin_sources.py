"""Plug-in source files the command-line tests write into their temporary folders: a strategy of
a new family and a per-pixel sampler, each a subclass of a shipped one."""

STRATEGY = """
from bnerr.strategies import WhiteStrategy


class Mine(WhiteStrategy):
    name = "mine"
    family = "experimental"
    stream = 0x51A7E0FF
"""

SAMPLER = """
from bnerr.sequences import WhiteSampler


class Hashy(WhiteSampler):
    name = "hashy"
"""
