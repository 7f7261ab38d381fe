#!/usr/bin/env bash
# Compares the cloud cost of the peer crate bevy-volumetric-clouds 0.2 with bevy_cloudscape's
# presets at one window size.
#
#   bench/peer/compare.sh [W H]     (default 1920 1080)
#
# The peer is timed with its clouds on and off (bench/peer, a window of W×H); its cost is the
# difference of the two medians. Then bevy_cloudscape's bench times LOW and MEDIUM at W×H
# (their cost, likewise with minus without clouds, is its `ms_per_frame` column). More
# arguments for the peer go in PEER_ARGS, e.g. PEER_ARGS="--frames 600 --warmup 200".
set -euo pipefail

width="${1:-1920}"
height="${2:-1080}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"

manifest=bench/peer/Cargo.toml
read -r -a peer_args <<< "${PEER_ARGS:-}"

peer() {
  # stdout carries one `peer,...` line; Bevy's log goes to stderr.
  cargo run --release --quiet --manifest-path "$manifest" -- \
    --width "$width" --height "$height" --clouds "$1" "${peer_args[@]}" | grep '^peer,' | tail -n 1
}

cargo build --release --manifest-path "$manifest"
on_line="$(peer on)"
off_line="$(peer off)"
on_ms="${on_line##*,}"
off_ms="${off_line##*,}"
cost_ms="$(awk -v on="$on_ms" -v off="$off_ms" 'BEGIN { printf "%.3f", on - off }')"
cost_line="peer,cost,${width},${height},${cost_ms}"

echo "$on_line"
echo "$off_line"
echo "peer cloud cost at ${width}x${height}: ${cost_ms} ms (on ${on_ms} ms - off ${off_ms} ms)"

echo "bevy_cloudscape at ${width}x${height} (ms_per_frame: cloud pass cost):"
cargo run --release --example bench -- --time-only --presets LOW,MEDIUM \
  --width "$width" --height "$height" --frames 5 --out /tmp/bench_compare

echo "$cost_line"
