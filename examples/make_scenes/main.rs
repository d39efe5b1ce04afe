//! Generates the bundled scenes in `scenes/` (run: `cargo run --example make_scenes`).
//!
//! Each scene is a self-contained `.gltf` with its buffer embedded as a base64 data URI,
//! written deterministically so regeneration is reviewable as a diff of this program.

use std::f64::consts::PI;
use std::path::Path;

use serde_json::json;

mod gltf;
mod hard;

use gltf::*;
use hard::*;

/// The Cornell box from the measured data published by the Cornell Program of Computer
/// Graphics (https://www.graphics.cornell.edu/online/box/data.html), converted from
/// millimetres to metres. The coordinate frame is the data's own: +Y up, the camera at
/// z = −0.8 looking down +Z, so +X is to the viewer's left (red wall). The light quad sits
/// 0.5 mm under the ceiling so it does not coincide with it. Reflectances are the usual RGB
/// fits of the measured spectra (as in the pbrt-v4 and Mitsuba scenes); the light's radiance
/// (17, 12, 4) likewise.
///
/// `with_blocks` keeps the two boxes; scenes that put other objects in the room omit them.
pub(crate) fn cornell(g: &mut Gltf, with_blocks: bool) {
    cornell_with_light(g, with_blocks, 1.0);
}

/// [`cornell`] with the light's sides scaled by `light_scale` about its centre and its
/// radiance by 1/light_scale², so it emits the same power.
fn cornell_with_light(g: &mut Gltf, with_blocks: bool, light_scale: f64) {
    let mm = |p: [f64; 3]| [p[0] / 1000.0, p[1] / 1000.0, p[2] / 1000.0];
    let inside = mm([278.0, 274.4, 279.6]);
    let white = g.material(lambert("white", [0.725, 0.71, 0.68]));
    let red = g.material(lambert("red", [0.63, 0.065, 0.05]));
    let green = g.material(lambert("green", [0.14, 0.45, 0.091]));
    let k = 1.0 / (light_scale * light_scale);
    let light = g.material(emitter("light", [17.0 * k, 12.0 * k, 4.0 * k], 0.78));

    let mut walls = Mesh::default();
    let quads = [
        // floor, ceiling, back wall
        [[552.8, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 559.2], [549.6, 0.0, 559.2]],
        [[556.0, 548.8, 0.0], [556.0, 548.8, 559.2], [0.0, 548.8, 559.2], [0.0, 548.8, 0.0]],
        [[549.6, 0.0, 559.2], [0.0, 0.0, 559.2], [0.0, 548.8, 559.2], [556.0, 548.8, 559.2]],
    ];
    for q in quads {
        walls.quad(q.map(mm), inside);
    }
    g.mesh("white walls", &walls, white);
    let mut left = Mesh::default();
    left.quad(
        [[552.8, 0.0, 0.0], [549.6, 0.0, 559.2], [556.0, 548.8, 559.2], [556.0, 548.8, 0.0]].map(mm),
        inside,
    );
    g.mesh("red wall", &left, red);
    let mut right = Mesh::default();
    right.quad([[0.0, 0.0, 559.2], [0.0, 0.0, 0.0], [0.0, 548.8, 0.0], [0.0, 548.8, 559.2]].map(mm), inside);
    g.mesh("green wall", &right, green);
    let mut lamp = Mesh::default();
    let (cx, cz) = (278.0, 279.5);
    let lamp_corner = |x: f64, z: f64| [cx + (x - cx) * light_scale, 548.3, cz + (z - cz) * light_scale];
    lamp.quad(
        [
            lamp_corner(343.0, 227.0),
            lamp_corner(343.0, 332.0),
            lamp_corner(213.0, 332.0),
            lamp_corner(213.0, 227.0),
        ]
        .map(mm),
        mm([278.0, 0.0, 279.6]),
    );
    g.mesh("light", &lamp, light);

    if with_blocks {
        let mut blocks = Mesh::default();
        let short: [[[f64; 3]; 4]; 5] = [
            [[130.0, 165.0, 65.0], [82.0, 165.0, 225.0], [240.0, 165.0, 272.0], [290.0, 165.0, 114.0]],
            [[290.0, 0.0, 114.0], [290.0, 165.0, 114.0], [240.0, 165.0, 272.0], [240.0, 0.0, 272.0]],
            [[130.0, 0.0, 65.0], [130.0, 165.0, 65.0], [290.0, 165.0, 114.0], [290.0, 0.0, 114.0]],
            [[82.0, 0.0, 225.0], [82.0, 165.0, 225.0], [130.0, 165.0, 65.0], [130.0, 0.0, 65.0]],
            [[240.0, 0.0, 272.0], [240.0, 165.0, 272.0], [82.0, 165.0, 225.0], [82.0, 0.0, 225.0]],
        ];
        let tall: [[[f64; 3]; 4]; 5] = [
            [[423.0, 330.0, 247.0], [265.0, 330.0, 296.0], [314.0, 330.0, 456.0], [472.0, 330.0, 406.0]],
            [[423.0, 0.0, 247.0], [423.0, 330.0, 247.0], [472.0, 330.0, 406.0], [472.0, 0.0, 406.0]],
            [[472.0, 0.0, 406.0], [472.0, 330.0, 406.0], [314.0, 330.0, 456.0], [314.0, 0.0, 456.0]],
            [[314.0, 0.0, 456.0], [314.0, 330.0, 456.0], [265.0, 330.0, 296.0], [265.0, 0.0, 296.0]],
            [[265.0, 0.0, 296.0], [265.0, 330.0, 296.0], [423.0, 330.0, 247.0], [423.0, 0.0, 247.0]],
        ];
        for (faces, center) in [(short, [185.0, 82.5, 168.5]), (tall, [368.5, 165.0, 351.25])] {
            for q in faces {
                // Outward: away from the block's centre.
                let q = q.map(mm);
                let c = mm(center);
                let qc = [0, 1, 2].map(|k| q.iter().map(|p| p[k]).sum::<f64>() / 4.0);
                let away = [2.0 * qc[0] - c[0], 2.0 * qc[1] - c[1], 2.0 * qc[2] - c[2]];
                blocks.quad(q, away);
            }
        }
        g.mesh("blocks", &blocks, white);
    }
    // 35 mm focal length on a 25 mm film: yfov = 2·atan(12.5 / 35).
    let yfov = 2.0 * (12.5f64 / 35.0).atan();
    g.perspective_camera("camera", yfov, [0.278, 0.273, -0.8], rot_y(PI));
}

