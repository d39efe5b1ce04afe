//! Helpers shared by the integration tests.
#![allow(dead_code)] // Each test binary uses a different subset of these helpers.

use std::path::PathBuf;

use glam::Vec3;
use pathlight::sampling::Rng;
use pathlight::stats::{chi2_test, Chi2Result};

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A bundled scene.
pub fn scene(name: &str) -> PathBuf {
    root().join("scenes").join(name)
}

/// `../shared/assets`, for the tests that need it. Those tests are ignored unless the
/// `shared-assets` feature is on (`#[cfg_attr(not(feature = "shared-assets"), ignore = …)]`),
/// so that a clone without the assets reports them as ignored, not passed; CI turns the
/// feature on (ci/test.sh), and there a missing folder fails the test.
pub fn assets() -> PathBuf {
    let dir = root().join("../shared/assets");
    assert!(
        dir.is_dir(),
        "{} is missing: the tests that need it run only with --features shared-assets, where it must exist",
        dir.display()
    );
    dir
}

/// Every Khronos sample model of the shared assets, by name (its file's), each loaded and
/// lit by the studio environment map, flattened square: what the Khronos tests render.
#[allow(dead_code)] // reason: each test binary compiles this module; only some use it
pub fn khronos_models() -> Vec<(String, pathlight::scene::FlatScene)> {
    let assets = assets();
    let env = pathlight::light::EnvironmentDesc::load(&assets.join("env/studio_small_05_1k.hdr")).unwrap();
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(assets.join("khronos"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    assert!(dirs.len() >= 17, "expected the 17 Khronos models, found {}", dirs.len());
    dirs.iter()
        .map(|dir| {
            let file = std::fs::read_dir(dir)
                .unwrap()
                .map(|e| e.unwrap().path())
                .find(|p| p.extension().is_some_and(|e| e == "glb" || e == "gltf"))
                .unwrap_or_else(|| panic!("no model file in {}", dir.display()));
            let name = file.file_name().unwrap().to_string_lossy().into_owned();
            let (mut scene, _) = pathlight::scene::load(&file).unwrap_or_else(|e| panic!("{e}"));
            scene.environment = Some(env.clone());
            let view = pathlight::scene::ViewSettings { camera: None, aspect: 1.0 };
            (name, pathlight::scene::FlatScene::build(&scene, &view).unwrap())
        })
        .collect()
}

/// Cells of the sphere in (cos θ, φ), equal in solid angle.
pub const Z_CELLS: usize = 40;
pub const PHI_CELLS: usize = 80;
pub fn direction_from(z: f64, phi: f64) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
}

fn cell_of(d: Vec3) -> usize {
    let d = d.normalize();
    let z = (d.z as f64).clamp(-1.0, 1.0);
    let phi = (d.y as f64).atan2(d.x as f64) + std::f64::consts::PI;
    let iz = (((z + 1.0) / 2.0 * Z_CELLS as f64) as usize).min(Z_CELLS - 1);
    let ip = ((phi / (2.0 * std::f64::consts::PI) * PHI_CELLS as f64) as usize).min(PHI_CELLS - 1);
    iz * PHI_CELLS + ip
}

/// ∫ pdf over one cell by the midpoint rule on an n×n grid.
fn integrate_cell(pdf: &(dyn Fn(Vec3) -> f64 + Sync), iz: usize, ip: usize, n: usize) -> f64 {
    let dz = 2.0 / Z_CELLS as f64;
    let dphi = 2.0 * std::f64::consts::PI / PHI_CELLS as f64;
    let mut sum = 0.0;
    for a in 0..n {
        for b in 0..n {
            let z = -1.0 + (iz as f64 + (a as f64 + 0.5) / n as f64) * dz;
            let phi = -std::f64::consts::PI + (ip as f64 + (b as f64 + 0.5) / n as f64) * dphi;
            sum += pdf(direction_from(z, phi));
        }
    }
    sum * dz * dphi / (n * n) as f64
}

/// ∫ pdf over each cell (dω = dz dφ). The midpoint grid starts at 32×32 and is refined per
/// cell until two successive resolutions agree to 1e-3 relative (or 1e-9 absolute), up to
/// 512×512. Narrow lobes and discontinuities (microfacets turning back-facing, triangle
/// edges) need far more points than smooth cells: a fixed 8×8 grid under-integrated such
/// cells by 10%, and 8×8 vs 16×16 could agree while both were 13% wrong. A discontinuous
/// cell's midpoint error falls as 1/n, so at the final resolution it is ≲ 0.2% of the cell.
pub fn integrate_cells(pdf: &(dyn Fn(Vec3) -> f64 + Sync)) -> Vec<f64> {
    let mut out = vec![0.0; Z_CELLS * PHI_CELLS];
    for iz in 0..Z_CELLS {
        for ip in 0..PHI_CELLS {
            let mut n = 32;
            let mut coarse = integrate_cell(pdf, iz, ip, n);
            loop {
                n *= 2;
                let fine = integrate_cell(pdf, iz, ip, n);
                let converged = (fine - coarse).abs() <= 1e-3 * fine.abs() || (fine - coarse).abs() < 1e-9;
                coarse = fine;
                if converged || n >= 512 {
                    break;
                }
            }
            out[iz * PHI_CELLS + ip] = coarse;
        }
    }
    out
}

/// The outcome of a chi-square test of a direction sampler.
pub struct DirectionTest {
    pub chi2: Chi2Result,
    /// Fraction of draws that produced a direction.
    pub success_fraction: f64,
    /// ∫ pdf over the sphere (numerical).
    pub pdf_integral: f64,
}

/// Draws `n` directions and tests their histogram against `pdf` (per unit solid angle)
/// with Pearson's chi-square test (as pbrt-v4's and Mitsuba 3's BSDF tests do).
pub fn chi2_directions(
    n: usize,
    seed: u32,
    mut sample: impl FnMut(&mut Rng) -> Option<Vec3>,
    pdf: &(dyn Fn(Vec3) -> f64 + Sync),
) -> DirectionTest {
    let mut observed = vec![0.0f64; Z_CELLS * PHI_CELLS];
    let mut rng = Rng::new(seed, 17, 0, 99);
    let mut successes = 0usize;
    for _ in 0..n {
        if let Some(d) = sample(&mut rng) {
            if d.is_finite() && d.length_squared() > 0.0 {
                observed[cell_of(d)] += 1.0;
                successes += 1;
            }
        }
    }
    let integrals = integrate_cells(pdf);
    let expected: Vec<f64> = integrals.iter().map(|p| p * n as f64).collect();
    DirectionTest {
        chi2: chi2_test(&observed, &expected, 5.0),
        success_fraction: successes as f64 / n as f64,
        pdf_integral: integrals.iter().sum(),
    }
}

/// Writes `rgb` (linear) as a PNG for inspection of failures.
pub fn write_debug_png(path: &std::path::Path, width: usize, height: usize, rgb: &[Vec3], scale: f32) {
    let mut film = pathlight::film::Film::new(width as u32, height as u32);
    for (p, c) in film.pixels.iter_mut().zip(rgb) {
        p.mean = (*c * scale).to_array();
        p.count = 1;
    }
    let _ = pathlight::film::write_png(&film, path, pathlight::film::Tonemap::Clamp, 0.0);
}

/// Loads a scene file and flattens it for rendering at `width × height`.
pub fn flat_scene(path: &std::path::Path, width: u32, height: u32) -> pathlight::scene::FlatScene {
    let (scene, _warnings) = pathlight::scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    pathlight::scene::FlatScene::build(
        &scene,
        &pathlight::scene::ViewSettings { camera: None, aspect: width as f64 / height as f64 },
    )
    .unwrap()
}

/// The multi-scale z-test `pathlight compare` runs, at family-wise false-alarm rate
/// `alpha` per comparison: `Err` names what differs.
pub fn statistically_equal_at(
    a: &pathlight::film::Film,
    b: &pathlight::film::Film,
    alpha: f64,
) -> Result<(), String> {
    use pathlight::film::{compare_images, CompareOptions, LinearImage};
    let options = CompareOptions { alpha, ..CompareOptions::default() };
    let report = compare_images(&LinearImage::from_film(a), &LinearImage::from_film(b), &options)
        .map_err(|e| e.to_string())?;
    if report.same() {
        Ok(())
    } else {
        Err(report.failures.join("; "))
    }
}

/// Renders with a backend to completion.
pub fn render(backend: &mut dyn pathlight::Backend, spp: u32) -> pathlight::film::Film {
    let stop = std::sync::atomic::AtomicBool::new(false);
    pathlight::render_progressive(backend, spp, &stop, |_| {}).unwrap();
    backend.film().unwrap()
}

/// Per channel: the mean over all pixels and its standard error. Pixels are independent (each
/// has its own random streams), so the variance of the image mean is Σ var(mean_i) / N². The
/// channels of one pixel share paths and are correlated, so each is tested on its own.
pub fn image_mean_and_standard_error(film: &pathlight::film::Film) -> [(f64, f64); 3] {
    let means = film.mean();
    let vars = film.variance_of_mean();
    let n = means.len() as f64;
    [0, 1, 2].map(|c| {
        let mean = means.iter().map(|m| m[c] as f64).sum::<f64>() / n;
        let var = vars.iter().map(|v| v[c] as f64).sum::<f64>() / (n * n);
        (mean, var.sqrt())
    })
}

/// The image's mean over pixels and channels and its standard error (the channels' errors
/// combined as independent: conservative enough for a bound of several of them).
pub fn image_mean_and_error(film: &pathlight::film::Film) -> (f64, f64) {
    let m = image_mean_and_standard_error(film);
    let mean = m.iter().map(|(m, _)| m).sum::<f64>() / 3.0;
    let se = (m.iter().map(|(_, s)| s * s).sum::<f64>()).sqrt() / 3.0;
    (mean, se)
}

/// relMSE of `film` against `reference`, the reference's own variance taken out (so that a
/// reference of finite samples does not set a floor), averaged over pixels and channels.
pub fn relmse_against(film: &pathlight::film::Film, reference: &pathlight::film::Film) -> f64 {
    let var = reference.variance_of_mean();
    let mut sum = 0.0;
    for ((a, b), v) in film.pixels.iter().zip(&reference.pixels).zip(&var) {
        for c in 0..3 {
            let (a, b) = (a.mean[c] as f64, b.mean[c] as f64);
            sum += ((a - b).powi(2) - v[c] as f64) / (b * b + 1e-2);
        }
    }
    sum / (film.pixels.len() * 3) as f64
}

/// The GPU every GPU test shares (creating a device per test would waste seconds each), or
/// `None` after saying loudly that the test was skipped. With `CI=true`, a missing adapter
/// fails the test instead: CI must run these on lavapipe.
pub fn gpu() -> Option<std::sync::Arc<pathlight::gpu::GpuContext>> {
    use std::sync::{Arc, OnceLock};
    static GPU: OnceLock<Result<Arc<pathlight::gpu::GpuContext>, String>> = OnceLock::new();
    let ctx =
        GPU.get_or_init(|| pathlight::gpu::GpuContext::new(None).map(Arc::new).map_err(|e| e.to_string()));
    match ctx {
        Ok(c) => Some(c.clone()),
        Err(e) if std::env::var("CI").as_deref() == Ok("true") => {
            panic!("CI=true but no usable GPU: {e} (install mesa-vulkan-drivers for lavapipe)")
        }
        Err(e) => {
            eprintln!("SKIPPED: no usable GPU ({e}); this GPU test did not run");
            None
        }
    }
}

/// A glTF buffer's bytes as a data URI.
pub fn buffer_data_uri(bin: &[u8]) -> String {
    use base64::Engine;
    format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(bin))
}

