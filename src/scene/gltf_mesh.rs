//! glTF 2.0 meshes → the scene's triangles: primitives assembled into triangles (strips
//! and fans expanded), positions, normals, UVs and tangents transformed to world space, and
//! MikkTSpace tangents where a normal map has none. Part of [`super::gltf_load`].

use std::path::Path;

use glam::{DMat4, DVec3, Vec3};

use super::accessor::{read_floats, read_indices, read_vec3};
use super::gltf_load::LoadStats;
use super::{MeshTransform, Scene};
use crate::error::{Error, Result};

pub(super) fn add_mesh(
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
pub(super) fn mikktspace_tangents(
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

/// Triangle vertex indices of a primitive, strips and fans expanded as glTF 2.0 §3.7.2.1
/// defines them (strip: {i, i+1+i%2, i+2−i%2}; fan: {i+1, i+2, 0}).
pub(super) fn assemble_triangles(indices: &[u32], mode: gltf::mesh::Mode) -> Vec<[u32; 3]> {
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

#[cfg(test)]
mod tests {
    use super::*;

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
}
