"""Sums whose rounding does not depend on the thread count or the device.

``torch.sum`` on the CPU splits a large reduction into one chunk per thread and adds the chunks'
partial sums, so the same float64 values summed with 1 and with 2 threads can differ in the last
bits (measured: 973 of 8064 metric values of one benchmark run differed, by up to 4e-16). The
metrics are the project's published numbers, so they sum in a fixed order instead.

:func:`fixed_sum` is a pairwise (tree) sum of a fixed shape: the values are padded with zeros to
a power of two along the summed axis, then the first half is added to the second half until one
element is left. Every addition is an elementwise IEEE operation on fixed operands, so the result
is bit-identical for every thread count, and on the CPU and on CUDA. Its rounding error grows as
``log2(n) eps`` (a sequential sum's as ``n eps``).

Not for: hot loops (``log2(n)`` kernel launches and about ``n`` extra additions).
"""

from __future__ import annotations

import torch

from bnerr.errors import check_tensor

__all__ = ["fixed_sum", "fixed_sum_reference"]


def fixed_sum(x: torch.Tensor, dim: int | None = None) -> torch.Tensor:
    """Sum of ``x`` over all elements (``dim=None``) or over one axis, in a fixed pairwise order.

    Args:
        x: any shape, any dtype that supports addition (sum float64 for the metrics).
        dim: the axis to sum over, or None for every element.

    Returns:
        ``x``'s shape without ``dim`` (a 0-dim tensor for ``dim=None``), ``x``'s dtype and device.
        An empty axis sums to 0.
    """
    check_tensor(x, "x")
    values = x.reshape(-1) if dim is None else x.movedim(dim, 0)
    n = values.shape[0]
    if n == 0:
        return values.new_zeros(values.shape[1:])
    size = 1 << (n - 1).bit_length()
    if size != n:
        pad = values.new_zeros((size - n, *values.shape[1:]))
        values = torch.cat([values, pad])
    while size > 1:
        size //= 2
        values = values[:size] + values[size:]
    return values[0]


def fixed_sum_reference(x: torch.Tensor, dim: int | None = None) -> torch.Tensor:
    """The slow twin of :func:`fixed_sum`: the same tree of additions, one Python add at a time."""
    values = x.reshape(-1) if dim is None else x.movedim(dim, 0)
    items = [values[i] for i in range(values.shape[0])]
    if not items:
        return values.new_zeros(values.shape[1:])
    size = 1 << (len(items) - 1).bit_length()
    items += [torch.zeros_like(items[0])] * (size - len(items))
    while len(items) > 1:
        half = len(items) // 2
        items = [items[i] + items[i + half] for i in range(half)]
    return items[0]
