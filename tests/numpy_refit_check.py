#!/usr/bin/python3
"""Independent check of btfgmm's least-squares refit of the colour means
(src/model/refine.cpp) against numpy: the conditional weights W_m(x_I) of Eq. (9)-(10)
computed here from the mixture (the x, y Gaussians wrapped around the tile), the pulled
least-squares problem min |r_c - W mu_c|^2 + lambda |mu_c - mu0_c|^2 solved by numpy's lstsq
on the stacked system [W; sqrt(lambda) I] mu_c = [r_c; sqrt(lambda) mu0_c]. btfgmm's means
must equal numpy's to 1e-6 relative, and the prediction's error must not have increased.

Usage: numpy_refit_check.py PATH/TO/refit_probe
"""
import subprocess
import sys
import tempfile

import numpy as np

TOLERANCE = 1e-6  # relative, to the largest |mean|


def conditional_weights(samples, mix, width, height):
    w, mu, var = mix[:, 0], mix[:, 1:10], mix[:, 10:19]
    x = samples[:, :6]
    d = x[:, None, :] - mu[None, :, :6]
    for n, period in ((0, width), (1, height)):
        d[:, :, n] -= period * np.round(d[:, :, n] / period)
    t = np.log(w)[None, :] - 0.5 * np.sum(np.log(var[:, :6]), axis=1)[None, :] \
        - 0.5 * np.sum(d * d / var[None, :, :6], axis=2)
    t -= t.max(axis=1, keepdims=True)
    e = np.exp(t)
    return e / e.sum(axis=1, keepdims=True)


def main():
    probe = sys.argv[1]
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([probe, tmp], check=True)
        n, m, width, height, ridge, before, after = open(f"{tmp}/problem.txt").read().split()
        n, m, width, height = int(n), int(m), int(width), int(height)
        ridge, before, after = float(ridge), float(before), float(after)
        samples = np.fromfile(f"{tmp}/samples.f64", dtype="<f8").reshape(n, 9)
        mix = np.fromfile(f"{tmp}/mixture.f64", dtype="<f8").reshape(m, 19)
        ours = np.fromfile(f"{tmp}/refit.f64", dtype="<f8").reshape(m, 3)
    weights = conditional_weights(samples, mix, width, height)
    mu0 = mix[:, 7:10]
    r = samples[:, 6:9]
    a = np.vstack([weights, np.sqrt(ridge) * np.eye(m)])
    b = np.vstack([r, np.sqrt(ridge) * mu0])
    numpy_mu = np.linalg.lstsq(a, b, rcond=None)[0]
    worst = float(np.max(np.abs(ours - numpy_mu))) / float(np.max(np.abs(numpy_mu)))
    err = lambda mu: float(np.sum((r - weights @ mu) ** 2))
    numpy_before, numpy_after = err(mu0), err(numpy_mu)
    ok_means = worst <= TOLERANCE
    ok_errors = abs(before - numpy_before) <= 1e-6 * numpy_before and \
        abs(after - numpy_after) <= 1e-6 * numpy_before
    ok_lower = after <= before and numpy_after < numpy_before
    print(f"  {n} samples, {m} components, lambda {ridge:.3g}: means differ from numpy's lstsq "
          f"by {worst:.2e} of the largest {'ok' if ok_means else 'FAIL'}")
    print(f"  squared error before {before:.10g} (numpy {numpy_before:.10g}), after "
          f"{after:.10g} (numpy {numpy_after:.10g}) {'ok' if ok_errors and ok_lower else 'FAIL'}")
    sys.exit(0 if ok_means and ok_errors and ok_lower else 1)


if __name__ == "__main__":
    main()
