"""Radially averaged power spectra and the low-frequency fraction: :mod:`bnerr.metrics.spectrum`."""

from bnerr.metrics.spectrum import low_frequency_fraction, radial_power_spectrum

__all__ = ["low_frequency_fraction", "radial_power_spectrum"]
