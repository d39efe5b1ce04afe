//! glTF 2.0 (.gltf / .glb) → [`Scene`].
//!
//! Node transforms are read from the JSON as f64 (the `gltf` crate stores them as f32) and
//! composed in f64, so a model placed far from the origin keeps its precision until
//! [`FlatScene`](super::FlatScene) makes it camera-relative.

use std::path::Path;

use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use gltf::json::validation::Validate;

use super::accessor::{load_buffers, read_floats, read_indices, read_vec3, scene_folder};
use super::camera::{CameraDesc, Projection};
use super::light::{PunctualKind, PunctualLight};
use super::material::{AlphaMode, MaterialDesc, TextureSlot};
use super::texture::{wrap_mode, ImageDesc, TextureDesc};
use super::uri::{read_uri, LoadOptions};
use super::{MeshTransform, Scene};
use crate::error::{Error, Result};

/// Extensions whose meaning pathlight implements.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// Loads a glTF scene under the rule for untrusted input (external URIs stay inside the
/// scene's folder; see [`super::uri`]). Warnings (ignored optional extensions, features not
/// yet rendered, dropped primitives) are returned beside it for the caller to show.
pub fn load(file: &Path) -> Result<(Scene, Vec<String>)> {
    load_with(file, &LoadOptions::default())
}

/// [`load`] with explicit options (e.g. [`LoadOptions::allow_any_path`] for trusted scenes).
pub fn load_with(file: &Path, options: &LoadOptions) -> Result<(Scene, Vec<String>)> {
    let bytes = std::fs::read(file).map_err(|e| Error::io(file, e))?;
    load_from_bytes(&bytes, file, options)
}

/// Loads a glTF scene from bytes; `file` names it in errors and its folder is where relative
/// URIs resolve.
///
/// Malformed input is an error, never a crash: besides our own checks, a panic inside a
/// third-party parser on a hostile file is caught and reported as an error naming the file.
pub fn load_from_bytes(bytes: &[u8], file: &Path, options: &LoadOptions) -> Result<(Scene, Vec<String>)> {
    match std::panic::catch_unwind(|| load_unchecked(bytes, file, options)) {
        Ok(result) => result,
        Err(panic) => {
            let what = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(Error::scene(file, format!("malformed glTF: the parser failed ({what})")))
        }
    }
}

