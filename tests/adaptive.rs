//! Adaptive sampling (issue 47): an adaptive render is unbiased (compare's z-test against a
//! converged uniform render, on the Cornell box and the mirror-and-glass box, on both
//! backends), its counts vary and are recorded, the backends decide the same counts, and
//! bad settings are clear errors. The rule's unbiasedness itself, and that a naive rule
//! is measurably biased, is tested beside it (`sampling::adaptive`).

mod common;

use std::sync::atomic::AtomicBool;

use pathlight::film::Film;
use pathlight::sampling::adaptive::AdaptiveSettings;
use pathlight::session::{BackendChoice, Session, SessionOptions};

fn options(scene: &str, size: u32, spp: u32, seed: u32, backend: BackendChoice) -> SessionOptions {
    SessionOptions {
        width: Some(size),
        height: Some(size),
        spp,
        seed,
        backend,
        ..SessionOptions::new(common::scene(scene))
    }
}

fn open(options: &SessionOptions) -> Session {
    let gpu = match options.backend {
        BackendChoice::Gpu => Some(common::gpu().expect("checked by the caller")),
        _ => None,
    };
    Session::open_with(options, gpu).unwrap_or_else(|e| panic!("{e}"))
}

fn render(session: &mut Session, spp: u32) -> Film {
    session.render_to(spp, &AtomicBool::new(false), |_, _| Ok(false)).unwrap();
    session.film().unwrap()
}

/// compare's multi-scale z-test at a false-alarm rate of 10⁻³ (these tests make a handful
/// of comparisons).
fn statistically_equal(a: &Film, b: &Film) -> Result<(), String> {
    common::statistically_equal_at(a, b, 1e-3)
}

fn backends() -> Vec<BackendChoice> {
    let mut b = vec![BackendChoice::Cpu];
    if common::gpu().is_some() {
        b.push(BackendChoice::Gpu);
    }
    b
}

/// An adaptive render of `scene` against a uniform one of `reference_spp` (CPU, another
/// seed): the same image by z-test, with counts that vary between the pilot's minimum and
/// `max_spp`.
fn adaptive_equals_uniform(scene: &str, size: u32, max_spp: u32, reference_spp: u32) {
    let reference =
        render(&mut open(&options(scene, size, reference_spp, 101, BackendChoice::Cpu)), reference_spp);
    for backend in backends() {
        let adaptive = AdaptiveSettings { threshold: 0.05, min_spp: 16 };
        let mut session =
            open(&SessionOptions { adaptive: Some(adaptive), ..options(scene, size, max_spp, 7, backend) });
        let film = render(&mut session, max_spp);
        let counts: Vec<u32> = film.pixels.iter().map(|p| p.count).collect();
        let budgets = session.sample_budgets().expect("decided").to_vec();
        let wrong: Vec<(usize, u32, u32)> = (0..counts.len())
            .filter(|&i| counts[i] != budgets[i])
            .map(|i| (i, counts[i], budgets[i]))
            .take(8)
            .collect();
        assert!(
            wrong.is_empty(),
            "{scene} {backend:?}: pixels that did not take their count (pixel, taken, count): {wrong:?}"
        );
        let (least, most) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
        assert!(
            *least >= 16 && *most <= max_spp && least < most,
            "{scene} {backend:?}: counts {least}..{most}"
        );
        if let Err(e) = statistically_equal(&film, &reference) {
            let dir = common::root().join("target/test-failures/adaptive");
            let _ = std::fs::create_dir_all(&dir);
            let (w, h) = (film.width as usize, film.height as usize);
            common::write_debug_png(&dir.join(format!("{scene}-{backend:?}.png")), w, h, &film.mean(), 1.0);
            common::write_debug_png(
                &dir.join(format!("{scene}-reference.png")),
                w,
                h,
                &reference.mean(),
                1.0,
            );
            panic!("{scene} on {backend:?}: the adaptive render differs from the uniform one: {e} (images in {})", dir.display());
        }
    }
}

#[test]
fn adaptive_renders_of_the_cornell_box_are_unbiased_on_both_backends() {
    adaptive_equals_uniform("cornell-box.gltf", 32, 512, 4096);
}

#[test]
fn adaptive_renders_of_the_mirror_and_glass_box_are_unbiased_on_both_backends() {
    adaptive_equals_uniform("cornell-spheres.gltf", 24, 1024, 4096);
}

