#!/usr/bin/env bash
# Frame and classification times on a machine with a GPU, at 1920x1080: the engine (256^3), the
# cranium CT (256x256x108 int16) and a 512^3 volume (the engine resampled twice as fine,
# `render_benchmark --upsample 2`), each post-classified and pre-classified full frames and the
# progressive preview (`examples/render_benchmark`, median of 30 frames after 3 warm-up frames,
# each waited for); then `volasso classify --repeat 5` on the engine and the cranium with their
# benchmark lassos (the classifier runs on the CPU; its JSON line carries the median seconds).
#
#   benches/gpu.sh            # builds the release binaries first when they are missing
#   FRAMES=60 benches/gpu.sh
#
# Where wgpu finds no GPU (no adapter, or only a CPU driver such as lavapipe or llvmpipe) it
# says so and exits 0 without measuring: CPU figures come from render_benchmark and
# benches/render_vs_vtk.sh. The measuring part takes well under 3 minutes on a GPU (building
# the release binaries, when needed, comes before and is timed apart). Data: ../shared/data.
set -euo pipefail
cd "$(dirname "$0")/.."

frames=${FRAMES:-30}
size=1920x1080
data=../shared/data
benchmark=target/release/examples/render_benchmark
volasso=target/release/volasso

if [[ ! -x $benchmark || ! -x $volasso ]]; then
    start=$SECONDS
    cargo build --release --bin volasso --example render_benchmark
    echo "build: $((SECONDS - start)) s (not part of the measurement)"
fi

if ! adapter=$("$benchmark" --adapter-only 2>/dev/null); then
    echo "no GPU: wgpu found no adapter at all; nothing measured"
    exit 0
fi
echo "$adapter"
if grep -q 'device type Cpu' <<<"$adapter"; then
    echo "no GPU: the only adapter is a CPU driver; nothing measured (CPU figures:" \
        "render_benchmark and benches/render_vs_vtk.sh)"
    exit 0
fi

start=$SECONDS
frame_times() {
    "$benchmark" "$@" "$size" --frames "$frames" 2>/dev/null | grep -E '^(volume|render-)'
}
echo "== engine 256^3"
frame_times "$data/engine_256x256x256_uint8.raw"
echo "== cranium 256x256x108 int16"
frame_times "$data/cranium_ct_256x256x108_int16.raw" --spacing 0.957,0.957,1.5
echo "== 512^3 (engine resampled)"
frame_times "$data/engine_256x256x256_uint8.raw" --upsample 2

echo "== classification (CPU), median of 5"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
"$volasso" classify "$data/engine_256x256x256_uint8.raw" --strokes benches/strokes/engine.strokes.json \
    --out "$out/engine.nrrd" --repeat 5 | sed 's/^/engine: /'
"$volasso" classify "$data/cranium_ct_256x256x108_int16.raw" --spacing 0.957,0.957,1.5 \
    --strokes benches/strokes/cranium.strokes.json --out "$out/cranium.nrrd" --repeat 5 | sed 's/^/cranium: /'
echo "measured in $((SECONDS - start)) s"