fn load_unchecked(bytes: &[u8], file: &Path, options: &LoadOptions) -> Result<(Scene, Vec<String>)> {
    let err = |m: String| Error::scene(file, m);
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| err(format!("not a valid glTF file: {e}")))?;
    let mut warnings = Vec::new();

    // Extensions: our own policy, since the gltf crate's list differs from what we render.
    for ext in gltf.extensions_required() {
        if !SUPPORTED_EXTENSIONS.contains(&ext) {
            return Err(err(format!("requires extension {ext}, which pathlight does not support")));
        }
    }
    let ignored: Vec<&str> = gltf.extensions_used().filter(|e| !SUPPORTED_EXTENSIONS.contains(e)).collect();
    if !ignored.is_empty() {
        warnings.push(format!("ignoring optional extensions: {}", ignored.join(", ")));
    }

    // Structural validation (index ranges etc.), minus the crate's own required-extension
    // check, which we replaced above. The validator itself indexes the POSITION accessor
    // without a bounds check, so check that reference first.
    let root = gltf.document.as_json();
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, primitive) in mesh.primitives.iter().enumerate() {
            let pos = gltf::json::validation::Checked::Valid(gltf::json::mesh::Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&pos) {
                if index.value() >= root.accessors.len() {
                    return Err(err(format!(
                        "mesh {mi} primitive {pi}: POSITION refers to accessor {}, but the file has {} accessors",
                        index.value(),
                        root.accessors.len()
                    )));
                }
            }
        }
    }
    let mut problems = Vec::new();
    let mut missing_bounds = 0;
    root.validate(root, gltf::json::Path::new, &mut |path, error| {
        let path = path().to_string();
        if path.starts_with("extensionsRequired") {
            return;
        }
        // POSITION min/max are required by the spec but many exporters omit them; pathlight
        // computes its own bounds, so this is only worth a warning.
        if path.contains("POSITION") && (path.ends_with(".min") || path.ends_with(".max")) {
            missing_bounds += 1;
            return;
        }
        problems.push(format!("{path}: {error:?}"));
    });
    if missing_bounds > 0 {
        warnings
            .push("POSITION accessors lack the min/max the spec requires; bounds computed instead".into());
    }
    if !problems.is_empty() {
        let shown: Vec<_> = problems.iter().take(5).cloned().collect();
        return Err(err(format!(
            "invalid glTF ({} problem{}): {}",
            problems.len(),
            if problems.len() == 1 { "" } else { "s" },
            shown.join("; ")
        )));
    }

    let raw_json = raw_json_value(bytes).map_err(|e| err(format!("cannot re-read the JSON: {e}")))?;
    let buffers = load_buffers(&gltf.document, gltf.blob.as_deref(), file, options)?;
    let doc = &gltf.document;
    let (images, textures) = load_images_and_textures(doc, &buffers, file, options, &mut warnings)?;

    let mut scene = Scene { source: file.to_path_buf(), images, textures, ..Scene::default() };
    scene.materials = doc
        .materials()
        .map(|m| {
            let mut desc = read_material(&m, file)?;
            let index = m.index().unwrap_or(0);
            read_raw_material(&raw_json["materials"][index], scene.textures.len(), &mut desc)
                .map_err(|e| err(format!("material {index} '{}': {e}", desc.name)))?;
            Ok(desc)
        })
        .collect::<Result<_>>()?;
    let default_material = scene.materials.len() as u32;
    scene.materials.push(MaterialDesc::default());
    let gltf_scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err("the file has no scene".into()))?;

    let mut stats = LoadStats::default();
    let node_count = doc.nodes().count();
    // Depth-first over the node hierarchy with f64 world transforms. A path longer than the
    // node count must repeat a node: the file has a cycle (forbidden by the spec).
    let mut stack: Vec<(gltf::Node, DMat4, usize)> =
        gltf_scene.nodes().map(|n| (n, DMat4::IDENTITY, 1)).collect();
    stack.reverse();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > node_count {
            return Err(err(format!("the node hierarchy has a cycle through node {}", node.index())));
        }
        let local = node_transform(&raw_json, node.index())
            .map_err(|m| err(format!("node {}: {m}", node.index())))?;
        let world = parent * local;
        if !world.is_finite() {
            return Err(err(format!("node {}: transform is not finite", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            add_mesh(&mut scene, &mut stats, &buffers, &mesh, &world, default_material, file)?;
        }
        if let Some(camera) = node.camera() {
            let (rotation, translation) = decompose(&world);
            let projection = match camera.projection() {
                gltf::camera::Projection::Perspective(p) => Projection::Perspective {
                    yfov: p.yfov() as f64,
                    aspect_ratio: p.aspect_ratio().map(|a| a as f64),
                },
                gltf::camera::Projection::Orthographic(o) => {
                    Projection::Orthographic { xmag: o.xmag().abs() as f64, ymag: o.ymag().abs() as f64 }
                }
            };
            let valid = match projection {
                Projection::Perspective { yfov, aspect_ratio } => {
                    yfov > 0.0
                        && yfov < std::f64::consts::PI
                        && aspect_ratio.is_none_or(|a| a > 0.0 && a.is_finite())
                }
                Projection::Orthographic { xmag, ymag } => xmag > 0.0 && ymag > 0.0,
            };
            let name =
                camera.name().map(str::to_owned).unwrap_or_else(|| format!("camera {}", camera.index()));
            match CameraDesc::from_node(name, projection, rotation, translation) {
                Some(c) if valid => scene.cameras.push(c),
                _ => warnings.push(format!(
                    "camera {} on node {} is degenerate; skipped",
                    camera.index(),
                    node.index()
                )),
            }
        }
        if let Some(light) = node.light() {
            let (rotation, translation) = decompose(&world);
            let color = Vec3::from(light.color());
            let intensity = color * light.intensity();
            if !intensity.is_finite() || intensity.min_element() < 0.0 {
                return Err(err(format!(
                    "light {}: colour × intensity is not a finite non-negative value",
                    light.index()
                )));
            }
            let kind = match light.kind() {
                gltf::khr_lights_punctual::Kind::Point => PunctualKind::Point,
                gltf::khr_lights_punctual::Kind::Directional => PunctualKind::Directional,
                gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                    PunctualKind::Spot {
                        inner_cone_angle: inner_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2),
                        outer_cone_angle: outer_cone_angle.clamp(0.0, std::f32::consts::FRAC_PI_2),
                    }
                }
            };
            let direction = (rotation * DVec3::NEG_Z).try_normalize().unwrap_or(DVec3::NEG_Z);
            scene.lights.push(PunctualLight {
                name: light.name().map(str::to_owned).unwrap_or_else(|| format!("light {}", light.index())),
                kind,
                intensity,
                position: translation,
                direction,
            });
        }
        for child in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
    }

    if stats.skipped_modes > 0 {
        warnings.push(format!("skipped {} point/line primitive(s)", stats.skipped_modes));
    }
    if stats.generated_tangents > 0 {
        warnings.push(format!(
            "generated MikkTSpace tangents for {} primitive(s) with a normal texture and no TANGENT",
            stats.generated_tangents
        ));
    }
    if stats.degenerate > 0 {
        warnings.push(format!("dropped {} zero-area triangle(s)", stats.degenerate));
    }
    if stats.non_finite > 0 {
        warnings.push(format!("dropped {} triangle(s) with a NaN or infinite vertex", stats.non_finite));
    }
    if stats.bad_normals > 0 {
        warnings.push(format!(
            "{} triangle(s) have a zero or non-finite vertex normal; they use their geometric normal",
            stats.bad_normals
        ));
    }
    if scene.triangle_count() == 0 {
        let dropped: Vec<&str> =
            warnings.iter().filter(|w| w.starts_with("dropped")).map(String::as_str).collect();
        let dropped = if dropped.is_empty() { String::new() } else { format!(" ({})", dropped.join("; ")) };
        return Err(err(format!("the scene has no triangles to render{dropped}")));
    }
    Ok((scene, warnings))
}

