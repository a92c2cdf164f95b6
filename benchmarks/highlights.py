"""The strategies and denoisers the reports single out by name, and why: their fixed questions.

The report modules (:mod:`benchmarks.reports`) read every strategy's and denoiser's identity from
the registries (:func:`bnerr.strategies.strategy_identity`, :func:`denoisers.denoiser_identity`):
family, order, colour, whether it is a bound, the baseline, the kind of denoiser. A few of their
questions are about one named method, though (issue 15: "does the temporal method keep its gain
after the Gaussian, after TAA?"; "does the U-Net trained on blue noise keep more of it?"). Those
names are chosen here, once, so that ``benchmarks/reports/`` names none
(``tests/benchmarks/reports/test_names.py`` checks it).

Not for: a strategy's or a denoiser's identity (their classes carry it), or what a suite runs
(:mod:`benchmarks.suites`).
"""

from __future__ import annotations

__all__ = [
    "BLUE_TRAINED",
    "HEADLINE_METHOD",
    "KEY_DENOISERS",
    "PLAIN_ACCUMULATOR",
    "SHARE_DENOISERS",
    "SINGLE_FRAME",
    "WHITE_TRAINED",
]

#: The method under test: the headline compares it (and the first bound) with the baseline, and
#: the U-Net section's goal is stated on its gain.
HEADLINE_METHOD = "temporal"
#: The single-frame filter the accumulation and OIDN sections compare the other denoisers with.
SINGLE_FRAME = "gaussian"
#: The temporal denoiser that accumulates and does nothing else: the accumulation factor is its
#: MSE over the raw MSE, and the accumulation section lists it first among the temporal ones.
PLAIN_ACCUMULATOR = "taa"
#: The U-Net trained on white noise, and the same network trained on white and blue noise.
WHITE_TRAINED, BLUE_TRAINED = "unet", "unet_blue"
#: The denoisers an adopter chooses among, in the charts' panel order: the own-tuned Gaussian and
#: a-trous, the U-Net trained on blue-noise frames, OIDN and TAA (plain names when no tuned one is
#: run).
KEY_DENOISERS: tuple[tuple[str, ...], ...] = (
    ("gaussian:own", "gaussian"),
    ("atrous:own", "atrous"),
    ("unet_blue",),
    ("oidn",),
    ("taa",),
)
#: The denoisers of the oracle-share chart, when present, after the blurred raw error.
SHARE_DENOISERS: tuple[str, ...] = ("gaussian", "atrous", "unet_blue", "oidn")
