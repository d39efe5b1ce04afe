#!/usr/bin/env python3
"""Averages two independent pathlight renders into one reference, and measures its noise.

A long reference can be rendered in two pieces with different seeds:

    pathlight render SCENE --backend cpu --width 256 --height 256 --spp 8192 --seed 11 -o a.exr
    pathlight render SCENE --backend cpu --width 256 --height 256 --spp 8192 --seed 12 -o b.exr
    python3 bench/mean_reference.py a.exr b.exr OUT/<scene>/reference.exr [--check PEER.exr ...]

Their difference measures their error: for independent unbiased images with equal noise,
E[relMSE(a, b)] = 2n, so each has relMSE n = relMSE(a, b) / 2 and their mean n / 2. (Under
the Sobol sampler the variance channels cannot give this: they hold the samples' spread.)
The mean is written with that figure as `pathlight.predictedRelMSE`, which
`pathlight bench --peer` reports next to the errors it compares, and with the variance
channels of the two halved twice (the variance of a mean of two).

`--downsample K` averages each K × K block of pixels of both renders first: pathlight's
pixel filter is a box (each camera sample lands uniformly in its pixel, and Metropolis's
splats by the point they hit), so a block's mean has the expectation of one pixel of a
render K times smaller, with a K²-th of the noise. One long render so gives the references
of several image sizes.

`--check` compares the reference with another renderer's converged image that carries its
own variance of the mean (Mitsuba's batches, `mitsuba_peer.py --converged`): the relMSE
between them less both noises is their systematic difference.

relMSE is the benchmark protocol's, mean over pixels and channels of
(x - ref)^2 / (ref^2 + 1e-2), with the mean of the pair as ref.
Reads and writes EXR through Mitsuba 3's Bitmap (`pip install mitsuba`), as the peer script does.
"""

import argparse
import sys

import numpy as np

EPSILON = 1e-2


def load(mi, path):
    bitmap = mi.Bitmap(path)
    data = np.array(bitmap, copy=False).astype(np.float64)
    if data.ndim != 3 or data.shape[2] != 6:
        sys.exit(f"mean_reference.py: {path}: expected R, G, B and variance.R/G/B, got {data.shape}")
    return data, bitmap.metadata()


def downsample(image, k, path):
    """Each k x k block's mean; the variance channels become the variance of that mean."""
    h, w, c = image.shape
    if h % k or w % k:
        sys.exit(f"mean_reference.py: {path} is {w}x{h}, not a multiple of --downsample {k}")
    blocks = image.reshape(h // k, k, w // k, k, c).mean(axis=(1, 3))
    blocks[..., 3:] /= k * k
    return blocks


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("out")
    p.add_argument("--check", action="append", default=[], help="a peer's converged EXR with variance")
    p.add_argument("--downsample", type=int, default=1, help="average K x K pixel blocks first")
    args = p.parse_args()

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    a, meta_a = load(mi, args.a)
    b, meta_b = load(mi, args.b)
    if a.shape != b.shape:
        sys.exit(f"mean_reference.py: {args.a} is {a.shape[1]}x{a.shape[0]}, {args.b} {b.shape[1]}x{b.shape[0]}")
    if "pathlight.seed" in meta_a and "pathlight.seed" in meta_b and meta_a["pathlight.seed"] == meta_b["pathlight.seed"]:
        sys.exit(f"mean_reference.py: both renders have seed {meta_a['pathlight.seed']}: they are not independent")
    if args.downsample > 1:
        a, b = downsample(a, args.downsample, args.a), downsample(b, args.downsample, args.b)
    mean = 0.5 * (a[..., :3] + b[..., :3])
    weight = 1.0 / (mean**2 + EPSILON)
    one = float((((a[..., :3] - b[..., :3]) ** 2) * weight).mean()) / 2.0
    noise = one / 2.0
    print(f"each render's relMSE {one:.3e}; their mean's {noise:.3e}")

    spp = sum(int(m["pathlight.spp"]) for m in (meta_a, meta_b) if "pathlight.spp" in m)
    data = np.concatenate([mean, (a[..., 3:] + b[..., 3:]) / 4.0], axis=-1).astype(np.float32)
    bitmap = mi.Bitmap(
        data,
        pixel_format=mi.Bitmap.PixelFormat.MultiChannel,
        channel_names=["R", "G", "B", "variance.R", "variance.G", "variance.B"],
    )
    meta = bitmap.metadata()
    if spp:
        meta["pathlight.spp"] = spp
    if "pathlight.scene" in meta_a:
        meta["pathlight.scene"] = meta_a["pathlight.scene"]
    backend = meta_a["pathlight.backend"] if "pathlight.backend" in meta_a else "?"
    meta["pathlight.backend"] = f"{backend}, mean of two renders"
    meta["pathlight.predictedRelMSE"] = noise
    bitmap.write(args.out)
    print(f"wrote {args.out}")

    for path in args.check:
        peer, _ = load(mi, path)
        if peer.shape != a.shape:
            sys.exit(f"mean_reference.py: {path} is {peer.shape[1]}x{peer.shape[0]}, not {a.shape[1]}x{a.shape[0]}")
        between = float((((peer[..., :3] - mean) ** 2) * weight).mean())
        peer_noise = float((peer[..., 3:] * weight).mean())
        ratio = peer[..., :3].mean(axis=(0, 1)) / mean.mean(axis=(0, 1))
        print(
            f"{path}: relMSE {between:.3e} against the reference; noises {noise:.3e} + {peer_noise:.3e}; "
            f"systematic {between - noise - peer_noise:.3e}; image mean ratio "
            + " ".join(f"{r:.5f}" for r in ratio)
        )


if __name__ == "__main__":
    main()
