//! Light sampling: the directions `sample_light` draws follow the density that MIS uses
//! when a BSDF-sampled ray hits an emitter (`triangle_light_pdf`).

mod common;

use common::chi2_directions;
use glam::{DVec3, Vec3};
use pathlight::bvh::intersect_closest;
use pathlight::geometry::Ray;
use pathlight::light::{sample_light, triangle_light_pdf};
use pathlight::sampling::Rng;
use pathlight::scene::layout::{LIGHT_TRIANGLE, MATERIAL_DOUBLE_SIDED};
use pathlight::scene::{
    CameraDesc, FlatScene, MaterialDesc, Projection, PunctualKind, PunctualLight, Scene, ViewSettings,
};
use pathlight::stats::sidak_alpha;

/// Emitters around the origin with different sizes, radiances and orientations, and a
/// point light; the camera (and so the shading point) is at the origin.
fn light_scene() -> FlatScene {
    let mut scene = Scene::default();
    let bright = MaterialDesc { emission: Vec3::new(5.0, 4.0, 3.0), ..MaterialDesc::default() };
    let dim = MaterialDesc { emission: Vec3::new(0.5, 0.5, 1.0), ..MaterialDesc::default() };
    let two_sided =
        MaterialDesc { emission: Vec3::new(1.0, 2.0, 1.0), double_sided: true, ..MaterialDesc::default() };
    scene.materials = vec![bright, dim, two_sided];
    let d = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    // Facing the origin (counter-clockwise seen from it).
    scene.push_triangle([d(0.0, 1.0, 3.0), d(1.0, -1.0, 3.0), d(-1.0, -1.0, 3.0)], None, 0);
    scene.push_triangle([d(2.0, 0.0, -0.5), d(2.0, 0.0, 0.5), d(2.0, 0.8, 0.0)], None, 1);
    // Facing away from the origin but double-sided: still lights it.
    scene.push_triangle([d(-0.5, 3.0, -0.5), d(0.5, 3.0, -0.5), d(0.0, 3.0, 0.7)], None, 2);
    // Facing away and one-sided: never contributes at the origin.
    scene.push_triangle([d(-2.0, -0.2, -0.5), d(-2.0, 0.6, 0.0), d(-2.0, -0.2, 0.5)], None, 0);
    scene.lights.push(PunctualLight {
        name: "point".into(),
        kind: PunctualKind::Point,
        intensity: Vec3::splat(3.0),
        position: d(0.0, -2.0, 0.0),
        direction: DVec3::NEG_Z,
    });
    scene.cameras.push(CameraDesc {
        name: "origin".into(),
        projection: Projection::Perspective { yfov: 1.0, aspect_ratio: None },
        position: DVec3::ZERO,
        forward: DVec3::NEG_Z,
        up: DVec3::Y,
    });
    FlatScene::build(&scene, &ViewSettings { camera: None, aspect: 1.0 }).unwrap()
}

/// The density per solid angle of choosing direction `w` from the origin by light
/// sampling, computed the way MIS computes it: trace, and ask the emitter hit.
fn light_pdf_along(scene: &FlatScene, w: Vec3) -> f32 {
    let ray = Ray { origin: Vec3::ZERO, direction: w, t_max: f32::MAX };
    let Some(hit) = intersect_closest(&scene.nodes, &scene.triangles, &ray) else { return 0.0 };
    let tri = &scene.triangles[hit.triangle as usize];
    if tri.emitter == u32::MAX {
        return 0.0;
    }
    let (n, _) = pathlight::light::triangle_normal_area(tri);
    let front = n.dot(-w) > 0.0;
    let m = &scene.materials[tri.material as usize];
    if !front && m.flags & MATERIAL_DOUBLE_SIDED == 0 {
        return 0.0;
    }
    let p = w * hit.hit.t;
    triangle_light_pdf(&scene.lights[tri.emitter as usize], Vec3::ZERO, p)
}

#[test]
fn area_light_directions_follow_the_mis_density() {
    let scene = light_scene();
    assert_eq!(scene.lights.iter().filter(|l| l.kind == LIGHT_TRIANGLE).count(), 4);
    let t = chi2_directions(
        1_000_000,
        11,
        |r| {
            let ls = sample_light(scene.light_arrays(), Vec3::ZERO, Vec3::ZERO, Vec3::Z, r.next_2d())?;
            (!ls.is_delta).then_some(ls.wi)
        },
        &|w| light_pdf_along(&scene, w) as f64,
    );
    let level = sidak_alpha(0.01, 1);
    assert!(t.chi2.p_value > level, "chi2 {:.1}, dof {}, p {:.3e}", t.chi2.chi2, t.chi2.dof, t.chi2.p_value);
    // Triangle edges cut cells, and a midpoint rule can miss a thin sliver of a triangle
    // inside a cell; a sampler putting real mass off its support would exceed this.
    assert!(
        t.chi2.observed_where_expected_zero <= 1e-4 * 1e6,
        "{} samples off the support",
        t.chi2.observed_where_expected_zero
    );
    // 5σ binomial + quadrature slack, as in tests/sampling.rs.
    assert!(
        (t.success_fraction - t.pdf_integral).abs() < 5e-3,
        "{} vs {}",
        t.success_fraction,
        t.pdf_integral
    );
}

