#!/bin/sh
# CPU time of 600 s of attract mode: idle.touch minus setup.touch, each run $1 times (default
# 3), with the release build
# (VOLASSO=target/debug/volasso for the debug one). Prints user+system seconds of each run and the share of one core.
set -eu
runs=${1:-3}
bin=${VOLASSO:-target/release/volasso}
dir=$(dirname "$0")
cpu() {
    /usr/bin/time -f "%U %S" -o /tmp/attract-cpu.$$ "$bin" replay "$dir/$1" >/dev/null 2>&1
    awk '{ printf "%.2f\n", $1 + $2 }' /tmp/attract-cpu.$$
}
for i in $(seq "$runs"); do
    setup=$(cpu setup.touch)
    idle=$(cpu idle.touch)
    echo "run $i: setup ${setup} s, setup + 600 s playing ${idle} s, playing $(echo "$idle $setup" | awk '{ printf "%.2f s = %.1f %% of one core", $1 - $2, 100 * ($1 - $2) / 600 }')"
done
rm -f /tmp/attract-cpu.$$