fn furnace(path: &Path, albedo: f64) {
    let mut g = Gltf::default();
    let mut m = lambert("furnace", [albedo; 3]);
    m["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    let mat = g.material(m);
    // Inward-facing, flat-shaded, one-sided emitter: the camera inside sees front faces.
    let sphere = Mesh::icosphere([0.0; 3], 1.0, 3, true, false);
    g.mesh("sphere", &sphere, mat);
    g.perspective_camera("camera", 60f64.to_radians(), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]);
    g.write(
        path,
        &format!(
            "Furnace: the camera inside a closed sphere of Lambertian albedo {albedo} whose inside emits radiance 1; every pixel's exact value is 1/(1 - {albedo}) = {}",
            1.0 / (1.0 - albedo)
        ),
    );
}

/// The benchmark's glass scene (issue 8): a perfect mirror sphere and a clear solid glass
/// sphere in the Cornell room, the classic pair, with materials a peer renderer models
/// identically (a mirror of reflectance 1; clear glass of index 1.5).
fn cornell_spheres(g: &mut Gltf) {
    cornell(g, false);
    let mirror = g.material(metal("mirror (reflectance 1)", [1.0, 1.0, 1.0], 0.0));
    let clear = g.material(json!({"name": "clear glass (solid, index 1.5)",
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5},
            "KHR_materials_volume": {"thicknessFactor": 0.1}}}));
    g.mesh("mirror sphere", &Mesh::icosphere([0.39, 0.1, 0.37], 0.1, 4, false, true), mirror);
    g.mesh("glass sphere", &Mesh::icosphere([0.17, 0.1, 0.2], 0.1, 4, false, true), clear);
}

/// The rooms' three materials: white walls and ceiling, the warm wall, the floor.
fn room_materials(g: &mut Gltf) -> [usize; 3] {
    [
        g.material(lambert("white walls", [0.75, 0.75, 0.72])),
        g.material(lambert("warm wall", [0.7, 0.45, 0.3])),
        g.material(lambert("floor", [0.45, 0.38, 0.3])),
    ]
}

