//! The megakernel's WGSL: one file per concept under `shaders/`, composed in one declared
//! order (each file may use what the files before it declare): the files every integrator
//! shares ([`COMMON_FILES`]), then the integrator's own ([`integrator_files`]), then the
//! declarations of the scene's small tables in the forms the kernel reads them in
//! ([`UniformTables`]). Errors are reported against the file and line they come from.

use super::tables::UniformTables;
use crate::integrator::Integrator;

/// A shader file: its name under `shaders/` and its text.
pub type ShaderFile = (&'static str, &'static str);

/// The files every integrator's kernel is built on, in dependency order: the layout and the
/// scene's features, the bindings, sampling, geometry, materials, lights, the camera and the
/// film, then what the integrators share (`src/integrator/`'s twins), the AOV pass among them.
pub const COMMON_FILES: &[ShaderFile] = &[
    ("layout.wgsl", include_str!("../../shaders/layout.wgsl")),
    ("features.wgsl", include_str!("../../shaders/features.wgsl")),
    ("bindings.wgsl", include_str!("../../shaders/bindings.wgsl")),
    ("sampling.wgsl", include_str!("../../shaders/sampling.wgsl")),
    ("geometry.wgsl", include_str!("../../shaders/geometry.wgsl")),
    ("bsdf.wgsl", include_str!("../../shaders/bsdf.wgsl")),
    ("bsdf_gltf.wgsl", include_str!("../../shaders/bsdf_gltf.wgsl")),
    ("environment.wgsl", include_str!("../../shaders/environment.wgsl")),
    ("texture.wgsl", include_str!("../../shaders/texture.wgsl")),
    ("bvh.wgsl", include_str!("../../shaders/bvh.wgsl")),
    ("light.wgsl", include_str!("../../shaders/light.wgsl")),
    ("camera.wgsl", include_str!("../../shaders/camera.wgsl")),
    ("film.wgsl", include_str!("../../shaders/film.wgsl")),
    ("interaction.wgsl", include_str!("../../shaders/interaction.wgsl")),
    ("mis.wgsl", include_str!("../../shaders/mis.wgsl")),
    ("roulette.wgsl", include_str!("../../shaders/roulette.wgsl")),
    ("partition.wgsl", include_str!("../../shaders/partition.wgsl")),
    ("aov.wgsl", include_str!("../../shaders/aov.wgsl")),
];

/// Next-event estimation, which the path tracer and photon mapping's camera paths share.
const NEXT_EVENT: ShaderFile = ("next_event.wgsl", include_str!("../../shaders/next_event.wgsl"));

/// The path tracer's irradiance cache (its lookup and placement passes), its entry point
/// (`render`) and its caustic light tracer's (`trace_caustics`).
const PATH_FILES: &[ShaderFile] = &[
    NEXT_EVENT,
    ("irradiance_cache.wgsl", include_str!("../../shaders/irradiance_cache.wgsl")),
    ("path.wgsl", include_str!("../../shaders/path.wgsl")),
    ("light_tracing.wgsl", include_str!("../../shaders/light_tracing.wgsl")),
];

/// The subpaths' vertices and walks, which bidirectional path tracing joins and photon
/// mapping walks photons with (`src/integrator/bdpt.rs`'s subpath half).
const BDPT_WALK: ShaderFile = ("bdpt_walk.wgsl", include_str!("../../shaders/bdpt_walk.wgsl"));

/// Bidirectional path tracing's entry points (`render`, `bdpt_resolve`).
const BDPT_FILES: &[ShaderFile] = &[BDPT_WALK, ("bdpt.wgsl", include_str!("../../shaders/bdpt.wgsl"))];

/// Metropolis light transport's passes (shaders/mlt.wgsl) over bidirectional path
/// tracing's strategies.
const MLT_FILES: &[ShaderFile] = &[
    BDPT_WALK,
    ("bdpt.wgsl", include_str!("../../shaders/bdpt.wgsl")),
    ("mlt.wgsl", include_str!("../../shaders/mlt.wgsl")),
];

