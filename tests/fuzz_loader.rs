//! Mutation fuzzing of the scene loader (issue 11): the bundled scenes and the small Khronos
//! GLBs, mutated (bit flips, interesting bytes, truncation, chunk deletion and duplication,
//! JSON numbers replaced by extreme ones, GLB length fields rewritten), are loaded,
//! flattened and rendered at 4×4, 1 spp. No panic may escape, none may come from
//! pathlight's own code (the loader turns a third-party parser's panic into an error; the
//! panic hook below records where each panic came from), no case may take long, and every
//! pixel of a scene that loads is finite or counted as rejected.
//!
//! `PATHLIGHT_FUZZ_CASES` sets the number of cases per seed set (CI runs the default, 500 of
//! the bundled scenes and 500 of the Khronos GLBs; the long run recorded in
//! bench/history/robustness.md used 10⁶), `PATHLIGHT_FUZZ_SEED` the seed.

mod common;

use std::sync::Mutex;
use std::time::{Duration, Instant};

use pathlight::cpu::CpuBackend;
use pathlight::scene::{FlatScene, LoadOptions, ViewSettings};
use pathlight::{Backend, RenderSettings};

/// Where panics came from (file:line), recorded by the hook.
static PANICS: Mutex<Vec<String>> = Mutex::new(Vec::new());

/// xorshift64*: a small deterministic generator for mutations.
struct Mutator(u64);

impl Mutator {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const INTERESTING_BYTES: &[u8] = b"\x00\xff\x7f\x80 -.0123456789e\"{}[]:,\\";
const EXTREME_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "-0",
    "1e309",
    "-1e309",
    "1e-45",
    "4294967295",
    "4294967296",
    "2147483648",
    "9e18",
    "1e38",
    "0.5",
    "65535",
    "3",
];

fn mutate(seed: &[u8], m: &mut Mutator) -> Vec<u8> {
    let mut b = seed.to_vec();
    let rounds = 1 + m.below(4);
    for _ in 0..rounds {
        if b.is_empty() {
            break;
        }
        match m.below(7) {
            0 => {
                let i = m.below(b.len());
                b[i] ^= 1 << m.below(8);
            }
            1 => {
                let i = m.below(b.len());
                b[i] = INTERESTING_BYTES[m.below(INTERESTING_BYTES.len())];
            }
            2 => {
                let n = m.below(b.len());
                b.truncate(n);
            }
            3 => {
                let start = m.below(b.len());
                let len = m.below((b.len() - start).min(64)) + 1;
                b.drain(start..(start + len).min(b.len()));
            }
            4 => {
                let start = m.below(b.len());
                let len = m.below((b.len() - start).min(64)) + 1;
                let chunk = b[start..(start + len).min(b.len())].to_vec();
                let at = m.below(b.len());
                b.splice(at..at, chunk);
            }
            5 => {
                // Replace a number in the JSON with an extreme one.
                let digits: Vec<usize> = (0..b.len()).filter(|&i| b[i].is_ascii_digit()).collect();
                if digits.is_empty() {
                    continue;
                }
                let start = digits[m.below(digits.len())];
                let mut end = start;
                while end < b.len() && (b[end].is_ascii_digit() || b".eE+-".contains(&b[end])) {
                    end += 1;
                }
                let with = EXTREME_NUMBERS[m.below(EXTREME_NUMBERS.len())].as_bytes();
                b.splice(start..end, with.iter().copied());
            }
            _ => {
                // A GLB's total or chunk length, rewritten.
                if b.starts_with(b"glTF") && b.len() >= 20 {
                    let field = [8usize, 12, 16][m.below(3)];
                    let v = [0u32, 1, 0x7fff_ffff, 0xffff_ffff, b.len() as u32 + 4][m.below(5)];
                    b[field..field + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
        }
    }
    b
}

/// The bundled scenes, the first seeds.
fn bundled_seeds() -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let files: Vec<std::path::PathBuf> = std::fs::read_dir(common::root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gltf"))
        .collect();
    read_seeds(files)
}

/// The Khronos GLBs under 100 KB (larger ones spend the budget building BVHs, not parsing):
/// binary chunks, textures and extensions the bundled scenes lack.
fn khronos_seeds() -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    for dir in std::fs::read_dir(common::assets().join("khronos")).unwrap() {
        for f in std::fs::read_dir(dir.unwrap().path()).unwrap() {
            let p = f.unwrap().path();
            if p.extension().is_some_and(|e| e == "glb") && std::fs::metadata(&p).unwrap().len() < 100_000 {
                files.push(p);
            }
        }
    }
    read_seeds(files)
}

fn read_seeds(mut files: Vec<std::path::PathBuf>) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    files.sort();
    files.into_iter().map(|p| (p.clone(), std::fs::read(&p).unwrap())).collect()
}

/// One case: load, flatten, render 4×4 at 1 spp. `Err` describes a failure.
fn run_case(bytes: &[u8], file: &std::path::Path) -> Result<(), String> {
    let Ok((scene, _)) = pathlight::scene::load_from_bytes(bytes, file, &LoadOptions::default()) else {
        return Ok(()); // A clear error is a correct answer to a broken file.
    };
    let Ok(flat) = FlatScene::build(&scene, &ViewSettings { camera: None, aspect: 1.0 }) else {
        return Ok(());
    };
    let settings =
        RenderSettings { width: 4, height: 4, spp: 1, max_depth: Some(4), ..RenderSettings::default() };
    let mut backend = CpuBackend::new(&flat, &settings);
    backend.render(0, 1).map_err(|e| e.to_string())?;
    let film = backend.film().map_err(|e| e.to_string())?;
    if film.mean().iter().any(|m| !m.is_finite()) {
        return Err("a pixel's mean is not finite".into());
    }
    Ok(())
}

#[test]
fn mutated_bundled_scenes_never_panic_hang_or_render_non_finite() {
    fuzz(&bundled_seeds());
}

#[test]
#[cfg_attr(
    not(feature = "shared-assets"),
    ignore = "needs ../shared/assets: cargo test --features shared-assets"
)]
fn mutated_khronos_models_never_panic_hang_or_render_non_finite() {
    fuzz(&khronos_seeds());
}

