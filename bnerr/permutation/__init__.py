"""The seed permutation of Heitz & Belcour 2019 and what feeds it (docs/METHODS.md, sections 4, 8
and 11). One module per pass or input:

- :mod:`bnerr.permutation.permute`: the block sorting pass (``torch.ops.bnerr.sort_pass``; groups
  and a shifted block grid), its plan, its slow twin, and histogram selection (the oracle's);
- :mod:`bnerr.permutation.retarget`: the retargeting pass (``torch.ops.bnerr.retarget``), its
  displacement field's optimizer and the shipped fields;
- :mod:`bnerr.permutation.sortkeys`: the keys the sorting pass sorts by (luminance, residual,
  relative; demodulation) and the group labels of its gap-closing variants;
- :mod:`bnerr.permutation.reproject`: the bijective reprojection of the seed image along motion;
- :mod:`bnerr.permutation.vertical`: the "vertical" bound, each pixel's choice among the oracle's
  K candidates for the whole image's blurred error.

Import the module you need (``from bnerr.permutation.permute import sort_pass``): importing this
package loads none of them, so the sort keys do not load the passes' custom ops.
"""

__all__: list[str] = []
