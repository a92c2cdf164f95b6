"""Convert OpenQMC's upstream files into what bnerr ships and tests (README.md beside this file).

``python -m tests.bnerr.sequences.openqmc_upstream.convert tables OPENQMC/include/oqmc/data``
writes ``bnerr/data/openqmc_{sobol,lattice}_{keys,ranks}.npy`` from OpenQMC's
``{sobol,lattice}/{keys,ranks}.txt`` (65536 ``0x........U,`` words each, the table index
``y * 256 + x``): the keys as uint32 ``[256, 256]``, the ranks (all < 128) as uint8.

``python -m tests.bnerr.sequences.openqmc_upstream.convert vectors DRIVER_OUTPUT`` writes
``vectors.npz`` beside this file from the text that ``driver.cpp`` prints: per sampler
``<name>_lanes`` int64 ``[N, 5]`` (x, y, frame, index, domain key), ``<name>_words`` uint32
``[N, 4]`` (``drawSample<4>`` as integers) and ``<name>_floats`` uint32 ``[N, 4]`` (the float32
bits of the float overload); ``float_words`` / ``float_bits``, OpenQMC's ``uintToFloat``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[3] / "bnerr" / "data"
SAMPLERS = ("sobolbn", "latticebn")


def read_table(path: Path) -> np.ndarray:
    """One upstream table: its 65536 words as uint32 ``[256, 256]`` (row y, column x)."""
    words = [int(w.strip().rstrip("U"), 16) for w in path.read_text().split(",") if w.strip()]
    if len(words) != 1 << 16:
        raise SystemExit(f"{path}: expected 65536 words, got {len(words)}")
    return np.array(words, dtype=np.uint32).reshape(256, 256)


def tables(source: Path) -> None:
    for base in ("sobol", "lattice"):
        keys = read_table(source / base / "keys.txt")
        ranks = read_table(source / base / "ranks.txt")
        if ranks.max() >= 256:
            raise SystemExit(f"{base}/ranks.txt: expected ranks < 256, got {ranks.max()}")
        np.save(DATA / f"openqmc_{base}_keys.npy", keys)
        np.save(DATA / f"openqmc_{base}_ranks.npy", ranks.astype(np.uint8))


def vectors(driver_output: Path) -> None:
    rows: dict[str, list[list[str]]] = {name: [] for name in (*SAMPLERS, "float")}
    for line in driver_output.read_text().splitlines():
        name, *fields = line.split()
        rows[name].append(fields)
    out: dict[str, np.ndarray] = {}
    for name in SAMPLERS:
        table = rows[name]
        out[f"{name}_lanes"] = np.array([[int(f) for f in r[:5]] for r in table], dtype=np.int64)
        hexes = np.array([[int(f, 16) for f in r[5:]] for r in table], dtype=np.uint32)
        out[f"{name}_words"], out[f"{name}_floats"] = hexes[:, :4], hexes[:, 4:]
    pairs = np.array([[int(f, 16) for f in r] for r in rows["float"]], dtype=np.uint32)
    out["float_words"], out["float_bits"] = pairs[:, 0], pairs[:, 1]
    np.savez_compressed(HERE / "vectors.npz", **out)


if __name__ == "__main__":
    command, path = sys.argv[1], Path(sys.argv[2])
    {"tables": tables, "vectors": vectors}[command](path)
