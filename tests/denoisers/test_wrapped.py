"""denoisers.wrapped: a plain function or nn.Module behind the Denoiser interface."""

from __future__ import annotations

import pytest
import torch

from bnerr.errors import DtypeError, ShapeError, ValueRangeError
from bnerr.frame import Frame
from denoisers.wrapped import as_denoiser


class _Halve(torch.nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.scale = torch.nn.Parameter(torch.tensor(0.5))
        self.seen_training: list[bool] = []

    def forward(self, frame: Frame) -> torch.Tensor:
        self.seen_training.append(self.training)
        return frame.color * self.scale


def _frame() -> Frame:
    return Frame(color=torch.ones(3, 4, 5))


def test_a_module_is_a_learned_denoiser_run_in_eval_mode_without_gradients():
    module = _Halve()
    cls = as_denoiser(module, name="halve")
    assert (cls.name, cls.kind, dict(cls.grid)) == ("halve", "learned", {})
    out = cls()(_frame())
    assert out.dtype == torch.float32 and not out.requires_grad
    assert torch.equal(out, torch.full((3, 4, 5), 0.5))
    assert module.seen_training == [False]


def test_grid_values_are_keyword_parameters_defaulting_to_the_first():
    def gain(frame: Frame, k: float = 9.0) -> torch.Tensor:
        return frame.color * k

    cls = as_denoiser(gain, kind="filter", grid={"k": [2.0, 3.0]})
    assert cls().params() == {"k": 2.0} and cls(k=3.0).params() == {"k": 3.0}
    assert torch.equal(cls(k=3.0)(_frame()), torch.full((3, 4, 5), 3.0))


def test_bad_callables_and_outputs_raise_typed_errors():
    with pytest.raises(DtypeError, match="function or module"):
        as_denoiser(42)  # type: ignore[arg-type]
    with pytest.raises(ValueRangeError, match="none for k"):
        as_denoiser(lambda f: f.color, name="empty", grid={"k": []})
    with pytest.raises(DtypeError, match="expected a tensor"):
        as_denoiser(lambda f: "no", name="text")()(_frame())
    with pytest.raises(ShapeError):
        as_denoiser(lambda f: f.color[:1], name="one_channel")()(_frame())
