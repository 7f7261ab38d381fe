#!/usr/bin/env bash
# Compares the cloud cost of the peer crate bevy-volumetric-clouds 0.2 with bevy_cloudscape's
# presets at one window size, on one machine in one run.
#
#   bench/peer/compare.sh [W H]     (default 1920 1080)
#
# The peer is timed with its clouds on and off (bench/peer, a window of W×H); its cost is the
# difference of the two medians. Then bevy_cloudscape's bench times LOW, MEDIUM and HIGH at W×H
# (their cost, likewise with minus without clouds, is its `ms_per_frame` column). Both sides are
# built with the same Cargo profile: PROFILE=release (the default) or PROFILE=dev. More
# arguments for the peer go in PEER_ARGS, e.g. PEER_ARGS="--frames 600 --warmup 200", and for
# the crate's bench in OURS_ARGS. The side-by-side rows are printed and appended to
# $OUT/peer.csv (OUT default /tmp/bench_compare), which `bench --from-csv` puts in
# docs/performance.md.
set -euo pipefail

width="${1:-1920}"
height="${2:-1080}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cd "$root"

manifest=bench/peer/Cargo.toml
read -r -a peer_args <<< "${PEER_ARGS:-}"
read -r -a ours_args <<< "${OURS_ARGS:-}"
profile="${PROFILE:-release}"
out="${OUT:-/tmp/bench_compare}"
mkdir -p "$out"

peer() {
  # stdout carries one `peer,...` line; Bevy's log goes to stderr.
  cargo run --profile "$profile" --quiet --manifest-path "$manifest" -- \
    --width "$width" --height "$height" --clouds "$1" "${peer_args[@]}" | grep '^peer,' | tail -n 1
}

cargo build --profile "$profile" --manifest-path "$manifest"
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
rm -rf "$out/ours"
cargo run --profile "$profile" --example bench -- --time-only --scene cumulus_noon \
  --presets LOW,MEDIUM,HIGH --sizes "${width}x${height}" --frames 5 --out "$out/ours" "${ours_args[@]}"

echo "$cost_line"
[ -s "$out/peer.csv" ] ||
  echo "width,height,peer_on_ms,peer_off_ms,peer_cost_ms,preset,ms_per_frame,share_of_peer" >"$out/peer.csv"
awk -F, -v w="$width" -v h="$height" -v on="$on_ms" -v off="$off_ms" -v cost="$cost_ms" \
  'NR > 1 && $3 == w && $4 == h { printf "%s,%s,%.1f,%.1f,%.1f,%s,%.1f,%.2f\n", w, h, on, off, cost, $2, $6, $6 / cost }' \
  "$out/ours/times.csv" | tee -a "$out/peer.csv"