/// The fuzz runs one at a time: each installs the process's panic hook for its duration.
static FUZZ_LOCK: Mutex<()> = Mutex::new(());

/// `PATHLIGHT_FUZZ_CASES` mutations (500 by default) of `seeds`, in turn, from
/// `PATHLIGHT_FUZZ_SEED`.
fn fuzz(seeds: &[(std::path::PathBuf, Vec<u8>)]) {
    let _one_at_a_time = FUZZ_LOCK.lock().unwrap_or_else(|p| p.into_inner());
    let cases: usize = std::env::var("PATHLIGHT_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(500);
    let seed: u64 = std::env::var("PATHLIGHT_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0x5eed);
    std::panic::set_hook(Box::new(|info| {
        let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
        PANICS.lock().unwrap_or_else(|p| p.into_inner()).push(at);
    }));
    let mut m = Mutator(seed | 1);
    let (mut loaded, mut slowest) = (0usize, Duration::ZERO);
    let mut failures = Vec::new();
    let start = Instant::now();
    for case in 0..cases {
        let (file, original) = &seeds[case % seeds.len()];
        let bytes = mutate(original, &mut m);
        let t = Instant::now();
        let outcome = std::panic::catch_unwind(|| run_case(&bytes, file));
        let took = t.elapsed();
        slowest = slowest.max(took);
        match outcome {
            Ok(Ok(())) => {}
            Ok(Err(e)) => failures.push(format!("case {case} ({}): {e}", file.display())),
            Err(_) => failures.push(format!("case {case} ({}): a panic escaped", file.display())),
        }
        if took > Duration::from_secs(10) {
            failures.push(format!("case {case} ({}): took {took:?}", file.display()));
        }
        if pathlight::scene::load_from_bytes(&bytes, file, &LoadOptions::default()).is_ok() {
            loaded += 1;
        }
        if failures.len() > 20 {
            break;
        }
    }
    let _ = std::panic::take_hook();
    let panics = std::mem::take(&mut *PANICS.lock().unwrap_or_else(|p| p.into_inner()));
    let ours: Vec<&String> =
        panics.iter().filter(|at| !at.contains(".cargo") && !at.contains("/rustc/")).collect();
    eprintln!(
        "fuzz: {cases} cases from {} seeds in {:.1} s; {loaded} loaded; slowest {slowest:?}; {} panics caught inside third-party parsers, {} in pathlight",
        seeds.len(),
        start.elapsed().as_secs_f64(),
        panics.len() - ours.len(),
        ours.len()
    );
    let mut theirs: Vec<&String> = panics.iter().filter(|at| !ours.contains(at)).collect();
    theirs.sort();
    theirs.dedup();
    if !theirs.is_empty() {
        eprintln!("fuzz: third-party panic sites (each caught and reported as a load error): {theirs:?}");
    }
    assert!(ours.is_empty(), "panics in pathlight's code at {:?}", &ours[..ours.len().min(10)]);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
