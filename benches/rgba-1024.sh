#!/usr/bin/env bash
# Peak memory of `volasso classify --rgba` on a 1024^3 uint8 volume (1 GiB; its labels 1 GiB, its
# RGBA volume 4 GiB), measured with /usr/bin/time -v. Not part of `cargo test`: it takes about a
# minute and a half on two cores and needs 7 GiB of disk (python3 with numpy makes the volume).
#
#   benches/rgba-1024.sh [FOLDER]      # FOLDER defaults to /tmp/volasso-rgba-1024, outside the repository
#
# The volume is a phantom: an ellipsoid of "soft tissue" (80 +- 6) holding a cylinder of "bone"
# (200 +- 6) in air (0), so that about a third of it is labelled; the lassos are
# benches/strokes/phantom-1024.strokes.json, on slice z 512. Uses target/release/volasso
# (`cargo build --release` first) or $VOLASSO.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-/tmp/volasso-rgba-1024}
binary=${VOLASSO:-target/release/volasso}
volume="$work/phantom_1024x1024x1024_uint8.raw"
mkdir -p "$work"
if [ ! -f "$volume" ]; then
    python3 - "$volume" <<'PYTHON'
import sys
import numpy as np
n = 1024
rng = np.random.default_rng(7)
y, x = np.mgrid[0:n, 0:n].astype(np.float32)
with open(sys.argv[1] + ".part", "wb") as out:
    for z in range(n):
        dz = (z - n / 2) / (0.45 * n)
        r2 = ((x - n / 2) / (0.45 * n)) ** 2 + ((y - n / 2) / (0.35 * n)) ** 2 + dz ** 2
        plane = np.zeros((n, n), np.float32)
        plane[r2 < 1.0] = 80
        plane[((x - 0.4 * n) ** 2 + (y - 0.5 * n) ** 2 < (0.08 * n) ** 2) & (abs(dz) < 0.8)] = 200
        plane += rng.normal(0, 6, (n, n)).astype(np.float32) * (plane > 0)
        out.write(np.clip(plane, 0, 255).astype(np.uint8).tobytes())
import os
os.rename(sys.argv[1] + ".part", sys.argv[1])
PYTHON
fi
for rgba in "--rgba $work/rgba.nrrd" ""; do
    # shellcheck disable=SC2086
    /usr/bin/time -v "$binary" classify "$volume" --strokes benches/strokes/phantom-1024.strokes.json \
        --out "$work/labels.nrrd" $rgba >"$work/classify.json" 2>"$work/time.txt"
    peak_kib=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$work/time.txt")
    echo "classify ${rgba:-(labels only)}: peak resident $peak_kib KiB ($((peak_kib * 1024 / 1000000)) MB), $(grep -o '"total":[0-9.]*' "$work/classify.json")"
done