#[derive(Default)]
struct LoadStats {
    skipped_modes: usize,
    degenerate: usize,
    /// Triangles dropped for a vertex that is NaN or infinite.
    non_finite: usize,
    bad_normals: usize,
    /// Primitives whose tangents MikkTSpace generated (a normal texture, no TANGENT).
    generated_tangents: usize,
}

/// The JSON document as a generic value, for reading node transforms at full precision.
fn raw_json_value(bytes: &[u8]) -> std::result::Result<serde_json::Value, String> {
    if bytes.starts_with(b"glTF") {
        let glb = gltf::binary::Glb::from_slice(bytes).map_err(|e| e.to_string())?;
        serde_json::from_slice(&glb.json).map_err(|e| e.to_string())
    } else {
        serde_json::from_slice(bytes).map_err(|e| e.to_string())
    }
}

fn f64_array<const N: usize>(
    v: Option<&serde_json::Value>,
    default: [f64; N],
    what: &str,
) -> std::result::Result<[f64; N], String> {
    let Some(v) = v else { return Ok(default) };
    let arr = v
        .as_array()
        .filter(|a| a.len() == N)
        .ok_or_else(|| format!("{what} must be an array of {N} numbers"))?;
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(arr) {
        *o = x.as_f64().ok_or_else(|| format!("{what} must contain numbers"))?;
    }
    Ok(out)
}

/// A node's local transform in f64: `matrix`, or T·R·S.
fn node_transform(root: &serde_json::Value, index: usize) -> std::result::Result<DMat4, String> {
    let node = &root["nodes"][index];
    if node.get("matrix").is_some() {
        let m = f64_array::<16>(node.get("matrix"), [0.0; 16], "matrix")?;
        return Ok(DMat4::from_cols_array(&m));
    }
    let t = f64_array::<3>(node.get("translation"), [0.0; 3], "translation")?;
    let r = f64_array::<4>(node.get("rotation"), [0.0, 0.0, 0.0, 1.0], "rotation")?;
    let s = f64_array::<3>(node.get("scale"), [1.0; 3], "scale")?;
    let q = DQuat::from_xyzw(r[0], r[1], r[2], r[3]);
    let q = if q.length_squared() > 0.0 { q.normalize() } else { DQuat::IDENTITY };
    Ok(DMat4::from_scale_rotation_translation(DVec3::from(s), q, DVec3::from(t)))
}

/// Splits an affine matrix into (rotation with scale removed, translation).
fn decompose(m: &DMat4) -> (DMat3, DVec3) {
    let linear = DMat3::from_mat4(*m);
    let rotation = DMat3::from_cols(
        linear.x_axis.try_normalize().unwrap_or(DVec3::X),
        linear.y_axis.try_normalize().unwrap_or(DVec3::Y),
        linear.z_axis.try_normalize().unwrap_or(DVec3::Z),
    );
    (rotation, m.w_axis.truncate())
}