/// The 5 m × 2.6 m × 5 m room of the lamp and slit rooms: walls and ceiling, the warm wall
/// (−x) and the floor, facing in, with [`room_materials`]'s materials.
fn room_shell(g: &mut Gltf, [white, warm, floor_m]: [usize; 3]) {
    let (x0, x1, y1, z0, z1) = (-2.5, 2.5, 2.6, -2.5, 2.5);
    let inside = [0.0, 1.3, 0.0];
    let mut walls = Mesh::default();
    walls.quad([[x0, y1, z0], [x1, y1, z0], [x1, y1, z1], [x0, y1, z1]], inside);
    walls.quad([[x0, 0.0, z0], [x1, 0.0, z0], [x1, y1, z0], [x0, y1, z0]], inside);
    walls.quad([[x1, 0.0, z0], [x1, 0.0, z1], [x1, y1, z1], [x1, y1, z0]], inside);
    walls.quad([[x0, 0.0, z1], [x1, 0.0, z1], [x1, y1, z1], [x0, y1, z1]], inside);
    g.mesh("walls and ceiling", &walls, white);
    let mut left = Mesh::default();
    left.quad([[x0, 0.0, z0], [x0, 0.0, z1], [x0, y1, z1], [x0, y1, z0]], inside);
    g.mesh("warm wall", &left, warm);
    let mut floor = Mesh::default();
    floor.quad([[x0, 0.0, z0], [x1, 0.0, z0], [x1, 0.0, z1], [x0, 0.0, z1]], inside);
    g.mesh("floor", &floor, floor_m);
}

/// A room lit only by a lamp inside a shade facing the ceiling: a small disk emitter at the
/// bottom of a deep, narrow cylindrical shade on a floor lamp. Its light leaves upward in a
/// narrow cone, lights a spot on the ceiling, and reaches everything the camera sees only
/// from there. A path tracer has to find that spot by chance from each wall point (its light
/// samples are shadowed by the shade); light subpaths start there at once. The setting of
/// issue 43's BDPT goal, all Lambertian so that Mitsuba 3 can render it too.
fn lamp_shade_room(path: &Path) {
    let mut g = Gltf::default();
    let room = room_materials(&mut g);
    let white = room[0];
    let dark = g.material(lambert("lamp and furniture", [0.3, 0.3, 0.32]));
    let lamp = g.material(emitter("lamp", [600.0, 500.0, 360.0], 0.0));
    room_shell(&mut g, room);
    // A cabinet and a low table, for shadows; the floor lamp: a base, a pole, and a
    // 12-sided shade of radius 0.15 from y = 1.2 to 1.8, closed below, open above.
    let mut furniture = Mesh::default();
    furniture.cuboid([1.2, 0.0, -2.5], [2.3, 1.1, -1.9]);
    furniture.cuboid([-0.6, 0.0, -0.9], [0.6, 0.45, -0.3]);
    let (cx, cz) = (-1.3, -1.4);
    furniture.cuboid([cx - 0.2, 0.0, cz - 0.2], [cx + 0.2, 0.04, cz + 0.2]);
    furniture.cuboid([cx - 0.02, 0.04, cz - 0.02], [cx + 0.02, 1.19, cz + 0.02]);
    let (r, y_lo, y_hi, sides) = (0.15, 1.2, 1.8, 12);
    let at = |k: usize, radius: f64, y: f64| {
        let a = 2.0 * PI * k as f64 / sides as f64;
        [cx + radius * a.cos(), y, cz + radius * a.sin()]
    };
    g.mesh("furniture and lamp stand", &furniture, dark);
    // The shade: one surface, white on both sides as every opaque pathlight surface is
    // (a second, coincident face for its inside would leave which one a ray hits to
    // rounding, and the backends would disagree).
    let mut shade = Mesh::default();
    for k in 0..sides {
        let q = [at(k, r, y_lo), at(k + 1, r, y_lo), at(k + 1, r, y_hi), at(k, r, y_hi)];
        shade.quad(q, [cx, 1.5, cz]);
        shade.triangle([at(k, r, y_lo), at(k + 1, r, y_lo), [cx, y_lo, cz]], [cx, 2.0, cz]);
    }
    g.mesh("shade", &shade, white);
    // The bulb: a disk of radius 0.1 facing up, 5 cm above the shade's floor.
    let mut bulb = Mesh::default();
    for k in 0..sides {
        bulb.triangle([at(k, 0.1, 1.25), at(k + 1, 0.1, 1.25), [cx, 1.25, cz]], [cx, 2.0, cz]);
    }
    g.mesh("bulb", &bulb, lamp);
    g.perspective_camera("camera", 65f64.to_radians(), [0.3, 1.3, 2.3], [-0.06, 0.0, 0.0, 0.998_198]);
    g.write(
        path,
        "A room lit only by a lamp inside a shade facing the ceiling: the light reaches everything the camera sees by way of a spot on the ceiling",
    );
}

