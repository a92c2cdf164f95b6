#!/usr/bin/env bash
# The GPU check: one call on a machine with a CUDA device, from the repository root, every part
# under `timeout` and the whole within 300 s of wall time (most important first).
#
#   1. the machine: nvidia-smi -L, torch's and CUDA's versions            -> $OUT/device.txt
#   2. tests/test_cuda.py and every test that has a CUDA branch, -n 8     -> $OUT/cuda_tests.log
#   3. bnerr bench on CUDA and on the CPU, side by side (direct; white, temporal, oracle; 1 and 4
#      spp; 128x128; 2 seed sets; gaussian): wall time and per-frame timings
#                                                     -> $OUT/bench_device.json, bench_device.md
#   4. the speed scripts that take --device (permute, copy, sequences) on CUDA
#                                                     -> $OUT/speed_cuda.txt
#
# Assumes the optional wheels are installed and PYTHONPATH is set, e.g.
#   python3 -m pip install -q --no-index --no-deps --no-compile --target /tmp/site .whl/*.whl \
#     && export PYTHONPATH=/tmp/site:$PWD && bash benchmarks/device_check.sh
#
# Dry run on a machine without a GPU (tiny sizes, the CPU standing in for the GPU, no -n):
#   DEVICE=cpu OUT=/tmp/out PYTHON=.venv/bin/python bash benchmarks/device_check.sh
# Nothing here writes results/: a GPU run's figures go to results/speed/ only by hand from
# $OUT, labelled with the device (docs/USAGE.md, "GPU runs").
set -u
PY=${PYTHON:-python3}
DEVICE=${DEVICE:-cuda}
OUT=${OUT:?set OUT to the folder the results go to}
BUDGET=${BUDGET:-290}
mkdir -p "$OUT"
START=$(date +%s)
export PYTHONUNBUFFERED=1 BNERR_COMPILE=0

stamp() { echo "[$(date +%H:%M:%S) +$(($(date +%s) - START))s] $*"; }
# seconds for the next part: at most $1, never past the budget (0: skip it)
cap() {
  local left=$((START + BUDGET - $(date +%s)))
  if [ "$left" -lt 10 ]; then echo 0; elif [ "$left" -lt "$1" ]; then echo "$left"; else echo "$1"; fi
}
run_for() {  # run_for SECONDS LABEL CMD...: the command under timeout, its status said
  local secs=$1 label=$2
  shift 2
  if [ "$secs" -eq 0 ]; then stamp "$label: skipped (out of time)"; return 0; fi
  stamp "$label: start (at most ${secs}s)"
  timeout -k 5 "$secs" "$@"
  local rc=$?
  stamp "$label: exit $rc$([ $rc -eq 124 ] && echo ' (timed out)')"
  return 0
}

if [ "$DEVICE" = cpu ]; then  # the dry run: tiny sizes, the CPU standing in
  export BNERR_TEST_DEVICE=cpu
  TESTS_K=(-k "metrics or denoiser_gives and gaussian")
  XDIST=()
  RES=16x16 REF_SPP=16 SPEED_W=64 SPEED_H=32 SEQ_N=4096 REPEATS=2
else
  TESTS_K=()
  XDIST=(-n 8)
  RES=128x128 REF_SPP=128 SPEED_W=1920 SPEED_H=1080 SEQ_N=1048576 REPEATS=20
fi

# 1. the machine --------------------------------------------------------------------------------
{
  stamp "machine"
  if command -v nvidia-smi >/dev/null; then nvidia-smi -L; else echo "no nvidia-smi"; fi
  "$PY" - <<'EOF'
import torch
print(f"torch {torch.__version__}, CUDA {torch.version.cuda}, available {torch.cuda.is_available()}")
for i in range(torch.cuda.device_count()):
    print(f"  cuda:{i} {torch.cuda.get_device_name(i)}")
print(f"cudnn {torch.backends.cudnn.version()}, tf32 conv {torch.backends.cudnn.allow_tf32}")
EOF
  nproc
} 2>&1 | tee "$OUT/device.txt"

# 2. the tests ----------------------------------------------------------------------------------
# tests/test_cuda.py whole, plus the test functions of other files that mention CUDA (their
# decorators or bodies: the `needs CUDA` skips), found now so that a new one is not missed.
mapfile -t CUDA_TESTS < <("$PY" - <<'EOF'
import ast
import pathlib

for path in sorted(pathlib.Path("tests").rglob("test_*.py")):
    if path.name == "test_cuda.py" or "cuda" not in path.read_text():
        continue
    text = path.read_text()
    for node in ast.parse(text).body:
        if isinstance(node, ast.FunctionDef) and node.name.startswith("test"):
            if "cuda" in (ast.get_source_segment(text, node) or "") or any(
                "cuda" in (ast.get_source_segment(text, d) or "") for d in node.decorator_list
            ):
                print(f"{path} {node.name}")
EOF
)
# Files and a -k of the functions' names, not file::function ids: given 26 such ids with -n 8 on
# the H200 (pytest 9, xdist, pytest-benchmark installed there) pytest collected none of them.
CUDA_FILES=() NAMES=()
for line in "${CUDA_TESTS[@]}"; do CUDA_FILES+=("${line% *}"); NAMES+=("${line#* }"); done
mapfile -t CUDA_FILES < <(printf '%s\n' "${CUDA_FILES[@]}" | sort -u)
SELECT=$(printf ' or %s' "${NAMES[@]}")
stamp "tests: tests/test_cuda.py and ${#CUDA_TESTS[@]} CUDA tests elsewhere" | tee "$OUT/cuda_tests.log"
run_for "$(cap 60)" "tests: test_cuda.py" "$PY" -m pytest -q -p no:cacheprovider -p no:benchmark \
  -rs "${XDIST[@]}" "${TESTS_K[@]}" tests/test_cuda.py >>"$OUT/cuda_tests.log" 2>&1