fn add_mesh(
    scene: &mut Scene,
    stats: &mut LoadStats,
    buffers: &[Vec<u8>],
    mesh: &gltf::Mesh,
    world: &DMat4,
    default_material: u32,
    file: &Path,
) -> Result<()> {
    let transform = MeshTransform::new(*world);
    for primitive in mesh.primitives() {
        let what = format!(
            "mesh {}{} primitive {}",
            mesh.index(),
            mesh.name().map(|n| format!(" '{n}'")).unwrap_or_default(),
            primitive.index()
        );
        let err = |m: String| Error::scene(file, m);
        let mode = primitive.mode();
        if !matches!(
            mode,
            gltf::mesh::Mode::Triangles | gltf::mesh::Mode::TriangleStrip | gltf::mesh::Mode::TriangleFan
        ) {
            stats.skipped_modes += 1;
            continue;
        }
        let pos_acc = primitive
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| err(format!("{what}: has no POSITION attribute")))?;
        let positions = read_vec3(buffers, &pos_acc, &format!("{what}: POSITION")).map_err(err)?;
        let normals = match primitive.get(&gltf::Semantic::Normals) {
            Some(acc) => {
                let n = read_vec3(buffers, &acc, &format!("{what}: NORMAL")).map_err(err)?;
                if n.len() != positions.len() {
                    return Err(err(format!(
                        "{what}: NORMAL has {} elements but POSITION has {}",
                        n.len(),
                        positions.len()
                    )));
                }
                Some(n)
            }
            None => None,
        };
        let indices: Vec<u32> = match primitive.indices() {
            Some(acc) => {
                let idx = read_indices(buffers, &acc, &format!("{what}: indices")).map_err(err)?;
                if let Some(bad) = idx.iter().position(|&i| i as usize >= positions.len()) {
                    // The position, not the value: buffer contents are never quoted (they
                    // may be any file's bytes).
                    return Err(err(format!(
                        "{what}: element {bad} of the indices (accessor {}) refers past the last of {} vertices",
                        acc.index(),
                        positions.len()
                    )));
                }
                idx
            }
            None => (0..positions.len() as u32).collect(),
        };
        let triangles = assemble_triangles(&indices, mode);
        let material = primitive.material().index().map(|i| i as u32).unwrap_or(default_material);
        let read_set = |semantic: gltf::Semantic, name: &str, dims: gltf::accessor::Dimensions| {
            primitive
                .get(&semantic)
                .map(|acc| {
                    let v = read_floats(buffers, &acc, &format!("{what}: {name}"), dims).map_err(err)?;
                    let n = dims.multiplicity();
                    if v.len() != positions.len() * n {
                        return Err(err(format!(
                            "{what}: {name} has {} elements but POSITION has {}",
                            v.len() / n,
                            positions.len()
                        )));
                    }
                    Ok(v)
                })
                .transpose()
        };
        use gltf::accessor::Dimensions;
        let uv_sets = [
            read_set(gltf::Semantic::TexCoords(0), "TEXCOORD_0", Dimensions::Vec2)?,
            read_set(gltf::Semantic::TexCoords(1), "TEXCOORD_1", Dimensions::Vec2)?,
        ];
        let uv = |set: usize, v: u32| -> glam::Vec2 {
            uv_sets[set]
                .as_ref()
                .map_or(glam::Vec2::ZERO, |s| glam::Vec2::new(s[2 * v as usize], s[2 * v as usize + 1]))
        };
        // Tangents only where a normal texture (the base's or the coat's) will read them: the
        // file's, else MikkTSpace's (Mikkelsen 2008, the generator glTF 2.0 §3.7.2.1 names) on
        // the normal texture's UVs.
        let normal_slot = scene.materials.get(material as usize).and_then(|m| m.needs_tangents().cloned());
        let object_tangents: Option<Vec<[glam::Vec4; 3]>> = match &normal_slot {
            None => None,
            Some(slot) => match read_set(gltf::Semantic::Tangents, "TANGENT", Dimensions::Vec4)? {
                Some(t) => Some(
                    triangles
                        .iter()
                        .map(|tri| {
                            tri.map(|v| glam::Vec4::from_slice(&t[4 * v as usize..4 * v as usize + 4]))
                        })
                        .collect(),
                ),
                None if uv_sets[slot.tex_coord.min(1) as usize].is_some() => {
                    stats.generated_tangents += 1;
                    Some(mikktspace_tangents(&positions, normals.as_deref(), &triangles, |v| {
                        uv(slot.tex_coord.min(1) as usize, v)
                    }))
                }
                None => None,
            },
        };

        let world_positions: Vec<DVec3> = positions
            .iter()
            .map(|p| transform.point(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)))
            .collect();
        let world_normals: Option<Vec<Option<Vec3>>> = normals.as_ref().map(|ns| {
            ns.iter().map(|n| transform.normal(DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64))).collect()
        });
        for (k, &[a, b, c]) in triangles.iter().enumerate() {
            let mut tangents = object_tangents.as_ref().map(|ts| {
                ts[k].map(|tv| {
                    let d = transform.vector(tv.truncate().as_dvec3()).normalize_or_zero().as_vec3();
                    let w = if tv.w < 0.0 { -1.0 } else { 1.0 };
                    d.extend(if transform.flips_winding { -w } else { w })
                })
            });
            if transform.flips_winding {
                if let Some(t) = tangents.as_mut() {
                    t.swap(1, 2);
                }
            }
            let (a, b, c) = if transform.flips_winding { (a, c, b) } else { (a, b, c) };
            let p = [world_positions[a as usize], world_positions[b as usize], world_positions[c as usize]];
            // A NaN or infinite vertex (in the file, or after the node transforms) has no
            // place in space: its triangles are dropped and counted.
            if !p.iter().all(|v| v.is_finite()) {
                stats.non_finite += 1;
                continue;
            }
            if (p[1] - p[0]).cross(p[2] - p[0]).length_squared() == 0.0 {
                stats.degenerate += 1;
                continue;
            }
            let n = world_normals.as_ref().and_then(|ns| {
                let n = [ns[a as usize], ns[b as usize], ns[c as usize]];
                match n {
                    [Some(n0), Some(n1), Some(n2)] => Some([n0, n1, n2]),
                    _ => {
                        stats.bad_normals += 1;
                        None
                    }
                }
            });
            scene.positions.extend_from_slice(&p);
            scene.normals.push(n);
            scene.triangle_materials.push(material);
            scene.texcoords.push([[uv(0, a), uv(0, b), uv(0, c)], [uv(1, a), uv(1, b), uv(1, c)]]);
            scene.tangents.push(tangents.filter(|t| t.iter().all(|v| v.truncate().length_squared() > 0.0)));
        }
    }
    Ok(())
}

