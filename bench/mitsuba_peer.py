#!/usr/bin/env python3
"""Renders a pathlight benchmark scene with Mitsuba 3, the peer of `pathlight bench --peer`.

The glTF is read by `gltf_scene.py`, independently of pathlight's loader (so a loader bug
shows up as a failed z-test rather than being copied into both renders), and converted to a
Mitsuba 3 scene: the same triangles and vertex normals, the same camera and box pixel filter,
Mitsuba's own `path` integrator with its defaults (unlimited depth, roulette from depth 5)
and its default `independent` sampler, or another with --sampler (`ldsampler`: Mitsuba's
low-discrepancy (0,2)-sequence sampler, the counterpart of pathlight's default).

Only the materials the benchmark scenes use are converted, each to the Mitsuba BSDF whose
model is the same as pathlight's for that case; anything else is an error rather than an
approximation:

  * Lambertian (metallic 0, roughness 1, KHR_materials_specular factor 0) -> `diffuse`,
    wrapped in `twosided` as pathlight shades both sides of an opaque surface
  * emissive (emissiveFactor x KHR_materials_emissive_strength)          -> `area` emitter
  * smooth metal (metallic 1, roughness 0, base colour 1)                  -> `conductor`,
    material `none` (reflectance 1: pathlight's Schlick Fresnel with F0 = 1 is 1 too),
    `twosided`
  * smooth solid glass (transmission 1, roughness 0, KHR_materials_volume,
    no attenuation)                                                        -> `dielectric`

What it does (all timings after a warm-up render that compiles Mitsuba's kernels):

  1. the error series: independent renders at 1, 2, 4, ... spp, each timed, until one
     takes longer than --time-limit; relMSE against --reference with the benchmark
     protocol's formula (mean over pixels and channels of (x - ref)^2 / (ref^2 + 1e-2));
  2. a converged image (--converged-spp spp in --batches independent batches), written as
     an EXR with pathlight's channels (R, G, B and variance.R/G/B = the variance of the
     mean from the batches) so `pathlight compare` can z-test it against pathlight.

Needs `pip install mitsuba numpy`. The `llvm_ad_rgb` variant needs LLVM (Debian 12:
`apt-get install libllvm19`); the library is found by itself or through DRJIT_LIBLLVM_PATH.
"""

import argparse
import csv
import glob
import math
import os
import sys
import tempfile
import time

import numpy as np

from gltf_scene import SceneError, camera_frame, peer_material, read_gltf, triangle_meshes

RELMSE_EPSILON = 1e-2  # the benchmark protocol's (and src/film/convergence.rs's) offset


# ---------------------------------------------------------------------------------------
# Materials


def two_sided(bsdf):
    """pathlight reflects light off either side of an opaque surface (a back-face hit is
    shaded about the flipped normal); Mitsuba's opaque BSDFs are black from behind unless
    wrapped. Closed meshes never show it; open ones (the text labels of
    MetalRoughSpheresNoTextures) do."""
    return {"type": "twosided", "bsdf": bsdf}


def mitsuba_material(material, white_override=None):
    """(bsdf dict, emitter dict or None) for a glTF material, or SceneError."""
    if white_override is not None:
        return two_sided({"type": "diffuse", "reflectance": {"type": "rgb", "value": [white_override] * 3}}), None
    kind, parameter, emission = peer_material(material)
    emitter = {"type": "area", "radiance": {"type": "rgb", "value": emission}} if emission else None
    if kind == "glass":
        return {"type": "dielectric", "int_ior": parameter, "ext_ior": 1.0}, emitter
    if kind == "mirror":
        return two_sided({"type": "conductor", "material": "none"}), emitter
    return two_sided({"type": "diffuse", "reflectance": {"type": "rgb", "value": parameter}}), emitter


# ---------------------------------------------------------------------------------------
# Scene conversion


def write_ply(path, positions, normals, faces):
    with open(path, "wb") as f:
        header = (
            "ply\nformat binary_little_endian 1.0\n"
            f"element vertex {len(positions)}\n"
            "property float x\nproperty float y\nproperty float z\n"
            + ("property float nx\nproperty float ny\nproperty float nz\n" if normals is not None else "")
            + f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n"
        )
        f.write(header.encode("ascii"))
        vertex = positions.astype("<f4")
        if normals is not None:
            vertex = np.hstack([vertex, normals.astype("<f4")])
        f.write(vertex.tobytes())
        face = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
        face["n"] = 3
        face["i"] = faces
        f.write(face.tobytes())


def convert_meshes(doc, buffers, transform, white_override, workdir, tag, shapes):
    for name, positions, normals, faces, material in triangle_meshes(doc, buffers, transform):
        bsdf, emitter = mitsuba_material(material, white_override)
        ply = os.path.join(workdir, f"{tag}-{name}-{len(shapes)}.ply")
        write_ply(ply, positions, normals, faces)
        shape = {"type": "ply", "filename": ply, "bsdf": bsdf, "face_normals": normals is None}
        if emitter is not None:
            shape["emitter"] = emitter
        shapes[f"shape{len(shapes)}"] = shape


