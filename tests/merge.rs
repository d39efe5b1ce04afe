//! Parts of one render (`--samples`, `--shard`) merged by `pathlight merge` (issue 48): the
//! merged film equals one render of all the samples up to the order of its sums, on the CPU
//! backend and on lavapipe; merging is associative; parts that do not belong together are
//! refused with messages naming the files; a merged image's variance is honest.

mod common;

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use pathlight::film::{merge_files, read_film_file, Film, Tonemap};
use pathlight::session::{BackendChoice, Session, SessionOptions};

fn out_dir(name: &str) -> PathBuf {
    let d = common::root().join("target").join("merge-tests").join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn options(
    scene: &str,
    backend: BackendChoice,
    seed: u32,
    samples: Option<std::ops::Range<u32>>,
) -> SessionOptions {
    SessionOptions {
        width: Some(24),
        height: Some(20),
        spp: 12,
        seed,
        backend,
        samples,
        ..SessionOptions::new(common::scene(scene))
    }
}

/// Renders `options` to `path` (an EXR), as `pathlight render` would.
fn render_to(options: &SessionOptions, path: &Path) {
    let gpu = match options.backend {
        BackendChoice::Gpu => Some(common::gpu().expect("checked by the caller")),
        _ => None,
    };
    let mut session = Session::open_with(options, gpu).unwrap();
    let end = options.samples.clone().map_or(options.spp, |r| r.end);
    session.render_to(end, &AtomicBool::new(false), |_, _| Ok(false)).unwrap();
    session.write(&[path.to_path_buf()], Tonemap::Clamp, 0.0).unwrap();
}

fn backends() -> Vec<BackendChoice> {
    let mut b = vec![BackendChoice::Cpu];
    if common::gpu().is_some() {
        b.push(BackendChoice::Gpu);
    }
    b
}

/// Equal sample counts and replicate counts, and means and M2 equal up to the order of the
/// sums. The film adds one sample at a time in f32 (each add rounds by at most half an ulp,
/// about 6·10⁻⁸ relative); the merge adds whole parts in f64. Over 12 samples the two orders
/// differ by at most a few dozen roundings of the values summed, well under 10⁻⁵ of the
/// largest of them; a sample counted twice or lost moves a mean by a twelfth of a sample.
fn assert_equal_up_to_summation_order(a: &Film, b: &Film, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    let scale = a.pixels.iter().flat_map(|p| p.mean).fold(0.0f32, f32::max).max(1e-3);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        assert_eq!(
            (p.count, p.odd_count, p.rejected),
            (q.count, q.odd_count, q.rejected),
            "{what}: pixel {i} counts"
        );
        for c in 0..3 {
            let tolerance = 1e-5 * scale.max(p.mean[c].abs());
            assert!(
                (p.mean[c] - q.mean[c]).abs() <= tolerance,
                "{what}: pixel {i} mean {} vs {}",
                p.mean[c],
                q.mean[c]
            );
            assert!((p.odd_mean[c] - q.odd_mean[c]).abs() <= tolerance, "{what}: pixel {i} replicate mean");
            let m2_tolerance = 1e-4 * (p.m2[c].abs() + scale * scale);
            assert!(
                (p.m2[c] - q.m2[c]).abs() <= m2_tolerance,
                "{what}: pixel {i} M2 {} vs {}",
                p.m2[c],
                q.m2[c]
            );
        }
    }
}

#[test]
fn shards_merged_equal_one_render_and_merging_is_associative() {
    // The Cornell box (Sobol, split samples) and a caustic the light tracer takes per sample
    // index (its pass must follow the sample indices of each shard).
    for scene in ["cornell-box.gltf", "hard/caustic-mirror.gltf"] {
        for backend in backends() {
            let dir = out_dir(&format!("{}-{backend:?}", scene.replace('/', "-")));
            let whole = dir.join("whole.exr");
            render_to(&options(scene, backend, 5, None), &whole);
            let parts: Vec<PathBuf> = [0..5, 5..6, 6..12]
                .into_iter()
                .enumerate()
                .map(|(i, range)| {
                    let p = dir.join(format!("part{i}.exr"));
                    render_to(&options(scene, backend, 5, Some(range)), &p);
                    p
                })
                .collect();
            let merged = dir.join("merged.exr");
            // Out of order on purpose: the merge sorts by sample range.
            let report =
                merge_files(&[parts[2].clone(), parts[0].clone(), parts[1].clone()], &merged).unwrap();
            assert_eq!((report.samples.clone(), report.parts), (0..12, 3));
            let what = format!("{scene} on {backend:?}");
            let whole_film = read_film_file(&whole).map(|f| f.film);
            // The whole render is not a part: it has no film state of its own.
            assert!(whole_film.is_err(), "{what}: a plain render must not pass for a part");
            let reference = pathlight::film::LinearImage::read(&whole).unwrap();
            let merged_file = read_film_file(&merged).unwrap();
            assert_eq!(merged_file.meta.samples, 0..12);
            assert_eq!(merged_file.meta.spp(), 12);
            assert_eq!(merged_file.meta.merged, vec![0..5, 5..6, 6..12], "{what}: the ranges merged");
            // The whole render through its session's film, compared pixel by pixel.
            let mut session = Session::open_with(
                &options(scene, backend, 5, None),
                (backend == BackendChoice::Gpu).then(|| common::gpu().unwrap()),
            )
            .unwrap();
            session.render_to(12, &AtomicBool::new(false), |_, _| Ok(false)).unwrap();
            let film = session.film().unwrap();
            assert_equal_up_to_summation_order(&film, &merged_file.film, &what);
            assert_eq!(reference.rgb.len(), film.pixels.len());

            // (a + b) + c against a + (b + c).
            let ab = dir.join("ab.exr");
            let bc = dir.join("bc.exr");
            merge_files(&[parts[0].clone(), parts[1].clone()], &ab).unwrap();
            merge_files(&[parts[1].clone(), parts[2].clone()], &bc).unwrap();
            let left = dir.join("ab-c.exr");
            let right = dir.join("a-bc.exr");
            merge_files(&[ab, parts[2].clone()], &left).unwrap();
            merge_files(&[parts[0].clone(), bc], &right).unwrap();
            let (l, r) = (read_film_file(&left).unwrap().film, read_film_file(&right).unwrap().film);
            assert_equal_up_to_summation_order(&l, &r, &format!("{what}, associativity"));
        }
    }
}

