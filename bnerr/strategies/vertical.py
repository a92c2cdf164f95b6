"""``vertical``: the oracle's K candidates, chosen per pixel for the whole image's blurred error.

The histogram oracle (:mod:`bnerr.strategies.oracle`) ranks each pixel's K candidates and keeps
the one at the blue-noise mask's rank: a choice pixel by pixel. ``vertical`` starts from that
choice and lets :func:`bnerr.permutation.vertical.vertical_select` move each pixel to the candidate
that most lowers the sigma-2 blurred error of the whole image (after Chizhov et al. 2022), with no
permutation constraint. A strategy does not see the reference, so the target is the best estimate
the K renders hold: their mean (K times the spp). The target's own error is then a floor of about
``1 / K`` of one candidate's blurred error that no choice removes; with the reference as target
(:mod:`benchmarks.studies.coherent_fade`) the bound is lower still. K renders per frame and a greedy
search (seconds at 128x128, K = 32): a bound to read next to the oracle, not a strategy to adopt.
"""

from __future__ import annotations

import torch

from bnerr.permutation.vertical import vertical_select
from bnerr.strategies.oracle import OracleStrategy

__all__ = ["VerticalStrategy"]

#: The blur the choice minimizes: the sigma-2 blurred MSE of the tables and the gap report.
VERTICAL_SIGMA = 2.0


class VerticalStrategy(OracleStrategy):
    """``vertical``: K candidate renders, per pixel the candidate that a greedy search over the
    whole image picks to minimize the sigma-2 blurred error against the candidates' mean,
    started from the oracle's histogram choice."""

    name = "vertical"
    rank = 130
    bound_note = "it renders K candidates per frame and searches the image: a second bound"

    def _choose(self, t: int, colors: list[torch.Tensor]) -> torch.Tensor:
        start = super()._choose(t, colors)
        stack = torch.stack(colors)
        return vertical_select(stack, stack.mean(0), sigma=VERTICAL_SIGMA, init=start)