/// An 8-bit RGBA image as a PNG `data:` URI (for glTF documents built inside tests).
pub fn png_data_uri(width: u32, height: u32, rgba: &[u8]) -> String {
    use base64::Engine;
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut bytes, width, height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(rgba).unwrap();
    }
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes))
}

/// Squares of side 1.5^i in the planes x = 1.5^i, i < 60, spanning (y, z) ≥ 0: as one
/// triangle each (the lower-left half, `pairs` false) or as two, in order of distance.
pub fn deep_row(pairs: bool) -> Vec<pathlight::scene::layout::Triangle> {
    use pathlight::scene::layout::Triangle;
    let triangle = |p0: [f32; 3], p1: [f32; 3], p2: [f32; 3]| Triangle { p0, p1, p2, ..Default::default() };
    (0..60)
        .flat_map(|i| {
            let s = 1.5f32.powi(i);
            let lower = triangle([s, 0.0, 0.0], [s, s, 0.0], [s, 0.0, s]);
            let upper = triangle([s, s, 0.0], [s, s, s], [s, 0.0, s]);
            if pairs {
                vec![lower, upper]
            } else {
                vec![lower]
            }
        })
        .collect()
}

/// A BVH as deep as a tree over `triangles` can be: the triangles in groups of `group` (1 or
/// 2) consecutive ones, and node k of the chain over groups 0 ..= m − 1 − k (m groups), its
/// first child the next such node and its second group m − 1 − k: a leaf, or a node whose
/// two leaves hold the pair. Group 0 lies deepest, at depth m − 1 (plus 1 for pairs) below
/// the root. Built by hand, so that traversal is tested far deeper than the builder's trees
/// of real scenes go (a builder change cannot make such a test lose its point).
pub fn chain_tree(
    triangles: &[pathlight::scene::layout::Triangle],
    group: usize,
) -> Vec<pathlight::scene::layout::BvhNode> {
    use pathlight::scene::layout::BvhNode;
    assert!((group == 1 || group == 2) && triangles.len() % group == 0);
    let bounds = |range: std::ops::Range<usize>| {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for t in &triangles[range] {
            for p in [t.p0, t.p1, t.p2] {
                lo = lo.min(Vec3::from(p));
                hi = hi.max(Vec3::from(p));
            }
        }
        (lo.to_array(), hi.to_array())
    };
    // An interior node over `range`, its second child set once that child's place is known.
    let interior = |range: std::ops::Range<usize>| {
        let (lo, hi) = bounds(range);
        BvhNode { bounds_min: lo, offset: 0, bounds_max: hi, count_axis: 0 }
    };
    let leaf = |i: usize| {
        let (lo, hi) = bounds(i..i + 1);
        BvhNode { bounds_min: lo, offset: i as u32, bounds_max: hi, count_axis: 1 }
    };
    let emit_group = |nodes: &mut Vec<BvhNode>, g: usize| {
        if group == 1 {
            nodes.push(leaf(g));
        } else {
            let at = nodes.len();
            nodes.push(interior(2 * g..2 * g + 2));
            nodes.push(leaf(2 * g));
            nodes[at].offset = nodes.len() as u32;
            nodes.push(leaf(2 * g + 1));
        }
    };
    // Depth-first: the chain's nodes, then the deepest group, then the others coming back up.
    let groups = triangles.len() / group;
    let mut nodes = Vec::with_capacity(4 * groups);
    for k in 0..groups - 1 {
        nodes.push(interior(0..(groups - k) * group));
    }
    emit_group(&mut nodes, 0);
    for k in (0..groups - 1).rev() {
        nodes[k].offset = nodes.len() as u32;
        emit_group(&mut nodes, groups - 1 - k);
    }
    nodes
}

