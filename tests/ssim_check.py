#!/usr/bin/python3
"""Independent check of btfgmm's image metrics (src/measure/metrics.cpp) against scikit-image.

SSIM equals skimage.metrics.structural_similarity(a, b, channel_axis=-1,
gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=R) to 1e-6 on random
and structured RGB image pairs of 11 pixels and more; RMSE and PSNR equal skimage's
mean_squared_error and peak_signal_noise_ratio. Images smaller than the 11 x 11 window (which
scikit-image refuses) are checked against the same formula written with
scipy.ndimage.gaussian_filter and the window btfgmm documents: the largest odd size that fits,
the same Gaussian cut at its edge.

Usage: ssim_check.py PATH/TO/ssim_probe
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy import ndimage
from skimage.metrics import (mean_squared_error, peak_signal_noise_ratio,
                             structural_similarity)

TOLERANCE = 1e-6


def probe(exe, a, b, data_range):
    h, w, _ = a.shape
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "pair.txt")
        with open(path, "w") as f:
            f.write(f"{w} {h} {data_range!r}\n")
            np.savetxt(f, a.reshape(-1, 3), fmt="%.9g")
            np.savetxt(f, b.reshape(-1, 3), fmt="%.9g")
        out = subprocess.run([exe, path], check=True, capture_output=True, text=True).stdout
    values = {}
    for line in out.splitlines():
        key, *rest = line.split()
        values[key] = [float(v) for v in rest]
    return values


def ssim_reference(a, b, data_range, radius):
    """Wang et al. 2004 with a Gaussian window of the given radius, no padding (scipy)."""
    sigma = 1.5
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    per_channel = []
    for c in range(3):
        x, y = a[..., c], b[..., c]
        f = lambda im: ndimage.gaussian_filter(im, sigma=sigma, truncate=radius / sigma,
                                               mode="reflect")
        ux, uy = f(x), f(y)
        vx, vy, vxy = f(x * x) - ux * ux, f(y * y) - uy * uy, f(x * y) - ux * uy
        s = ((2 * ux * uy + c1) * (2 * vxy + c2)) / ((ux ** 2 + uy ** 2 + c1) * (vx + vy + c2))
        h, w = s.shape
        per_channel.append(s[radius:h - radius, radius:w - radius].mean(dtype=np.float64))
    return float(np.mean(per_channel))


def pairs(rng):
    """(name, a, b, range): float32-representable images, as btfgmm holds them."""
    out = []
    for k, (h, w) in enumerate([(11, 11), (16, 16), (23, 31), (48, 40)]):
        a = rng.integers(0, 256, size=(h, w, 3)).astype(np.float32)
        b = rng.integers(0, 256, size=(h, w, 3)).astype(np.float32)
        out.append((f"random independent {w}x{h}", a, b, 255.0))
        noisy = np.clip(a + rng.normal(0, 12, size=a.shape), 0, 255).round().astype(np.float32)
        out.append((f"random + noise {w}x{h}", a, noisy, 255.0))
    yy, xx = np.mgrid[0:40, 0:36].astype(np.float64)
    grad = np.stack([xx * 6, yy * 5, (xx + yy) * 3], axis=-1)
    out.append(("gradient vs shifted gradient", grad.astype(np.float32),
                np.clip(grad + 9, 0, 255).astype(np.float32), 255.0))
    checker = (((xx // 4 + yy // 4) % 2) * 200 + 20)[..., None].repeat(3, axis=-1)
    blurred = ndimage.uniform_filter(checker, size=(3, 3, 1))
    out.append(("checkerboard vs blurred", checker.astype(np.float32),
                blurred.astype(np.float32), 255.0))
    wave = 127 + 100 * np.sin(xx / 3.0)[..., None] * np.cos(yy / 5.0)[..., None] * [1, 0.8, 0.6]
    out.append(("sine texture vs half contrast", wave.astype(np.float32),
                (127 + 0.5 * (wave - 127)).astype(np.float32), 255.0))
    edge = np.where(xx < 18, 30.0, 220.0)[..., None].repeat(3, axis=-1)
    out.append(("step edge vs moved edge", edge.astype(np.float32),
                np.roll(edge, 2, axis=1).astype(np.float32), 255.0))
    flat = np.full((12, 14, 3), 100.0)
    out.append(("flat 100 vs flat 110", flat.astype(np.float32),
                (flat + 10).astype(np.float32), 255.0))
    hdr = rng.gamma(2.0, 0.6, size=(20, 24, 3)).astype(np.float32)
    hdr_model = (hdr * rng.uniform(0.8, 1.2, size=hdr.shape)).astype(np.float32)
    out.append(("HDR floats, range = peak", hdr, hdr_model, float(hdr.max())))
    return out


def small_pairs(rng):
    out = []
    for h, w in [(10, 12), (7, 9), (5, 5), (3, 8), (1, 1)]:
        a = rng.integers(0, 256, size=(h, w, 3)).astype(np.float32)
        b = np.clip(a + rng.normal(0, 20, size=a.shape), 0, 255).round().astype(np.float32)
        out.append((f"small {w}x{h}", a, b, 255.0))
    return out


def main():
    exe = sys.argv[1]
    rng = np.random.default_rng(2004)
    failed, worst = 0, 0.0
    for name, a, b, r in pairs(rng):
        ours = probe(exe, a, b, r)
        a64, b64 = a.astype(np.float64), b.astype(np.float64)
        theirs = structural_similarity(a64, b64, channel_axis=-1, gaussian_weights=True,
                                       sigma=1.5, use_sample_covariance=False, data_range=r)
        reference = ssim_reference(a64, b64, r, 5)  # the scipy formula, checked here too
        rmse = float(np.sqrt(mean_squared_error(a64, b64)))
        psnr = (float(peak_signal_noise_ratio(a64, b64, data_range=r)) if rmse > 0
                else float("inf"))
        d_ssim = abs(ours["ssim"][3] - theirs)
        d_ref = abs(reference - theirs)
        d_rmse = abs(ours["rmse"][3] - rmse)
        d_psnr = abs(ours["psnr"][3] - psnr)
        ok = (d_ssim <= TOLERANCE and d_ref <= TOLERANCE and d_rmse <= 1e-9 * max(1, rmse)
              and d_psnr <= 1e-9 and ours["window"][0] == 11)
        worst = max(worst, d_ssim)
        failed += not ok
        print(f"  {'ok  ' if ok else 'FAIL'} {name:34s} SSIM btfgmm {ours['ssim'][3]:.12f} "
              f"skimage {theirs:.12f} |diff| {d_ssim:.1e}; RMSE {ours['rmse'][3]:.6f} "
              f"({d_rmse:.1e}); PSNR {ours['psnr'][3]:.6f} dB ({d_psnr:.1e})")
    for name, a, b, r in small_pairs(rng):
        ours = probe(exe, a, b, r)
        radius = (min(a.shape[0], a.shape[1]) - 1) // 2
        reference = ssim_reference(a.astype(np.float64), b.astype(np.float64), r, radius)
        d_ssim = abs(ours["ssim"][3] - reference)
        ok = d_ssim <= TOLERANCE and ours["window"][0] == 2 * radius + 1
        worst = max(worst, d_ssim)
        failed += not ok
        print(f"  {'ok  ' if ok else 'FAIL'} {name:34s} SSIM btfgmm {ours['ssim'][3]:.12f} "
              f"scipy window {2 * radius + 1} {reference:.12f} |diff| {d_ssim:.1e}")
    total = len(pairs(np.random.default_rng(0))) + len(small_pairs(np.random.default_rng(0)))
    print(f"worst SSIM difference {worst:.2e} (tolerance {TOLERANCE:g})")
    print(f"{total - failed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
