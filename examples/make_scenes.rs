//! Generates the bundled scenes in `scenes/` (run: `cargo run --example make_scenes`).
//!
//! Each scene is a self-contained `.gltf` with its buffer embedded as a base64 data URI,
//! written deterministically so regeneration is reviewable as a diff of this program.

use std::collections::BTreeSet;
use std::f64::consts::PI;
use std::path::Path;

use base64::Engine;
use serde_json::{json, Value};

/// Assembles one glTF document.
#[derive(Default)]
struct Gltf {
    buffer: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    materials: Vec<Value>,
    nodes: Vec<Value>,
    cameras: Vec<Value>,
    lights: Vec<Value>,
    extensions: BTreeSet<&'static str>,
    /// When set, every node is placed under one root node with this transform (its
    /// `translation`, `rotation`, `scale`), composed by the loader in f64.
    root: Option<Value>,
}

fn bounds(points: &[[f32; 3]]) -> (Vec<f32>, Vec<f32>) {
    let mut lo = vec![f32::INFINITY; 3];
    let mut hi = vec![f32::NEG_INFINITY; 3];
    // Non-finite vertices (the degenerate-input scene has some) stay out of the bounds.
    for p in points.iter().filter(|p| p.iter().all(|c| c.is_finite())) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

impl Gltf {
    fn push_view(&mut self, bytes: &[u8], target: u32) -> usize {
        while self.buffer.len() % 4 != 0 {
            self.buffer.push(0);
        }
        let offset = self.buffer.len();
        self.buffer.extend_from_slice(bytes);
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}));
        self.views.len() - 1
    }

    fn vec3_accessor(&mut self, data: &[[f32; 3]], with_bounds: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&bytes, 34962);
        let mut acc = json!({"bufferView": view, "componentType": 5126, "count": data.len(), "type": "VEC3"});
        if with_bounds {
            let (lo, hi) = bounds(data);
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn index_accessor(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&bytes, 34963);
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }

    fn material(&mut self, m: Value) -> usize {
        if let Some(ext) = m.get("extensions").and_then(|e| e.as_object()) {
            for k in ext.keys() {
                self.extensions.insert(match k.as_str() {
                    "KHR_materials_emissive_strength" => "KHR_materials_emissive_strength",
                    "KHR_materials_specular" => "KHR_materials_specular",
                    "KHR_materials_transmission" => "KHR_materials_transmission",
                    "KHR_materials_volume" => "KHR_materials_volume",
                    "KHR_materials_ior" => "KHR_materials_ior",
                    other => panic!("unexpected extension {other}"),
                });
            }
        }
        self.materials.push(m);
        self.materials.len() - 1
    }

    /// A mesh node; `normals` may be empty for flat shading.
    fn mesh(&mut self, name: &str, mesh: &Mesh, material: usize) -> usize {
        let pos = self.vec3_accessor(&mesh.positions, true);
        let mut attributes = json!({"POSITION": pos});
        if !mesh.normals.is_empty() {
            attributes["NORMAL"] = json!(self.vec3_accessor(&mesh.normals, false));
        }
        let idx = self.index_accessor(&mesh.indices);
        self.meshes.push(json!({"name": name, "primitives": [{"attributes": attributes, "indices": idx, "material": material}]}));
        self.nodes.push(json!({"name": name, "mesh": self.meshes.len() - 1}));
        self.nodes.len() - 1
    }

    fn perspective_camera(&mut self, name: &str, yfov: f64, translation: [f64; 3], rotation: [f64; 4]) {
        self.cameras.push(
            json!({"type": "perspective", "perspective": {"yfov": yfov, "aspectRatio": 1.0, "znear": 0.01}}),
        );
        self.nodes.push(json!({"name": name, "camera": self.cameras.len() - 1, "translation": translation, "rotation": rotation}));
    }

    /// An orthographic camera at `translation` looking down −Z, showing ±`mag` units.
    fn orthographic_camera(&mut self, name: &str, mag: f64, translation: [f64; 3]) {
        self.cameras.push(json!({"type": "orthographic",
            "orthographic": {"xmag": mag, "ymag": mag, "znear": 0.01, "zfar": 100.0}}));
        self.nodes.push(json!({"name": name, "camera": self.cameras.len() - 1, "translation": translation}));
    }

    fn light(&mut self, light: Value, translation: [f64; 3], rotation: [f64; 4]) {
        self.extensions.insert("KHR_lights_punctual");
        self.lights.push(light);
        let name = format!("light {}", self.lights.len() - 1);
        self.nodes.push(json!({"name": name, "translation": translation, "rotation": rotation,
            "extensions": {"KHR_lights_punctual": {"light": self.lights.len() - 1}}}));
    }

    fn write(self, path: &Path, description: &str) {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.buffer)
        );
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "pathlight examples/make_scenes.rs", "extras": {"description": description}},
            "scene": 0,
            "scenes": [{"nodes": match &self.root {
                Some(_) => vec![self.nodes.len()],
                None => (0..self.nodes.len()).collect::<Vec<_>>(),
            }}],
            "nodes": match &self.root {
                Some(t) => {
                    let mut root = t.clone();
                    root["name"] = json!("root");
                    root["children"] = json!((0..self.nodes.len()).collect::<Vec<_>>());
                    let mut nodes = self.nodes.clone();
                    nodes.push(root);
                    nodes
                }
                None => self.nodes.clone(),
            },
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.views,
            "buffers": [{"byteLength": self.buffer.len(), "uri": uri}],
        });
        if !self.cameras.is_empty() {
            doc["cameras"] = json!(self.cameras);
        }
        if !self.lights.is_empty() {
            doc["extensions"] = json!({"KHR_lights_punctual": {"lights": self.lights}});
        }
        if !self.extensions.is_empty() {
            doc["extensionsUsed"] = json!(self.extensions.iter().collect::<Vec<_>>());
        }
        let text = serde_json::to_string_pretty(&doc).unwrap() + "\n";
        std::fs::write(path, text).unwrap();
        println!("wrote {}", path.display());
    }
}

