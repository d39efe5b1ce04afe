//! Photon mapping (issue 44), progressive (`sppm`) and with fixed maps (`photon`), against
//! the path tracer, bidirectional path tracing and analytic
//! answers, on the CPU backend. The WGSL twins equal these CPU halves for a seed
//! (tests/gpu/sppm.rs: SPPM to rounding, the photon-map integrator to its maps' rounding),
//! so what holds here holds for them.
//!
//! SPPM is biased: its radius blurs the photons' light, a bias that shrinks with the
//! passes. Each test states the bound it holds it to and why.

mod common;

use pathlight::cpu::CpuBackend;
use pathlight::film::Film;
use pathlight::integrator::Integrator;
use pathlight::scene::FlatScene;
use pathlight::RenderSettings;

fn settings(integrator: Integrator, size: u32, spp: u32, seed: u32) -> RenderSettings {
    RenderSettings { integrator, width: size, height: size, spp, seed, ..RenderSettings::default() }
}

fn render(scene: &FlatScene, settings: &RenderSettings) -> Film {
    common::render(&mut CpuBackend::new(scene, settings), settings.spp)
}

/// The bias bound of a 256-pass SPPM image mean at 24² against the path tracer's: the
/// blur of a radius that started at 3 pixel footprints (an eighth of these small images)
/// darkens corners and edges and moves light across shadow boundaries. The largest offset
/// measured over the bundled scenes when this was written was −3.8% (cornell-tiny-light,
/// whose light is mostly indirect; the Cornell box −1.7%); since the gather keeps the
/// photons on surfaces meeting a visible point's (`facing_each_other`, 2026-12-05), −1.6%
/// (punctual; cornell-tiny-light −1.4%, the Cornell box −0.7%); since each gather
/// measures the area it reads (`gather_area`, 2026-12-07), −0.8% (punctual;
/// cornell-tiny-light −0.3%, the Cornell box −0.25%). The photon-map integrator
/// with its default maps (2¹⁸ photons each, 32 per global estimate) is held to the same
/// bound: its largest offset measured was −1.9% (glass-index-1; now −1.4%), leaving aside
/// the lamp room, whose path-traced reference is itself noisy at 1,024 samples (now +8%
/// with a combined standard error of 3%).
///
/// The slit room is the exception the noise term covers. Its lamp box is about 10⁴ times
/// brighter inside than the room and its walls have no thickness, so a visible point on
/// the floor just outside the box, in front of the inner faces of the box's far walls and
/// lid, gathers their photons: no plane test can see the near wall between them, only a
/// ray could. SPPM is +18% here (against this test's 1,024-spp reference, whose own
/// standard error is 2.5%; +11.5% against a 4,096-spp one, +7.9% at 1,024 passes, −2.1%
/// with an initial radius of one pixel footprint: the leak shrinks with the radius). Until
/// 2026-12-06 it was +114%, and the scene was exempt: the gather also took the photons on
/// the box's floor inside, a step 1 mm above the room's floor, which
/// `in_front_of_each_other` now refuses.
const IMAGE_MEAN_BIAS_24PX_256_PASSES: f64 = 0.05;

