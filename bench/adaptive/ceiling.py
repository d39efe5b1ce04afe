#!/usr/bin/env python3
"""How much any per-pixel sample count could gain at equal time: a model, not a render.

    python3 bench/adaptive/ceiling.py REF.exr REF_SPP PILOT.exr PILOT_SPP COST.txt [MEAN_SPP ...]

REF.exr is a converged render with pathlight's `variance.R/G/B` channels (the variance of
each pixel's mean), PILOT.exr a render of PILOT_SPP samples of the same scene and size,
COST.txt one line per pixel in pixel order, "rays seconds", what each pixel cost over any
fixed number of samples (only ratios between pixels are read); MEAN_SPP the mean samples
per pixel to compare at (default 50 and 200; an adaptive render's own, to set it beside
one). The cost files behind
`bench/history/sampling.md` ("The equal-time ceiling") came from a per-pixel timer put into
the CPU backend for the measurement and taken out again.

Model: samples independent, pixel i's per-sample relative variance v_i (the reference's,
over L² + 0.01 per channel, as `examples/adaptive_error.rs` weighs error), N_i samples
costing c_i each. A count rule's error is mean(v_i / N_i); the uniform render given the
same time takes M = Σ c_i N_i / Σ c_i samples per pixel, error mean(v) / M. The oracle
counts N_i ∝ √(v_i / c_i) (the allocation minimising Σ v/N at fixed Σ c N); the rule is
`src/sampling/adaptive.rs`'s, N_i ∝ √(max(v over the 5 × 5 neighbours, v̄/4) · v̄) from the
pilot. Both clipped to [16, 1024] and scaled to a mean of M samples. The model ignores
that Sobol points beat 1/N in smooth regions, which favours the uniform render.
"""
import sys

import Imath
import numpy as np
import OpenEXR
from numpy.lib.stride_tricks import sliding_window_view

LOW, HIGH = 16, 1024


def relative_variance(path, spp):
    exr = OpenEXR.InputFile(path)
    window = exr.header()["dataWindow"]
    w, h = window.max.x - window.min.x + 1, window.max.y - window.min.y + 1
    float_type = Imath.PixelType(Imath.PixelType.FLOAT)

    def channel(name):
        return np.frombuffer(exr.channel(name, float_type), dtype=np.float32).reshape(h, w)

    per_sample = sum(channel("variance." + c) * spp / (channel(c) ** 2 + 1e-2) for c in "RGB") / 3
    return per_sample.astype(np.float64), (h, w)


def counts(weight, mean_spp):
    """weight scaled by the λ that makes mean(clip(λ·weight)) = mean_spp (bisection)."""
    lo, hi = 1e-12, 1e12
    for _ in range(200):
        lam = np.sqrt(lo * hi)
        if np.clip(lam * weight, LOW, HIGH).mean() > mean_spp:
            hi = lam
        else:
            lo = lam
    return np.clip(lam * weight, LOW, HIGH)


def neighbours_largest(v, radius=2):
    padded = np.pad(v, radius, constant_values=np.nan)
    size = 2 * radius + 1
    windows = sliding_window_view(padded, (size, size)).reshape(*v.shape, -1).copy()
    windows[:, :, size * size // 2] = np.nan  # never the pixel's own
    return np.nanmax(windows, -1)


def main():
    ref, ref_spp, pilot, pilot_spp, cost_file = sys.argv[1:6]
    v, shape = relative_variance(ref, float(ref_spp))
    v = v.ravel()
    pilot_v = relative_variance(pilot, float(pilot_spp))[0]
    cost = np.loadtxt(cost_file)[:, 1]
    ordered = np.sort(v)[::-1].cumsum() / v.sum()
    for share in (0.01, 0.05):
        print(f"the top {share:.0%} of pixels hold {ordered[int(share * v.size) - 1]:.0%} of Σv")

    def gain_equal_samples(n):
        return (v.mean() / n.mean()) / np.mean(v / n)

    def gain_equal_time(n):
        uniform_spp = (cost * n).sum() / cost.sum()
        return (v.mean() / uniform_spp) / np.mean(v / n)

    widened = np.maximum(neighbours_largest(pilot_v), 0.25 * pilot_v.mean())
    rule = np.sqrt(widened * pilot_v.mean()).ravel()
    for mean_spp in [float(m) for m in sys.argv[6:]] or [50, 200]:
        print(
            f"mean {mean_spp:g} spp: oracle {gain_equal_samples(counts(np.sqrt(v), mean_spp)):.2f}× "
            f"at equal samples, {gain_equal_time(counts(np.sqrt(v / cost), mean_spp)):.2f}× at "
            f"equal time ({gain_equal_time(counts(np.sqrt(v), mean_spp)):.2f}× blind to cost); "
            f"the rule {gain_equal_samples(counts(rule, mean_spp)):.2f}× at equal samples, "
            f"{gain_equal_time(counts(rule, mean_spp)):.2f}× at equal time"
        )


if __name__ == "__main__":
    main()
