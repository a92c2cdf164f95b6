"""Module paths that moved, kept importable for one release with a warning that names the new path.

The blue-noise masks and the permutation passes became the packages :mod:`bnerr.masks` and
:mod:`bnerr.permutation`, and ``bnerr.spectrum``, a re-export of :mod:`bnerr.metrics.spectrum`,
went. :data:`MOVED` maps each old path to its new one; ``bnerr.masks`` itself did not move (it is
the package now, with the same names).

:class:`MovedFinder`, which :func:`install` puts on :data:`sys.meta_path` when :mod:`bnerr` is
imported, answers for these paths only: ``import bnerr.permute``, ``from bnerr.permute import
sort_pass`` and ``from bnerr import permute`` warn at the first import (Python caches the module
afterwards) and give the module at its new path itself, not a copy, so its torch ops register
once and its classes stay the same classes. Python shows a :class:`DeprecationWarning` raised in
``__main__``, under pytest and with ``python -X dev``, and hides it elsewhere by default.

Not for: new moves. Remove this module, and its call in ``bnerr/__init__.py``, in the release
after the one that moved them.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from collections.abc import Sequence
from types import ModuleType

__all__ = ["MOVED", "MovedFinder", "install"]

#: Old module path -> the module that holds its names now.
MOVED = {
    "bnerr.fast": "bnerr.masks.fast",
    "bnerr.permute": "bnerr.permutation.permute",
    "bnerr.reproject": "bnerr.permutation.reproject",
    "bnerr.retarget": "bnerr.permutation.retarget",
    "bnerr.sortkeys": "bnerr.permutation.sortkeys",
    "bnerr.spectrum": "bnerr.metrics.spectrum",
    "bnerr.stbn": "bnerr.masks.stbn",
    "bnerr.vertical": "bnerr.permutation.vertical",
}


class MovedFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old paths of :data:`MOVED` and loads each as its new module, with a warning."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        """A spec for an old path of :data:`MOVED`, else None (the other finders' turn)."""
        return importlib.machinery.ModuleSpec(fullname, self) if fullname in MOVED else None

    def exec_module(self, module: ModuleType) -> None:
        """Warn, import the new module and put it in ``sys.modules`` under the old name: the
        import system returns what it finds there, so the placeholder ``module`` is dropped."""
        new = MOVED[module.__name__]
        # Above level 1 Python skips the import system's frames: 2 names the importing line.
        warnings.warn(
            f"{module.__name__} is deprecated: import {new} instead "
            "(the old path is removed in the next release)",
            DeprecationWarning,
            stacklevel=2,
        )
        sys.modules[module.__name__] = importlib.import_module(new)


def install() -> None:
    """Put one :class:`MovedFinder` first on :data:`sys.meta_path` (again: nothing to do).

    First, not last: an editable install's finder, which comes after the path's, would otherwise
    answer for an old path with the old file of the checkout it points to. It costs one dictionary
    lookup per import."""
    if not any(isinstance(finder, MovedFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, MovedFinder())
