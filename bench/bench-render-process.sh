#!/usr/bin/env bash
# The whole `btfgmm render MODEL -o OUT.png` process (800 x 800, the command's defaults: a
# sphere, M = the model's), timed by hyperfine, for one btfgmm or several side by side: each
# round runs every binary in turn (10 runs after a warm-up each), so that a change in the
# machine's load falls on all of them alike; the load average before each round. Then, where
# bench_render is built, the process's stages once each (bench_render --stages).
#
#   bench/bench-render-process.sh [--rounds R] [--bench-render PATH] MODEL [BTFGMM...]
#
# MODEL: a .btfgmm (e.g. btfgmm generate --material corduroy --size 32 -o cord32 && btfgmm fit
# cord32 --tile 0,0,16,16 -M 600 --iterations 24 -o cord16_m600.btfgmm). BTFGMM: the binaries
# to compare (default build/btfgmm).
set -euo pipefail

rounds=3 bench_render=build/bench_render
while [ $# -gt 0 ]; do
  case "$1" in
    --rounds) rounds=$2; shift 2 ;;
    --bench-render) bench_render=$2; shift 2 ;;
    -h | --help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench-render-process: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) break ;;
  esac
done
[ $# -ge 1 ] || { echo "bench-render-process: give the model (see --help)" >&2; exit 2; }
model=$1
shift
binaries=("$@")
[ ${#binaries[@]} -gt 0 ] || binaries=(build/btfgmm)
command -v hyperfine >/dev/null || { echo "bench-render-process: needs hyperfine (Debian hyperfine)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

for ((r = 1; r <= rounds; ++r)); do
  echo "round $r: $(uptime)"
  for b in "${binaries[@]}"; do
    hyperfine -w 1 -r 10 -N --style basic \
      "$b render $model -o $work/out.png --overwrite" 2>&1 | grep -E 'Benchmark|Time|Range'
  done
done
if [ -x "$bench_render" ]; then
  echo "stages ($bench_render --stages): $(uptime)"
  "$bench_render" --stages "$work/stages.png" --model "$model"
fi