#[test]
fn sampled_pdf_equals_the_pdf_of_the_hit() {
    let scene = light_scene();
    let mut rng = Rng::new(3, 1, 4, 1);
    let mut checked = 0;
    for _ in 0..100_000 {
        let Some(ls) = sample_light(scene.light_arrays(), Vec3::ZERO, Vec3::ZERO, Vec3::Z, rng.next_2d())
        else {
            continue;
        };
        if ls.is_delta {
            // Point light: radiance is I / d², pdf its selection probability.
            assert!((ls.radiance - Vec3::splat(3.0 / 4.0)).abs().max_element() < 1e-5);
            continue;
        }
        let along = light_pdf_along(&scene, ls.wi);
        // Both are a handful of f32 operations on the same quantities: agreement to 1e-3
        // relative allows for the ray hitting the point through a different rounding path.
        assert!((along - ls.pdf).abs() <= 1e-3 * ls.pdf, "sampled pdf {} vs hit pdf {along}", ls.pdf);
        checked += 1;
    }
    assert!(checked > 50_000);
    // The alias table chooses lights by power; the pmfs sum to one.
    let total: f32 = scene.lights.iter().map(|l| l.pmf).sum();
    assert!((total - 1.0).abs() < 1e-5);
}

/// A synthetic environment: a gradient, a bright spot, and a black band (zero density),
/// turned 30° about +Y.
fn environment() -> pathlight::light::FlatEnvironment {
    let (w, h) = (32u32, 16u32);
    let texels = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            if j == 11 {
                Vec3::ZERO
            } else if (i, j) == (5, 4) {
                Vec3::new(200.0, 150.0, 100.0)
            } else {
                Vec3::new(0.2 + i as f32 / w as f32, 0.5, 1.0 - j as f32 / h as f32)
            }
        })
        .collect();
    let desc = pathlight::light::EnvironmentDesc {
        width: w,
        height: h,
        texels,
        intensity: 2.0,
        rotation_degrees: 30.0,
        source: None,
    };
    pathlight::light::FlatEnvironment::build(&desc, 1.0)
}

#[test]
fn environment_directions_follow_their_density() {
    use pathlight::light::{environment_lookup, sample_environment};
    let env = environment();
    let t = chi2_directions(
        1_000_000,
        12,
        |r| sample_environment(&env.params, &env.texels, &env.cdf, r.next_2d()).map(|s| s.0),
        &|w| environment_lookup(&env.params, &env.texels, w).1 as f64,
    );
    let level = sidak_alpha(0.01, 1);
    assert!(t.chi2.p_value > level, "chi2 {:.1}, dof {}, p {:.3e}", t.chi2.chi2, t.chi2.dof, t.chi2.p_value);
    // The band of black texels has zero density and must get no samples; texel edges cut
    // cells, so the quadrature may assign a sliver of a non-zero texel a zero.
    assert!(t.chi2.observed_where_expected_zero <= 1e-4 * 1e6, "{}", t.chi2.observed_where_expected_zero);
    // The density integrates to 1 over the sphere and every draw succeeds (up to the poles,
    // a set of measure zero): 5σ binomial + quadrature slack.
    assert!((t.pdf_integral - 1.0).abs() < 5e-3, "∫ pdf = {}", t.pdf_integral);
    assert!((t.success_fraction - 1.0).abs() < 5e-3, "{}", t.success_fraction);
}

#[test]
fn environment_samples_carry_the_lookup_radiance_and_density() {
    use pathlight::light::{environment_lookup, sample_environment};
    let env = environment();
    let mut rng = Rng::new(5, 2, 7, 1);
    for _ in 0..100_000 {
        let Some((wi, radiance, pdf)) = sample_environment(&env.params, &env.texels, &env.cdf, rng.next_2d())
        else {
            continue;
        };
        let (le, pdf_lookup) = environment_lookup(&env.params, &env.texels, wi);
        // Same texel unless the direction rounds across a texel edge (the rotation's few ulps):
        // then radiance and density jump, so compare only where the texel is the same.
        if le == radiance {
            assert!((pdf_lookup - pdf).abs() <= 1e-3 * pdf, "sampled pdf {pdf} vs lookup {pdf_lookup}");
        }
        assert!(radiance.max_element() > 0.0, "a black texel was sampled");
    }
}
