"""Image error metrics, their update over frames, bootstrap intervals and error spectra.

One module per concern (docs/METHODS.md, section 6):

- :mod:`bnerr.metrics.image`: the per-image metrics (``mse``, ``relmse``, ``psnr``, ``ssim``, the
  blurred MSEs, ``flip``, ``lowfreq``), the pixel mask of object edges, the error's correlation
  from frame to frame, and :class:`ImagePair`, the update half of every metric;
- :mod:`bnerr.metrics.frames`: the metrics' table (:data:`METRIC_TABLE`, name -> update and
  how summary tables show it) and :class:`FrameMetrics`, which updates every metric per frame and
  computes their pooled means with intervals;
- :mod:`bnerr.metrics.stats`: :class:`Estimate`, :func:`bootstrap_interval`,
  :func:`paired_ratio` and the resampling pieces they are built from;
- :mod:`bnerr.metrics.spectrum`: radially averaged power spectra and the low-frequency fraction
  (also importable as :mod:`bnerr.spectrum`).

Every name of the former single module ``bnerr.metrics`` is importable from here as before.
"""

from bnerr.metrics.frames import BLUR_SIGMAS, METRIC_TABLE, METRICS, FrameMetrics, Metric
from bnerr.metrics.image import (
    ImagePair,
    PreparedReference,
    blurred_mse,
    edge_mask,
    flip,
    flip_available,
    lowfreq,
    mse,
    psnr,
    relmse,
    ssim,
    temporal_correlation,
)
from bnerr.metrics.stats import (
    Estimate,
    as_stats,
    bootstrap_interval,
    check_bootstrap,
    paired_ratio,
    percentile_interval,
    pooled_mean,
    resample_weights,
    resampled_values,
)

__all__ = [
    "BLUR_SIGMAS",
    "METRICS",
    "METRIC_TABLE",
    "Estimate",
    "FrameMetrics",
    "ImagePair",
    "Metric",
    "PreparedReference",
    "as_stats",
    "blurred_mse",
    "bootstrap_interval",
    "check_bootstrap",
    "edge_mask",
    "flip",
    "flip_available",
    "lowfreq",
    "mse",
    "paired_ratio",
    "percentile_interval",
    "pooled_mean",
    "psnr",
    "relmse",
    "resample_weights",
    "resampled_values",
    "ssim",
    "temporal_correlation",
]
