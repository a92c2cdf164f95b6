"""Arrays shipped as package data (``bnerr/data/*.npy``): the one loader, checked on the way in.

Masks, the retargeting fields and any other table bnerr ships are ``.npy`` files read with
``allow_pickle=False`` (a shipped file can never run code) and checked for dtype and shape; a
missing, corrupt or foreign file raises :class:`~bnerr.errors.FileFormatError` naming it.
"""

from __future__ import annotations

import io
from importlib import resources

import numpy as np

from bnerr.errors import FileFormatError

__all__ = ["data_dir", "load_array", "shipped_files"]


def data_dir() -> resources.abc.Traversable:
    """The package's data folder (``bnerr/data``), wherever bnerr is installed."""
    return resources.files("bnerr").joinpath("data")


def shipped_files(prefix: str, suffix: str = ".npy") -> list[str]:
    """Names of the shipped files that start with ``prefix`` and end with ``suffix``, sorted."""
    data = data_dir()
    if not data.is_dir():
        return []
    return sorted(
        e.name for e in data.iterdir() if e.name.startswith(prefix) and e.name.endswith(suffix)
    )


def load_array(name: str, dtype: np.dtype | type, shape: tuple[int | None, ...]) -> np.ndarray:
    """Read ``bnerr/data/<name>`` and check that it is ``dtype`` of ``shape`` (a ``None`` entry
    accepts any size on that axis).

    Returns:
        A writable numpy array owned by the caller.

    Raises:
        FileFormatError: the file is missing, unreadable, or of another dtype or shape.
    """
    resource = data_dir().joinpath(name)
    try:
        array = np.load(io.BytesIO(resource.read_bytes()), allow_pickle=False)
    except (OSError, ValueError) as err:
        raise FileFormatError(
            f"{resource}: expected a .npy array, got unreadable data ({err})"
        ) from err
    fits = array.ndim == len(shape) and all(
        want is None or want == got for want, got in zip(shape, array.shape)
    )
    if not fits or array.dtype != np.dtype(dtype):
        raise FileFormatError(
            f"{resource}: expected {np.dtype(dtype)} of shape "
            f"{['*' if n is None else n for n in shape]}, "
            f"got {array.dtype} of shape {list(array.shape)}"
        )
    return array.copy()