#[test]
fn both_backends_decide_the_same_counts_and_render_the_same_pixels() {
    same_counts_and_pixels_on_both_backends("cornell-box.gltf");
}

/// The mirror-and-glass box's caustics are light traced, and an adaptive render sums every
/// pass's light paths into one image for it (`CausticSums`; on the GPU
/// `accumulate_caustic_sums`): the same sums on both backends.
#[test]
fn both_backends_sum_the_light_traced_caustics_alike() {
    same_counts_and_pixels_on_both_backends("cornell-spheres.gltf");
}

fn same_counts_and_pixels_on_both_backends(scene: &str) {
    let Some(_) = common::gpu() else { return };
    let adaptive = Some(AdaptiveSettings { threshold: 0.05, min_spp: 8 });
    let films: Vec<(Film, Vec<u32>)> = [BackendChoice::Cpu, BackendChoice::Gpu]
        .into_iter()
        .map(|backend| {
            let mut session = open(&SessionOptions { adaptive, ..options(scene, 32, 256, 5, backend) });
            let film = render(&mut session, 256);
            (film, session.sample_budgets().unwrap().to_vec())
        })
        .collect();
    let ((cpu, cpu_counts), (gpu, gpu_counts)) = (&films[0], &films[1]);
    // The pilots agree to f32 rounding (the same random numbers), so a count can differ only
    // where the needed count sits on an integer boundary: at most 1% of the pixels.
    let differ = cpu_counts.iter().zip(gpu_counts).filter(|(a, b)| a != b).count();
    assert!(differ * 100 <= cpu_counts.len(), "{scene}: {differ} of {} counts differ", cpu_counts.len());
    // Where the counts agree the pixels took the same samples: equal to rounding (the
    // same-seed bound of tests/gpu, 1e-3 relative, in 99% of them).
    let mut far = 0;
    let mut same = 0;
    for i in 0..cpu.pixels.len() {
        if cpu_counts[i] != gpu_counts[i] {
            continue;
        }
        same += 1;
        let (a, b) = (cpu.pixels[i].mean, gpu.pixels[i].mean);
        far += (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3 * a[c].abs().max(1e-2)) as usize;
    }
    assert!(far * 100 <= same, "{scene}: {far} of {same} pixels differ beyond rounding");
}

#[test]
fn an_adaptive_exr_records_each_pixels_count() {
    let dir = common::root().join("target/test-output/adaptive");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("counts.exr");
    let adaptive = Some(AdaptiveSettings { threshold: 0.05, min_spp: 8 });
    let mut session =
        open(&SessionOptions { adaptive, ..options("cornell-box.gltf", 16, 128, 3, BackendChoice::Cpu) });
    let film = render(&mut session, 128);
    session.write(std::slice::from_ref(&path), pathlight::film::Tonemap::Clamp, 0.0).unwrap();
    let exr = pathlight::film::read_exr(&path).unwrap();
    let counts = &exr.channels["sampleCount"];
    let expected: Vec<f32> = film.pixels.iter().map(|p| p.count as f32).collect();
    assert_eq!(counts, &expected);
    let note = &exr.attributes["pathlight.adaptive"];
    assert!(note.contains("threshold 0.05") && note.contains("pilot of 8 spp"), "{note}");
}

#[test]
fn bad_adaptive_settings_are_clear_errors() {
    let open_err = |options: SessionOptions| Session::open(&options).err().expect("refused").to_string();
    let base = options("cornell-box.gltf", 8, 64, 0, BackendChoice::Cpu);
    let with = |threshold: f32, min_spp: u32| SessionOptions {
        adaptive: Some(AdaptiveSettings { threshold, min_spp }),
        ..base.clone()
    };
    assert!(open_err(with(0.0, 16)).contains("--adaptive-threshold"));
    assert!(open_err(with(f32::NAN, 16)).contains("--adaptive-threshold"));
    assert!(open_err(with(0.05, 1)).contains("--adaptive-min-spp"));
    assert!(open_err(with(0.05, 128)).contains("exceeds --spp 64"));
    let bdpt = SessionOptions { integrator: pathlight::integrator::Integrator::Bdpt, ..with(0.05, 16) };
    assert!(open_err(bdpt).contains("--integrator path only"));
    let shard = SessionOptions { samples: Some(0..32), ..with(0.05, 16) };
    assert!(open_err(shard).contains("--samples, --shard"));
}
