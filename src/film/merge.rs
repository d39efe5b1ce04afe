//! Exact merges of images of one render's parts (`pathlight merge`): per pixel the sample
//! counts add, and means, M2 and the replicate means combine by the parallel form of
//! Welford's update (Chan, Golub & LeVeque 1979, "Updating formulae and a pairwise algorithm
//! for computing sample variances"):
//!
//! n = n_a + n_b, δ = x̄_b − x̄_a, x̄ = x̄_a + δ·n_b/n, M2 = M2_a + M2_b + δ²·n_a·n_b/n,
//!
//! evaluated in f64 and stored in f32, as the film keeps them. The result is the film one
//! render of all the samples would hold, up to the order of the sums (the film adds one
//! sample at a time in f32, the merge adds whole parts). The parts must be of one render:
//! the same scene (by `crate::session::scene_digest`), size, seed, integrator, sampler,
//! splitting, depth and light tracing, with sample ranges that neither overlap nor leave a
//! gap between them.

use std::ops::Range;
use std::path::{Path, PathBuf};

use super::state::{read_film, read_film_header, FilmHeader};
use super::{write_exr, Film, RenderMetadata};
use crate::error::{Error, Result};
use crate::scene::layout::FilmPixel;

/// What a merge produced.
#[derive(Clone, Debug)]
pub struct MergeReport {
    /// The sample indices of the merged image.
    pub samples: Range<u32>,
    /// The samples per pixel of the whole render (`--spp`); samples outside `samples` are
    /// not in the image.
    pub total_spp: u32,
    pub parts: usize,
    /// The merged image's predicted relMSE, when it has one.
    pub predicted_relmse: Option<f64>,
}

/// Merges the images `inputs` (each written with its film's state: a shard or a merge) into
/// `output` (an EXR, written atomically, itself mergeable).
pub fn merge_files(inputs: &[PathBuf], output: &Path) -> Result<MergeReport> {
    if inputs.is_empty() {
        return Err(Error::Settings("merge: no input images".into()));
    }
    if !output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        return Err(Error::Settings(format!("{}: the merged image must be an .exr", output.display())));
    }
    super::check_writable(output)?;
    // Every header first, so that a part that does not belong is refused before any pixel
    // is read; then the films one at a time, so that memory holds two films, not all.
    let parts = inputs.iter().map(|p| read_film_header(p)).collect::<Result<Vec<_>>>()?;
    let count = parts.len();
    let (film, meta) = merge_parts(parts, read_film)?;
    let predicted_relmse = film.predicted_relmse();
    write_exr(&film, &meta, output)?;
    Ok(MergeReport {
        samples: meta.samples.clone(),
        total_spp: meta.total_spp,
        parts: count,
        predicted_relmse,
    })
}

/// Merges the parts `parts` describe (any order), each film read by `load` when its turn
/// comes, into one film and the metadata of its EXR, or says which file does not belong and
/// why.
pub fn merge_parts(
    mut parts: Vec<FilmHeader>,
    mut load: impl FnMut(&FilmHeader) -> Result<Film>,
) -> Result<(Film, RenderMetadata)> {
    let Some(first) = parts.first() else {
        return Err(Error::Settings("merge: no input images".into()));
    };
    for part in &parts[1..] {
        check_same_render(first, part)?;
    }
    // In sample order, so that overlaps and gaps are between neighbours.
    parts.sort_by_key(|p| (p.meta.samples.start, p.meta.samples.end));
    let describe = |p: &FilmHeader| {
        format!("{} (samples {}..{})", p.path.display(), p.meta.samples.start, p.meta.samples.end)
    };
    for pair in parts.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let (ra, rb) = (&a.meta.samples, &b.meta.samples);
        if rb.start < ra.end {
            return Err(Error::Settings(format!(
                "{} and {} overlap: a sample would be counted twice",
                describe(a),
                describe(b)
            )));
        }
        if rb.start > ra.end {
            return Err(Error::Settings(format!(
                "samples {}..{} are missing between {} and {}",
                ra.end,
                rb.start,
                describe(a),
                describe(b)
            )));
        }
    }
    let mut iter = parts.into_iter();
    let first = iter.next().expect("checked non-empty");
    let mut film = load(&first)?;
    let mut meta = first.meta;
    let mut backends = vec![meta.backend.clone()];
    for part in iter {
        let part_film = load(&part)?;
        if (part_film.width, part_film.height) != (film.width, film.height) {
            return Err(Error::image(&part.path, "its pixels do not have the size its header gives"));
        }
        for (p, q) in film.pixels.iter_mut().zip(&part_film.pixels) {
            *p = merge_pixels(p, q);
        }
        meta.samples.end = part.meta.samples.end;
        meta.render_seconds += part.meta.render_seconds;
        meta.rejected_samples += part.meta.rejected_samples;
        meta.rays += part.meta.rays;
        meta.merged.extend(part.meta.merged.iter().cloned());
        if !backends.contains(&part.meta.backend) {
            backends.push(part.meta.backend.clone());
        }
    }
    meta.backend = backends.join(" + ");
    meta.film_state = true;
    Ok((film, meta))
}

