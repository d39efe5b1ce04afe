#!/usr/bin/env python3
"""Converts a pathlight benchmark scene to pbrt-v4's scene format, for `pathlight bench
--peer pbrt` (pbrt-v4's `bdpt` is the peer of pathlight's BDPT, issue 43).

    python3 bench/pbrt_peer.py SCENE.gltf --width W --height H --integrator bdpt --out scene.pbrt
        [--insert MODEL.glb --matrix=m00,... --insert-white 0.75]

The glTF is read by `gltf_scene.py`, independently of pathlight's loader. pbrt is run by
`pathlight bench` (`src/bench/pbrt.rs`) with `--spp`, `--seed` and `--outfile`, so the file
holds neither. What is set, and why (../shared/peers/pbrt-v4/README.md lists pbrt's defaults
that differ from pathlight's):

  * `Scale -1 1 1` before `LookAt`: pbrt is left-handed, glTF right-handed;
  * the perspective camera's `fov` is the shorter image axis's (pbrt's convention);
  * `PixelFilter "box"` (pbrt's default is a Gaussian), radius ½: pathlight's box pixel;
  * `Film "rgb"` written as 32-bit float EXR (`savefp16` false);
  * the integrator with `maxdepth` 100 (pbrt's default is 5; pathlight's is unlimited with
    roulette, and in these scenes a path of more than 100 bounces carries < 0.75¹⁰⁰ of its
    start), or `--max-depth D` where pathlight's renders are bounded too (`bench
    --max-depth`, e.g. for Metropolis, whose bootstrap spans every depth up to it);
  * `Sampler "zsobol"`, pbrt's default, Owen-scrambled Sobol points as pathlight's default;
  * for `sppm`, the initial radius pathlight's default gives (three pixel footprints at the
    scene's centroid) instead of pbrt's 1 world unit; photons per iteration stay pbrt's
    default, one per pixel, as pathlight's.

Materials, each to the pbrt material whose model is pathlight's for that case (anything
else is refused): Lambertian -> `diffuse` (pbrt's BSDFs reflect on both sides, as
pathlight's opaque surfaces do); emission -> a one-sided `diffuse` area light with `rgb L`
(pbrt scales an RGB illuminant by the colour space's white so it renders back as that RGB);
a smooth mirror of reflectance 1 -> `conductor` with `reflectance` 1; smooth clear solid
glass -> `dielectric` (a constant index: no dispersion).

pbrt renders spectrally: RGB reflectances are uplifted to smooth spectra, so its
interreflections differ from an RGB renderer's by 0.2-2% on these scenes (more under a
coloured light). The benchmark therefore measures each renderer against its own converged
image, and reports how far pbrt's converged image is from pathlight's.
"""

import argparse
import math
import sys

import numpy as np

from gltf_scene import SceneError, camera_frame, peer_material, read_gltf, triangle_meshes

MAX_DEPTH = 100


def pbrt_material(material, white_override=None):
    """(material directive, area light directive or None) for a glTF material."""
    if white_override is not None:
        return f'Material "diffuse" "rgb reflectance" [{white_override} {white_override} {white_override}]', None
    kind, parameter, emission = peer_material(material)
    light = None
    if emission:
        light = 'AreaLightSource "diffuse" "rgb L" [{} {} {}] "bool twosided" false'.format(*emission)
    if kind == "glass":
        return f'Material "dielectric" "float eta" [{parameter}] "float roughness" [0]', light
    if kind == "mirror":
        return 'Material "conductor" "rgb reflectance" [1 1 1] "float roughness" [0]', light
    return 'Material "diffuse" "rgb reflectance" [{} {} {}]'.format(*parameter), light


def numbers(values):
    return " ".join(f"{v:.9g}" for v in values)