#[test]
fn merge_refuses_parts_of_different_renders_overlaps_and_gaps() {
    let dir = out_dir("refusals");
    let part = |name: &str, scene: &str, seed: u32, range: std::ops::Range<u32>| {
        let p = dir.join(name);
        render_to(&options(scene, BackendChoice::Cpu, seed, Some(range)), &p);
        p
    };
    let a = part("a.exr", "cornell-box.gltf", 1, 0..4);
    let b = part("b.exr", "cornell-box.gltf", 1, 4..8);
    let c = part("c.exr", "cornell-box.gltf", 1, 8..12);
    let other_seed = part("seed2.exr", "cornell-box.gltf", 2, 4..8);
    let other_scene = part("spheres.exr", "cornell-spheres.gltf", 1, 4..8);
    let overlapping = part("overlap.exr", "cornell-box.gltf", 1, 2..6);
    let out = dir.join("out.exr");
    // Left by an earlier run of this test: the refusals below must not write it.
    let _ = std::fs::remove_file(&out);
    let error = |inputs: &[&PathBuf]| {
        let inputs: Vec<PathBuf> = inputs.iter().map(|p| p.to_path_buf()).collect();
        merge_files(&inputs, &out).map(|_| ()).unwrap_err().to_string()
    };
    let e = error(&[&a, &other_seed]);
    assert!(e.contains("a.exr") && e.contains("seed2.exr") && e.contains("seed 1 against 2"), "{e}");
    let e = error(&[&a, &other_scene]);
    assert!(e.contains("spheres.exr") && e.contains("scene"), "{e}");
    let e = error(&[&a, &overlapping]);
    assert!(e.contains("overlap") && e.contains("0..4") && e.contains("2..6"), "{e}");
    let e = error(&[&a, &c]);
    assert!(e.contains("samples 4..8 are missing") && e.contains("a.exr") && e.contains("c.exr"), "{e}");
    // A render without its film's state is not a part.
    let plain = dir.join("plain.exr");
    render_to(&options("cornell-box.gltf", BackendChoice::Cpu, 1, None), &plain);
    let e = error(&[&a, &plain]);
    assert!(e.contains("plain.exr") && e.contains("film"), "{e}");
    assert!(!out.exists(), "a refused merge must not write its output");
    // The three parts that do belong together merge.
    merge_files(&[a, b, c], &out).unwrap();
    assert_eq!(read_film_file(&out).unwrap().meta.samples, 0..12);
}

/// A merged image's variance is the samples' own: `compare`'s z-test finds it the same image
/// as an unsplit render of another seed.
#[test]
fn a_merged_image_passes_the_z_test_against_another_seed() {
    let dir = out_dir("z-test");
    let parts: Vec<PathBuf> = [0..6, 6..12]
        .into_iter()
        .enumerate()
        .map(|(i, range)| {
            let p = dir.join(format!("part{i}.exr"));
            let o = SessionOptions {
                sampler: pathlight::sampling::SamplerKind::Independent,
                ..options("cornell-box.gltf", BackendChoice::Cpu, 3, Some(range))
            };
            render_to(&o, &p);
            p
        })
        .collect();
    let merged = dir.join("merged.exr");
    merge_files(&parts, &merged).unwrap();
    let other = dir.join("other-seed.exr");
    let o = SessionOptions {
        sampler: pathlight::sampling::SamplerKind::Independent,
        ..options("cornell-box.gltf", BackendChoice::Cpu, 4, None)
    };
    render_to(&o, &other);
    let test = pathlight::film::LinearImage::read(&merged).unwrap();
    let reference = pathlight::film::LinearImage::read(&other).unwrap();
    let report =
        pathlight::film::compare_images(&test, &reference, &pathlight::film::CompareOptions::default())
            .unwrap();
    assert!(report.same(), "{report}");
}