/// Stochastic progressive photon mapping's passes (shaders/sppm.wgsl): its camera paths use
/// the path tracer's next-event estimation, its photons the subpath walk.
const SPPM_FILES: &[ShaderFile] =
    &[NEXT_EVENT, BDPT_WALK, ("sppm.wgsl", include_str!("../../shaders/sppm.wgsl"))];

/// The photon-map integrator's render (shaders/photon.wgsl) after SPPM's files, whose
/// camera path, photon passes and gathers it uses.
const PHOTON_FILES: &[ShaderFile] = &[
    NEXT_EVENT,
    BDPT_WALK,
    ("sppm.wgsl", include_str!("../../shaders/sppm.wgsl")),
    ("photon.wgsl", include_str!("../../shaders/photon.wgsl")),
];

/// The files that follow [`COMMON_FILES`] in `integrator`'s kernel: its WGSL twins, named as
/// its CPU half in `src/integrator/` is.
pub fn integrator_files(integrator: Integrator) -> &'static [ShaderFile] {
    match integrator {
        Integrator::Path => PATH_FILES,
        Integrator::Bdpt => BDPT_FILES,
        Integrator::Sppm => SPPM_FILES,
        Integrator::Photon => PHOTON_FILES,
        Integrator::Mlt => MLT_FILES,
    }
}

/// Every file of `integrator`'s kernel, in order.
pub fn kernel_files(integrator: Integrator) -> Vec<ShaderFile> {
    COMMON_FILES.iter().chain(integrator_files(integrator)).copied().collect()
}

/// The composed source of `files`, each after a header line naming it.
pub fn compose(files: &[ShaderFile]) -> String {
    let mut out = String::new();
    for (name, text) in files {
        out.push_str(&format!("// ---- shaders/{name}\n"));
        out.push_str(text);
        if !text.ends_with('\n') {
            out.push('\n');
        }
    }
    out
}

/// The viewer's display pass: the shared layout, then `shaders/display.wgsl`.
pub fn display_source() -> String {
    format!("{}{}", compose(&COMMON_FILES[..1]), include_str!("../../shaders/display.wgsl"))
}

/// `integrator`'s whole kernel, reading the scene's small tables in the forms `tables` gives
/// them. WGSL lets module-scope declarations come in any order, so the generated
/// declarations follow the files and [`locate`] still maps every file's lines.
pub fn kernel_source(integrator: Integrator, tables: UniformTables) -> String {
    compose_with_tables(&kernel_files(integrator), tables)
}

/// `files` followed by the declarations of the scene's tables in the forms `tables` (what a
/// test kernel built from part of the files needs).
pub fn compose_with_tables(files: &[ShaderFile], tables: UniformTables) -> String {
    let mut source = compose(files);
    source.push_str(&tables.declarations());
    source
}

/// Maps a 1-based line of the source composed from `files` back to `shaders/<file>:<line>`.
pub fn locate(files: &[ShaderFile], line: u32) -> String {
    let mut start = 1u32;
    for (name, text) in files {
        let lines = text.lines().count() as u32 + 1; // + the header line
        if line < start + lines {
            return format!("shaders/{name}:{}", line - start);
        }
        start += lines;
    }
    format!("composed kernel line {line}")
}

/// Parses and validates WGSL composed from `files` with naga, as wgpu will; errors name the
/// shader file and line.
pub fn parse_and_validate(source: &str, files: &[ShaderFile]) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        let at = e.location(source).map(|l| locate(files, l.line_number)).unwrap_or_default();
        format!("{at}: {}", e.emit_to_string(source))
    })?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
        .validate(&module)
        .map_err(|e| {
            let at = e.location(source).map(|l| locate(files, l.line_number)).unwrap_or_default();
            format!("{at}: {}", e.emit_to_string(source))
        })?;
    Ok(module)
}

