#!/usr/bin/env bash
# The paper's fit (--objective likelihood) beside the default fit for the prediction, on the
# same tile with the same M, iterations and seed, one after the other: fit time, its ratio,
# the true file size and ratio, and PSNR / SSIM over every image (btfgmm compare --json), and
# a report with both models side by side (btfgmm compare --report).
#
#   bench/bench-objective.sh [--btfgmm PATH] (--btf DIR | --size S [--lights SET] [--views SET])
#                            [-M M] [--iterations N] [--work DIR]
#
# --size generates a knit BTF of S x S pixels (seed 5) in the work folder.
set -euo pipefail

btfgmm=${BTFGMM:-build/btfgmm}
btf='' size='' lights=ubo81 views=ubo81 components=600 iterations=40 work=''
while [ $# -gt 0 ]; do
  case "$1" in
    --btfgmm) btfgmm=$2; shift 2 ;;
    --btf) btf=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --lights) lights=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    -M) components=$2; shift 2 ;;
    --iterations) iterations=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    -h | --help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-objective: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -n "$btf" ] || [ -n "$size" ] || { echo "bench-objective: give --btf DIR or --size S (e.g. btfgmm generate --material knit --size 25 --seed 5 -o knit25)" >&2; exit 2; }
[ -x "$btfgmm" ] || { echo "bench-objective: no btfgmm at '$btfgmm'; build first or give --btfgmm" >&2; exit 2; }
if [ -z "$work" ]; then
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work"
if [ -z "$btf" ]; then
  btf=$work/btf
  "$btfgmm" generate --material knit --size "$size" --seed 5 --lights "$lights" --views "$views" \
    -o "$btf" -q --overwrite
fi

printf '%-11s %9s %7s %11s %11s %8s %7s  %s\n' objective fit_s ratio file_bytes true_ratio PSNR_dB SSIM load
first=''
for objective in likelihood prediction; do
  model=$work/$objective.btfgmm
  load=$(cut -d' ' -f1 /proc/loadavg)
  start=$(date +%s.%N)
  "$btfgmm" fit "$btf" -M "$components" --iterations "$iterations" --seed 1 \
    --objective "$objective" -o "$model" --overwrite -q
  seconds=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.3f", b - a }')
  [ -z "$first" ] && first=$seconds
  "$btfgmm" compare "$btf" "$model" --json -q > "$work/$objective.json"
  /usr/bin/python3 - "$work/$objective.json" "$objective" "$seconds" "$first" "$load" <<'EOF'
import json, sys
c = json.load(open(sys.argv[1]))
seconds, first = float(sys.argv[3]), float(sys.argv[4])
ratio = seconds / first if first > 0 else float("nan")  # a tiny fit may take under a millisecond
print(f"{sys.argv[2]:<11} {seconds:9.1f} {ratio:7.2f} {c['file_bytes']:>11,} "
      f"{'1:%.1f' % c['compression_ratio_file']:>11} {c['psnr_db']:8.2f} {c['ssim']:7.3f}  {sys.argv[5]}")
EOF
done
"$btfgmm" compare "$btf" "$work/likelihood.btfgmm" "$work/prediction.btfgmm" --report "$work/report" \
  --overwrite -q > /dev/null
echo "report with both models side by side: $work/report/index.html"