run_for "$(cap 60)" "tests: elsewhere" "$PY" -m pytest -q -p no:cacheprovider -p no:benchmark \
  -rs "${XDIST[@]}" -k "${SELECT# or }" "${CUDA_FILES[@]}" >>"$OUT/cuda_tests.log" 2>&1
tail -n 25 "$OUT/cuda_tests.log"

# 3. bnerr bench on the device and on the CPU ---------------------------------------------------
bench() {  # bench DEVICE: the sweep into $OUT/../bench_DEVICE (not $OUT: only its files return)
  local dev=$1 dir="$WORK/bench_${1//:/_}"
  local t0
  t0=$(date +%s%N)
  run_for "$(cap 60)" "bench --device $dev" "$PY" -m benchmarks.cli bench --suite quick \
    --scenes direct --strategies white temporal oracle --denoisers gaussian --spp 1 4 \
    --res "$RES" --seed-sets 2 --frames 2 --warmup 2 --reference-spp "$REF_SPP" --quiet \
    --no-charts --out "$dir/results" --cache "$dir/cache" --device "$dev" \
    >"$dir.log" 2>&1
  echo "$((($(date +%s%N) - t0) / 1000000))" >"$dir.wall"  # milliseconds
  tail -n 3 "$dir.log"
}
WORK=$(mktemp -d)
bench "$DEVICE"
[ "$DEVICE" = cpu ] || bench cpu
stamp "bench: summary"
"$PY" - "$WORK" "$OUT" "$DEVICE" <<'EOF'
import json
import statistics
import sys
from pathlib import Path

import torch

from benchmarks.sweep.records import load_records

work, out, device = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]


def mean(rows):
    return statistics.fmean(v for row in rows for v in row)


summary = {"torch": torch.__version__, "cuda": torch.version.cuda, "runs": {}}
for dev in dict.fromkeys([device, "cpu"]):
    folder = work / f"bench_{dev.replace(':', '_')}"
    wall = folder.with_suffix(".wall")
    run = {"wall_s": int(wall.read_text()) / 1e3 if wall.exists() else None, "cells": {}}
    try:
        records = load_records(folder / "results")
    except Exception as err:  # a run cut short: say so, keep the other
        records, run["error"] = [], str(err)
    for r in records:
        if r.cell.region != "all":
            continue
        run["cells"][f"{r.cell.strategy}/{r.cell.spp}spp"] = {
            "render_ms": mean(r.timings.render_ms),
            "perm_ms": mean(r.timings.perm_ms),
            "denoise_ms": mean(r.timings.denoise_ms),
            "device": r.device,
        }
    summary["runs"][dev] = run
(out / "bench_device.json").write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n")
devs = list(summary["runs"])
keys = sorted({k for run in summary["runs"].values() for k in run["cells"]})
lines = [f"# bnerr bench, {' vs '.join(devs)} (torch {summary['torch']}, CUDA {summary['cuda']})", ""]
lines += ["wall: " + ", ".join(f"{d} {summary['runs'][d]['wall_s']} s" for d in devs), ""]
lines += ["| cell | " + " | ".join(f"{d} render / perm / denoise ms" for d in devs) + " |"]
lines += ["|---|" + "---|" * len(devs)]
for key in keys:
    cells = [summary["runs"][d]["cells"].get(key) for d in devs]
    text = [
        "-" if c is None else f"{c['render_ms']:.2f} / {c['perm_ms']:.2f} / {c['denoise_ms']:.2f}"
        for c in cells
    ]
    lines.append(f"| {key} | " + " | ".join(text) + " |")
(out / "bench_device.md").write_text("\n".join(lines) + "\n")
print("\n".join(lines))
EOF

# 4. the speed scripts on the device ------------------------------------------------------------
{
  run_for "$(cap 30)" "speed.permute" "$PY" -m benchmarks.speed.permute --device "$DEVICE" \
    --width "$SPEED_W" --height "$SPEED_H" --repeats "$REPEATS"
  run_for "$(cap 20)" "speed.copy" "$PY" -m benchmarks.speed.copy --device "$DEVICE" \
    --width "$SPEED_W" --height "$SPEED_H" --repeats "$REPEATS"
  run_for "$(cap 30)" "speed.sequences" "$PY" -m benchmarks.speed.sequences --device "$DEVICE" \
    --n "$SEQ_N" --repeats 3
} >"$OUT/speed_${DEVICE//:/_}.txt" 2>&1
cat "$OUT/speed_${DEVICE//:/_}.txt"
rm -rf "$WORK"
stamp "done"