/// A room lit only through a slit (issue 45's Metropolis goal, after Veach's door ajar): a
/// closed box on the floor holds the lamp, a square emitter on its floor facing up, and its
/// only opening is a slit 2 cm wide across its lid. Light leaves it as a thin sheet that
/// draws a line on the ceiling, and reaches everything the camera sees from there; the box's
/// white inside scatters more out through the slit. A path tracer must find the slit from
/// every wall point, and most of BDPT's light subpaths never leave the box; a Markov chain
/// that found a path through the slit explores its neighbours. All Lambertian, so that
/// peers render it too.
fn slit_room(path: &Path) {
    let mut g = Gltf::default();
    let room = room_materials(&mut g);
    let white = room[0];
    let lamp = g.material(emitter("lamp", [4000.0, 3400.0, 2500.0], 0.0));
    room_shell(&mut g, room);
    // The box: 0.6 × 0.5 × 0.6 m, one surface (white on both sides), its lid in two halves
    // with the slit between them along z.
    let (bx0, bx1, by1, bz0, bz1) = (-1.2, -0.6, 0.5, -1.8, -1.2);
    let slit = 0.02;
    let (sx0, sx1) = ((bx0 + bx1 - slit) / 2.0, (bx0 + bx1 + slit) / 2.0);
    let centre = [(bx0 + bx1) / 2.0, by1 / 2.0, (bz0 + bz1) / 2.0];
    let mut boxm = Mesh::default();
    boxm.quad([[bx0, 0.0, bz0], [bx1, 0.0, bz0], [bx1, by1, bz0], [bx0, by1, bz0]], centre);
    boxm.quad([[bx0, 0.0, bz1], [bx1, 0.0, bz1], [bx1, by1, bz1], [bx0, by1, bz1]], centre);
    boxm.quad([[bx0, 0.0, bz0], [bx0, 0.0, bz1], [bx0, by1, bz1], [bx0, by1, bz0]], centre);
    boxm.quad([[bx1, 0.0, bz0], [bx1, 0.0, bz1], [bx1, by1, bz1], [bx1, by1, bz0]], centre);
    boxm.quad([[bx0, 0.001, bz0], [bx1, 0.001, bz0], [bx1, 0.001, bz1], [bx0, 0.001, bz1]], centre);
    boxm.quad([[bx0, by1, bz0], [sx0, by1, bz0], [sx0, by1, bz1], [bx0, by1, bz1]], centre);
    boxm.quad([[sx1, by1, bz0], [bx1, by1, bz0], [bx1, by1, bz1], [sx1, by1, bz1]], centre);
    g.mesh("lamp box", &boxm, white);
    // The lamp: 0.2 m square, 1 cm above the box's floor, facing up.
    let (lx, lz, h) = (centre[0], centre[2], 0.1);
    let mut bulb = Mesh::default();
    bulb.quad(
        [[lx - h, 0.011, lz - h], [lx + h, 0.011, lz - h], [lx + h, 0.011, lz + h], [lx - h, 0.011, lz + h]],
        [lx, 1.0, lz],
    );
    g.mesh("lamp", &bulb, lamp);
    g.perspective_camera("camera", 65f64.to_radians(), [0.3, 1.3, 2.3], [-0.06, 0.0, 0.0, 0.998_198]);
    g.write(path, "A room lit only through a 2 cm slit in the lid of a closed box that holds the lamp");
}