/// Triangle geometry.
#[derive(Default, Clone)]
struct Mesh {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    indices: Vec<u32>,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}
fn f32x3(a: [f64; 3]) -> [f32; 3] {
    [a[0] as f32, a[1] as f32, a[2] as f32]
}

impl Mesh {
    /// Adds a planar quad (corners in order around it), wound so its front faces `toward`:
    /// a point the front side must see.
    fn quad(&mut self, corners: [[f64; 3]; 4], toward: [f64; 3]) {
        let n = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]));
        let center = [0, 1, 2].map(|k| corners.iter().map(|c| c[k]).sum::<f64>() / 4.0);
        let c = if dot(n, sub(toward, center)) >= 0.0 {
            corners
        } else {
            [corners[3], corners[2], corners[1], corners[0]]
        };
        let base = self.positions.len() as u32;
        self.positions.extend(c.iter().map(|p| f32x3(*p)));
        self.indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }

    /// A geodesic sphere: an icosahedron subdivided `level` times, projected onto the
    /// sphere. Faces point outward, or inward with `inward`; smooth normals if `smooth`.
    fn icosphere(center: [f64; 3], radius: f64, level: u32, inward: bool, smooth: bool) -> Mesh {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut verts: Vec<[f64; 3]> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|v| normalize(*v))
        .collect();
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..level {
            let mut cache = std::collections::HashMap::new();
            let mut mid = |a: u32, b: u32, verts: &mut Vec<[f64; 3]>| -> u32 {
                *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (va, vb) = (verts[a as usize], verts[b as usize]);
                    verts.push(normalize([
                        (va[0] + vb[0]) / 2.0,
                        (va[1] + vb[1]) / 2.0,
                        (va[2] + vb[2]) / 2.0,
                    ]));
                    verts.len() as u32 - 1
                })
            };
            let mut next = Vec::with_capacity(faces.len() * 4);
            for [a, b, c] in faces {
                let ab = mid(a, b, &mut verts);
                let bc = mid(b, c, &mut verts);
                let ca = mid(c, a, &mut verts);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            faces = next;
        }
        let mut mesh = Mesh {
            positions: verts
                .iter()
                .map(|v| {
                    f32x3([center[0] + radius * v[0], center[1] + radius * v[1], center[2] + radius * v[2]])
                })
                .collect(),
            ..Mesh::default()
        };
        if smooth {
            mesh.normals =
                verts.iter().map(|v| f32x3(if inward { [-v[0], -v[1], -v[2]] } else { *v })).collect();
        }
        for [a, b, c] in faces {
            mesh.indices.extend(if inward { [a, c, b] } else { [a, b, c] });
        }
        mesh
    }
}

// ---------------------------------------------------------------------------------------
// Materials

fn lambert(name: &str, rgb: [f64; 3]) -> Value {
    json!({"name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}})
}

fn emitter(name: &str, radiance: [f64; 3], reflectance: f64) -> Value {
    let strength = radiance.iter().cloned().fold(0.0, f64::max);
    let mut m = lambert(name, [reflectance; 3]);
    m["emissiveFactor"] = json!(radiance.map(|r| r / strength));
    m["extensions"]["KHR_materials_emissive_strength"] = json!({"emissiveStrength": strength});
    m
}

fn metal(name: &str, rgb: [f64; 3], roughness: f64) -> Value {
    json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 1.0, "roughnessFactor": roughness}})
}

