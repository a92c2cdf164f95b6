"""The ``bnerr`` command line, the benchmark runner behind ``bnerr bench``, its suites and reports.

Top of the import graph: it drives :mod:`renderers`, :mod:`denoisers` and :mod:`bnerr`.
"""

__all__: list[str] = []
