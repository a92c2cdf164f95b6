"""The LDBN optimizer: per-pixel ranking and scrambling keys for the ``ldbn`` sampler
(:class:`bnerr.sequences.LDBNSampler`; docs/METHODS.md, section 10).

- :mod:`~bnerr.ldbn.integrands`: the test integrands and the error features of a key;
- :mod:`~bnerr.ldbn.swaps`: the energy and its two descents (key swaps, rank-bit flips);
- :mod:`~bnerr.ldbn.keys`: a whole key set, resumable (``bnerr mask --ldbn``), and the shipped sets;
- :mod:`~bnerr.ldbn.quality`: the share of the error variance a blur keeps on held-out tests.
"""

from bnerr.ldbn.keys import KeyOptions, load_ldbn_keys, optimize_keys

__all__ = ["KeyOptions", "load_ldbn_keys", "optimize_keys"]
