#!/usr/bin/python3
"""Independent check of btfgmm's PCAs (src/methods/pca.cpp and the PCA methods) against
numpy's SVD: with c components, the squared error of a reconstruction equals the sum of the
discarded squared singular values (Eckart-Young), and a rank-c reconstruction is unique.

Usage: numpy_pca_check.py PATH/TO/pca_probe
"""
import subprocess
import sys
import tempfile

import numpy as np

ENERGY_TOLERANCE = 1e-6  # relative, on the discarded energy
RECON_TOLERANCE = 1e-5  # relative to the largest |value|


def load(spec):
    path, rows, cols = spec.rsplit(":", 2)
    return np.fromfile(path, dtype="<f4").astype(np.float64).reshape(int(rows), int(cols))


def centred(x, centre):
    return x - x.mean(axis=0) if centre else x


def tail_energy(x, c, centre):
    s = np.linalg.svd(centred(x, centre), compute_uv=False)
    return float(np.sum(s[c:] ** 2))


def rank_c(x, c, centre):
    mean = x.mean(axis=0) if centre else np.zeros(x.shape[1])
    u, s, vt = np.linalg.svd(x - mean, full_matrices=False)
    return mean + (u[:, :c] * s[:c]) @ vt[:c]


def check_error(fields):
    name, c, centre, error, discarded = fields[0], int(fields[1]), fields[2] == "1", \
        float(fields[3]), float(fields[4])
    tail = sum(tail_energy(load(spec), c, centre) for spec in fields[5:])
    worst = max(abs(error - tail), abs(discarded - tail)) / tail
    ok = worst <= ENERGY_TOLERANCE
    print(f"  {name}: c {c} numpy {tail:.10g} btfgmm error {error:.10g} discarded "
          f"{discarded:.10g} relative difference {worst:.2e} {'ok' if ok else 'FAIL'}")
    return ok


def check_recon(fields):
    name, c, centre, spec, recon = fields[0], int(fields[1]), fields[2] == "1", fields[3], \
        fields[4]
    x = load(spec)
    ours = np.fromfile(recon, dtype="<f4").astype(np.float64).reshape(x.shape)
    worst = float(np.max(np.abs(ours - rank_c(x, c, centre)))) / float(np.max(np.abs(x)))
    ok = worst <= RECON_TOLERANCE
    print(f"  {name}: c {c} largest difference from numpy's rank-{c} reconstruction "
          f"{worst:.2e} of the largest value {'ok' if ok else 'FAIL'}")
    return ok


def main():
    probe = sys.argv[1]
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([probe, tmp], check=True)
        with open(f"{tmp}/cases.txt") as f:
            lines = [line.split() for line in f if line.strip()]
        results = [check_error(l[1:]) if l[0] == "error" else check_recon(l[1:]) for l in lines]
    passed = sum(results)
    print(f"{passed} passed, {len(results) - passed} failed")
    sys.exit(0 if results and passed == len(results) else 1)


if __name__ == "__main__":
    main()