/// MikkTSpace tangents (object space, sign in w) for each triangle's three corners.
fn mikktspace_tangents(
    positions: &[[f32; 3]],
    normals: Option<&[[f32; 3]]>,
    triangles: &[[u32; 3]],
    uv: impl Fn(u32) -> glam::Vec2,
) -> Vec<[glam::Vec4; 3]> {
    struct Mesh<'a, F: Fn(u32) -> glam::Vec2> {
        positions: &'a [[f32; 3]],
        normals: Option<&'a [[f32; 3]]>,
        triangles: &'a [[u32; 3]],
        uv: F,
        out: Vec<[glam::Vec4; 3]>,
    }
    impl<F: Fn(u32) -> glam::Vec2> bevy_mikktspace::Geometry for Mesh<'_, F> {
        fn num_faces(&self) -> usize {
            self.triangles.len()
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.positions[self.triangles[face][vert] as usize]
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            match self.normals {
                Some(n) => n[self.triangles[face][vert] as usize],
                None => {
                    let p = self.triangles[face].map(|v| glam::Vec3::from(self.positions[v as usize]));
                    (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero().to_array()
                }
            }
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            (self.uv)(self.triangles[face][vert]).to_array()
        }
        fn set_tangent(
            &mut self,
            tangent_space: Option<bevy_mikktspace::TangentSpace>,
            face: usize,
            vert: usize,
        ) {
            if let Some(t) = tangent_space {
                self.out[face][vert] = glam::Vec4::from(t.tangent_encoded());
            }
        }
    }
    let mut mesh =
        Mesh { positions, normals, triangles, uv, out: vec![[glam::Vec4::ZERO; 3]; triangles.len()] };
    // The crate's error type has no variants: generation cannot fail.
    let _ = bevy_mikktspace::generate_tangents(&mut mesh);
    mesh.out
}

/// Most texels per side accepted from a file (the texel array is bounded separately).
const MAX_IMAGE_SIDE: u32 = 16384;