/// The depth (root 0) of the leaf holding each triangle.
pub fn leaf_depths(nodes: &[pathlight::scene::layout::BvhNode]) -> Vec<u32> {
    let mut depths = Vec::new();
    let mut stack = vec![(0usize, 0u32)];
    while let Some((i, depth)) = stack.pop() {
        let node = &nodes[i];
        if node.triangle_count() > 0 {
            let end = (node.offset + node.triangle_count()) as usize;
            depths.resize(depths.len().max(end), 0);
            depths[node.offset as usize..end].fill(depth);
        } else {
            stack.push((i + 1, depth + 1));
            stack.push((node.offset as usize, depth + 1));
        }
    }
    depths
}

/// The glTF scenes (`.gltf`, `.glb`) in `dir`, sorted.
pub fn gltf_files(dir: &std::path::Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gltf" || e == "glb"))
        .collect();
    files.sort();
    files
}

/// Splits every triangle of `scene` into four, the new vertices pushed out onto the unit
/// sphere: the 1,280-face icosphere of the furnace scenes, refined, is a sphere to within
/// 1 − cos(face radius) — 8e-5 after two refinements (81,920 faces).
pub fn refine_unit_sphere(scene: &mut pathlight::scene::Scene) {
    let mut positions = Vec::with_capacity(scene.positions.len() * 4);
    let mut materials = Vec::with_capacity(scene.triangle_materials.len() * 4);
    for (tri, material) in scene.positions.chunks_exact(3).zip(&scene.triangle_materials) {
        let [a, b, c] = [tri[0], tri[1], tri[2]];
        let (ab, bc, ca) = ((a + b).normalize(), (b + c).normalize(), (c + a).normalize());
        for t in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
            positions.extend(t);
            materials.push(*material);
        }
    }
    let n = materials.len();
    scene.positions = positions;
    scene.triangle_materials = materials;
    scene.normals = vec![None; n];
    scene.texcoords = vec![Default::default(); n];
    scene.tangents = vec![None; n];
}

/// Every bundled scene: the `.gltf` files in `scenes/` and `scenes/hard/`. 12 and 24 when
/// this was written: a listing that found far fewer would be testing nothing.
pub fn bundled_scene_files() -> Vec<PathBuf> {
    let mut files = gltf_files(&root().join("scenes"));
    files.extend(gltf_files(&root().join("scenes/hard")));
    assert!(files.len() >= 30, "found only {} scenes", files.len());
    files
}
