//! The hard cases in `scenes/hard/`: sealed rooms, degenerate geometry, mirrors, glass
//! furnaces, coplanar faces, terminators and caustics, each with an exact or checkable answer.

use std::f64::consts::PI;
use std::path::Path;

use serde_json::{json, Value};

use super::cornell;
use super::gltf::*;

/// A closed cube (12 triangles on 8 shared vertices, with the averaged corner normals a
/// modelling tool exports) lit only from outside by a point light and an emissive quad
/// above it, the camera inside: no light can reach the camera, so every pixel is exactly 0.
pub(crate) fn sealed_room(path: &Path) {
    let mut g = Gltf::default();
    let white = g.material(lambert("white", [0.8, 0.8, 0.8]));
    let v = |i: usize| {
        [
            if i & 1 != 0 { 1.0f32 } else { -1.0 },
            if i & 2 != 0 { 1.0 } else { -1.0 },
            if i & 4 != 0 { 1.0 } else { -1.0 },
        ]
    };
    let positions: Vec<[f32; 3]> = (0..8).map(v).collect();
    let k = 1.0 / 3f32.sqrt();
    let normals: Vec<[f32; 3]> = positions.iter().map(|p| [p[0] * k, p[1] * k, p[2] * k]).collect();
    // Outward winding, two triangles per face.
    let faces: [[u32; 4]; 6] =
        [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let indices: Vec<u32> = faces.iter().flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]]).collect();
    g.mesh("sealed cube", &Mesh { positions, normals, indices }, white);
    let lamp = g.material(emitter("lamp", [50.0, 50.0, 50.0], 0.0));
    let mut quad = Mesh::default();
    quad.quad([[-0.8, 1.5, -0.8], [0.8, 1.5, -0.8], [0.8, 1.5, 0.8], [-0.8, 1.5, 0.8]], [0.0, 0.0, 0.0]);
    g.mesh("lamp above the cube", &quad, lamp);
    g.light(
        json!({"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 100.0}),
        [0.0, 2.5, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    );
    // Inside, looking up at a corner of the ceiling (where shading normals tilt most).
    g.perspective_camera("inside", 70f64.to_radians(), [0.0, -0.2, 0.3], rot_yaw_pitch(0.6, 0.35));
    g.write(
        path,
        "Sealed room: the camera inside a closed cube lit only from outside; every pixel is exactly 0",
    );
}

/// The Cornell box with its camera, under a root node that translates or scales it: an image
/// equal to the untransformed box, whatever the transform (the loader composes in f64 and
/// renders camera-relative).
pub(crate) fn transformed_cornell(path: &Path, root: Value, description: &str) {
    let mut g = Gltf { root: Some(root), ..Gltf::default() };
    cornell(&mut g, true);
    g.write(path, description);
}

/// Degenerate input beside a well-formed floor and lamp: zero-area and repeated-vertex
/// triangles (4), triangles with a NaN or infinite vertex (3), and two valid triangles
/// sharing a zero-length vertex normal. The loader must drop the 7 with warnings that
/// count them, shade the 2 with their geometric normal (counted too), and render finite
/// pixels.
pub(crate) fn degenerate(path: &Path) {
    let mut g = Gltf::default();
    let white = g.material(lambert("white", [0.8, 0.8, 0.8]));
    let mut floor = Mesh::default();
    floor.quad([[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], [0.0, 1.0, 0.0]);
    g.mesh("floor", &floor, white);
    let lamp = g.material(emitter("lamp", [8.0, 8.0, 8.0], 0.0));
    let mut quad = Mesh::default();
    quad.quad([[-0.5, 2.0, -0.5], [0.5, 2.0, -0.5], [0.5, 2.0, 0.5], [-0.5, 2.0, 0.5]], [0.0, 0.0, 0.0]);
    g.mesh("lamp", &quad, lamp);
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let positions: Vec<[f32; 3]> = vec![
        // 0–3: a valid quad (two triangles) standing on the floor.
        [-0.5, 0.0, 0.0],
        [0.5, 0.0, 0.0],
        [0.5, 1.0, 0.0],
        [-0.5, 1.0, 0.0],
        // 4–6: collinear.
        [0.0, 0.5, 0.5],
        [0.5, 0.5, 0.5],
        [1.0, 0.5, 0.5],
        // 7–9: NaN and infinite vertices.
        [nan, 0.2, 0.2],
        [0.3, inf, 0.1],
        [0.1, 0.1, -inf],
    ];
    let up = [0.0f32, 0.0, 1.0];
    let normals: Vec<[f32; 3]> = vec![up, up, [0.0, 0.0, 0.0], up, up, up, up, [nan, 0.0, 1.0], up, up];
    let indices: Vec<u32> = vec![
        0, 1, 2, 0, 2, 3, // valid, vertex 2's normal is zero
        4, 5, 6, 5, 6, 4, // zero area (collinear)
        0, 0, 1, 3, 2, 2, // zero area (a repeated vertex)
        7, 0, 1, 8, 1, 2, 9, 2, 3, // a NaN or infinite vertex
    ];
    g.mesh("degenerate", &Mesh { positions, normals, indices }, white);
    g.perspective_camera("camera", 50f64.to_radians(), [0.0, 1.0, 3.5], [-0.12, 0.0, 0.0, 0.993]);
    g.write(path, "Degenerate input: zero-area, repeated-vertex and non-finite triangles and a zero normal beside a lit floor");
}

/// A closed box of perfect mirrors (metal, base colour 1, roughness 0) with a small light
/// inside and the camera inside: every path is a chain of delta bounces ended by roulette,
/// the bounce guard, or the light.
pub(crate) fn mirror_box(path: &Path) {
    let mut g = Gltf::default();
    let mirror = g.material(metal("perfect mirror", [1.0, 1.0, 1.0], 0.0));
    let mut walls = Mesh::default();
    let c = |x: f64, y: f64, z: f64| [x, y, z];
    let faces = [
        [c(-1.0, -1.0, -1.0), c(1.0, -1.0, -1.0), c(1.0, -1.0, 1.0), c(-1.0, -1.0, 1.0)],
        [c(-1.0, 1.0, -1.0), c(1.0, 1.0, -1.0), c(1.0, 1.0, 1.0), c(-1.0, 1.0, 1.0)],
        [c(-1.0, -1.0, -1.0), c(1.0, -1.0, -1.0), c(1.0, 1.0, -1.0), c(-1.0, 1.0, -1.0)],
        [c(-1.0, -1.0, 1.0), c(1.0, -1.0, 1.0), c(1.0, 1.0, 1.0), c(-1.0, 1.0, 1.0)],
        [c(-1.0, -1.0, -1.0), c(-1.0, 1.0, -1.0), c(-1.0, 1.0, 1.0), c(-1.0, -1.0, 1.0)],
        [c(1.0, -1.0, -1.0), c(1.0, 1.0, -1.0), c(1.0, 1.0, 1.0), c(1.0, -1.0, 1.0)],
    ];
    for f in faces {
        walls.quad(f, [0.0, 0.0, 0.0]);
    }
    g.mesh("mirror walls", &walls, mirror);
    let mut lamp = Mesh::default();
    lamp.quad([[-0.1, 0.95, -0.1], [0.1, 0.95, -0.1], [0.1, 0.95, 0.1], [-0.1, 0.95, 0.1]], [0.0, 0.0, 0.0]);
    let mut lamp_material = emitter("small lamp", [10.0, 10.0, 10.0], 0.0);
    lamp_material["doubleSided"] = json!(true);
    let lamp_material = g.material(lamp_material);
    g.mesh("small lamp", &lamp, lamp_material);
    g.perspective_camera("inside", 70f64.to_radians(), [0.2, -0.3, 0.6], [0.0, 0.0, 0.0, 1.0]);
    g.write(path, "Mirror box: the camera inside a closed box of perfect mirrors with one small light");
}

/// Glass of index exactly 1 in the Cornell room: a smooth refracting sphere and a rough one,
/// and a thin-walled pane. With no change of index the interfaces vanish: the image equals
/// the empty room's.
pub(crate) fn index_matched_glass(path: &Path) {
    let mut g = Gltf::default();
    cornell(&mut g, true);
    let mut matched = |name: &str, roughness: f64, solid: bool| {
        let mut m = glass(name, roughness, if solid { Some(([1.0, 1.0, 1.0], 1.0)) } else { None });
        m["extensions"]["KHR_materials_ior"] = json!({"ior": 1.0});
        g.material(m)
    };
    let smooth = matched("index-matched smooth solid", 0.0, true);
    let rough = matched("index-matched rough solid", 0.4, true);
    let thin = matched("index-matched thin pane", 0.0, false);
    g.mesh("smooth sphere", &Mesh::icosphere([0.2, 0.3, 0.2], 0.1, 3, false, true), smooth);
    g.mesh("rough sphere", &Mesh::icosphere([0.38, 0.25, 0.3], 0.08, 3, false, true), rough);
    let mut pane = Mesh::default();
    pane.quad(
        [[0.1, 0.05, 0.15], [0.45, 0.05, 0.15], [0.45, 0.45, 0.15], [0.1, 0.45, 0.15]],
        [0.28, 0.27, -1.0],
    );
    g.mesh("pane", &pane, thin);
    g.write(
        path,
        "Glass of index 1 (smooth and rough solids, a thin pane) in the Cornell box: it must vanish",
    );
}

/// A smooth sphere of white metal (F₀ = 1) of perceptual roughness `roughness`, to be lit by
/// a uniform white environment: each pixel then shows the GGX lobe's directional albedo at
/// its viewing angle.
pub(crate) fn glossy_furnace(path: &Path, roughness: f64) {
    let mut g = Gltf::default();
    let m = g.material(metal(&format!("white metal r={roughness}"), [1.0, 1.0, 1.0], roughness));
    g.mesh("sphere", &Mesh::icosphere([0.0, 0.0, 0.0], 1.0, 4, false, true), m);
    g.perspective_camera("camera", 40f64.to_radians(), [0.0, 0.0, 3.2], [0.0, 0.0, 0.0, 1.0]);
    g.write(
        path,
        &format!("Glossy furnace: a white GGX conductor (F0 = 1, roughness {roughness}) sphere for a uniform white environment"),
    );
}

/// A solid glass sphere without absorption, to be lit by a uniform white environment.
pub(crate) fn glass_furnace(path: &Path, roughness: f64) {
    let mut g = Gltf::default();
    let m = g.material(glass(&format!("clear glass r={roughness}"), roughness, Some(([1.0, 1.0, 1.0], 1.0))));
    g.mesh("sphere", &Mesh::icosphere([0.0, 0.0, 0.0], 1.0, 4, false, true), m);
    g.perspective_camera("camera", 40f64.to_radians(), [0.0, 0.0, 3.2], [0.0, 0.0, 0.0, 1.0]);
    g.write(
        path,
        &format!(
            "Glass furnace: a clear glass sphere (roughness {roughness}) for a uniform white environment"
        ),
    );
}

/// A thick slab of clear glass (2 × 0.5 × 2, no absorption) seen at a grazing angle, to be
/// lit by a uniform white environment: light meets its faces at grazing incidence and is
/// totally internally reflected inside it.
pub(crate) fn glass_slab(path: &Path, roughness: f64) {
    let mut g = Gltf::default();
    let m = g.material(glass(
        &format!("clear glass slab r={roughness}"),
        roughness,
        Some(([1.0, 1.0, 1.0], 1.0)),
    ));
    let (hx, hy, hz) = (1.0, 0.25, 1.0);
    let mut slab = Mesh::default();
    let c = |x: f64, y: f64, z: f64| [x * hx, y * hy, z * hz];
    let faces = [
        ([c(-1.0, -1.0, -1.0), c(1.0, -1.0, -1.0), c(1.0, -1.0, 1.0), c(-1.0, -1.0, 1.0)], [0.0, -1.0, 0.0]),
        ([c(-1.0, 1.0, -1.0), c(1.0, 1.0, -1.0), c(1.0, 1.0, 1.0), c(-1.0, 1.0, 1.0)], [0.0, 1.0, 0.0]),
        ([c(-1.0, -1.0, -1.0), c(1.0, -1.0, -1.0), c(1.0, 1.0, -1.0), c(-1.0, 1.0, -1.0)], [0.0, 0.0, -1.0]),
        ([c(-1.0, -1.0, 1.0), c(1.0, -1.0, 1.0), c(1.0, 1.0, 1.0), c(-1.0, 1.0, 1.0)], [0.0, 0.0, 1.0]),
        ([c(-1.0, -1.0, -1.0), c(-1.0, 1.0, -1.0), c(-1.0, 1.0, 1.0), c(-1.0, -1.0, 1.0)], [-1.0, 0.0, 0.0]),
        ([c(1.0, -1.0, -1.0), c(1.0, 1.0, -1.0), c(1.0, 1.0, 1.0), c(1.0, -1.0, 1.0)], [1.0, 0.0, 0.0]),
    ];
    for (corners, out) in faces {
        slab.quad(corners, [out[0] * 10.0, out[1] * 10.0, out[2] * 10.0]);
    }
    g.mesh("slab", &slab, m);
    // 0.4 above the top face, 3 away, looking down by 10°: the top face is seen at 80–85°.
    let pitch = -10f64.to_radians();
    g.perspective_camera(
        "grazing",
        50f64.to_radians(),
        [0.0, 0.65, 3.0],
        [(pitch / 2.0).sin(), 0.0, 0.0, (pitch / 2.0).cos()],
    );
    g.write(
        path,
        &format!("Glass slab (roughness {roughness}) at grazing incidence for a uniform white environment"),
    );
}

/// Two quads of different materials lying in one plane and overlapping in the middle,
/// under an area light, seen from above; `which` keeps both, or only the red or the green
/// one (the references for the blend in the overlap).
/// Case 4 (shadow terminator): a white Lambertian unit sphere at the origin, an icosphere of
/// `level` subdivisions with smooth (vertex = position) normals, lit by a directional light
/// from 76° off the view direction, seen by an orthographic camera down −Z (±1.1 units).
/// The terminator crosses the visible disk at x ≈ −0.24; around it light arrives at grazing
/// angles, where a coarse mesh's smooth normals disagree most with its faces.
pub(crate) fn terminator(path: &Path, level: u32) {
    let mut g = Gltf::default();
    let white = g.material(lambert("white", [0.8, 0.8, 0.8]));
    g.mesh("sphere", &Mesh::icosphere([0.0, 0.0, 0.0], 1.0, level, false, true), white);
    // The light travels along −Z turned 76° about +Y: (−sin 76°, 0, −cos 76°).
    g.light(
        json!({"type": "directional", "color": [1.0, 1.0, 1.0], "intensity": 3.0}),
        [0.0; 3],
        rot_y(76f64.to_radians()),
    );
    g.orthographic_camera("camera", 1.1, [0.0, 0.0, 3.0]);
    let faces = 20 * 4u32.pow(level);
    g.write(
        path,
        &format!(
            "Shadow terminator: a {faces}-triangle smooth-shaded sphere under grazing directional light"
        ),
    );
}

pub(crate) fn coplanar(path: &Path, which: &str) {
    let mut g = Gltf::default();
    let red = g.material(lambert("red", [0.8, 0.1, 0.1]));
    let green = g.material(lambert("green", [0.1, 0.8, 0.1]));
    let grey = g.material(lambert("grey floor", [0.3, 0.3, 0.3]));
    let mut floor = Mesh::default();
    floor.quad([[-3.0, -0.5, -3.0], [3.0, -0.5, -3.0], [3.0, -0.5, 3.0], [-3.0, -0.5, 3.0]], [0.0, 1.0, 0.0]);
    g.mesh("floor", &floor, grey);
    if which != "green" {
        let mut q = Mesh::default();
        q.quad([[-1.2, 0.0, -0.8], [0.4, 0.0, -0.8], [0.4, 0.0, 0.8], [-1.2, 0.0, 0.8]], [0.0, 1.0, 0.0]);
        g.mesh("red quad", &q, red);
    }
    if which != "red" {
        let mut q = Mesh::default();
        // Another triangulation of the shared plane: its edges cross the red quad's.
        q.quad([[-0.4, 0.0, 0.8], [-0.4, 0.0, -0.8], [1.2, 0.0, -0.8], [1.2, 0.0, 0.8]], [0.0, 1.0, 0.0]);
        g.mesh("green quad", &q, green);
    }
    let lamp = g.material(emitter("lamp", [6.0, 6.0, 6.0], 0.0));
    let mut l = Mesh::default();
    l.quad([[-0.6, 2.5, -0.6], [0.6, 2.5, -0.6], [0.6, 2.5, 0.6], [-0.6, 2.5, 0.6]], [0.0, 0.0, 0.0]);
    g.mesh("lamp", &l, lamp);
    // Straight down from above (−Z turned to −Y: −90° about X).
    let h = (PI / 4.0).sin();
    g.perspective_camera("above", 60f64.to_radians(), [0.0, 2.2, 0.0], [-h, 0.0, 0.0, h]);
    g.write(path, &format!("Coplanar overlapping quads of two materials ({which})"));
}

/// A caustic with a known answer. A lamp at height 0.5 emits only downwards, onto a perfect
/// mirror (F₀ = 1, so F = 1 at every angle) at height 0; a diffuse ceiling at height 1
/// receives its light only through the mirror; a camera between lamp and ceiling looks up
/// at the ceiling. Every two-bounce path is ceiling → mirror → lamp (the lamp's back is
/// black and emits nothing). With `virtual_lamp` the mirror is gone and the lamp's mirror
/// image (height −0.5, emitting upwards) lights the ceiling directly, the real lamp staying
/// as a black occluder: the one-bounce image of that scene equals the two-bounce image of
/// the first.
pub(crate) fn caustic_mirror(path: &Path, virtual_lamp: bool) {
    let mut g = Gltf::default();
    let white = g.material(lambert("white ceiling", [0.8, 0.8, 0.8]));
    let mut ceiling = Mesh::default();
    ceiling.quad([[-2.0, 1.0, -2.0], [2.0, 1.0, -2.0], [2.0, 1.0, 2.0], [-2.0, 1.0, 2.0]], [0.0, 0.0, 0.0]);
    g.mesh("ceiling", &ceiling, white);
    let lamp_at = |y: f64| [[-0.15, y, -0.15], [0.15, y, -0.15], [0.15, y, 0.15], [-0.15, y, 0.15]];
    let black = g.material(lambert("black", [0.0, 0.0, 0.0]));
    let lamp_material = g.material(emitter("lamp", [20.0, 16.0, 12.0], 0.0));
    let mut lamp = Mesh::default();
    if virtual_lamp {
        let mut occluder = Mesh::default();
        occluder.quad(lamp_at(0.5), [0.0, 0.0, 0.0]);
        g.mesh("the real lamp, dark", &occluder, black);
        lamp.quad(lamp_at(-0.5), [0.0, 1.0, 0.0]);
        g.mesh("the lamp's mirror image", &lamp, lamp_material);
    } else {
        lamp.quad(lamp_at(0.5), [0.0, -1.0, 0.0]);
        g.mesh("lamp", &lamp, lamp_material);
        let mirror = g.material(metal("perfect mirror", [1.0, 1.0, 1.0], 0.0));
        let mut floor = Mesh::default();
        floor.quad([[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], [0.0, 1.0, 0.0]);
        g.mesh("mirror", &floor, mirror);
    }
    // Looking up (+y): a quarter turn about x takes the camera's −z to +y.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    g.perspective_camera("up", 80f64.to_radians(), [0.1, 0.6, 0.05], [h, 0.0, 0.0, h]);
    g.write(
        path,
        if virtual_lamp {
            "A ceiling lit directly by a lamp below a dark occluder: the one-bounce twin of caustic-mirror.gltf"
        } else {
            "A ceiling lit only through a perfect mirror (a caustic): at two bounces it equals caustic-mirror-virtual.gltf at one"
        },
    );
}
