#!/usr/bin/env bash
# The default fit (--objective prediction) of generated tiles for several M, with two builds
# (an older one and this one), one run after the other: the fit's wall time, the true file
# size and ratio, PSNR and SSIM over every image of the tile (btfgmm compare --json). One
# markdown row a run, appended to OUT as it finishes (a long table can be cut short and still
# holds every run done).
#
#   bench/bench-refine-table.sh --out FILE [--before PATH] [--after PATH] [--work DIR]
#                               [--tiles "knit25 corduroy25 ..."] [--components "300 600"]
#                               [--iterations N] [--builds "after before"]
#
# A tile is MATERIAL followed by its size (btfgmm generate --material MATERIAL --size S,
# seed 1, ubo81 directions), generated once in the work folder. --builds "before" fits with the
# older build alone (this one still generates the tiles and measures every model).
set -euo pipefail

after=${BTFGMM:-build/btfgmm} before='' work='' out=''
tiles="knit25 corduroy25 leather25 knit32 corduroy32 leather32"
components="300 600 1200 2400" iterations=40 builds="after before"
while [ $# -gt 0 ]; do
  case "$1" in
    --before) before=$2; shift 2 ;;
    --after) after=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --tiles) tiles=$2; shift 2 ;;
    --components) components=$2; shift 2 ;;
    --iterations) iterations=$2; shift 2 ;;
    --builds) builds=$2; shift 2 ;;
    -h | --help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-refine-table: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -n "$out" ] || { echo "bench-refine-table: give --out FILE" >&2; exit 2; }
[ -x "$after" ] || { echo "bench-refine-table: no btfgmm at '$after'" >&2; exit 2; }
[ -n "$work" ] || work=$(mktemp -d)
mkdir -p "$work"
echo "| tile | M | build | file bytes | true ratio | PSNR dB | SSIM | fit time s |" >> "$out"
echo "|---|---|---|---|---|---|---|---|" >> "$out"
for tile in $tiles; do
  material=${tile%%[0-9]*} size=${tile#"$material"}
  [ -d "$work/$tile" ] || "$after" generate --material "$material" --size "$size" -o "$work/$tile" -q
  for m in $components; do
    for build in $builds; do
      exe=$after
      [ "$build" = before ] && exe=$before
      [ -n "$exe" ] || continue
      model=$work/$tile-$m-$build.btfgmm
      start=$(date +%s.%N)
      "$exe" fit "$work/$tile" -M "$m" --iterations "$iterations" -q -o "$model" \
        > "$model.log" 2>&1 || { echo "| $tile | $m | $build | failed: $(tail -1 "$model.log") |" >> "$out"; continue; }
      seconds=$(awk -v a="$(date +%s.%N)" -v b="$start" 'BEGIN { printf "%.1f", a - b }')
      "$after" compare "$work/$tile" "$model" --json -q > "$model.json"
      python3 - "$model.json" "$tile" "$m" "$build" "$seconds" >> "$out" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
d = d[0] if isinstance(d, list) else d
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {d['file_bytes']} | "
      f"1:{d['compression_ratio_file']:.0f} | {d['psnr_db']:.2f} | {d['ssim']:.4f} | "
      f"{float(sys.argv[5]):.0f} |")
PY
    done
  done
done
