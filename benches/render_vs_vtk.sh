#!/usr/bin/env bash
# volasso's ray caster against VTK's shaded GPU ray caster (vtkGPUVolumeRayCastMapper) on the
# same machine, volume, image size, camera, classes and sample distance, in one run.
#
#   benches/render_vs_vtk.sh [ROUNDS] [FRAMES]      (defaults 3 rounds of 5 frames)
#   VOLUME=... DIMS=X,Y,Z TYPE=uint8 SPACING=X,Y,Z SIZE=1280x800 benches/render_vs_vtk.sh
#
# Each round runs examples/render_benchmark (post-classified and pre-classified full frames,
# the preview) and then benches/vtk_raycast.py, one after the other, and prints the ratio
# VTK / volasso of that round's medians. On a shared machine the load changes between runs:
# the median of the rounds' ratios is the figure to quote, not a ratio of separate runs.
# Needs `pip install vtk numpy` and a release build (`cargo build --release --example
# render_benchmark`); without a GPU both draw on Mesa's CPU drivers (lavapipe, llvmpipe).
set -euo pipefail
cd "$(dirname "$0")/.."

rounds=${1:-3}
frames=${2:-5}
volume=${VOLUME:-../shared/data/engine_256x256x256_uint8.raw}
dims=${DIMS:-256,256,256}
type=${TYPE:-uint8}
spacing=${SPACING:-1,1,1}
size=${SIZE:-1280x800}
benchmark=target/release/examples/render_benchmark
[[ -x $benchmark ]] || { echo "build first: cargo build --release --example render_benchmark" >&2; exit 1; }

median_of() { grep -F -- "$1" | sed -E 's/.*: median ([0-9.]+) ms.*/\1/' | head -n 1; }
post_ratios=()
pre_ratios=()
for round in $(seq 1 "$rounds"); do
    ours=$("$benchmark" "$volume" "$size" --spacing "$spacing" --frames "$frames" 2>/dev/null)
    theirs=$(python3 benches/vtk_raycast.py "$volume" --dims "$dims" --type "$type" --spacing "$spacing" \
        --size "$size" --frames "$frames" 2>/dev/null)
    [[ $round == 1 ]] && { grep -E '^(adapter|volume):' <<<"$ours"; grep '^vtk renderer' <<<"$theirs"; }
    post=$(median_of "render-Postclassified-default-$size" <<<"$ours")
    pre=$(median_of "render-Preclassified-default-$size" <<<"$ours")
    preview=$(median_of "render-Postclassified-preview-$size" <<<"$ours")
    vtk=$(median_of "vtk-shaded-$size" <<<"$theirs")
    post_ratio=$(awk -v a="$vtk" -v b="$post" 'BEGIN { printf "%.2f", a / b }')
    pre_ratio=$(awk -v a="$vtk" -v b="$pre" 'BEGIN { printf "%.2f", a / b }')
    post_ratios+=("$post_ratio")
    pre_ratios+=("$pre_ratio")
    echo "round $round: volasso post $post ms, pre $pre ms, preview $preview ms; VTK shaded $vtk ms;" \
        "VTK/post $post_ratio, VTK/pre $pre_ratio"
done
median() { printf '%s\n' "$@" | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }
echo "median over $rounds rounds: VTK shaded / volasso post-classified $(median "${post_ratios[@]}")x," \
    "/ pre-classified $(median "${pre_ratios[@]}")x"
