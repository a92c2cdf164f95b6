"""The sweep behind ``bnerr bench``: a suite becomes runs and cells, each run is measured, and the
records land in ``<out>/cells.jsonl``.

One module per concern, imported where they are used (this package re-exports nothing, so that
importing one module does not import the whole sweep):

- :mod:`~benchmarks.sweep.plan`: a suite becomes runs (what is rendered together) and cells;
- :mod:`~benchmarks.sweep.parts`: the scenes, renderer, strategies and denoisers as typed
  callables, and :class:`~benchmarks.sweep.parts.BoundRender`, the render a strategy calls;
- :mod:`~benchmarks.sweep.version`: the code version of the references (a leaf);
- :mod:`~benchmarks.sweep.references`: the high-spp references, cached as EXR;
- :mod:`~benchmarks.sweep.measure`: one seed set of a run, rendered, denoised and measured;
- :mod:`~benchmarks.sweep.tuning`: the denoisers' parameters, fair and ``NAME:own``;
- :mod:`~benchmarks.sweep.records`: the typed records and ``cells.jsonl``;
- :mod:`~benchmarks.sweep.runner`: the serial sweep; :mod:`~benchmarks.sweep.ray_runner`: the
  same sweep as Ray tasks.
"""

__all__: list[str] = []
