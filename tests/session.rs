//! The session API (issue 10): an interrupted session keeps its samples and resumes to the
//! film an uninterrupted one makes; two sessions in one process do not interfere; bounded
//! row-band rendering (the viewer's) adds up to the same film as whole passes.

mod common;

use std::sync::atomic::AtomicBool;

use pathlight::film::Film;
use pathlight::session::{BackendChoice, Session, SessionOptions};

fn options(scene: &str, backend: BackendChoice) -> SessionOptions {
    SessionOptions {
        width: Some(20),
        height: Some(14),
        spp: 16,
        seed: 9,
        backend,
        ..SessionOptions::new(common::scene(scene))
    }
}

fn open(scene: &str, backend: BackendChoice) -> Session {
    let gpu = match backend {
        BackendChoice::Gpu => Some(common::gpu().expect("checked by the caller")),
        _ => None,
    };
    Session::open_with(&options(scene, backend), gpu).unwrap()
}

fn never() -> AtomicBool {
    AtomicBool::new(false)
}

/// Every pixel's statistics, bit for bit: sessions are deterministic per sample.
fn assert_same(a: &Film, b: &Film, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        assert_eq!(p.count, q.count, "{what}: pixel {i} sample count");
        for c in 0..3 {
            assert_eq!(p.mean[c].to_bits(), q.mean[c].to_bits(), "{what}: pixel {i} mean");
            assert_eq!(p.m2[c].to_bits(), q.m2[c].to_bits(), "{what}: pixel {i} M2");
        }
    }
}

fn backends() -> Vec<BackendChoice> {
    let mut b = vec![BackendChoice::Cpu];
    if common::gpu().is_some() {
        b.push(BackendChoice::Gpu);
    }
    b
}

#[test]
fn an_interrupted_session_keeps_its_samples_and_resumes() {
    for backend in backends() {
        let mut straight = open("cornell-box.gltf", backend);
        straight.render_to(16, &never(), |_, _| Ok(false)).unwrap();

        let mut interrupted = open("cornell-box.gltf", backend);
        // Stopped by its checkpoint once it has 4 samples or more.
        let stats = interrupted.render_to(16, &never(), |_, done| Ok(done >= 4)).unwrap();
        assert!(stats.spp >= 4 && stats.spp < 16, "{backend:?}: stopped at {}", stats.spp);
        assert_eq!(interrupted.spp(), stats.spp);
        let kept = interrupted.film().unwrap();
        assert!(kept.pixels.iter().all(|p| p.count == stats.spp), "{backend:?}: the samples are kept");
        // A stop flag set before the next pass leaves the film as it is.
        let stop = AtomicBool::new(true);
        let stats = interrupted.render_to(16, &stop, |_, _| Ok(false)).unwrap();
        assert!(stats.interrupted);
        assert_same(&interrupted.film().unwrap(), &kept, "after a stopped call");
        // Resumed, it ends where the uninterrupted session did.
        interrupted.render_to(16, &never(), |_, _| Ok(false)).unwrap();
        assert_same(&interrupted.film().unwrap(), &straight.film().unwrap(), &format!("{backend:?} resumed"));
    }
}

#[test]
fn two_sessions_in_one_process_do_not_interfere() {
    for backend in backends() {
        let solo = |scene: &str| {
            let mut s = open(scene, backend);
            s.render_to(8, &never(), |_, _| Ok(false)).unwrap();
            s.film().unwrap()
        };
        let (solo_a, solo_b) = (solo("cornell-box.gltf"), solo("glossy-metal.gltf"));
        // Both open at once (on the GPU, on one shared device), rendered in turns.
        let mut a = open("cornell-box.gltf", backend);
        let mut b = open("glossy-metal.gltf", backend);
        for spp in [2, 4, 8] {
            a.render_to(spp, &never(), |_, _| Ok(false)).unwrap();
            b.render_to(spp, &never(), |_, _| Ok(false)).unwrap();
        }
        assert_same(&a.film().unwrap(), &solo_a, &format!("{backend:?} cornell-box"));
        assert_same(&b.film().unwrap(), &solo_b, &format!("{backend:?} glossy-metal"));
    }
}

#[test]
fn row_bands_add_up_to_whole_passes() {
    for backend in backends() {
        let mut whole = open("cornell-box.gltf", backend);
        whole.render_to(3, &never(), |_, _| Ok(false)).unwrap();
        let mut banded = open("cornell-box.gltf", backend);
        for _ in 0..3 {
            // Uneven bands, the last one past the image's end.
            for rows in [0..5, 5..6, 6..20] {
                banded.render_rows(rows).unwrap();
            }
        }
        assert_eq!(banded.spp(), 3);
        assert_same(&banded.film().unwrap(), &whole.film().unwrap(), &format!("{backend:?} bands"));
        // Restarting forgets the samples.
        banded.restart().unwrap();
        assert_eq!(banded.spp(), 0);
        assert!(banded.film().unwrap().pixels.iter().all(|p| p.count == 0));
    }
}