def build_scene(args, workdir):
    import mitsuba as mi

    doc, buffers = read_gltf(args.scene)
    shapes = {}
    convert_meshes(doc, buffers, np.eye(4), None, workdir, "scene", shapes)
    if args.insert:
        insert_doc, insert_buffers = read_gltf(args.insert)
        values = [float(v) for v in args.matrix.split(",")]
        if len(values) != 16:
            raise SceneError(f"--matrix: 16 numbers expected, {len(values)} given")
        m = np.array(values, dtype=np.float64).reshape(4, 4).T  # column-major
        convert_meshes(insert_doc, insert_buffers, m, args.insert_white, workdir, "insert", shapes)
    perspective, origin, forward, up = camera_frame(doc)
    sensor = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": math.degrees(perspective["yfov"]),
        "near_clip": perspective.get("znear", 0.01),
        "to_world": mi.ScalarTransform4f().look_at(
            origin=origin.tolist(), target=(origin + forward).tolist(), up=up.tolist()
        ),
        "sampler": {"type": args.sampler},
        "film": {
            "type": "hdrfilm",
            "width": args.width,
            "height": args.height,
            "rfilter": {"type": "box"},
            "pixel_format": "rgb",
        },
    }
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": -1}, "sensor": sensor}
    scene.update(shapes)
    return mi.load_dict(scene)


# ---------------------------------------------------------------------------------------
# Rendering


def read_reference(path):
    import mitsuba as mi

    # Mitsuba groups an EXR's channels into layers; R, G, B form the unnamed root layer.
    layers = dict(mi.Bitmap(path).split())
    if "<root>" not in layers:
        raise SceneError(f"{path}: no R, G, B channels")
    return np.array(layers["<root>"], dtype=np.float64)[..., :3]


def errors(image, reference):
    d = image.astype(np.float64) - reference
    return float(np.sqrt(np.mean(d * d))), float(np.mean(d * d / (reference * reference + RELMSE_EPSILON)))


def render(scene, spp, seed):
    """One render, timed to the finished image (Dr.Jit evaluates lazily: the numpy copy
    forces it)."""
    import mitsuba as mi

    start = time.perf_counter()
    image = np.array(mi.render(scene, spp=spp, seed=seed))
    return image, time.perf_counter() - start


def setup_variant(variant):
    if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        found = sorted(glob.glob("/usr/lib/x86_64-linux-gnu/libLLVM.so.*") + glob.glob("/usr/lib/llvm-*/lib/libLLVM*.so*"))
        if found:
            os.environ["DRJIT_LIBLLVM_PATH"] = found[-1]
    import mitsuba as mi

    try:
        mi.set_variant(variant)
    except Exception as e:  # Mitsuba reports a missing LLVM as a generic error
        raise SceneError(f"Mitsuba variant {variant} is unavailable ({e}); install libllvm19 or use --variant scalar_rgb")
    return mi


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene")
    p.add_argument("--insert", help="a second glTF placed in the scene (e.g. the bunny)")
    p.add_argument("--matrix", help="its transform: 16 comma-separated numbers, column-major")
    p.add_argument("--insert-white", type=float, help="give the insert a Lambertian of this albedo")
    p.add_argument("--width", type=int, default=256)
    p.add_argument("--height", type=int, default=256)
    p.add_argument("--variant", default="llvm_ad_rgb")
    p.add_argument("--reference", required=True, help="reference EXR (R, G, B)")
    p.add_argument("--time-limit", type=float, default=30.0, help="stop the series after a render this long")
    p.add_argument("--max-spp", type=int, default=65536)
    p.add_argument("--converged-spp", type=int, default=8192)
    p.add_argument("--batches", type=int, default=16)
    p.add_argument("--log", required=True, help="CSV: spp, seconds, rmse, relmse")
    p.add_argument("--converged", help="EXR written with mean and variance (none: no converged image)")
    p.add_argument("--sampler", default="independent", help="Mitsuba sampler plugin (independent, ldsampler, ...)")
    args = p.parse_args()

    try:
        mi = setup_variant(args.variant)
        with tempfile.TemporaryDirectory() as workdir:
            scene = build_scene(args, workdir)
            reference = read_reference(args.reference)
            if reference.shape[:2] != (args.height, args.width):
                raise SceneError(f"{args.reference}: {reference.shape[1]}x{reference.shape[0]}, not {args.width}x{args.height}")
            # Warm-up: Dr.Jit traces and compiles the kernel once per scene (and caches it).
            # ldsampler takes square powers of two from 4 on (it renders 4 when asked for 1).
            first_spp = 4 if args.sampler == "ldsampler" else 1
            render(scene, first_spp, 999_999)
            rows = []
            spp = first_spp
            while spp <= args.max_spp:
                image, seconds = render(scene, spp, spp)
                rmse, relmse = errors(image, reference)
                rows.append((spp, seconds, rmse, relmse))
                print(f"mitsuba {spp:>6} spp {seconds:>9.3f} s  RMSE {rmse:.5f}  relMSE {relmse:.5f}", file=sys.stderr, flush=True)
                if seconds >= args.time_limit:
                    break
                spp *= 4 if args.sampler == "ldsampler" else 2
            with open(args.log, "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(["spp", "seconds", "rmse", "relmse"])
                w.writerows(rows)

            if not args.converged:
                return
            per_batch = max(1, args.converged_spp // args.batches)
            batches = [render(scene, per_batch, 1_000_000 + b)[0].astype(np.float64) for b in range(args.batches)]
            stack = np.stack(batches)
            mean = stack.mean(axis=0)
            variance = stack.var(axis=0, ddof=1) / len(batches)
            data = np.concatenate([mean, variance], axis=-1).astype(np.float32)
            bitmap = mi.Bitmap(
                data,
                pixel_format=mi.Bitmap.PixelFormat.MultiChannel,
                channel_names=["R", "G", "B", "variance.R", "variance.G", "variance.B"],
            )
            bitmap.write(args.converged)
    except SceneError as e:
        print(f"mitsuba_peer.py: {args.scene}: {e}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
