#!/usr/bin/python3
"""Independent check of Eq. (3)-(7): the same EM iterations from the same starting parameters
in btfgmm's reference EM and in scikit-learn's GaussianMixture(covariance_type='diag') give
the same mean log-likelihood to 1e-5 relative, iteration by iteration.

Usage: sklearn_em_check.py PATH/TO/em_probe
"""
import os
import subprocess
import sys
import tempfile
import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.mixture import GaussianMixture

ITERATIONS = 6
TOLERANCE = 1e-5


def case(probe, seed, n, m):
    rng = np.random.default_rng(seed)
    # Data: a few product clusters with different spreads, plus a little uniform noise.
    centres = rng.normal(0.0, 5.0, size=(m + 1, 9))
    spreads = rng.uniform(0.5, 2.0, size=(m + 1, 9))
    labels = rng.integers(0, m + 1, size=n)
    x = centres[labels] + spreads[labels] * rng.normal(size=(n, 9))
    # Starting parameters: random samples as means, the overall variance, random weights.
    weights = rng.uniform(0.5, 1.5, size=m)
    weights /= weights.sum()
    means = x[rng.choice(n, size=m, replace=False)]
    variances = np.tile(x.var(axis=0), (m, 1)) * rng.uniform(0.5, 1.5, size=(m, 9))

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "input.txt")
        with open(path, "w") as f:
            f.write(f"{n} {m} {ITERATIONS}\n")
            np.savetxt(f, x, fmt="%.17g")
            np.savetxt(f, np.hstack([weights[:, None], means, variances]), fmt="%.17g")
        out = subprocess.run([probe, path], check=True, capture_output=True, text=True).stdout
    ours = [float(v) for v in out.split()]

    theirs = []
    for k in range(1, ITERATIONS + 1):
        gm = GaussianMixture(n_components=m, covariance_type="diag", max_iter=k, tol=0.0,
                             reg_covar=0.0, weights_init=weights, means_init=means,
                             precisions_init=1.0 / variances, random_state=0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            gm.fit(x)
        theirs.append(gm.lower_bound_)

    worst = 0.0
    for k, (a, b) in enumerate(zip(ours, theirs), start=1):
        rel = abs(a - b) / abs(b)
        worst = max(worst, rel)
        print(f"  seed {seed} n {n} M {m} iteration {k}: btfgmm {a:.12f} "
              f"scikit-learn {b:.12f} relative difference {rel:.2e}")
    return len(ours) == ITERATIONS and worst <= TOLERANCE, worst


def main():
    probe = sys.argv[1]
    results = [case(probe, seed, n, m) for seed, n, m in [(1, 1500, 3), (2, 3000, 6), (3, 800, 10)]]
    worst = max(w for _, w in results)
    passed = sum(ok for ok, _ in results)
    print(f"worst relative difference {worst:.2e} (tolerance {TOLERANCE:g})")
    print(f"{passed} passed, {len(results) - passed} failed")
    sys.exit(0 if passed == len(results) else 1)


if __name__ == "__main__":
    main()