#[test]
fn a_resized_session_renders_what_a_fresh_one_at_that_size_does() {
    // The viewer's window resize: the camera keeps its vertical field of view and follows
    // the new aspect ratio, as a session opened at that size frames it.
    let mut resized = open("cornell-box.gltf", BackendChoice::Cpu);
    resized.render_to(2, &never(), |_, _| Ok(false)).unwrap();
    resized.resize(30, 12).unwrap();
    assert_eq!(resized.spp(), 0, "a resize restarts");
    resized.render_to(2, &never(), |_, _| Ok(false)).unwrap();
    let fresh_options = SessionOptions {
        width: Some(30),
        height: Some(12),
        ..options("cornell-box.gltf", BackendChoice::Cpu)
    };
    let mut fresh = Session::open(&fresh_options).unwrap();
    fresh.render_to(2, &never(), |_, _| Ok(false)).unwrap();
    let (a, b) = (resized.film().unwrap(), fresh.film().unwrap());
    // The aspect ratio goes through f32 once more on the resized path: compare images, not bits.
    assert_eq!((a.width, a.height), (30, 12));
    let worst =
        a.mean().iter().zip(b.mean()).map(|(x, y)| (*x - y).abs().max_element()).fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "resized and fresh sessions differ by {worst}");
}

/// A backend that fails on its `fail_at`-th pass, as a GPU fault or timeout would.
struct FailingBackend {
    inner: pathlight::cpu::CpuBackend<'static>,
    passes: u32,
    fail_at: u32,
}

impl pathlight::Backend for FailingBackend {
    fn name(&self) -> String {
        "failing".into()
    }
    fn render(&mut self, sample_offset: u32, samples: u32) -> pathlight::Result<()> {
        self.passes += 1;
        if self.passes == self.fail_at {
            return Err(pathlight::Error::Gpu("simulated device loss".into()));
        }
        self.inner.render(sample_offset, samples)
    }
    fn film(&mut self) -> pathlight::Result<Film> {
        self.inner.film()
    }
    fn rays_traced(&mut self) -> pathlight::Result<u64> {
        self.inner.rays_traced()
    }
    fn aovs(&mut self) -> pathlight::Result<Vec<pathlight::scene::layout::PixelAov>> {
        self.inner.aovs()
    }
    fn render_rows(&mut self, sample_index: u32, rows: std::ops::Range<u32>) -> pathlight::Result<()> {
        self.inner.render_rows(sample_index, rows)
    }
    fn reset(&mut self) -> pathlight::Result<()> {
        self.inner.reset()
    }
    fn set_camera(&mut self, camera: &pathlight::scene::layout::Camera) -> pathlight::Result<()> {
        self.inner.set_camera(camera)
    }
}

#[test]
fn a_failed_pass_keeps_the_passes_before_it_and_they_can_be_written() {
    let reference = open("cornell-box.gltf", BackendChoice::Cpu);
    let flat = reference.flat.clone();
    let settings = reference.settings.clone();
    let inner = pathlight::cpu::CpuBackend::shared(flat.clone(), &settings);
    let backend = Box::new(FailingBackend { inner, passes: 0, fail_at: 3 });
    let mut session =
        Session::with_backend(reference.source.clone(), reference.scene.clone(), flat, settings, backend);
    let err = session.render_to(16, &never(), |_, _| Ok(false)).unwrap_err();
    assert!(err.to_string().contains("simulated device loss"), "{err}");
    let kept = session.spp();
    assert!(kept > 0 && kept < 16, "two passes completed before the failure, {kept} spp");
    let film = session.film().unwrap();
    assert!(film.pixels.iter().all(|p| p.count == kept));
    // What the command line does on such a failure: write what there is.
    let exr = std::env::temp_dir().join(format!("pathlight-failed-pass-{}.exr", std::process::id()));
    session.write(std::slice::from_ref(&exr), pathlight::film::Tonemap::Clamp, 0.0).unwrap();
    let image = pathlight::film::read_exr(&exr).unwrap();
    assert_eq!(image.attributes["pathlight.spp"], kept.to_string());
    let means = film.mean();
    assert!(image.channels["R"].iter().zip(&means).all(|(r, m)| *r == m.x));
    let _ = std::fs::remove_file(&exr);
}
