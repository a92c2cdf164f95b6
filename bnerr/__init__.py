"""bnerr: blue-noise distribution of Monte Carlo error in screen space, as a library.

The parts any renderer can use, with no dependency on this project's path tracer or denoisers, by
family: blue-noise masks (:mod:`bnerr.masks`: 2D, spatiotemporal, filter-adapted), per-pixel
sample sequences (:mod:`bnerr.sequences`), the seed permutation of Heitz & Belcour 2019 and what
feeds it (:mod:`bnerr.permutation`: the sorting and retargeting passes, sort keys, reprojection),
the seed strategies (:mod:`bnerr.strategies`), metrics and spectra (:mod:`bnerr.metrics`), the
LDBN key optimizer (:mod:`bnerr.ldbn`), image I/O (:mod:`bnerr.io`) and the
:class:`~bnerr.frame.Frame`.

Import the submodules you need (``from bnerr.permutation.permute import sort_pass``); importing
:mod:`bnerr` itself loads nothing heavy. The paths of the modules that moved into those families
(``bnerr.permute``, ``bnerr.stbn``, ...) still import, with a :class:`DeprecationWarning` naming
the new one, until the next release (:mod:`bnerr._moved`).
"""

from bnerr import _moved

_moved.install()

__all__: list[str] = []