/// The value of `module`'s constant `name`, a literal (the tests that read a WGSL twin's
/// constants against the Rust ones).
#[cfg(test)]
pub(crate) fn literal_constant(module: &naga::Module, name: &str) -> f64 {
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("constant {name} is missing from the WGSL"));
    match module.global_expressions[c.init] {
        naga::Expression::Literal(naga::Literal::U32(v)) => v as f64,
        naga::Expression::Literal(naga::Literal::F32(v)) => v as f64,
        naga::Expression::Literal(naga::Literal::I32(v)) => v as f64,
        ref other => panic!("{name}: unexpected initializer {other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::layout;

    #[test]
    fn every_wgsl_file_validates_with_its_dependencies() {
        for integrator in Integrator::ALL.into_iter().filter(|i| i.has_gpu_kernel()) {
            let files = kernel_files(integrator);
            for i in 1..=files.len() {
                if let Err(e) =
                    parse_and_validate(&compose_with_tables(&files[..i], UniformTables::default()), &files)
                {
                    panic!("{} ({integrator} kernel) does not validate: {e}", files[i - 1].0);
                }
            }
        }
    }

    /// Each integrator's kernel validates with each table in either form (uniform arrays
    /// have stricter layout rules than storage ones).
    #[test]
    fn kernel_validates_with_every_table_form() {
        for integrator in Integrator::ALL.into_iter().filter(|i| i.has_gpu_kernel()) {
            for bits in 0..16u32 {
                let tables = UniformTables {
                    nodes: bits & 1 != 0,
                    triangles: bits & 2 != 0,
                    materials: bits & 4 != 0,
                    lights: bits & 8 != 0,
                };
                if let Err(e) =
                    parse_and_validate(&kernel_source(integrator, tables), &kernel_files(integrator))
                {
                    panic!("the {integrator} kernel with {tables:?} does not validate: {e}");
                }
            }
        }
    }

    #[test]
    fn locate_maps_lines_to_files() {
        assert_eq!(locate(COMMON_FILES, 2), "shaders/layout.wgsl:1");
        let layout_lines = COMMON_FILES[0].1.lines().count() as u32;
        assert_eq!(locate(COMMON_FILES, layout_lines + 3), "shaders/features.wgsl:1");
    }

    /// Every struct in `src/scene/layout.rs` exists in WGSL with the same size and the same
    /// field offsets, and every shared constant has the same value.
    #[test]
    fn layout_matches_wgsl() {
        let files = kernel_files(Integrator::Path);
        let module =
            parse_and_validate(&kernel_source(Integrator::Path, UniformTables::default()), &files).unwrap();
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        for (name, size, fields) in layout::all_layouts() {
            let (handle, ty) = module
                .types
                .iter()
                .find(|(_, t)| t.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("struct {name} is missing from shaders/layout.wgsl"));
            let naga::TypeInner::Struct { members, .. } = &ty.inner else {
                panic!("{name} is not a struct in WGSL")
            };
            assert_eq!(layouter[handle].size as usize, size, "{name}: WGSL size vs Rust size_of");
            assert_eq!(members.len(), fields.len(), "{name}: field count differs");
            for (member, (field, offset)) in members.iter().zip(&fields) {
                assert_eq!(member.name.as_deref(), Some(*field), "{name}: field order differs");
                assert_eq!(member.offset as usize, *offset, "{name}.{field}: WGSL offset vs Rust offset_of");
            }
        }
        let constant = |name: &str| literal_constant(&module, name);
        let shared: &[(&str, f64)] = &[
            ("INVALID_INDEX", layout::INVALID_INDEX as f64),
            ("AOV_NO_MATERIAL", layout::AOV_NO_MATERIAL as f64),
            ("AOV_MIXED_MATERIALS", layout::AOV_MIXED_MATERIALS as f64),
            ("TRIANGLE_HAS_NORMALS", layout::TRIANGLE_HAS_NORMALS as f64),
            ("TRIANGLE_HAS_TANGENTS", layout::TRIANGLE_HAS_TANGENTS as f64),
            ("WRAP_REPEAT", layout::WRAP_REPEAT as f64),
            ("WRAP_CLAMP_TO_EDGE", layout::WRAP_CLAMP_TO_EDGE as f64),
            ("WRAP_MIRRORED_REPEAT", layout::WRAP_MIRRORED_REPEAT as f64),
            ("TEXTURE_NEAREST", layout::TEXTURE_NEAREST as f64),
            ("MATERIAL_DOUBLE_SIDED", layout::MATERIAL_DOUBLE_SIDED as f64),
            ("MATERIAL_VOLUME", layout::MATERIAL_VOLUME as f64),
            ("MATERIAL_ALPHA_MASK", layout::MATERIAL_ALPHA_MASK as f64),
            ("MATERIAL_ALPHA_BLEND", layout::MATERIAL_ALPHA_BLEND as f64),
            ("MATERIAL_DELTA_ONLY", layout::MATERIAL_DELTA_ONLY as f64),
            ("ALPHA_HASH_SALT", crate::scene::texture::ALPHA_HASH_SALT as f64),
            ("TEXTURE_LEVELS_SHIFT", crate::scene::texture::TEXTURE_LEVELS_SHIFT as f64),
            ("LOD_FINEST", crate::scene::texture::LOD_FINEST as f64),
            ("LIGHT_TRIANGLE", layout::LIGHT_TRIANGLE as f64),
            ("LIGHT_POINT", layout::LIGHT_POINT as f64),
            ("LIGHT_SPOT", layout::LIGHT_SPOT as f64),
            ("LIGHT_DIRECTIONAL", layout::LIGHT_DIRECTIONAL as f64),
            ("LIGHT_ENVIRONMENT", layout::LIGHT_ENVIRONMENT as f64),
            ("PROJECTION_PERSPECTIVE", layout::PROJECTION_PERSPECTIVE as f64),
            ("DISPLAY_CLAMP", layout::DISPLAY_CLAMP as f64),
            ("DISPLAY_ACES", layout::DISPLAY_ACES as f64),
            ("DISPLAY_RELATIVE_ERROR", layout::DISPLAY_RELATIVE_ERROR as f64),
            ("PROJECTION_ORTHOGRAPHIC", layout::PROJECTION_ORTHOGRAPHIC as f64),
            ("SHORT_STACK_SIZE", crate::bvh::SHORT_STACK_SIZE as f64),
            ("MAX_BOUNCES_GUARD", crate::integrator::MAX_BOUNCES_GUARD as f64),
            ("RR_MAX_SURVIVAL", crate::integrator::RR_MAX_SURVIVAL as f64),
            ("RR_ANY_BOUNCE_DEPTH", crate::integrator::RR_ANY_BOUNCE_DEPTH as f64),
            ("LOBE_SELECTION_FLOOR", crate::bsdf::LOBE_SELECTION_FLOOR as f64),
            ("MIN_ALPHA", crate::bsdf::MIN_ALPHA as f64),
            ("CLEARCOAT_F0", crate::bsdf::CLEARCOAT_F0 as f64),
            ("COAT_MIN_BASE_COSINE", crate::bsdf::COAT_MIN_BASE_COSINE as f64),
            ("MIN_SHEEN_ROUGHNESS", crate::bsdf::sheen::MIN_SHEEN_ROUGHNESS as f64),
            ("SHEEN_ALBEDO_SIZE", crate::bsdf::sheen::SHEEN_ALBEDO_SIZE as f64),
            ("SHADOW_EPSILON", crate::geometry::SHADOW_EPSILON as f64),
            ("DIMENSION_STEP", crate::sampling::DIMENSION_STEP as f64),
            ("SPLIT_STREAM_SALT", crate::sampling::SPLIT_STREAM_SALT as f64),
            ("LIGHT_RR_MIN_VERTICES", crate::integrator::LIGHT_RR_MIN_VERTICES as f64),
            ("LIGHT_PATH_STREAM", crate::integrator::LIGHT_PATH_STREAM as f64),
            ("CAUSTIC_FRACTION_BITS", crate::integrator::CAUSTIC_FRACTION_BITS as f64),
            ("CAUSTIC_MAX_FIXED", crate::integrator::CAUSTIC_MAX_FIXED as f64),
            ("CAUSTIC_SUM_WORDS", crate::integrator::CAUSTIC_SUM_WORDS as f64),
            ("CAUSTICS_PER_SAMPLE", layout::CAUSTICS_PER_SAMPLE as f64),
            ("CAUSTICS_APART", layout::CAUSTICS_APART as f64),
        ];
        for (name, value) in shared {
            assert_eq!(constant(name), *value, "constant {name}: WGSL vs Rust");
        }
        // Each integrator's own constants, in its own kernel.
        let module_of = |integrator: Integrator| {
            parse_and_validate(
                &kernel_source(integrator, UniformTables::default()),
                &kernel_files(integrator),
            )
            .unwrap()
        };
        let bdpt = module_of(Integrator::Bdpt);
        let max_vertices = crate::integrator::bdpt::BDPT_MAX_VERTICES as f64;
        let bdpt_vertices = literal_constant(&bdpt, "BDPT_MAX_VERTICES");
        assert_eq!(bdpt_vertices, max_vertices, "BDPT_MAX_VERTICES: WGSL vs Rust");
        let ring = literal_constant(&bdpt, "BDPT_CAMERA_RING");
        assert!(ring > max_vertices && (ring as u32).is_power_of_two(), "BDPT_CAMERA_RING {ring} too small");
        use crate::integrator::{photon, sppm};
        let photon_module = module_of(Integrator::Photon);
        for (name, value) in [
            ("CAUSTIC_RADIUS_PIXELS", photon::CAUSTIC_RADIUS_PIXELS as f64),
            ("GATHER_DELTA_BOUNCES", photon::GATHER_DELTA_BOUNCES as f64),
        ] {
            assert_eq!(literal_constant(&photon_module, name), value, "constant {name}: WGSL vs Rust");
        }
        let sppm_module = module_of(Integrator::Sppm);
        for (name, value) in [
            ("SPPM_ALPHA", sppm::SPPM_ALPHA as f64),
            ("SPPM_ALPHA_ONE_PLANE", sppm::SPPM_ALPHA_ONE_PLANE as f64),
            ("ONE_PLANE_AREA_TOLERANCE", sppm::ONE_PLANE_AREA_TOLERANCE as f64),
            ("PHOTON_STREAM", sppm::PHOTON_STREAM as f64),
            ("PLANE_TOLERANCE", sppm::PLANE_TOLERANCE as f64),
            ("STEP_TOLERANCE", sppm::STEP_TOLERANCE as f64),
            ("PLANE_POSITION_ERROR", sppm::PLANE_POSITION_ERROR as f64),
            ("GATHER_STACK_SIZE", crate::bvh::MAX_DEPTH as f64),
            ("MAX_COVERAGE_CORRECTION", crate::integrator::gather_area::MAX_COVERAGE_CORRECTION as f64),
            ("SPPM_HEADER_WORDS", crate::gpu::renderer::SPPM_HEADER_WORDS as f64),
            ("SPPM_DISPATCH", crate::gpu::renderer::SPPM_DISPATCH_WORD as f64),
            ("SPPM_SCAN_BLOCK", crate::gpu::renderer::SPPM_SCAN_BLOCK as f64),
            ("PHOTONS_INDIRECT", sppm::PhotonKind::Indirect.index() as f64),
            ("PHOTONS_ALL", sppm::PhotonKind::All.index() as f64),
            ("PHOTONS_CAUSTIC", sppm::PhotonKind::Caustic.index() as f64),
        ] {
            assert_eq!(literal_constant(&sppm_module, name), value, "constant {name}: WGSL vs Rust");
        }
    }
}
