"""Inputs shared by the sort pass's tests: random values with adversarial floats (signed zeros,
infinities, NaN, ties) and a seeded case of seeds, values and mask."""

import torch

# Values that stress the order: signed zeros, infinities, NaN, and few distinct values (ties).
SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, float("inf"), float("-inf"), float("nan"), 2.0**-149]


def adversarial_values(
    gen: torch.Generator, shape: tuple[int, ...], special: float
) -> torch.Tensor:
    """Random floats in which a fraction ``special`` is replaced by the adversarial values above."""
    base = torch.randint(-3, 4, shape, generator=gen).float() / 2  # many ties
    pick = torch.rand(shape, generator=gen) < special
    table = torch.tensor(SPECIAL)
    base[pick] = table[torch.randint(0, len(SPECIAL), (int(pick.sum()),), generator=gen)]
    return base


def permute_case(seed: int, h: int, w: int, channels: int, special: float):
    gen = torch.Generator().manual_seed(seed)
    shape = (h, w) if channels == 0 else (channels, h, w)
    values = adversarial_values(gen, shape, special)
    mask = adversarial_values(gen, (h, w), special / 2)
    seeds = torch.randperm(h * w, generator=gen).view(h, w) * 7 + 3
    return seeds, values, mask
