#!/usr/bin/env bash
# The EM iteration of this build beside an earlier revision's, on the same tile, one after the
# other: the benchmark that catches an iteration grown slower (docs/BENCHMARKS.md).
#
#   bench/bench-em-history.sh [--rev REV | --old-btfgmm PATH] [--btfgmm PATH] [--tile T]
#                             [-M M] [--threads N] [--runs R] [--work DIR]
#
# Builds REV's command (default 0288a93, the last revision before the per-light statistics
# and the wrapped tile) in a temporary worktree of this repository, or takes --old-btfgmm.
# Generates a T x T corduroy (81 x 81 directions; default 16), then times, with hyperfine, each
# build's paper EM (`fit --objective likelihood`; the old build has no other) of M components
# (default 600) for 22 and for 2 iterations, R runs each (default 3), all four commands
# interleaved; the time of an iteration is (t(22) - t(2)) / 20, which leaves out the loading,
# the first two (densest) iterations and the writing. Prints both and their ratio.
set -euo pipefail

btfgmm=${BTFGMM:-build/btfgmm}
rev=0288a93 old='' tile=16 components=600 threads=0 runs=3 work=''
while [ $# -gt 0 ]; do
  case "$1" in
    --rev) rev=$2; shift 2 ;;
    --old-btfgmm) old=$2; shift 2 ;;
    --btfgmm) btfgmm=$2; shift 2 ;;
    --tile) tile=$2; shift 2 ;;
    -M) components=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    -h | --help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-em-history: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -x "$btfgmm" ] || { echo "bench-em-history: no btfgmm at '$btfgmm'; build first (make build) or give --btfgmm" >&2; exit 2; }
command -v hyperfine >/dev/null || { echo "bench-em-history: needs hyperfine (Debian package hyperfine)" >&2; exit 2; }
btfgmm=$(realpath "$btfgmm")
repo=$(cd "$(dirname "$0")/.." && pwd)
if [ -z "$work" ]; then
  work=$(mktemp -d)
  trap 'git -C "$repo" worktree remove --force "$work/src" 2>/dev/null || true; rm -rf "$work"' EXIT
fi
mkdir -p "$work"

if [ -z "$old" ]; then
  echo "building $rev's btfgmm in $work/src (minutes)" >&2
  git -C "$repo" worktree add --detach "$work/src" "$rev" >/dev/null
  cmake -S "$work/src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release -DBTFGMM_TESTS=OFF \
    -DBTFGMM_BENCH=OFF >/dev/null
  cmake --build "$work/build" -j"$(nproc)" --target btfgmm_cli >/dev/null
  old=$work/build/btfgmm
else
  rev=$old
fi
old=$(realpath "$old")

echo "generating a ${tile} x ${tile} corduroy (81 x 81 directions) in $work/btf" >&2
"$btfgmm" generate --material corduroy --size "$tile" --seed 7 -o "$work/btf" -q --overwrite

# The fit command of a build for K iterations; the paper's EM where the build has a choice.
fit_command() {
  local bin=$1 k=$2 name=$3 objective=''
  if "$bin" fit --help 2>&1 | grep -q -- '--objective'; then objective='--objective likelihood'; fi
  echo "$bin fit $work/btf -M $components --iterations $k --seed 7 --threads $threads" \
    "$objective -o $work/$name-$k.btfgmm --overwrite -q"
}
commands=()
for k in 22 2; do
  commands+=("$(fit_command "$old" "$k" old)" "$(fit_command "$btfgmm" "$k" new)")
done
hyperfine -N -w 1 -r "$runs" --export-json "$work/times.json" "${commands[@]}" >&2

python3 - "$work/times.json" "$rev" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))["results"]
mean = [x["mean"] for x in r]
old = (mean[0] - mean[2]) / 20
new = (mean[1] - mean[3]) / 20
print(f"| build | s per EM iteration ((t(22) - t(2)) / 20) |\n|---|---|")
print(f"| {sys.argv[2]} | {old:.4f} |\n| this build | {new:.4f} |")
print(f"\nthis build / {sys.argv[2]}: {new / old:.2f}")
EOF