fn plastic(name: &str, rgb: [f64; 3], roughness: f64) -> Value {
    json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": roughness}})
}

/// Glass: a refracting solid with absorption when `attenuation` is given, else thin-walled.
fn glass(name: &str, roughness: f64, attenuation: Option<([f64; 3], f64)>) -> Value {
    let mut m = json!({"name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": roughness},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5}}});
    if let Some((color, distance)) = attenuation {
        m["extensions"]["KHR_materials_volume"] =
            json!({"thicknessFactor": 0.1, "attenuationColor": color, "attenuationDistance": distance});
    }
    m
}

// ---------------------------------------------------------------------------------------
// Scenes

/// glTF rotation (x, y, z, w) of `angle` radians about +Y.
fn rot_y(angle: f64) -> [f64; 4] {
    [0.0, (angle / 2.0).sin(), 0.0, (angle / 2.0).cos()]
}

/// The Cornell box from the measured data published by the Cornell Program of Computer
/// Graphics (https://www.graphics.cornell.edu/online/box/data.html), converted from
/// millimetres to metres. The coordinate frame is the data's own: +Y up, the camera at
/// z = −0.8 looking down +Z, so +X is to the viewer's left (red wall). The light quad sits
/// 0.5 mm under the ceiling so it does not coincide with it. Reflectances are the usual RGB
/// fits of the measured spectra (as in the pbrt-v4 and Mitsuba scenes); the light's radiance
/// (17, 12, 4) likewise.
///
/// `with_blocks` keeps the two boxes; scenes that put other objects in the room omit them.
fn cornell(g: &mut Gltf, with_blocks: bool) {
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

/// A closed cube (12 triangles on 8 shared vertices, with the averaged corner normals a
/// modelling tool exports) lit only from outside by a point light and an emissive quad
/// above it, the camera inside: no light can reach the camera, so every pixel is exactly 0.
fn sealed_room(path: &Path) {
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
    let pitch = 0.35f64;
    let yaw = 0.6f64;
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    // q = yaw(Y) * pitch(X)
    let q = [cy * sp, sy * cp, -sy * sp, cy * cp];
    g.perspective_camera("inside", 70f64.to_radians(), [0.0, -0.2, 0.3], q);
    g.write(
        path,
        "Sealed room: the camera inside a closed cube lit only from outside; every pixel is exactly 0",
    );
}

/// The Cornell box with its camera, under a root node that translates or scales it: an image
/// equal to the untransformed box, whatever the transform (the loader composes in f64 and
/// renders camera-relative).
fn transformed_cornell(path: &Path, root: Value, description: &str) {
    let mut g = Gltf { root: Some(root), ..Gltf::default() };
    cornell(&mut g, true);
    g.write(path, description);
}

/// Degenerate input beside a well-formed floor and lamp: zero-area and repeated-vertex
/// triangles (4), triangles with a NaN or infinite vertex (3), and two valid triangles
/// sharing a zero-length vertex normal. The loader must drop the 7 with warnings that
/// count them, shade the 2 with their geometric normal (counted too), and render finite
/// pixels.
fn degenerate(path: &Path) {
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
fn mirror_box(path: &Path) {
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
fn index_matched_glass(path: &Path) {
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
fn glossy_furnace(path: &Path, roughness: f64) {
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
fn glass_furnace(path: &Path, roughness: f64) {
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
fn glass_slab(path: &Path, roughness: f64) {
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
fn terminator(path: &Path, level: u32) {
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

fn coplanar(path: &Path, which: &str) {
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
fn caustic_mirror(path: &Path, virtual_lamp: bool) {
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

    // The benchmark's glass scene (issue 8): a perfect mirror sphere and a clear solid
    // glass sphere in the Cornell room, the classic pair, with materials a peer renderer
    // models identically (a mirror of reflectance 1; clear glass of index 1.5).
    let mut g = Gltf::default();
    cornell(&mut g, false);
    let mirror = g.material(metal("mirror (reflectance 1)", [1.0, 1.0, 1.0], 0.0));
    let clear = g.material(json!({"name": "clear glass (solid, index 1.5)",
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5},
            "KHR_materials_volume": {"thicknessFactor": 0.1}}}));
    g.mesh("mirror sphere", &Mesh::icosphere([0.39, 0.1, 0.37], 0.1, 4, false, true), mirror);
    g.mesh("glass sphere", &Mesh::icosphere([0.17, 0.1, 0.2], 0.1, 4, false, true), clear);
    g.write(
        &dir.join("cornell-spheres.gltf"),
        "A mirror sphere and a clear glass sphere in the Cornell room (the speed-against-error benchmark's glass scene)",
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