def shapes(doc, buffers, transform, white_override, out):
    for name, positions, normals, faces, material in triangle_meshes(doc, buffers, transform):
        mat, light = pbrt_material(material, white_override)
        out.append(f"AttributeBegin # mesh {name}")
        out.append(f"  {mat}")
        if light is not None:
            out.append(f"  {light}")
        shape = f'  Shape "trianglemesh" "point3 P" [{numbers(positions.ravel())}] "integer indices" [{" ".join(str(int(i)) for i in faces.ravel())}]'
        if normals is not None:
            shape += f' "normal N" [{numbers(normals.ravel())}]'
        out.append(shape)
        out.append("AttributeEnd")


def sppm_radius(args, doc, buffers, eye, forward, fov):
    """For pbrt's `sppm`, its initial photon radius as pathlight's default sets it: three
    pixel footprints (`DEFAULT_SPPM_RADIUS_PIXELS` in src/integrator/sppm.rs), taken here at
    the scene's centroid (pathlight takes it per pixel; pbrt has one radius for the image).
    pbrt's own default is 1 world unit, the whole of a unit Cornell box. Other integrators:
    nothing."""
    if args.integrator != "sppm":
        return ""
    points = np.concatenate([positions for _, positions, _, _, _ in triangle_meshes(doc, buffers, np.eye(4))])
    depth = float(np.dot(points.mean(axis=0) - eye, forward / np.linalg.norm(forward)))
    shorter = min(args.width, args.height)
    footprint = 2.0 * math.tan(fov / 2.0) * depth / shorter
    return f' "float radius" [{3.0 * footprint:.6g}]'


def convert(args):
    doc, buffers = read_gltf(args.scene)
    perspective, eye, forward, up = camera_frame(doc)
    yfov = perspective["yfov"]
    aspect = args.width / args.height
    # pbrt's fov is the shorter axis's.
    fov = yfov if aspect >= 1.0 else 2.0 * math.atan(math.tan(yfov / 2.0) * aspect)
    out = [
        f"# {args.scene}, converted by bench/pbrt_peer.py",
        "Scale -1 1 1",
        f"LookAt {numbers(eye)}  {numbers(eye + forward)}  {numbers(up)}",
        f'Camera "perspective" "float fov" [{math.degrees(fov):.9g}]',
        'Sampler "zsobol"',
        'PixelFilter "box" "float xradius" [0.5] "float yradius" [0.5]',
        f'Film "rgb" "integer xresolution" [{args.width}] "integer yresolution" [{args.height}] '
        '"bool savefp16" false "string filename" ["pbrt.exr"]',
        f'Integrator "{args.integrator}" "integer maxdepth" [{args.max_depth}]{sppm_radius(args, doc, buffers, eye, forward, fov)}',
        "WorldBegin",
    ]
    shapes(doc, buffers, np.eye(4), None, out)
    if args.insert:
        insert_doc, insert_buffers = read_gltf(args.insert)
        values = [float(v) for v in args.matrix.split(",")]
        if len(values) != 16:
            raise SceneError(f"--matrix: 16 numbers expected, {len(values)} given")
        m = np.array(values, dtype=np.float64).reshape(4, 4).T  # column-major
        shapes(insert_doc, insert_buffers, m, args.insert_white, out)
    with open(args.out, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene")
    p.add_argument("--insert", help="a second glTF placed in the scene (e.g. the bunny)")
    p.add_argument("--matrix", help="its transform: 16 comma-separated numbers, column-major")
    p.add_argument("--insert-white", type=float, help="give the insert a Lambertian of this albedo")
    p.add_argument("--width", type=int, default=256)
    p.add_argument("--height", type=int, default=256)
    p.add_argument("--integrator", default="bdpt", help="pbrt's integrator: bdpt, path, ...")
    p.add_argument("--max-depth", type=int, default=MAX_DEPTH, help="the integrator's maxdepth")
    p.add_argument("--out", required=True, help="the .pbrt file to write")
    args = p.parse_args()
    try:
        convert(args)
    except SceneError as e:
        print(f"pbrt_peer.py: {e}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
