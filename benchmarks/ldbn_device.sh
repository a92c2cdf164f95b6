#!/usr/bin/env bash
# The LDBN key sets on a borrowed GPU (issue 40, item 2): python -m bnerr.ldbn.device.
#
# Run from the repository root (a copy of the working tree) with $OUT the folder that comes back:
#     bash benchmarks/ldbn_device.sh
# It times one descent iteration (64 and 128 tiles, pairs alone and batched), then optimizes the
# 128x128 screen set (spp 1..64, D = 12) and the 128x128x4 spatiotemporal set (spp 1..16, D = 12),
# stopping cleanly BUDGET seconds after the start (default 400): checkpoints after every round,
# the finished tables and NOTE.txt (what finished) in $OUT. To continue a stopped run, copy the
# checkpoints that came back into a folder of the working tree and name it:
#     RESUME=path/to/them bash benchmarks/ldbn_device.sh
# Extra arguments go to the Python entry (e.g. --tiny --device cpu --sets screen_128: the test).
# Imports: torch and numpy only (no kornia, OpenEXR, scipy, tqdm).
set -euo pipefail
cd "$(dirname "$0")/.."
: "${OUT:?set OUT to the output folder}"
mkdir -p "$OUT"
if [ -n "${RESUME:-}" ]; then
    for f in "$RESUME"/*.ckpt.npz; do
        [ -e "$f" ] && cp -v "$f" "$OUT"/
    done
fi
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
export CUBLAS_WORKSPACE_CONFIG=:4096:8  # deterministic cuBLAS
echo "ldbn_device: $(date -u +%FT%TZ) on $(hostname); python ${PYTHON:-python3}"
exec "${PYTHON:-python3}" -m bnerr.ldbn.device --out "$OUT" --measure 64 128 \
    --budget "${BUDGET:-400}" "$@"
