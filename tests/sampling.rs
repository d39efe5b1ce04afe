//! Goodness of fit of every sampling routine against its density (chi-square, 1M samples
//! each, Šidák-corrected α = 0.01 per test function, as in Mitsuba 3 and pbrt-v4), and the
//! consistency of `eval`, `pdf` and `sample`.

mod common;

use common::{chi2_directions, DirectionTest};
use glam::{Vec2, Vec3};
use pathlight::bsdf::microfacet::{sample_visible_normal, visible_normal_pdf};
use pathlight::bsdf::reflection::{reflection_pdf, reflection_sample};
use pathlight::bsdf::thin_transmission::{thin_transmission_pdf, thin_transmission_sample};
use pathlight::bsdf::transmission::{transmission_pdf, transmission_sample};
use pathlight::bsdf::{alpha_from_roughness, GltfBsdf};
use pathlight::sampling::{
    build_alias_table, cosine_hemisphere_pdf, sample_cosine_hemisphere, sample_uniform_sphere,
    sample_uniform_triangle, Rng,
};
use pathlight::scene::layout::{Material, MATERIAL_VOLUME};
use pathlight::stats::{chi2_test, sidak_alpha};

const SAMPLES: usize = 1_000_000;
const ALPHA: f64 = 0.01;

fn dir(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// Asserts a direction test passed at the Šidák-corrected level, and that the sampler's
/// success rate matches ∫ pdf (samplers may fail, e.g. below the horizon, but only where
/// the density says so).
fn check(name: &str, t: &DirectionTest, tests_in_family: usize) {
    let level = sidak_alpha(ALPHA, tests_in_family);
    assert!(
        t.chi2.p_value > level,
        "{name}: chi-square rejected the sampler: chi2 = {:.1}, dof = {}, p = {:.3e} < {:.3e}",
        t.chi2.chi2,
        t.chi2.dof,
        t.chi2.p_value,
        level
    );
    // Only quadrature slivers may land where the integrated density is zero.
    assert!(
        t.chi2.observed_where_expected_zero <= 1e-4 * SAMPLES as f64,
        "{name}: {} samples where the density integrates to zero",
        t.chi2.observed_where_expected_zero
    );
    // The success fraction is binomial (σ ≤ 0.5/√n = 5e-4); the quadrature of a smooth
    // density on this grid is good to ~1e-3 relative. 5σ + 2e-3 bounds both.
    let tol = 5.0 * 0.5 / (SAMPLES as f64).sqrt() + 2e-3;
    assert!(
        (t.success_fraction - t.pdf_integral).abs() < tol,
        "{name}: {:.5} of samples succeeded but the pdf integrates to {:.5}",
        t.success_fraction,
        t.pdf_integral
    );
}

#[test]
fn warps_match_their_densities() {
    let cases: Vec<(&str, DirectionTest)> = vec![
        (
            "cosine hemisphere",
            chi2_directions(SAMPLES, 1, |r| Some(sample_cosine_hemisphere(r.next_2d())), &|d| {
                cosine_hemisphere_pdf(d.z) as f64
            }),
        ),
        (
            "uniform sphere",
            chi2_directions(SAMPLES, 2, |r| Some(sample_uniform_sphere(r.next_2d())), &|_| {
                1.0 / (4.0 * std::f64::consts::PI)
            }),
        ),
    ];
    for (name, t) in &cases {
        check(name, t, cases.len());
    }
}

#[test]
fn ggx_lobes_match_their_densities() {
    let mut cases: Vec<(String, DirectionTest)> = Vec::new();
    for (alpha, theta) in [(0.3f32, 30.0f32), (0.3, 80.0), (0.7, 60.0), (0.12, 45.0)] {
        let wo = dir(theta);
        cases.push((
            format!("visible normals α={alpha} θo={theta}"),
            chi2_directions(SAMPLES, 3, |r| Some(sample_visible_normal(wo, alpha, r.next_2d())), &|m| {
                visible_normal_pdf(wo, m, alpha) as f64
            }),
        ));
        cases.push((
            format!("GGX reflection α={alpha} θo={theta}"),
            chi2_directions(SAMPLES, 4, |r| reflection_sample(wo, alpha, r.next_2d()), &|wi| {
                reflection_pdf(wo, wi, alpha) as f64
            }),
        ));
        cases.push((
            format!("thin transmission α={alpha} θo={theta}"),
            chi2_directions(SAMPLES, 5, |r| thin_transmission_sample(wo, alpha, r.next_2d()), &|wi| {
                thin_transmission_pdf(wo, wi, alpha) as f64
            }),
        ));
        for eta in [1.5f32, 1.0 / 1.5, 1.33] {
            cases.push((
                format!("rough refraction α={alpha} θo={theta} η={eta:.3}"),
                chi2_directions(SAMPLES, 6, |r| transmission_sample(wo, alpha, eta, r.next_2d()), &|wi| {
                    transmission_pdf(wo, wi, alpha, eta) as f64
                }),
            ));
        }
    }
    for (name, t) in &cases {
        check(name, t, cases.len());
    }
}

/// glTF materials that exercise every non-delta lobe combination.
fn test_materials() -> Vec<(&'static str, Material, bool, Vec3)> {
    let base = Material {
        base_color: [0.8, 0.6, 0.4],
        alpha: 1.0,
        specular_color: [1.0; 3],
        specular_factor: 1.0,
        ior: 1.5,
        alpha_roughness: alpha_from_roughness(0.5),
        ..Default::default()
    };
    let glass = Material {
        base_color: [1.0; 3],
        transmission: 1.0,
        alpha_roughness: alpha_from_roughness(0.55),
        ..base
    };
    let coat = Material { clearcoat: 0.8, clearcoat_roughness: 0.3, ..base };
    let sheen = Material { sheen_color: [0.9, 0.5, 0.7], sheen_roughness: 0.4, ..base };
    let tilted = Vec3::new(0.3, -0.2, 0.9).normalize();
    let z = Vec3::Z;
    vec![
        ("plastic r=0.5", base, true, z),
        (
            "metal r=0.6",
            Material { metallic: 1.0, alpha_roughness: alpha_from_roughness(0.6), ..base },
            true,
            z,
        ),
        (
            "half metal r=0.8",
            Material { metallic: 0.5, alpha_roughness: alpha_from_roughness(0.8), ..base },
            true,
            z,
        ),
        ("lambertian", Material { specular_factor: 0.0, alpha_roughness: 1.0, ..base }, true, z),
        (
            "tinted specular",
            Material { specular_color: [1.5, 0.5, 0.2], specular_factor: 0.7, ior: 1.8, ..base },
            true,
            z,
        ),
        ("thin rough glass", glass, true, z),
        ("rough glass entering", Material { flags: MATERIAL_VOLUME, ..glass }, true, z),
        ("rough glass exiting", Material { flags: MATERIAL_VOLUME, ..glass }, false, z),
        ("half-transmissive thin", Material { transmission: 0.5, ..glass }, true, z),
        (
            "glass of roughness 1 entering",
            Material { flags: MATERIAL_VOLUME, alpha_roughness: 1.0, ..glass },
            true,
            z,
        ),
        (
            "glass of roughness 1 exiting",
            Material { flags: MATERIAL_VOLUME, alpha_roughness: 1.0, ..glass },
            false,
            z,
        ),
        ("clearcoat over plastic", coat, true, z),
        ("clearcoat with its own normal", coat, true, tilted),
        ("coated metal", Material { metallic: 1.0, ..coat }, true, tilted),
        ("sheen over plastic", sheen, true, z),
        ("smooth sheen r=0.1", Material { sheen_roughness: 0.1, ..sheen }, true, z),
        (
            "coat and sheen over thin glass",
            Material {
                clearcoat: 0.5,
                clearcoat_roughness: 0.2,
                ..Material { sheen_color: [0.5; 3], ..glass }
            },
            true,
            z,
        ),
    ]
}

#[test]
fn gltf_bsdf_sampling_matches_its_density() {
    let mut cases: Vec<(String, DirectionTest)> = Vec::new();
    for (name, material, front, coat_normal) in test_materials() {
        for theta in [20.0f32, 75.0] {
            let wo = dir(theta);
            let bsdf = GltfBsdf::new(&material, wo, front, coat_normal);
            assert!(bsdf.has_non_delta());
            let t = chi2_directions(
                SAMPLES,
                7,
                |r| {
                    let u_lobe = r.next_1d();
                    let u = r.next_2d();
                    let s = bsdf.sample(wo, u_lobe, u)?;
                    assert!(!s.is_delta, "{name}: rough materials have no delta lobes");
                    Some(s.wi)
                },
                &|wi| bsdf.pdf(wo, wi) as f64,
            );
            cases.push((format!("{name} θo={theta}"), t));
        }
    }
    for (name, t) in &cases {
        check(name, t, cases.len());
    }
}

#[test]
fn bsdf_sample_weights_equal_eval_cos_over_pdf() {
    for (name, material, front, coat_normal) in test_materials() {
        let wo = dir(50.0);
        let bsdf = GltfBsdf::new(&material, wo, front, coat_normal);
        let mut rng = Rng::new(1, 2, 3, 4);
        for _ in 0..20_000 {
            let (u_lobe, u) = (rng.next_1d(), rng.next_2d());
            let Some(s) = bsdf.sample(wo, u_lobe, u) else { continue };
            let f = bsdf.eval(wo, s.wi);
            let pdf = bsdf.pdf(wo, s.wi);
            assert!(pdf > 0.0 && (pdf - s.pdf_solid_angle).abs() <= 1e-6 * pdf, "{name}: pdf mismatch");
            let expected = f * s.wi.z.abs() / pdf;
            // The same f32 expression, evaluated twice: only rounding of the final division.
            assert!(
                (expected - s.weight).abs().max_element() <= 1e-5 * expected.max_element().max(1e-3),
                "{name}: weight {:?} vs {:?}",
                s.weight,
                expected
            );
            assert!(s.weight.min_element() >= 0.0 && s.weight.is_finite());
        }
    }
}

#[test]
fn lambertian_and_white_metal_do_not_create_energy() {
    // Albedo ∫ f cos dω estimated by the sample weights. Lambertian is exactly 1·baseColor;
    // a white GGX metal with Smith masking loses energy (< 1). With 200k samples the
    // standard error of the mean weight is < 2e-3, so 1 + 1e-2 is a > 5σ bound.
    let white = Material {
        base_color: [1.0; 3],
        alpha: 1.0,
        specular_color: [1.0; 3],
        ior: 1.5,
        ..Default::default()
    };
    let lambert = Material { specular_factor: 0.0, alpha_roughness: 1.0, ..white };
    let metal = Material { metallic: 1.0, specular_factor: 1.0, alpha_roughness: 0.3, ..white };
    // The layers' energy rules: a rough coat takes from the base what its Fresnel reflects,
    // and a white sheen takes its albedo E (KHR_materials_sheen albedo scaling).
    let coated = Material { clearcoat: 1.0, clearcoat_roughness: 0.4, ..lambert };
    let sheened = Material { sheen_color: [1.0; 3], sheen_roughness: 0.5, ..lambert };
    for (name, m) in [
        ("lambert", lambert),
        ("white metal", metal),
        ("coated lambert", coated),
        ("sheen over lambert", sheened),
    ] {
        for theta in [0.0f32, 45.0, 85.0] {
            let wo = dir(theta);
            let bsdf = GltfBsdf::new(&m, wo, true, Vec3::Z);
            let mut rng = Rng::new(5, 6, 7, 8);
            let n = 200_000;
            let mut sum = Vec3::ZERO;
            for _ in 0..n {
                if let Some(s) = bsdf.sample(wo, rng.next_1d(), rng.next_2d()) {
                    sum += s.weight;
                }
            }
            let albedo = sum / n as f32;
            assert!(albedo.max_element() < 1.01, "{name} θ={theta}: albedo {albedo:?}");
            // Lower bounds for the layered whites away from grazing, so that a layer that
            // dims the base without reflecting in its place is caught. The coat loses little
            // there (GGX single scattering). The sheen's albedo scaling is conservative by
            // specification: it dims the base by the larger of E(μo) and E(μi), so the sum
            // stays below 1 (measured 0.86 at normal incidence). At grazing angles the coat's
            // Fresnel dims the base by 1 − F_c(n·v) while its rough lobe loses much of that
            // to Smith masking (0.6 at 85°): the model's known loss, not bounded here.
            let floor = match name {
                "coated lambert" => 0.9,
                "sheen over lambert" => 0.8,
                _ => 0.0,
            };
            if theta < 60.0 {
                assert!(albedo.min_element() > floor, "{name} θ={theta}: albedo {albedo:?}");
            }
            if name == "lambert" {
                assert!((albedo - Vec3::ONE).abs().max_element() < 1e-2, "{name}: albedo {albedo:?} ≠ 1");
            }
        }
    }
}

/// Smooth, clear glass of index 1.5: a refracting solid.
fn smooth_solid_glass() -> Material {
    Material {
        base_color: [1.0; 3],
        alpha: 1.0,
        specular_color: [1.0; 3],
        specular_factor: 1.0,
        ior: 1.5,
        transmission: 1.0,
        flags: MATERIAL_VOLUME,
        ..Default::default()
    }
}

#[test]
fn delta_lobes_are_exact() {
    // Smooth glass entering at normal incidence: reflect 4%, transmit 96%/η² of radiance.
    let glass = smooth_solid_glass();
    let wo = dir(0.0);
    let bsdf = GltfBsdf::new(&glass, wo, true, Vec3::Z);
    assert!(!bsdf.has_non_delta());
    let [_, _, pr, _, pt] = bsdf.lobe_probabilities();
    let r = bsdf.sample(wo, 0.5 * pr, Vec2::ZERO).unwrap();
    assert!(r.is_delta && (r.wi - Vec3::Z).length() < 1e-6);
    assert!((r.weight.x * pr - 0.04).abs() < 1e-6, "reflectance {}", r.weight.x * pr);
    let t = bsdf.sample(wo, pr + 0.5 * pt, Vec2::ZERO).unwrap();
    assert!(t.is_delta && (t.wi + Vec3::Z).length() < 1e-6);
    assert!((t.weight.x * pt - 0.96 / 2.25).abs() < 1e-6, "transmittance {}", t.weight.x * pt);
    // From inside beyond the critical angle (41.8°): total internal reflection.
    let wo = dir(60.0);
    let inside = GltfBsdf::new(&glass, wo, false, Vec3::Z);
    assert_eq!(inside.dielectric_fresnel(wo.z), Vec3::ONE);
    let [_, _, pr, _, pt] = inside.lobe_probabilities();
    let r = inside.sample(wo, 0.5 * pr, Vec2::ZERO).unwrap();
    assert!((r.weight.x * pr - 1.0).abs() < 1e-6, "TIR must reflect everything");
    assert!(inside.sample(wo, pr + 0.5 * pt, Vec2::ZERO).is_none(), "no refraction under TIR");
    // A polished metal reflects F_Schlick(baseColor) into the mirror direction.
    let mirror = Material { metallic: 1.0, base_color: [0.9, 0.5, 0.2], alpha: 1.0, ..glass };
    let mirror = Material { transmission: 0.0, flags: 0, ..mirror };
    let b = GltfBsdf::new(&mirror, Vec3::Z, true, Vec3::Z);
    let s = b.sample(Vec3::Z, 0.0, Vec2::ZERO).unwrap();
    let [_, _, pr, _, _] = b.lobe_probabilities();
    assert!((s.weight * pr - Vec3::new(0.9, 0.5, 0.2)).abs().max_element() < 1e-6);
}

#[test]
fn uniform_triangle_sampling_is_uniform() {
    // Histogram (b0, b1) on an n×n grid of the unit square. Cells below the diagonal
    // b0 + b1 = 1 hold area 1/n², cells on it exactly half that (the diagonal runs through
    // their corners), cells above none: the exact expected counts.
    let n = 64;
    let mut observed = vec![0.0f64; n * n];
    let mut rng = Rng::new(1, 1, 1, 1);
    for _ in 0..SAMPLES {
        let b = sample_uniform_triangle(rng.next_2d());
        assert!(b.min_element() >= 0.0 && (b.x + b.y + b.z - 1.0).abs() < 1e-6);
        let i = ((b.x * n as f32) as usize).min(n - 1);
        let j = ((b.y * n as f32) as usize).min(n - 1);
        observed[i * n + j] += 1.0;
    }
    let cell = 2.0 / (n * n) as f64 * SAMPLES as f64;
    let expected: Vec<f64> = (0..n * n)
        .map(|k| {
            let (i, j) = (k / n, k % n);
            match (i + j).cmp(&(n - 1)) {
                std::cmp::Ordering::Less => cell,
                std::cmp::Ordering::Equal => cell / 2.0,
                std::cmp::Ordering::Greater => 0.0,
            }
        })
        .collect();
    let r = chi2_test(&observed, &expected, 5.0);
    assert!(r.p_value > ALPHA, "triangle sampling: p = {:.3e}", r.p_value);
}

/// Lights that carry only the alias table of `weights` (what the light choice reads).
fn lights_weighted(weights: &[f64]) -> Vec<pathlight::scene::layout::Light> {
    build_alias_table(weights)
        .unwrap()
        .iter()
        .map(|e| pathlight::scene::layout::Light {
            alias_probability: e.probability,
            alias_index: e.alias,
            pmf: e.pmf,
            ..Default::default()
        })
        .collect()
}

#[test]
fn alias_table_sampling_matches_weights() {
    let weights: Vec<f64> =
        (0..1000).map(|i| ((i * 7919) % 101) as f64 + if i % 13 == 0 { 500.0 } else { 0.0 }).collect();
    let lights = lights_weighted(&weights);
    let mut observed = vec![0.0f64; weights.len()];
    let mut rng = Rng::new(2, 2, 2, 2);
    for _ in 0..SAMPLES {
        observed[pathlight::light::choose_light(&lights, rng.next_2d())] += 1.0;
    }
    let total: f64 = weights.iter().sum();
    let expected: Vec<f64> = weights.iter().map(|w| w / total * SAMPLES as f64).collect();
    let r = chi2_test(&observed, &expected, 5.0);
    assert!(r.p_value > ALPHA, "alias sampling: chi2 {:.1} dof {} p = {:.3e}", r.chi2, r.dof, r.p_value);
}

/// `choose_light_reusing` chooses lights by their weights, and the number it hands back is
/// uniform given the light: one chi-square over (light, tenth of [0, 1)) cells. Dropping the
/// rescaling (handing back the column's fraction unstretched) fails it, as does a coin that
/// ignores the alias table.
#[test]
fn light_choice_reusing_its_number_matches_weights_and_leaves_a_uniform() {
    let weights = [1.0f64, 2.0, 3.0, 4.0, 10.0, 0.5, 7.0];
    let lights = lights_weighted(&weights);
    const BINS: usize = 10;
    let mut observed = vec![0.0f64; weights.len() * BINS];
    let mut rng = Rng::new(5, 6, 7, 8);
    for _ in 0..SAMPLES {
        let (index, u) = pathlight::light::choose_light_reusing(&lights, rng.next_1d());
        assert!((0.0..1.0).contains(&u), "rescaled number {u} outside [0, 1)");
        observed[index * BINS + (u * BINS as f32) as usize] += 1.0;
    }
    let total: f64 = weights.iter().sum();
    let expected: Vec<f64> =
        weights.iter().flat_map(|w| [w / total * SAMPLES as f64 / BINS as f64; BINS]).collect();
    let r = chi2_test(&observed, &expected, 5.0);
    assert!(
        r.p_value > ALPHA,
        "light choice reusing: chi2 {:.1} dof {} p = {:.3e}",
        r.chi2,
        r.dof,
        r.p_value
    );
    // The ends of [0, 1) stay inside it.
    for u in [0.0, f32::MIN_POSITIVE, 0.5, 1.0 - f32::EPSILON / 2.0] {
        let (index, rescaled) = pathlight::light::choose_light_reusing(&lights, u);
        assert!(index < lights.len() && (0.0..1.0).contains(&rescaled), "u {u}: {index}, {rescaled}");
    }
}

#[test]
fn smooth_glass_at_grazing_incidence_stays_finite_and_reflects_almost_all() {
    // wo.z from 1e-2 down to 1e-7 (and exactly 0, edge-on): no NaN, no infinite weight, and
    // the Fresnel reflectance tends to 1 from both sides.
    let glass = smooth_solid_glass();
    for cos in [1e-2f32, 1e-4, 1e-7, 0.0] {
        let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
        for front in [true, false] {
            let bsdf = GltfBsdf::new(&glass, wo, front, Vec3::Z);
            let f = bsdf.dielectric_fresnel(cos).x;
            assert!(f.is_finite() && (0.0..=1.0).contains(&f), "cos {cos}: F = {f}");
            if cos <= 1e-4 {
                assert!(f > 0.99, "cos {cos} front {front}: F = {f}");
            }
            let mut rng = Rng::new(9, 9, 9, 9);
            for _ in 0..1000 {
                if let Some(s) = bsdf.sample(wo, rng.next_1d(), rng.next_2d()) {
                    assert!(
                        s.weight.is_finite() && s.weight.min_element() >= 0.0,
                        "cos {cos}: weight {:?}",
                        s.weight
                    );
                    assert!(s.pdf_solid_angle.is_finite() && s.pdf_solid_angle > 0.0);
                }
            }
        }
    }
}
