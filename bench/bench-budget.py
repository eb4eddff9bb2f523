#!/usr/bin/env python3
"""`fit --budget B` against the sweep: for each material and budget, the method and size the
budget chooses, its PSNR, the best PSNR of the sweep's candidates whose file fits B, and the
time the budget took. Prints a Markdown table (docs/BENCHMARKS.md).

Usage: bench-budget.py BTFGMM_BINARY WORK_DIR [--materials knit,corduroy] [--size 25]
                       [--budgets 10000,20000,30000,60000] [--iterations N]

Each material is generated at SIZE x SIZE (the generator's 81 x 81 directions), swept once
(`sweep --tile 0,0,SIZE,SIZE --json`), then fitted within each budget. A sweep candidate is
compared by its own file's bytes; the budget's chosen file also holds the choice's note in its
provenance (a few dozen bytes).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time


def run(argv):
    start = time.time()
    done = subprocess.run(argv, capture_output=True, text=True)
    if done.returncode != 0:
        return None, done.stderr, time.time() - start
    return done.stdout, done.stderr, time.time() - start


def chosen_row(err):
    """The candidates' row marked chosen: method, size, bytes, PSNR."""
    for line in err.splitlines():
        if line.rstrip().endswith("chosen"):
            words = line.split()[:-1]
            return words[0], " ".join(words[1:-2]), int(words[-2]), float(words[-1])
    return None


def main():
    p = argparse.ArgumentParser()
    p.add_argument("binary")
    p.add_argument("work")
    p.add_argument("--materials", default="knit,corduroy")
    p.add_argument("--size", type=int, default=25)
    p.add_argument("--budgets", default="10000,20000,30000,60000")
    p.add_argument("--iterations", type=int, default=0)
    a = p.parse_args()
    os.makedirs(a.work, exist_ok=True)
    extra = ["--iterations", str(a.iterations)] if a.iterations else []
    tile = f"0,0,{a.size},{a.size}"
    print("| material | budget B | chosen | bytes | PSNR dB | best sweep PSNR within B "
          "(its model) | equal | candidates | time |")
    print("|---|---|---|---|---|---|---|---|---|")
    for material in a.materials.split(","):
        btf = os.path.join(a.work, f"{material}{a.size}")
        if not os.path.isdir(btf):
            run([a.binary, "generate", "--material", material, "--size", str(a.size), "-o", btf])
        sweep_dir = os.path.join(a.work, f"sweep-{material}{a.size}")
        out, err, sweep_s = run([a.binary, "sweep", btf, "--tile", tile, "--json", "--overwrite",
                                 "-o", sweep_dir] + extra)
        if out is None:
            sys.exit(f"sweep failed: {err}")
        models = [m for m in json.loads(out)["models"] if m.get("pixelwise_meaningful", True)]
        print(f"<!-- sweep of {material}: {len(models)} pixel-wise models in {sweep_s:.0f} s -->",
              flush=True)
        for budget in [int(b) for b in a.budgets.split(",")]:
            model = os.path.join(a.work, f"budget-{material}-{budget}.btfgmm")
            out, err, seconds = run([a.binary, "fit", btf, "--tile", tile, "--budget", str(budget),
                                     "--overwrite", "-o", model] + extra)
            within = [m for m in models if m["file_bytes"] <= budget]
            best = max(within, key=lambda m: m["psnr_db"] or 1e9) if within else None
            best_text = (f"{best['psnr_db']:.2f} ({best['method']} {best['size']}, "
                         f"{best['file_bytes']} B)" if best else "none fits")
            if out is None:
                first = err.strip().splitlines()[-1] if err.strip() else "failed"
                print(f"| {material} | {budget} | refused: {first} | | | {best_text} | | | "
                      f"{seconds:.0f} s |", flush=True)
                continue
            method, size, nbytes, psnr = chosen_row(err)
            tried = len(re.findall(r"^\S+ +.* \d+ +[\d.]+ ", err, re.M))
            equal = "yes" if best and abs(best["psnr_db"] - psnr) < 0.005 else (
                "higher" if not best or psnr > best["psnr_db"] else "LOWER")
            print(f"| {material} | {budget} | {method} {size} | {nbytes} | {psnr:.2f} | "
                  f"{best_text} | {equal} | {tried} | {seconds:.0f} s |", flush=True)


if __name__ == "__main__":
    main()
