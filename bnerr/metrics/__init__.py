"""Image error metrics, their update over frames, intervals over seed sets and error spectra.

One module per concern (docs/METHODS.md, section 6):

- :mod:`bnerr.metrics.image`: the per-image metrics (``mse``, ``relmse``, ``psnr``, ``ssim``, the
  blurred MSEs, ``flip``, ``lowfreq``), the pixel masks of object edges and of visible lights,
  the error's correlation from frame to frame, and :class:`ImagePair`, the update half of every
  metric;
- :mod:`bnerr.metrics.cvvdp`: ColorVideoVDP's JOD of a seed set's sequence (the metric
  ``cvvdp``), with its display model and HDR-to-display mapping;
- :mod:`bnerr.metrics.regions`: :func:`coherent_mask`, the spatio-temporally coherent pixels
  (one object, similar normals, depth and albedo in a 5x5 window, no disocclusion);
- :mod:`bnerr.metrics.frames`: the metrics' table (:data:`METRIC_TABLE`, name -> update and
  how summary tables show it) and :class:`FrameMetrics`, which updates every metric per frame and
  computes their pooled means with intervals;
- :mod:`bnerr.metrics.stats`: :class:`Estimate`, :func:`bootstrap_interval`,
  :func:`paired_ratio` (t-intervals over seed sets), the claims :func:`better`,
  :func:`not_worse` and :func:`equivalent`, and the pieces they are built from;
- :mod:`bnerr.metrics.share`: the share of a gap a strategy closes (the gap suite's) with its
  linearized t-interval, and the Bonferroni level of a verdict on the best of m shares;
- :mod:`bnerr.metrics.sequential`: adaptive seed sets, a group-sequential design (alpha spent
  over the looks) that keeps a verdict's coverage when seed sets are added until it is settled;
- :mod:`bnerr.metrics.coverage`: the coverage study behind the choice of interval and of the
  adaptive design, and the gap shares' (``python -m bnerr.metrics.coverage [--sequential TRIALS |
  --shares TRIALS]``);
- :mod:`bnerr.metrics.spectrum`: radially averaged power spectra and the low-frequency fraction.

Every name of the former single module ``bnerr.metrics`` is importable from here as before.
"""

from bnerr.metrics.frames import (
    BLUR_SIGMAS,
    METRIC_TABLE,
    METRICS,
    FrameMetrics,
    Metric,
    load_metric,
)
from bnerr.metrics.image import (
    ImagePair,
    PreparedReference,
    blurred_mse,
    edge_mask,
    flip,
    flip_available,
    highlight_mask,
    light_mask,
    lowfreq,
    mse,
    psnr,
    relmse,
    ssim,
    temporal_correlation,
)
from bnerr.metrics.power import (
    resolve_power,
    seed_set_spread,
    seed_sets_needed,
    seed_sets_to_settle,
)
from bnerr.metrics.regions import coherent_mask
from bnerr.metrics.share import best_level, relevel_share, share_interval
from bnerr.metrics.stats import (
    METHODS,
    Estimate,
    as_stats,
    better,
    bootstrap_interval,
    check_bootstrap,
    equivalent,
    not_worse,
    paired_differences,
    paired_ratio,
    paired_ratios,
    percentile_interval,
    pooled_intervals,
    pooled_mean,
    relevel_difference,
    relevel_ratio,
    replicates,
    resample_weights,
    resampled_values,
    set_means,
    t_interval,
    t_quantile,
)

__all__ = [
    "best_level",
    "relevel_share",
    "share_interval",
    "resolve_power",
    "seed_set_spread",
    "seed_sets_needed",
    "seed_sets_to_settle",
    "BLUR_SIGMAS",
    "METHODS",
    "METRICS",
    "METRIC_TABLE",
    "load_metric",
    "Estimate",
    "FrameMetrics",
    "ImagePair",
    "Metric",
    "PreparedReference",
    "as_stats",
    "better",
    "blurred_mse",
    "bootstrap_interval",
    "check_bootstrap",
    "coherent_mask",
    "edge_mask",
    "highlight_mask",
    "light_mask",
    "equivalent",
    "flip",
    "flip_available",
    "lowfreq",
    "mse",
    "not_worse",
    "paired_differences",
    "paired_ratio",
    "paired_ratios",
    "pooled_intervals",
    "percentile_interval",
    "pooled_mean",
    "psnr",
    "relevel_difference",
    "relevel_ratio",
    "relmse",
    "replicates",
    "resample_weights",
    "resampled_values",
    "set_means",
    "ssim",
    "t_interval",
    "t_quantile",
    "temporal_correlation",
]
