"""Values derived from a tensor, made once per tensor: :class:`TensorMemo`.

A pass run every frame with the same mask or field (the sorting pass's plan of a mask, the
retargeting field on a device and in its C kernel's form) derives its working form once and looks
it up by the tensor itself. An entry is keyed by the tensor's identity and a tag (what was derived:
a block size, a device); a weak reference proves that the tensor is still the same object (ids are
reused after garbage collection) and ``Tensor._version`` changes on every in-place write, so a
tensor edited in place is derived again. Inference-mode tensors have no version counter and are
derived on every call.

Not for: values that depend on anything but the tensor's contents and the tag.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

import torch

__all__ = ["TensorMemo"]

T = TypeVar("T")


class TensorMemo(Generic[T]):
    """The last ``capacity`` values derived from tensors, oldest dropped first; thread-safe."""

    def __init__(self, capacity: int = 8) -> None:
        self.capacity = capacity
        self.entries: dict[tuple[int, Hashable], tuple[weakref.ref[torch.Tensor], int, T]] = {}
        self.lock = threading.Lock()

    def get(self, tensor: torch.Tensor, tag: Hashable, make: Callable[[], T]) -> T:
        """The value ``make()`` derived from ``tensor`` for ``tag``: made at the first call, and
        again after ``tensor`` was edited in place."""
        try:
            version = tensor._version
        except RuntimeError:  # an inference tensor
            return make()
        key = (id(tensor), tag)
        with self.lock:
            hit = self.entries.get(key)
        if hit is not None and hit[0]() is tensor and hit[1] == version:
            return hit[2]
        value = make()
        with self.lock:
            self.entries.pop(key, None)
            while self.entries and len(self.entries) >= self.capacity:
                self.entries.pop(next(iter(self.entries)))
            self.entries[key] = (weakref.ref(tensor), version, value)
        return value