/// Two rooms joined by a door left ajar (issue 45's Metropolis goal; Veach 1997, §11.5,
/// fig. 11.4): the camera's room, 5 × 2.6 × 4 m, is lit only through the door to the room
/// behind it, open 3° into that room. The door reaches from floor to ceiling, so the only
/// way through is the wedge, 5 cm at its widest, between the door's edge and its frame. The
/// lamp, a square on that room's ceiling to the left of the door, cannot see through it
/// (the door's back hides it), so all the light the camera sees has bounced off that room's
/// right side, passed the wedge, and come in sideways along the wall. A path from either end
/// rarely finds the wedge; a Markov chain that found one explores its neighbours. All
/// Lambertian, so that peers render it too.
fn door_ajar(path: &Path) {
    let mut g = Gltf::default();
    let [white, warm, floor_m] = room_materials(&mut g);
    let lamp = g.material(emitter("lamp", [20000.0, 17000.0, 12500.0], 0.0));
    // One shell over both rooms (z from −4 to 4), the dividing wall at z = 0 with a door
    // opening from x = 0.3 to 1.2, floor to ceiling.
    let (x0, x1, y1, z0, z1) = (-2.5, 2.5, 2.6, -4.0, 4.0);
    let (dx0, dx1) = (0.3, 1.2);
    let near = [0.0, 1.3, 2.0];
    let far = [0.0, 1.3, -2.0];
    let mut walls = Mesh::default();
    for (za, zb, inside) in [(0.0, z1, near), (z0, 0.0, far)] {
        walls.quad([[x0, y1, za], [x1, y1, za], [x1, y1, zb], [x0, y1, zb]], inside);
        walls.quad([[x1, 0.0, za], [x1, 0.0, zb], [x1, y1, zb], [x1, y1, za]], inside);
    }
    walls.quad([[x0, 0.0, z0], [x1, 0.0, z0], [x1, y1, z0], [x0, y1, z0]], far);
    // The dividing wall: one surface (white on both sides), around the opening.
    walls.quad([[x0, 0.0, 0.0], [dx0, 0.0, 0.0], [dx0, y1, 0.0], [x0, y1, 0.0]], near);
    walls.quad([[dx1, 0.0, 0.0], [x1, 0.0, 0.0], [x1, y1, 0.0], [dx1, y1, 0.0]], near);
    g.mesh("walls and ceilings", &walls, white);
    let mut left = Mesh::default();
    for (za, zb, inside) in [(0.0, z1, near), (z0, 0.0, far)] {
        left.quad([[x0, 0.0, za], [x0, 0.0, zb], [x0, y1, zb], [x0, y1, za]], inside);
    }
    left.quad([[x0, 0.0, z1], [x1, 0.0, z1], [x1, y1, z1], [x0, y1, z1]], near);
    g.mesh("warm walls", &left, warm);
    let mut floor = Mesh::default();
    floor.quad([[x0, 0.0, z0], [x1, 0.0, z0], [x1, 0.0, z1], [x0, 0.0, z1]], [0.0, 1.0, 0.0]);
    g.mesh("floor", &floor, floor_m);
    // The door: one surface, hinged at x = 0.3 and swung 3° into the far room (−z).
    let angle = 3f64.to_radians();
    let (lx, lz) = (dx0 + (dx1 - dx0) * angle.cos(), -(dx1 - dx0) * angle.sin());
    let mut door = Mesh::default();
    door.quad([[dx0, 0.0, 0.0], [lx, 0.0, lz], [lx, y1, lz], [dx0, y1, 0.0]], [0.5, 1.0, 1.0]);
    g.mesh("door", &door, white);
    // The lamp: 0.5 m square on the far room's ceiling, left of the door, facing down.
    let (cx, cz, h) = (-1.4, -2.0, 0.25);
    let mut bulb = Mesh::default();
    let y = y1 - 0.001;
    bulb.quad(
        [[cx - h, y, cz - h], [cx + h, y, cz - h], [cx + h, y, cz + h], [cx - h, y, cz + h]],
        [cx, 0.0, cz],
    );
    g.mesh("lamp", &bulb, lamp);
    // The camera in the near room's back right corner, looking at the door's wall and the
    // floor to its left, where the light comes in.
    let (eye, target) = ([2.1, 1.5, 3.7], [-0.6, 0.7, 0.3]);
    let d = sub(target, eye);
    let (yaw, pitch) = ((-d[0]).atan2(-d[2]), d[1].atan2((d[0] * d[0] + d[2] * d[2]).sqrt()));
    g.perspective_camera("camera", 65f64.to_radians(), eye, rot_yaw_pitch(yaw, pitch));
    g.write(
        path,
        "Two rooms joined by a door ajar: the camera's room lit only through the 5 cm gap at the door's edge",
    );
}

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::create_dir_all(dir.join("hard")).unwrap();
    sealed_room(&dir.join("hard/sealed-room.gltf"));
    degenerate(&dir.join("hard/degenerate.gltf"));
    mirror_box(&dir.join("hard/mirror-box.gltf"));
    glass_furnace(&dir.join("hard/glass-furnace-smooth.gltf"), 0.0);
    glass_furnace(&dir.join("hard/glass-furnace-rough.gltf"), 0.5);
    for which in ["both", "red", "green"] {
        coplanar(&dir.join(format!("hard/coplanar-{which}.gltf")), which);
    }
    terminator(&dir.join("hard/terminator-80.gltf"), 1);
    terminator(&dir.join("hard/terminator-20480.gltf"), 5);
    glass_slab(&dir.join("hard/glass-slab-smooth.gltf"), 0.0);
    glass_slab(&dir.join("hard/glass-slab-rough-1.gltf"), 1.0);
    for r in ["0.3", "0.6", "1.0"] {
        glossy_furnace(&dir.join(format!("hard/glossy-furnace-{r}.gltf")), r.parse().unwrap());
    }
    index_matched_glass(&dir.join("hard/glass-index-1.gltf"));
    caustic_mirror(&dir.join("hard/caustic-mirror.gltf"), false);
    caustic_mirror(&dir.join("hard/caustic-mirror-virtual.gltf"), true);
    let mut g = Gltf::default();
    cornell_with_light(&mut g, true, 0.01);
    g.write(
        &dir.join("hard/cornell-tiny-light.gltf"),
        "The Cornell box with its light shrunk to 1e-4 of its area at the same power (radiance x 1e4)",
    );
    for (name, root, what) in [
        ("far-1e6", json!({"translation": [1e6, -1e6, 1e6]}), "translated by 1e6 along each axis"),
        ("far-1e7", json!({"translation": [1e7, 1e7, -1e7]}), "translated by 1e7 along each axis"),
        ("tiny-1e-5", json!({"scale": [1e-5, 1e-5, 1e-5]}), "scaled by 1e-5"),
        ("huge-1e5", json!({"scale": [1e5, 1e5, 1e5]}), "scaled by 1e5"),
    ] {
        transformed_cornell(
            &dir.join(format!("hard/cornell-{name}.gltf")),
            root,
            &format!("The Cornell box and its camera {what}: the image equals the untransformed box's"),
        );
    }

    let mut g = Gltf::default();
    cornell(&mut g, true);
    g.write(
        &dir.join("cornell-box.gltf"),
        "The Cornell box (measured geometry), diffuse walls, area light under the ceiling",
    );

    lamp_shade_room(&dir.join("lamp-shade-room.gltf"));
    slit_room(&dir.join("slit-room.gltf"));
    // A benchmark scene, not a bundled one: the path tracer takes hours to converge on it,
    // which every test that walks scenes/ would pay for.
    door_ajar(&dir.join("../bench/scenes/door-ajar.gltf"));
    furnace(&dir.join("furnace-0.5.gltf"), 0.5);
    furnace(&dir.join("furnace-0.9.gltf"), 0.9);

    // Glossy metal: rough gold and a polished (roughness 0, delta) silver sphere, and a
    // glossy dielectric (plastic) sphere with its diffuse base, in the Cornell room.
    let mut g = Gltf::default();
    cornell(&mut g, false);
    let gold = g.material(metal("rough gold", [1.0, 0.71, 0.29], 0.35));
    let silver = g.material(metal("polished silver", [0.95, 0.93, 0.88], 0.0));
    let blue = g.material(plastic("glossy blue plastic", [0.1, 0.2, 0.6], 0.25));
    g.mesh("gold sphere", &Mesh::icosphere([0.39, 0.1, 0.35], 0.1, 3, false, true), gold);
    g.mesh("silver sphere", &Mesh::icosphere([0.17, 0.1, 0.25], 0.1, 3, false, true), silver);
    g.mesh("plastic sphere", &Mesh::icosphere([0.28, 0.3, 0.42], 0.08, 3, false, true), blue);
    g.write(
        &dir.join("glossy-metal.gltf"),
        "Rough and polished metal and glossy plastic spheres in the Cornell room",
    );

    // Smooth glass: a refracting solid sphere with Beer–Lambert absorption, and a thin-walled
    // pane, both perfectly smooth (delta lobes).
    let mut g = Gltf::default();
    cornell(&mut g, false);
    let solid = g.material(glass("smooth glass (solid, tinted)", 0.0, Some(([0.85, 0.95, 1.0], 0.1))));
    let thin = g.material(glass("smooth glass (thin-walled)", 0.0, None));
    g.mesh("glass sphere", &Mesh::icosphere([0.3, 0.13, 0.3], 0.13, 3, false, true), solid);
    let mut pane = Mesh::default();
    pane.quad([[0.08, 0.0, 0.45], [0.2, 0.0, 0.45], [0.2, 0.3, 0.45], [0.08, 0.3, 0.45]], [0.14, 0.15, -1.0]);
    g.mesh("glass pane", &pane, thin);
    g.write(
        &dir.join("glass-smooth.gltf"),
        "Smooth glass: a tinted refracting sphere and a thin-walled pane in the Cornell room",
    );

    // The benchmark's glass scene.
    let mut g = Gltf::default();
    cornell_spheres(&mut g);
    g.write(
        &dir.join("cornell-spheres.gltf"),
        "A mirror sphere and a clear glass sphere in the Cornell room (the speed-against-error benchmark's glass scene)",
    );

    // The same behind a thin glass pane filling the camera's view (issue 43): every
    // camera ray meets the pane first, so nothing the light tracer (or BDPT's t = 1)
    // joins to the camera can reach it, and both skip that work; the image is the
    // glass scene's, seen through a pane.
    let mut g = Gltf::default();
    cornell_spheres(&mut g);
    let pane_m = g.material(glass("thin glass pane", 0.0, None));
    let mut pane = Mesh::default();
    pane.quad(
        [[-0.2, -0.2, -0.7], [0.8, -0.2, -0.7], [0.8, 0.8, -0.7], [-0.2, 0.8, -0.7]],
        [0.278, 0.273, -0.8],
    );
    g.mesh("pane", &pane, pane_m);
    g.write(
        &dir.join("hard/cornell-spheres-behind-glass.gltf"),
        "The glass scene (cornell-spheres) seen through a thin glass pane that fills the camera's view",
    );

    // Rough glass: the same objects frosted.
    let mut g = Gltf::default();
    cornell(&mut g, false);
    let solid = g.material(glass("rough glass (solid)", 0.3, Some(([0.9, 0.9, 1.0], 0.2))));
    let thin = g.material(glass("rough glass (thin-walled)", 0.45, None));
    g.mesh("glass sphere", &Mesh::icosphere([0.3, 0.13, 0.3], 0.13, 3, false, true), solid);
    let mut pane = Mesh::default();
    pane.quad([[0.08, 0.0, 0.45], [0.2, 0.0, 0.45], [0.2, 0.3, 0.45], [0.08, 0.3, 0.45]], [0.14, 0.15, -1.0]);
    g.mesh("glass pane", &pane, thin);
    g.write(
        &dir.join("glass-rough.gltf"),
        "Rough glass: a frosted refracting sphere and a frosted thin pane in the Cornell room",
    );

    // Punctual lights only: point, spot and directional lights over a floor and wall.
    let mut g = Gltf::default();
    let white = g.material(lambert("white", [0.8, 0.8, 0.8]));
    let red = g.material(plastic("red plastic", [0.7, 0.1, 0.1], 0.3));
    let steel = g.material(metal("brushed steel", [0.6, 0.6, 0.62], 0.25));
    let mut room = Mesh::default();
    room.quad([[-2.0, 0.0, -2.0], [2.0, 0.0, -2.0], [2.0, 0.0, 2.0], [-2.0, 0.0, 2.0]], [0.0, 1.0, 0.0]);
    room.quad([[-2.0, 0.0, -1.0], [2.0, 0.0, -1.0], [2.0, 2.0, -1.0], [-2.0, 2.0, -1.0]], [0.0, 1.0, 0.0]);
    g.mesh("floor and wall", &room, white);
    g.mesh("red sphere", &Mesh::icosphere([-0.45, 0.35, 0.0], 0.35, 3, false, true), red);
    g.mesh("steel sphere", &Mesh::icosphere([0.45, 0.3, 0.2], 0.3, 3, false, true), steel);
    g.light(
        json!({"type": "point", "color": [1.0, 0.9, 0.8], "intensity": 2.0}),
        [0.0, 1.4, 0.8],
        [0.0, 0.0, 0.0, 1.0],
    );
    // Spot pointing straight down (−Z rotated to −Y: +90° about X).
    let h = (PI / 4.0).sin();
    g.light(
        json!({"type": "spot", "color": [0.6, 0.8, 1.0], "intensity": 6.0, "spot": {"innerConeAngle": 0.25, "outerConeAngle": 0.5}}),
        [0.45, 1.8, 0.2],
        [-h, 0.0, 0.0, h],
    );
    // Directional light from the upper left, travelling down and back.
    g.light(
        json!({"type": "directional", "color": [1.0, 1.0, 1.0], "intensity": 0.5}),
        [0.0, 0.0, 0.0],
        [-0.3, -0.3, 0.0, 0.905_538_5],
    );
    g.perspective_camera("camera", 45f64.to_radians(), [0.0, 0.9, 2.6], [-0.12, 0.0, 0.0, 0.992_774_4]);
    g.write(&dir.join("punctual.gltf"), "Point, spot and directional lights only (no emissive surfaces)");

    // Environment furnace: a closed, convex, white Lambertian sphere and no light of its own.
    // Under a constant environment of radiance L every point of it sees only sky, so every
    // pixel, sphere and background alike, is exactly L (with no --env or --background,
    // pathlight's default background: L = 1).
    let mut g = Gltf::default();
    let white = g.material(lambert("white", [1.0, 1.0, 1.0]));
    g.mesh("sphere", &Mesh::icosphere([0.0; 3], 1.0, 3, false, true), white);
    g.perspective_camera("camera", 40f64.to_radians(), [0.0, 0.0, 4.0], [0.0, 0.0, 0.0, 1.0]);
    g.write(
        &dir.join("env-furnace.gltf"),
        "Environment furnace: a white Lambertian sphere with no lights; under a constant environment of radiance L every pixel is exactly L",
    );

    // Objects for environment lighting (no light of their own: render with --env).
    let mut g = Gltf::default();
    let grey = g.material(lambert("grey floor", [0.5, 0.5, 0.5]));
    let gold = g.material(metal("rough gold", [1.0, 0.78, 0.34], 0.3));
    let chrome = g.material(metal("chrome", [0.95, 0.95, 0.95], 0.0));
    let clay = g.material(lambert("clay", [0.8, 0.45, 0.3]));
    let glass = g.material(glass("glass", 0.0, Some(([0.9, 0.95, 1.0], 0.5))));
    let mut floor = Mesh::default();
    floor.quad([[-3.0, 0.0, -3.0], [3.0, 0.0, -3.0], [3.0, 0.0, 3.0], [-3.0, 0.0, 3.0]], [0.0, 1.0, 0.0]);
    g.mesh("floor", &floor, grey);
    g.mesh("gold sphere", &Mesh::icosphere([-0.9, 0.4, 0.0], 0.4, 3, false, true), gold);
    g.mesh("chrome sphere", &Mesh::icosphere([0.0, 0.4, -0.5], 0.4, 3, false, true), chrome);
    g.mesh("clay sphere", &Mesh::icosphere([0.9, 0.4, 0.0], 0.4, 3, false, true), clay);
    g.mesh("glass sphere", &Mesh::icosphere([0.0, 0.3, 0.6], 0.3, 3, false, true), glass);
    g.perspective_camera("camera", 45f64.to_radians(), [0.0, 1.3, 3.4], [-0.17, 0.0, 0.0, 0.985_445_3]);
    g.write(
        &dir.join("env-objects.gltf"),
        "Metal, diffuse and glass spheres on a floor, no lights: render them under an environment (--env)",
    );
}
