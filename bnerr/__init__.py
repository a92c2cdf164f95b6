"""bnerr: blue-noise distribution of Monte Carlo error in screen space, as a library.

The parts any renderer can use, with no dependency on this project's path tracer or denoisers:
blue-noise masks (:mod:`bnerr.masks`), per-pixel sample sequences (:mod:`bnerr.sequences`), the
seed permutation op of Heitz & Belcour 2019 (:mod:`bnerr.permute`, :mod:`bnerr.retarget`), the
seed strategies (:mod:`bnerr.strategies`), metrics and spectra (:mod:`bnerr.metrics`,
:mod:`bnerr.spectrum`), image I/O (:mod:`bnerr.io`) and the :class:`~bnerr.frame.Frame`.

Import the submodules you need (``from bnerr.permute import sort_pass``); importing :mod:`bnerr`
itself loads nothing heavy.
"""

__all__: list[str] = []