/// Decodes every image (PNG and JPEG; other formats are a warning naming the texture, and
/// inputs reading it fall back to their factor) and reads every texture's sampler.
fn load_images_and_textures(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    file: &Path,
    options: &LoadOptions,
    warnings: &mut Vec<String>,
) -> Result<(Vec<ImageDesc>, Vec<TextureDesc>)> {
    let err = |m: String| Error::scene(file, m);
    let mut images = Vec::new();
    let mut decoded: Vec<Option<usize>> = Vec::new();
    for image in doc.images() {
        let i = image.index();
        let name = image.name().map(|n| format!("image {i} '{n}'")).unwrap_or_else(|| format!("image {i}"));
        let (bytes, mime) = match image.source() {
            gltf::image::Source::Uri { uri, mime_type } => (
                read_uri(uri, scene_folder(file), options).map_err(|m| err(format!("{name}: {m}")))?,
                mime_type.map(str::to_owned),
            ),
            gltf::image::Source::View { view, mime_type } => {
                let buffer = &buffers[view.buffer().index()];
                let bytes = view
                    .offset()
                    .checked_add(view.length())
                    .filter(|end| *end <= buffer.len())
                    .map(|end| buffer[view.offset()..end].to_vec())
                    .ok_or_else(|| {
                        err(format!("{name}: buffer view {} lies outside its buffer", view.index()))
                    })?;
                (bytes, Some(mime_type.to_owned()))
            }
        };
        let format = match image::guess_format(&bytes) {
            Ok(f @ (image::ImageFormat::Png | image::ImageFormat::Jpeg)) => f,
            _ => {
                warnings.push(format!(
                    "{name} ({}) is not PNG or JPEG, which pathlight decodes; textures using it are ignored",
                    mime.unwrap_or_else(|| "unknown type".into())
                ));
                decoded.push(None);
                continue;
            }
        };
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(&bytes), format);
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_IMAGE_SIDE);
        limits.max_image_height = Some(MAX_IMAGE_SIDE);
        reader.limits(limits);
        let rgba = reader.decode().map_err(|e| err(format!("{name}: cannot decode: {e}")))?.to_rgba8();
        decoded.push(Some(images.len()));
        images.push(ImageDesc { name, width: rgba.width(), height: rgba.height(), rgba8: rgba.into_raw() });
    }
    let textures = doc
        .textures()
        .map(|t| {
            let sampler = t.sampler();
            TextureDesc {
                image: decoded.get(t.source().index()).copied().flatten(),
                wrap_s: wrap_mode(sampler.wrap_s()),
                wrap_t: wrap_mode(sampler.wrap_t()),
                nearest: sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
                // Without a minFilter the renderer chooses: mip maps.
                mipmaps: !matches!(
                    sampler.min_filter(),
                    Some(gltf::texture::MinFilter::Nearest | gltf::texture::MinFilter::Linear)
                ),
            }
        })
        .collect();
    Ok((images, textures))
}

/// Triangle vertex indices of a primitive, strips and fans expanded as glTF 2.0 §3.7.2.1
/// defines them (strip: {i, i+1+i%2, i+2−i%2}; fan: {i+1, i+2, 0}).
fn assemble_triangles(indices: &[u32], mode: gltf::mesh::Mode) -> Vec<[u32; 3]> {
    match mode {
        gltf::mesh::Mode::Triangles => indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        gltf::mesh::Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|i| [indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]])
            .collect(),
        gltf::mesh::Mode::TriangleFan => (0..indices.len().saturating_sub(2))
            .map(|i| [indices[i + 1], indices[i + 2], indices[0]])
            .collect(),
        _ => Vec::new(),
    }
}

fn slot(info: Option<gltf::texture::Info>) -> Option<TextureSlot> {
    info.map(|i| {
        let (tex_coord, transform) = match i.texture_transform() {
            Some(t) => {
                let sane = |v: f32, default: f32| if v.is_finite() { v } else { default };
                let offset = t.offset().map(|v| sane(v, 0.0));
                let scale = t.scale().map(|v| sane(v, 1.0));
                (
                    t.tex_coord().unwrap_or(i.tex_coord()),
                    TextureSlot::transform_from(offset, sane(t.rotation(), 0.0), scale),
                )
            }
            None => (i.tex_coord(), TextureSlot::IDENTITY),
        };
        TextureSlot { texture: i.texture().index(), tex_coord, transform }
    })
}

