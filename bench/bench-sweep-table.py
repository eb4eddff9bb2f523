#!/usr/bin/env python3
"""The sweep's table at true file bytes, before and after, from the sweep.json of each run.

    bench/bench-sweep-table.py --before DIR [DIR ...] --after DIR

Each DIR is a folder `btfgmm sweep -o DIR` wrote; several before-folders are merged (a sweep
run in parts with --methods or --components). Prints a markdown table with a row for every
method and size of either ladder (file bytes, PSNR, the storage each file uses, "*" on the
pixel-wise Pareto front, the after/before ratio of bytes where both swept the size), then the
best PSNR each sweep reaches within budgets of 10, 20, 30, 60 and 100 KB. Synthesis models
(3d-car, 2d-car, gmrf) make new texture: listed, never the best within a budget.
"""
import argparse
import json
import os
import re

SYNTHESIS = {"3d-car", "2d-car", "gmrf"}
BUDGETS = (10_000, 20_000, 30_000, 60_000, 100_000)


def load(folders):
    models = {}
    for folder in folders:
        with open(os.path.join(folder, "sweep.json")) as f:
            for m in json.load(f)["models"]:
                models[(m["method"], m["size"])] = m
    return models


def storage(m):
    details = m.get("details", {})
    text = details.get("factor encoding") or details.get("precision") or m.get("precision", "")
    word = text.split(" ")[0]
    return "f16" if word == "16-bit" else word


def size_key(size):
    numbers = [int(n) for n in re.findall(r"\d+", size)]
    return numbers[-2:] if len(numbers) > 1 else [0] + numbers


def cell(m):
    if m is None:
        return ["–", "–", ""]
    mark = "synthesis" if m["method"] in SYNTHESIS else ("*" if m.get("pareto") else "")
    return [f"{m['file_bytes']:,}", f"{m['psnr_db']:.2f}", f"{storage(m)} {mark}".strip()]


def best_within(models, budget):
    fits = [m for m in models.values()
            if m["method"] not in SYNTHESIS and m["file_bytes"] <= budget]
    if not fits:
        return "none"
    m = max(fits, key=lambda m: m["psnr_db"])
    return f"{m['method']} {m['size']}, {m['file_bytes']:,} B, {m['psnr_db']:.2f} dB"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", nargs="+", required=True, help="the earlier build's sweep folders")
    ap.add_argument("--after", required=True, help="this build's sweep folder")
    a = ap.parse_args()
    before, after = load(a.before), load([a.after])
    methods = list(dict.fromkeys(k[0] for k in list(after) + list(before)))
    keys = sorted(set(before) | set(after),
                  key=lambda k: (methods.index(k[0]), size_key(k[1])))
    print("| method | size | before: bytes | PSNR dB | stored | after: bytes | PSNR dB | stored "
          "| bytes after/before |")
    print("|---|---|---|---|---|---|---|---|---|")
    for k in keys:
        b, f = before.get(k), after.get(k)
        ratio = f"{f['file_bytes'] / b['file_bytes']:.2f}" if b and f else ""
        print("| " + " | ".join([k[0], k[1]] + cell(b) + cell(f) + [ratio]) + " |")
    print()
    print("| B (bytes) | best within B, before | best within B, after |")
    print("|---|---|---|")
    for budget in BUDGETS:
        print(f"| {budget:,} | {best_within(before, budget)} | {best_within(after, budget)} |")


if __name__ == "__main__":
    main()
