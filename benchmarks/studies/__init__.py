"""The studies: each module is the measurement behind one finding, run once by hand and quoted by
docs/FINDINGS.md (and docs/METHODS.md, which has its tables), never imported by the framework.

A study asks one question and is named by it; ``python -m benchmarks.studies.NAME`` runs it
exactly as the docs quote it, and its docstring names the finding it measures. Most print a
table (a diagnosis: nothing is written under ``results/``); a study may import the library, the
renderers, the denoisers, the benchmark framework and another study, but nothing outside this
package imports a study (tests/test_structure.py checks it), so ``bnerr bench`` never loads one.

- :mod:`~benchmarks.studies.seed_spread`: why the Cornell box's seed sets disagree;
- :mod:`~benchmarks.studies.snooker_raw_mse`: why LDBN's raw MSE is low on the snooker tables
  (how a sampler pairs the light choice with the light's position);
- :mod:`~benchmarks.studies.coherent_fade`: why the temporal method's gain fades with spp in
  coherent regions (the sort key ranks the shading, not the error);
- :mod:`~benchmarks.studies.short_moves`: what shorter retargeting moves trade (the error a seed
  carries against the mask it meets);
- :mod:`~benchmarks.studies.denoiser_kernels`: the denoisers' effective spatial kernels;
- :mod:`~benchmarks.studies.matched_keys`: whether keys matched to those kernels beat the generic
  ones;
- :mod:`~benchmarks.studies.jitter_loss`: whether the pixel jitter takes the a-priori samplers'
  blue noise away at high spp;
- :mod:`~benchmarks.studies.integrand_motion`: why the a-priori keys' blue noise fades past 4
  spp (the integrand moves from pixel to pixel).
"""

__all__: list[str] = []