/// A `textureInfo` (or `normalTextureInfo`) read from the raw JSON, with its
/// KHR_texture_transform: for the extensions the gltf crate does not parse. `Ok(None)` when
/// absent.
fn raw_texture_slot(
    v: &serde_json::Value,
    texture_count: usize,
    what: &str,
) -> std::result::Result<Option<TextureSlot>, String> {
    if v.is_null() {
        return Ok(None);
    }
    let index = v["index"].as_u64().ok_or_else(|| format!("{what}.index must be a non-negative integer"))?;
    if index as usize >= texture_count || index > u32::MAX as u64 {
        return Err(format!("{what}.index is {index}, but the file has {texture_count} textures"));
    }
    let tex_coord = |v: &serde_json::Value, default: u64| -> std::result::Result<u32, String> {
        match v {
            serde_json::Value::Null => Ok(default as u32),
            v => v
                .as_u64()
                .filter(|&t| t <= u32::MAX as u64)
                .map(|t| t as u32)
                .ok_or_else(|| format!("{what}.texCoord must be a non-negative integer")),
        }
    };
    let base_tex_coord = tex_coord(&v["texCoord"], 0)?;
    let t = &v["extensions"]["KHR_texture_transform"];
    let (tex_coord, transform) = if t.is_object() {
        let sane = |x: f64, default: f32| if x.is_finite() { x as f32 } else { default };
        let offset = f64_array::<2>(t.get("offset"), [0.0, 0.0], "KHR_texture_transform.offset")?;
        let scale = f64_array::<2>(t.get("scale"), [1.0, 1.0], "KHR_texture_transform.scale")?;
        let rotation = t["rotation"].as_f64().unwrap_or(0.0);
        (
            tex_coord(&t["texCoord"], base_tex_coord as u64)?,
            TextureSlot::transform_from(
                [sane(offset[0], 0.0), sane(offset[1], 0.0)],
                sane(rotation, 0.0),
                [sane(scale[0], 1.0), sane(scale[1], 1.0)],
            ),
        )
    } else {
        (base_tex_coord, TextureSlot::IDENTITY)
    };
    Ok(Some(TextureSlot { texture: index as usize, tex_coord, transform }))
}

/// A number of the raw JSON, `default` when absent; an error when present and not a finite
/// number.
fn raw_number(v: &serde_json::Value, default: f32, what: &str) -> std::result::Result<f32, String> {
    match v {
        serde_json::Value::Null => Ok(default),
        v => v
            .as_f64()
            .map(|x| x as f32)
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{what} must be a finite number")),
    }
}

/// What the gltf crate does not read, from the material's raw JSON: KHR_materials_clearcoat,
/// KHR_materials_sheen, and KHR_texture_transform on the normal texture.
fn read_raw_material(
    m: &serde_json::Value,
    texture_count: usize,
    desc: &mut MaterialDesc,
) -> std::result::Result<(), String> {
    if let Some(slot) = raw_texture_slot(&m["normalTexture"], texture_count, "normalTexture")? {
        desc.normal_texture = Some(slot);
    }
    let c = &m["extensions"]["KHR_materials_clearcoat"];
    if c.is_object() {
        desc.clearcoat = raw_number(&c["clearcoatFactor"], 0.0, "clearcoatFactor")?.clamp(0.0, 1.0);
        desc.clearcoat_roughness =
            raw_number(&c["clearcoatRoughnessFactor"], 0.0, "clearcoatRoughnessFactor")?.clamp(0.0, 1.0);
        desc.clearcoat_texture = raw_texture_slot(&c["clearcoatTexture"], texture_count, "clearcoatTexture")?;
        desc.clearcoat_roughness_texture =
            raw_texture_slot(&c["clearcoatRoughnessTexture"], texture_count, "clearcoatRoughnessTexture")?;
        let normal = &c["clearcoatNormalTexture"];
        desc.clearcoat_normal_texture = raw_texture_slot(normal, texture_count, "clearcoatNormalTexture")?;
        desc.clearcoat_normal_scale = raw_number(&normal["scale"], 1.0, "clearcoatNormalTexture.scale")?;
    }
    let sh = &m["extensions"]["KHR_materials_sheen"];
    if sh.is_object() {
        let color = f64_array::<3>(sh.get("sheenColorFactor"), [0.0; 3], "sheenColorFactor")?;
        let color = Vec3::new(color[0] as f32, color[1] as f32, color[2] as f32);
        if !color.is_finite() {
            return Err("sheenColorFactor must be finite".into());
        }
        desc.sheen_color = color.clamp(Vec3::ZERO, Vec3::ONE);
        desc.sheen_roughness =
            raw_number(&sh["sheenRoughnessFactor"], 0.0, "sheenRoughnessFactor")?.clamp(0.0, 1.0);
        desc.sheen_color_texture =
            raw_texture_slot(&sh["sheenColorTexture"], texture_count, "sheenColorTexture")?;
        desc.sheen_roughness_texture =
            raw_texture_slot(&sh["sheenRoughnessTexture"], texture_count, "sheenRoughnessTexture")?;
    }
    Ok(())
}