/// `integrator`'s image mean (256 samples or passes) within
/// [`IMAGE_MEAN_BIAS_24PX_256_PASSES`] of the path tracer's, plus 5 standard errors of
/// their difference (noise: a false alarm has probability 6e-7 per scene), on every bundled
/// scene.
fn equals_the_path_tracer_within_its_bias_on_every_bundled_scene(integrator: Integrator) {
    let size = 24;
    let files = common::bundled_scene_files();
    let mut failures = Vec::new();
    for file in files {
        let name = file.file_stem().unwrap().to_string_lossy().into_owned();
        let scene = common::flat_scene(&file, size, size);
        let reference = render(&scene, &settings(Integrator::Path, size, 1024, 12));
        let film = render(&scene, &settings(integrator, size, 256, 11));
        let ((a, sa), (b, sb)) =
            (common::image_mean_and_error(&film), common::image_mean_and_error(&reference));
        let bound = IMAGE_MEAN_BIAS_24PX_256_PASSES * b.abs() + 5.0 * (sa * sa + sb * sb).sqrt();
        eprintln!("{name:30} {integrator} {a:.5} ± {sa:.5}, path {b:.5} ± {sb:.5}, bound {bound:.5}");
        if film.total_rejected() != 0 {
            failures.push(format!("{name}: {} non-finite samples", film.total_rejected()));
        }
        if (a - b).abs() > bound {
            failures.push(format!(
                "{name}: {integrator} {a:.5} ± {sa:.5}, path {b:.5} ± {sb:.5}, bound {bound:.5}"
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{integrator} differs from the path tracer beyond its bias:\n{}",
        failures.join("\n")
    );
}

#[test]
fn sppm_equals_the_path_tracer_within_its_bias_on_every_bundled_scene() {
    equals_the_path_tracer_within_its_bias_on_every_bundled_scene(Integrator::Sppm);
}

#[test]
fn photon_mapping_equals_the_path_tracer_within_its_bias_on_every_bundled_scene() {
    equals_the_path_tracer_within_its_bias_on_every_bundled_scene(Integrator::Photon);
}

/// The photon-map integrator's bias shrinks as its maps grow: on a 24² Cornell box its
/// image mean's offset from the path tracer's with 2¹⁴ global photons is more than with
/// 2²⁰ (5% and 0.1% when this was written, photon-map blur at the box's edges and
/// corners), and the latter within 0.5% plus 5 standard errors.
#[test]
fn photon_mapping_bias_shrinks_with_more_photons() {
    let size = 24;
    let scene = common::flat_scene(&common::scene("cornell-box.gltf"), size, size);
    let (reference, sr) =
        common::image_mean_and_error(&render(&scene, &settings(Integrator::Path, size, 1024, 12)));
    let offset = |photons: u32| {
        let s = RenderSettings { photons: Some(photons), ..settings(Integrator::Photon, size, 64, 11) };
        let (m, se) = common::image_mean_and_error(&render(&scene, &s));
        eprintln!("{photons} photons: {m:.5} ± {se:.5} (path {reference:.5} ± {sr:.5})");
        ((m - reference).abs(), se)
    };
    let (few, _) = offset(1 << 14);
    let (many, se) = offset(1 << 20);
    assert!(few > many, "offsets {few:.5} (2^14 photons) and {many:.5} (2^20)");
    assert!(many <= 0.005 * reference + 5.0 * se.hypot(sr), "offset {many:.5} with 2^20 photons");
}

/// SPPM's error against a converged path-traced reference, measured at 32, 128 and 512
/// passes: the least-squares slope of log relMSE over log passes. The noise alone falls as
/// passes⁻¹ and the bias as the radius² ∝ passes^(α−1) = passes^(−1/3) (Knaus & Zwicker
/// 2011), so the slope lies between −1 and −1/3 while both matter; −0.3 leaves a margin
/// for the reference's own noise (taken out on average, `common::relmse_against`). Below about 32
/// passes the error of a 32² image hardly falls: the blur of the initial radius (3 pixel
/// footprints, a tenth of the image) dominates it, and shrinks slowly.
fn converges(file: &str) {
    let size = 32;
    let scene = common::flat_scene(&common::scene(file), size, size);
    let reference = render(&scene, &settings(Integrator::Path, size, 4096, 5));
    let mut points = Vec::new();
    for passes in [32u32, 128, 512] {
        let film = render(&scene, &settings(Integrator::Sppm, size, passes, 6));
        let e = common::relmse_against(&film, &reference);
        let ((a, _), (b, _)) =
            (common::image_mean_and_error(&film), common::image_mean_and_error(&reference));
        eprintln!("{file}: {passes} passes: relMSE {e:.5}, image mean {a:.5} (reference {b:.5})");
        assert!(e > 0.0, "{file}: relMSE {e} at {passes} passes is below the reference's own noise");
        points.push(((passes as f64).ln(), e.ln()));
    }
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let slope = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / points.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    eprintln!("{file}: log-log slope {slope:.3}");
    assert!(slope < -0.3, "{file}: SPPM's error falls with slope {slope:.3} in passes, not below −0.3");
}

#[test]
fn sppm_converges_on_the_cornell_box() {
    converges("cornell-box.gltf");
}

#[test]
fn sppm_converges_on_the_mirror_and_glass_cornell_box() {
    converges("cornell-spheres.gltf");
}

/// The mirror-and-glass Cornell box with its ceiling light replaced by a spot light just
/// under the ceiling, its cone (10° half-angle) on the glass sphere: most of its light
/// reaches the room through the glass, a caustic from a point, which no path from the
/// camera can find.
fn spot_lit_glass_sphere() -> FlatScene {
    let (mut scene, _) = pathlight::scene::load(&common::scene("cornell-spheres.gltf")).unwrap();
    let mut lamps = 0;
    for m in scene.materials.iter_mut().filter(|m| m.emission.max_element() > 0.0) {
        m.emission = glam::Vec3::ZERO;
        lamps += 1;
    }
    assert_eq!(lamps, 1, "the scene has one lamp material");
    // The glass sphere's centre: the middle of its triangles' bounds.
    let (mut lo, mut hi) = (glam::DVec3::splat(f64::MAX), glam::DVec3::splat(f64::MIN));
    for (tri, &m) in scene.positions.chunks_exact(3).zip(&scene.triangle_materials) {
        if scene.materials[m as usize].transmission > 0.0 {
            for p in tri {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
    }
    assert!(lo.x < hi.x, "the scene has a glass sphere");
    let glass = (lo + hi) * 0.5;
    let (room_lo, room_hi) = scene.bounds().unwrap();
    let position = glam::DVec3::new(glass.x, room_hi.y - 0.05 * (room_hi.y - room_lo.y), glass.z);
    scene.lights.push(pathlight::scene::PunctualLight {
        name: "spot".into(),
        kind: pathlight::scene::PunctualKind::Spot {
            inner_cone_angle: 8f32.to_radians(),
            outer_cone_angle: 10f32.to_radians(),
        },
        intensity: glam::Vec3::splat(20.0),
        position,
        direction: (glass - position).normalize(),
    });
    FlatScene::build(&scene, &pathlight::scene::ViewSettings { camera: None, aspect: 1.0 }).unwrap()
}

/// A spot light on a glass sphere: every bit of its light reaches the room through the
/// glass, a caustic from a point, and the path tracer renders none of it (its image is
/// black, exactly), while SPPM renders it: its image mean is at least 80% of bidirectional
/// path tracing's (which reaches the caustic by joining light subpaths to the camera), and
/// so does the photon-map integrator's. How SPPM and BDPT compare is the next test.
#[test]
fn a_caustic_from_a_spot_light_the_path_tracer_cannot_render_is_rendered_by_photon_mapping() {
    let size = 24;
    let scene = spot_lit_glass_sphere();
    let path = render(&scene, &settings(Integrator::Path, size, 256, 1));
    let bdpt = render(&scene, &settings(Integrator::Bdpt, size, 64, 3));
    let ((p, _), (b, _)) = (common::image_mean_and_error(&path), common::image_mean_and_error(&bdpt));
    assert_eq!(p, 0.0, "the path tracer found light from a point through glass");
    assert!(b > 0.1, "bdpt renders no caustic ({b}): the scene does not test anything");
    for integrator in [Integrator::Sppm, Integrator::Photon] {
        let film = render(&scene, &settings(integrator, size, 256, 2));
        let (a, sa) = common::image_mean_and_error(&film);
        eprintln!("spot-lit glass sphere: {integrator} {a:.5} ± {sa:.5}, bdpt {b:.5}, path {p:.5}");
        assert!(a > 0.8 * b, "{integrator} renders {a:.5} of bdpt's {b:.5} caustic");
    }
}

/// Pixels of `scene` (size²) that see only diffuse surfaces (no transmission, no metal),
/// they and their eight neighbours, over four jittered camera rays each.
fn diffuse_view_mask(scene: &FlatScene, size: u32) -> Vec<bool> {
    let diffuse = |x: i32, y: i32| -> bool {
        let (x, y) = (x.clamp(0, size as i32 - 1) as u32, y.clamp(0, size as i32 - 1) as u32);
        (0..4).all(|seed| {
            let hit = pathlight::integrator::first_hit(scene, size, size, x, y, seed);
            if hit.triangle == u32::MAX {
                return false;
            }
            let m = &scene.materials[scene.triangles[hit.triangle as usize].material as usize];
            m.transmission == 0.0 && m.metallic < 0.01
        })
    };
    (0..(size * size) as i32)
        .map(|i| {
            let (x, y) = (i % size as i32, i / size as i32);
            (-1..=1).all(|dy| (-1..=1).all(|dx| diffuse(x + dx, y + dy)))
        })
        .collect()
}

/// The mean over pixels and channels of `film` where `mask` holds, and its standard error
/// from the pixels' own variances.
fn masked_mean(film: &Film, mask: &[bool]) -> (f64, f64) {
    let var = film.variance_of_mean();
    let (mut sum, mut var_sum, mut n) = (0.0, 0.0, 0usize);
    for ((p, v), _) in film.pixels.iter().zip(&var).zip(mask).filter(|(_, &m)| m) {
        sum += (p.mean[0] + p.mean[1] + p.mean[2]) as f64 / 3.0;
        var_sum += (v[0] + v[1] + v[2]) as f64 / 9.0;
        n += 1;
    }
    (sum / n as f64, var_sum.sqrt() / n as f64)
}

/// SPPM against bidirectional path tracing on the spot-lit glass sphere. Where the camera
/// sees diffuse surfaces directly, both render the caustic, and SPPM's mean lies within
/// [`IMAGE_MEAN_BIAS_24PX_256_PASSES`] plus 5 standard errors of BDPT's. Where it sees them
/// through the glass or in the mirror sphere, the caustic is light from a point through a
/// delta surface onto a diffuse one and back through a delta surface to the camera
/// (L S D S E): no BDPT strategy can make such a path, and SPPM renders it, so its whole
/// image is brighter than BDPT's by many standard errors (by 14% when this was written:
/// 0.280 against 0.246 on a 32² image, while the diffuse view agreed to 2%).
#[test]
fn sppm_equals_bdpt_where_bdpt_can_see_a_spot_lights_caustic_and_adds_what_it_cannot() {
    let size = 32;
    let scene = spot_lit_glass_sphere();
    let mask = diffuse_view_mask(&scene, size);
    let count = mask.iter().filter(|&&m| m).count();
    assert!(
        count > mask.len() / 4 && count < mask.len(),
        "{count} of {} pixels see only diffuse surfaces",
        mask.len()
    );
    let sppm = render(&scene, &settings(Integrator::Sppm, size, 256, 2));
    // Independent BDPT renders: its t = 1 splats make one render's pixels correlated, so
    // the spread of independent means is its honest error.
    let renders: Vec<((f64, f64), (f64, f64))> = (0..6)
        .map(|seed| {
            let film = render(&scene, &settings(Integrator::Bdpt, size, 32, 10 + seed));
            (masked_mean(&film, &mask), common::image_mean_and_error(&film))
        })
        .collect();
    let spread = |values: Vec<f64>| {
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        (mean, (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n * (n - 1.0))).sqrt())
    };
    let (b_diffuse, sb_diffuse) = spread(renders.iter().map(|r| r.0 .0).collect());
    let (b_all, sb_all) = spread(renders.iter().map(|r| r.1 .0).collect());
    let (a_diffuse, sa_diffuse) = masked_mean(&sppm, &mask);
    let (a_all, sa_all) = common::image_mean_and_error(&sppm);
    eprintln!(
        "diffuse view: sppm {a_diffuse:.5} ± {sa_diffuse:.5}, bdpt {b_diffuse:.5} ± {sb_diffuse:.5}; \
         whole image: sppm {a_all:.5} ± {sa_all:.5}, bdpt {b_all:.5} ± {sb_all:.5}"
    );
    let bound = IMAGE_MEAN_BIAS_24PX_256_PASSES * b_diffuse + 5.0 * sa_diffuse.hypot(sb_diffuse);
    assert!(
        (a_diffuse - b_diffuse).abs() <= bound,
        "diffuse view: sppm {a_diffuse:.5} against bdpt {b_diffuse:.5}: bound {bound:.5}"
    );
    // Above BDPT by more than SPPM's bias bound and 3 standard errors (the excess expected
    // is about 8 of them, so this fails falsely with probability about 1e-4).
    let se = sa_all.hypot(sb_all);
    assert!(
        a_all - b_all > 3.0 * se + IMAGE_MEAN_BIAS_24PX_256_PASSES * b_all,
        "whole image: sppm {a_all:.5} is not above bdpt {b_all:.5} by the light seen through the spheres"
    );
}

/// A caustic seen through a glass pane (scenes/hard/cornell-spheres-behind-glass.gltf: the
/// mirror-and-glass box behind a window): specular–diffuse–specular light, which SPPM's
/// visible points behind the pane gather. At 256 passes of a 32² image its image mean
/// lies within [`IMAGE_MEAN_BIAS_24PX_256_PASSES`] plus 5 standard errors of a 4096-sample
/// path-traced reference (the path tracer finds these paths only by chance, but it does
/// find them: unbiased, only noisy), and its relMSE below 0.02 (measured 0.007 when
/// written; the path tracer's own at equal time is the benchmark's business).
#[test]
fn a_caustic_seen_through_a_glass_pane_is_rendered_by_sppm() {
    let size = 32;
    let scene = common::flat_scene(&common::scene("hard/cornell-spheres-behind-glass.gltf"), size, size);
    let reference = render(&scene, &settings(Integrator::Path, size, 4096, 3));
    let sppm = render(&scene, &settings(Integrator::Sppm, size, 256, 4));
    let ((a, sa), (b, sb)) = (common::image_mean_and_error(&sppm), common::image_mean_and_error(&reference));
    let e = common::relmse_against(&sppm, &reference);
    eprintln!("behind glass: sppm {a:.5} ± {sa:.5}, path {b:.5} ± {sb:.5}, relMSE {e:.5}");
    let bound = IMAGE_MEAN_BIAS_24PX_256_PASSES * b + 5.0 * (sa * sa + sb * sb).sqrt();
    assert!((a - b).abs() <= bound, "sppm {a:.5} ± {sa:.5}, path {b:.5} ± {sb:.5}: bound {bound:.5}");
    assert!(e < 0.02, "relMSE {e:.5} at 256 passes");
}

/// The analytic furnace (tests/furnace.rs): inside a closed Lambertian sphere of albedo ρ
/// emitting 1 every pixel is exactly 1 / (1 − ρ). Photons spread uniformly over a sphere
/// are gathered without the blur bias a non-uniform density has, so the bound is 1% (the
/// radius update's own small bias: the photon count M that shrinks the radius is
/// correlated with the flux it keeps) plus 5 standard errors.
fn furnace(integrator: Integrator, albedo: f64, file: &str) {
    let size = 32;
    let scene = common::flat_scene(&common::scene(file), size, size);
    let film = render(&scene, &settings(integrator, size, 256, 9));
    let exact = 1.0 / (1.0 - albedo);
    let (mean, se) = common::image_mean_and_error(&film);
    eprintln!("{integrator} furnace ρ = {albedo}: {mean:.5} ± {se:.5} (exact {exact})");
    assert_eq!(film.total_rejected(), 0);
    assert!(
        (mean - exact).abs() <= 0.01 * exact + 5.0 * se,
        "furnace ρ = {albedo}: {mean:.5} ± {se:.5}, exact {exact}"
    );
    assert!(se < 0.01 * exact, "standard error {se} is too large to test anything");
}

#[test]
fn sppm_furnace_albedo_0_5() {
    furnace(Integrator::Sppm, 0.5, "furnace-0.5.gltf");
}

#[test]
fn sppm_furnace_albedo_0_9() {
    furnace(Integrator::Sppm, 0.9, "furnace-0.9.gltf");
}

#[test]
fn photon_mapping_furnace_albedo_0_9() {
    furnace(Integrator::Photon, 0.9, "furnace-0.9.gltf");
}

/// The same seed gives the same image on any number of threads: the photons are stored
/// and gathered in photon order.
#[test]
fn a_seed_gives_the_same_image_on_one_thread_and_on_several() {
    let size = 24;
    let scene = common::flat_scene(&common::scene("cornell-spheres.gltf"), size, size);
    for integrator in [Integrator::Sppm, Integrator::Photon] {
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| render(&scene, &settings(integrator, size, 8, 3)))
        };
        let (one, three) = (on(1), on(3));
        assert!(one.pixels == three.pixels, "{integrator}: the images differ between 1 and 3 threads");
    }
}

/// Photon-mapping options are checked before any work, with messages naming them.
#[test]
fn bad_photon_mapping_options_are_clear_errors() {
    let sppm = settings(Integrator::Sppm, 8, 4, 0);
    let cases: Vec<(RenderSettings, &str)> = vec![
        (RenderSettings { photons: Some(0), ..sppm.clone() }, "--photons must be between 1"),
        (RenderSettings { photons: Some(u32::MAX), ..sppm.clone() }, "--photons must be between 1"),
        (RenderSettings { sppm_radius: Some(0.0), ..sppm.clone() }, "--sppm-radius"),
        (RenderSettings { sppm_radius: Some(f32::NAN), ..sppm.clone() }, "--sppm-radius"),
        (
            RenderSettings { max_depth: Some(3), ..sppm.clone() },
            "--max-depth is not supported by --integrator sppm",
        ),
        (
            RenderSettings { gather_photons: Some(0), ..settings(Integrator::Photon, 8, 4, 0) },
            "--gather-photons",
        ),
        (
            RenderSettings { caustic_photons: Some(0), ..settings(Integrator::Photon, 8, 4, 0) },
            "--caustic-photons must be between 1",
        ),
        (RenderSettings { caustic_photons: Some(10), ..sppm.clone() }, "options of --integrator photon"),
        (
            RenderSettings { sppm_radius: Some(2.0), ..settings(Integrator::Photon, 8, 4, 0) },
            "--sppm-radius is an option of --integrator sppm",
        ),
        (
            RenderSettings { photons: Some(100), ..settings(Integrator::Path, 8, 4, 0) },
            "--photons is an option of --integrator sppm and photon, not of --integrator path",
        ),
    ];
    for (s, expected) in cases {
        let e = s.validate().expect_err(expected).to_string();
        assert!(e.contains(expected), "{e:?} lacks {expected:?}");
    }
    let options = pathlight::session::SessionOptions {
        integrator: Integrator::Sppm,
        spp: 8,
        samples: Some(2..4),
        width: Some(8),
        height: Some(8),
        ..pathlight::session::SessionOptions::new(common::scene("cornell-box.gltf"))
    };
    let e = pathlight::session::Session::open(&options).err().expect("a part of an sppm render").to_string();
    assert!(e.contains("--integrator sppm renders whole images"), "{e}");
}
