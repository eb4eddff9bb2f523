#!/usr/bin/env bash
# Opening a Bonn .btf file and converting a tile of it: time and peak memory of the whole
# `btfgmm convert FILE --tile 0,0,T,T -o DIR` process (/usr/bin/time -v), for a 400 x 400 DFMF
# of 151 lights x 151 views with 20 components per channel written by the tests' writer
# (bench_ubo_write). Beside it, its peers in separate processes: `btfgmm info` (the opening
# alone: header and angular factors) and the same conversion of a tile twice as wide (memory
# proportional to the tile: the tile's factors and one decoded image per thread).
#
#   bench/bench-ubo.sh [--size W] [--components C] [--tile T] [BUILD]
#
# BUILD: the build folder holding btfgmm and bench_ubo_write (default build).
set -euo pipefail

size=400 components=20 tile=32
while [ $# -gt 0 ]; do
  case "$1" in
    --size) size=$2; shift 2 ;;
    --components) components=$2; shift 2 ;;
    --tile) tile=$2; shift 2 ;;
    -h | --help) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench-ubo: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) break ;;
  esac
done
build=${1:-build}
[ -x /usr/bin/time ] || { echo "bench-ubo: needs /usr/bin/time (Debian time)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$build/bench_ubo_write" "$work/m.btf" --size "$size" --components "$components"

# seconds and peak resident KiB of one command
measure() {
  /usr/bin/time -v "$@" >"$work/out" 2>"$work/time" || { cat "$work/out" "$work/time" >&2; exit 1; }
  local secs kib
  secs=$(sed -n 's/.*Elapsed (wall clock) time (h:mm:ss or m:ss): //p' "$work/time" |
    awk -F: '{ s = 0; for (i = 1; i <= NF; ++i) s = s * 60 + $i; print s }')
  kib=$(sed -n 's/.*Maximum resident set size (kbytes): //p' "$work/time")
  echo "$secs $kib"
}

read -r t_info m_info < <(measure "$build/btfgmm" info "$work/m.btf")
read -r t_conv m_conv < <(measure "$build/btfgmm" convert "$work/m.btf" --tile "0,0,$tile,$tile" -q -o "$work/t1")
t2=$((2 * tile))
read -r t_conv2 m_conv2 < <(measure "$build/btfgmm" convert "$work/m.btf" --tile "0,0,$t2,$t2" -q -o "$work/t2")
images=$(find "$work/t1" -name '*.exr' | wc -l)
awk -v ti="$t_info" -v mi="$m_info" -v tc="$t_conv" -v mc="$m_conv" -v t2c="$t_conv2" \
  -v m2c="$m_conv2" -v tile="$tile" -v t2="$t2" -v images="$images" 'BEGIN {
  printf "%-44s %10s %12s\n", "process", "seconds", "peak MiB"
  printf "%-44s %10.2f %12.1f\n", "info (open: header, U)", ti, mi / 1024
  printf "%-44s %10.2f %12.1f\n", "convert --tile 0,0," tile "," tile " (" images " EXR images)", tc, mc / 1024
  printf "%-44s %10.2f %12.1f\n", "convert --tile 0,0," t2 "," t2, t2c, m2c / 1024
  printf "ratios: convert / info peak memory %.2f; %dx%d / %dx%d tile: time %.2f, peak memory %.2f\n", mc / mi, t2, t2, tile, tile, t2c / tc, m2c / mc
}'
