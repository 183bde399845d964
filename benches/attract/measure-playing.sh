#!/bin/sh
# CPU time of attract mode while it plays: runs idle.touch (the turn prepared, then 600 s of
# script time playing) and reads the process's CPU time from /proc/PID/stat when the turn is
# ready (its log line) and from /usr/bin/time at the end; the difference is what 600 s of
# playing cost. VOLASSO picks the binary (default the release build).
set -eu
bin=${VOLASSO:-target/release/volasso}
dir=$(dirname "$0")
log=$(mktemp); total=$(mktemp)
RUST_LOG=info /usr/bin/time -f "%U %S" -o "$total" "$bin" replay "$dir/idle.touch" >/dev/null 2>"$log" &
sleep 0.2
pid=$(pgrep -n -f "replay $dir/idle.touch")
ticks=$(getconf CLK_TCK)
ready=""
while kill -0 "$pid" 2>/dev/null; do
    if [ -z "$ready" ] && grep -q "pictures of .* ready" "$log"; then
        ready=$(awk -v t="$ticks" '{ printf "%.2f", ($14 + $15) / t }' "/proc/$pid/stat")
    fi
    sleep 0.05
done
wait
end=$(awk '{ printf "%.2f", $1 + $2 }' "$total")
echo "CPU at the turn ready: ${ready} s; at the end: ${end} s; 600 s playing: $(echo "$end $ready" | awk '{ printf "%.2f s = %.2f %% of one core", $1 - $2, 100 * ($1 - $2) / 600 }')"
rm -f "$log" "$total"