fn read_material(m: &gltf::Material, file: &Path) -> Result<MaterialDesc> {
    let index = m.index().unwrap_or(0);
    let name = m.name().map(str::to_owned).unwrap_or_else(|| format!("material {index}"));
    let err = |what: &str| Error::scene(file, format!("material {index} '{name}': {what} is not finite"));
    let pbr = m.pbr_metallic_roughness();
    let bc = pbr.base_color_factor();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emission = Vec3::from(m.emissive_factor()) * strength;
    if !emission.is_finite() {
        return Err(err("emissiveFactor × emissiveStrength"));
    }
    let finite = |v: f32, what: &str| if v.is_finite() { Ok(v) } else { Err(err(what)) };
    let mut desc = MaterialDesc {
        name: name.clone(),
        base_color: Vec3::new(bc[0], bc[1], bc[2]).clamp(Vec3::ZERO, Vec3::ONE),
        alpha: finite(bc[3], "baseColorFactor")?.clamp(0.0, 1.0),
        metallic: finite(pbr.metallic_factor(), "metallicFactor")?.clamp(0.0, 1.0),
        roughness: finite(pbr.roughness_factor(), "roughnessFactor")?.clamp(0.0, 1.0),
        emission: emission.max(Vec3::ZERO),
        double_sided: m.double_sided(),
        alpha_mode: match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask,
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        },
        alpha_cutoff: m.alpha_cutoff().filter(|c| c.is_finite()).unwrap_or(0.5),
        base_color_texture: slot(pbr.base_color_texture()),
        metallic_roughness_texture: slot(pbr.metallic_roughness_texture()),
        // normalTexture is re-read with its KHR_texture_transform by `read_raw_material`.
        normal_texture: m.normal_texture().map(|t| TextureSlot {
            texture: t.texture().index(),
            tex_coord: t.tex_coord(),
            transform: TextureSlot::IDENTITY,
        }),
        normal_scale: m.normal_texture().map(|t| t.scale()).filter(|s| s.is_finite()).unwrap_or(1.0),
        occlusion_texture: m.occlusion_texture().map(|t| TextureSlot {
            texture: t.texture().index(),
            tex_coord: t.tex_coord(),
            transform: TextureSlot::IDENTITY,
        }),
        emissive_texture: slot(m.emissive_texture()),
        ..MaterialDesc::default()
    };
    if !Vec3::new(bc[0], bc[1], bc[2]).is_finite() {
        return Err(err("baseColorFactor"));
    }
    if let Some(ior) = m.ior() {
        let ior = finite(ior, "ior")?;
        // KHR_materials_ior: 0 (meaning ∞) or ≥ 1.
        desc.ior = if ior == 0.0 { 0.0 } else { ior.max(1.0) };
    }
    if let Some(s) = m.specular() {
        desc.specular_factor = finite(s.specular_factor(), "specularFactor")?.clamp(0.0, 1.0);
        let c = Vec3::from(s.specular_color_factor());
        if !c.is_finite() {
            return Err(err("specularColorFactor"));
        }
        desc.specular_color = c.max(Vec3::ZERO);
        desc.specular_texture = slot(s.specular_texture());
        desc.specular_color_texture = slot(s.specular_color_texture());
    }
    if let Some(t) = m.transmission() {
        desc.transmission = finite(t.transmission_factor(), "transmissionFactor")?.clamp(0.0, 1.0);
        desc.transmission_texture = slot(t.transmission_texture());
    }
    if let Some(v) = m.volume() {
        desc.thickness = finite(v.thickness_factor(), "thicknessFactor")?.max(0.0);
        let d = v.attenuation_distance();
        desc.attenuation_distance = if d > 0.0 { d } else { f32::INFINITY };
        let c = Vec3::from(v.attenuation_color());
        if !c.is_finite() {
            return Err(err("attenuationColor"));
        }
        desc.attenuation_color = c.clamp(Vec3::ZERO, Vec3::ONE);
        desc.thickness_texture = slot(v.thickness_texture());
    }
    Ok(desc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    #[test]
    fn strips_and_fans_follow_the_spec() {
        let idx = [0, 1, 2, 3, 4];
        assert_eq!(
            assemble_triangles(&idx, gltf::mesh::Mode::TriangleStrip),
            vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]
        );
        assert_eq!(
            assemble_triangles(&idx, gltf::mesh::Mode::TriangleFan),
            vec![[1, 2, 0], [2, 3, 0], [3, 4, 0]]
        );
        assert_eq!(assemble_triangles(&idx, gltf::mesh::Mode::Triangles), vec![[0, 1, 2]]);
    }

    /// Checks the collection of unique names used in warnings is stable.
    #[test]
    fn supported_extensions_are_sorted_and_unique() {
        let set: BTreeSet<_> = SUPPORTED_EXTENSIONS.iter().collect();
        assert_eq!(set.len(), SUPPORTED_EXTENSIONS.len());
    }
}