/// Refuses `b` as a part of `a`'s render, naming the setting that differs.
fn check_same_render(a: &FilmHeader, b: &FilmHeader) -> Result<()> {
    let (m, n) = (&a.meta, &b.meta);
    let differ = |what: &str, x: String, y: String| -> Result<()> {
        if x == y {
            return Ok(());
        }
        Err(Error::Settings(format!(
            "{} and {} are not parts of one render: {what} {x} against {y}",
            a.path.display(),
            b.path.display()
        )))
    };
    differ("image size", format!("{}×{}", a.width, a.height), format!("{}×{}", b.width, b.height))?;
    // The digest decides: one scene file may sit at different paths on different machines.
    if m.scene_digest != n.scene_digest {
        differ(
            "scene",
            format!("{} ({:016x})", m.scene, m.scene_digest.unwrap_or_default()),
            format!("{} ({:016x})", n.scene, n.scene_digest.unwrap_or_default()),
        )?;
    }
    differ("seed", m.seed.to_string(), n.seed.to_string())?;
    differ("integrator", m.integrator.to_string(), n.integrator.to_string())?;
    differ("sampler", m.sampler.name().into(), n.sampler.name().into())?;
    differ("splits", m.splits.to_string(), n.splits.to_string())?;
    differ("max depth", format!("{:?}", m.max_depth), format!("{:?}", n.max_depth))?;
    differ("spp of the whole render", m.total_spp.to_string(), n.total_spp.to_string())?;
    differ("light tracing", m.light_tracing.to_string(), n.light_tracing.to_string())
}

/// The accumulator of `a`'s samples and `b`'s together (the module's formulas).
pub fn merge_pixels(a: &FilmPixel, b: &FilmPixel) -> FilmPixel {
    let (na, nb) = (a.count as f64, b.count as f64);
    let m2 = std::array::from_fn(|c| {
        let delta = b.mean[c] as f64 - a.mean[c] as f64;
        // With no sample on either side the cross term is 0 · δ² / 0: there is nothing to add.
        let cross = if a.count > 0 && b.count > 0 { delta * delta * na * nb / (na + nb) } else { 0.0 };
        (a.m2[c] as f64 + b.m2[c] as f64 + cross) as f32
    });
    FilmPixel {
        mean: merged_mean(a.count, a.mean, b.count, b.mean),
        count: a.count + b.count,
        m2,
        rejected: a.rejected + b.rejected,
        odd_mean: merged_mean(a.odd_count, a.odd_mean, b.odd_count, b.odd_mean),
        odd_count: a.odd_count + b.odd_count,
    }
}

/// The mean of `na` samples of mean `a` and `nb` of mean `b`, x̄_a + (x̄_b − x̄_a)·n_b/n; a side
/// with no samples leaves the other's mean exactly as it was.
fn merged_mean(na: u32, a: [f32; 3], nb: u32, b: [f32; 3]) -> [f32; 3] {
    match (na, nb) {
        (_, 0) => a,
        (0, _) => b,
        _ => {
            let share = nb as f64 / (na as f64 + nb as f64);
            std::array::from_fn(|c| (a[c] as f64 + (b[c] as f64 - a[c] as f64) * share) as f32)
        }
    }
}
