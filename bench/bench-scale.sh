#!/usr/bin/env bash
# The fit over processes beside the fit in one process, on the same tile (docs/SCALING.md):
# time per EM iteration, peak memory per process, and whether the models are the same bytes.
#
#   bench/bench-scale.sh [--btfgmm PATH] [--size S | --btf DIR] [-M M] [--iterations N]
#                        [--lights SET] [--views SET] [--runs "1x2 2x1"] [--work DIR]
#
# Each run is PROCESSESxTHREADS: 1x2 is one process with two threads, 2x1 two MPI processes
# (mpirun --oversubscribe) of one thread each. Every run fits the same tile with the same seed
# and the paper's EM (--objective likelihood, the objective that runs over processes), writes
# its iteration log (fit --log) and is timed by /usr/bin/time -v, each process on its own. The
# table gives the time to load the tile, each iteration's time (from the log), their mean after
# the first, the peak resident memory of each process, and the ratio of the mean iteration
# time to the first run's. Runs one after the other, never at once: on a shared machine, read
# the load printed with each run.
set -euo pipefail

btfgmm=${BTFGMM:-build/btfgmm}
size=64 btf='' components=600 iterations=3 runs='1x2 2x1' work='' lights=ubo81 views=ubo81
while [ $# -gt 0 ]; do
  case "$1" in
    --btfgmm) btfgmm=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --btf) btf=$2; shift 2 ;;
    -M) components=$2; shift 2 ;;
    --iterations) iterations=$2; shift 2 ;;
    --lights) lights=$2; shift 2 ;;
    --views) views=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    -h | --help) sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-scale: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -x "$btfgmm" ] || { echo "bench-scale: no btfgmm at '$btfgmm'; build first (make build) or give --btfgmm" >&2; exit 2; }
[ -x /usr/bin/time ] || { echo "bench-scale: needs /usr/bin/time (Debian package time)" >&2; exit 2; }
btfgmm=$(realpath "$btfgmm")
if [ -z "$work" ]; then
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
mkdir -p "$work"

if [ -z "$btf" ]; then
  btf=$work/btf
  echo "generating a ${size} x ${size} corduroy BTF ($lights x $views) in $btf" >&2
  "$btfgmm" generate --material corduroy --size "$size" --seed 7 --lights "$lights" \
    --views "$views" -o "$btf" -q --overwrite
fi

# The peak resident memory of a run's processes, "a and b kB".
peaks() {
  local out=()
  for f in "$1"/time.*; do out+=("$(awk -F': ' '/Maximum resident/ {print $2}' "$f")"); done
  local IFS=/
  echo "${out[*]} kB"
}

# Per-iteration seconds from a fit --log CSV (its seconds are since the fit started).
iteration_times() {
  awk -F, 'NR > 1 { printf "%s%.2f", (NR > 2 ? " " : ""), $6 - prev; prev = $6 }' "$1"
}

mean_after_first() {
  awk -F, 'NR == 2 { first = $6 } NR > 2 { last = $6; n++ }
           END { if (n) printf "%.2f", (last - first) / n; else printf "%.2f", first }' "$1"
}

printf '%-6s %-8s %-9s %-28s %-12s %-24s %s\n' run load_s iter1_s "iterations_s" mean_s "peak_rss_per_process" ratio
first_mean='' first_model=''
for run in $runs; do
  procs=${run%x*} threads=${run#*x}
  dir=$work/run-$run
  rm -rf "$dir" && mkdir -p "$dir"
  fit=("$btfgmm" fit "$btf" -M "$components" --iterations "$iterations" --seed 7
       --objective likelihood --threads "$threads" --log "$dir/log.csv" -o "$dir/model.btfgmm")
  load=$(cut -d' ' -f1 /proc/loadavg)
  if [ "$procs" = 1 ]; then
    /usr/bin/time -v -o "$dir/time.0" "${fit[@]}" 2> "$dir/err.txt"
  else
    command -v mpirun >/dev/null || { echo "bench-scale: run $run needs mpirun (openmpi-bin)" >&2; exit 2; }
    mpirun --oversubscribe --allow-run-as-root -np "$procs" sh -c \
      '/usr/bin/time -v -o "$0/time.$OMPI_COMM_WORLD_RANK" "$@"' "$dir" "${fit[@]}" 2> "$dir/err.txt"
  fi
  loaded=$(sed -n 's/^loaded .* in \(.*\)$/\1/p' "$dir/err.txt" | head -1)
  mean=$(mean_after_first "$dir/log.csv")
  [ -z "$first_mean" ] && first_mean=$mean
  ratio=$(awk -v a="$mean" -v b="$first_mean" 'BEGIN { printf "%.2f", a / b }')
  printf '%-6s %-8s %-9s %-28s %-12s %-24s %s (load %s)\n' "$run" "$loaded" \
    "$(awk -F, 'NR == 2 { printf "%.2f", $6 }' "$dir/log.csv")" "$(iteration_times "$dir/log.csv")" \
    "$mean" "$(peaks "$dir")" "$ratio" "$load"
  # The same model: every iteration's L to 17 digits and the L after the last M-step.
  sed -n 's/^wrote .* L = \([^ ]*\) after.*/\1/p' "$dir/err.txt" > "$dir/likelihoods"
  cut -d, -f2 "$dir/log.csv" >> "$dir/likelihoods"
  if [ -z "$first_model" ]; then
    first_model=$dir/likelihoods
  elif ! cmp -s "$first_model" "$dir/likelihoods"; then
    echo "bench-scale: run $run gave another fit than the first run (see $work)" >&2
    exit 1
  fi
done
echo "every run: the same log-likelihood to 17 digits in every iteration and after the last M-step"
