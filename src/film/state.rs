//! A film's whole per-pixel state in an EXR, so that images of parts of one render (shards:
//! `render --samples A..B`, `--shard I/N`) can be read back and merged exactly
//! (`super::merge`).
//!
//! Besides the mean (`R`, `G`, `B`) and its variance, such a file holds each pixel's
//! accumulator as the renderer kept it ([`FilmPixel`]): `film.count`, `film.rejected` and
//! `film.oddCount` as 32-bit integers, `film.m2.R/G/B` (Σ (x − mean)²) and
//! `film.oddMean.R/G/B` (the mean of replicate 1, the odd sample indices) as f32. The
//! variance channels alone would not do: they are M2 / ((n − 1) n) rounded to f32, from
//! which M2 comes back only approximately, and they say nothing of the replicates that the
//! predicted error is measured from.

use std::path::{Path, PathBuf};

use exr::prelude::*;

use super::{Film, RenderMetadata};
use crate::error::{Error, Result};
use crate::integrator::Integrator;
use crate::sampling::SamplerKind;
use crate::scene::layout::FilmPixel;

/// The state channels of `film`, beside the mean and variance [`super::write_exr`] writes.
pub(super) fn state_channels(film: &Film) -> Vec<AnyChannel<FlatSamples>> {
    let f32s = |name: &str, f: &dyn Fn(&FilmPixel) -> f32| {
        AnyChannel::new(name, FlatSamples::F32(film.pixels.iter().map(f).collect()))
    };
    let u32s = |name: &str, f: &dyn Fn(&FilmPixel) -> u32| {
        AnyChannel::new(name, FlatSamples::U32(film.pixels.iter().map(f).collect()))
    };
    vec![
        u32s("film.count", &|p| p.count),
        u32s("film.rejected", &|p| p.rejected),
        u32s("film.oddCount", &|p| p.odd_count),
        f32s("film.m2.R", &|p| p.m2[0]),
        f32s("film.m2.G", &|p| p.m2[1]),
        f32s("film.m2.B", &|p| p.m2[2]),
        f32s("film.oddMean.R", &|p| p.odd_mean[0]),
        f32s("film.oddMean.G", &|p| p.odd_mean[1]),
        f32s("film.oddMean.B", &|p| p.odd_mean[2]),
    ]
}

/// An image with its film's state, read back.
#[derive(Clone, Debug)]
pub struct FilmFile {
    pub path: PathBuf,
    pub film: Film,
    pub meta: RenderMetadata,
}

/// The header of a part: its size and how it was rendered, read without its pixels.
#[derive(Clone, Debug)]
pub struct FilmHeader {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    pub meta: RenderMetadata,
}

/// Reads the header of an EXR that [`super::write_exr`] wrote with `film_state` (a shard, or
/// a merge), with a message naming the file and what is missing or malformed.
pub fn read_film_header(path: &Path) -> Result<FilmHeader> {
    let bad = |message: String| Error::image(path, message);
    let meta_data = std::panic::catch_unwind(|| exr::meta::MetaData::read_from_file(path, false))
        .map_err(|_| bad("the EXR decoder failed on malformed data".into()))?
        .map_err(|e| bad(format!("cannot read EXR: {e}")))?;
    let header = meta_data.headers.first().ok_or_else(|| bad("the EXR has no layer".into()))?;
    if !header.channels.list.iter().any(|c| c.name.to_string() == "film.count") {
        return Err(bad(
            "no channel film.count: not a pathlight image with its film's state (render the parts \
             with --shard or --samples, or merge files that `pathlight merge` wrote)"
                .into(),
        ));
    }
    let attribute = |key: &str| -> Result<String> {
        let key_text = Text::from(key);
        let value = header
            .own_attributes
            .other
            .get(&key_text)
            .or_else(|| header.shared_attributes.other.get(&key_text));
        value.map(super::exr_io::attribute_text).ok_or_else(|| bad(format!("no header attribute {key}")))
    };
    let meta = parse_metadata(path, &attribute)?;
    let size = header.layer_size;
    Ok(FilmHeader {
        path: path.to_path_buf(),
        width: size.width() as u32,
        height: size.height() as u32,
        meta,
    })
}

/// Reads a part whole: its header ([`read_film_header`]) and its film.
pub fn read_film_file(path: &Path) -> Result<FilmFile> {
    let header = read_film_header(path)?;
    let film = read_film(&header)?;
    Ok(FilmFile { path: header.path, film, meta: header.meta })
}

/// The film of the part `header` describes.
pub fn read_film(header: &FilmHeader) -> Result<Film> {
    let path = header.path.as_path();
    let bad = |message: String| Error::image(path, message);
    let image = std::panic::catch_unwind(|| super::exr_io::read_first_layer(path))
        .map_err(|_| bad("the EXR decoder failed on malformed data".into()))?
        .map_err(|e| bad(format!("cannot read EXR: {e}")))?;
    let (width, height) = (image.layer_data.size.width(), image.layer_data.size.height());
    // The channels are moved out of the decoded image, not copied: a 4K part's are 300 MB.
    let mut channels: std::collections::HashMap<String, FlatSamples> =
        image.layer_data.channel_data.list.into_iter().map(|c| (c.name.to_string(), c.sample_data)).collect();
    let missing = |name: &str| bad(format!("no channel {name}: not a pathlight image with its film's state"));
    let mut floats = |name: &str| -> Result<Vec<f32>> {
        match channels.remove(name) {
            Some(FlatSamples::F32(v)) => Ok(v),
            Some(_) => Err(bad(format!("channel {name} is not 32-bit float"))),
            None => Err(missing(name)),
        }
    };
    let mean = [floats("R")?, floats("G")?, floats("B")?];
    let m2 = [floats("film.m2.R")?, floats("film.m2.G")?, floats("film.m2.B")?];
    let odd = [floats("film.oddMean.R")?, floats("film.oddMean.G")?, floats("film.oddMean.B")?];
    let mut integers = |name: &str| -> Result<Vec<u32>> {
        match channels.remove(name) {
            Some(FlatSamples::U32(v)) => Ok(v),
            Some(_) => Err(bad(format!("channel {name} is not 32-bit unsigned"))),
            None => Err(missing(name)),
        }
    };
    let (count, rejected, odd_count) =
        (integers("film.count")?, integers("film.rejected")?, integers("film.oddCount")?);
    // What is left (the variance channels) is not needed: the film derives it.
    drop(channels);
    let pixels = (0..width * height)
        .map(|i| FilmPixel {
            mean: [mean[0][i], mean[1][i], mean[2][i]],
            count: count[i],
            m2: [m2[0][i], m2[1][i], m2[2][i]],
            rejected: rejected[i],
            odd_mean: [odd[0][i], odd[1][i], odd[2][i]],
            odd_count: odd_count[i],
        })
        .collect();
    Ok(Film { width: width as u32, height: height as u32, pixels })
}

/// The metadata of a part from its header attributes (`attribute` reads one as text).
fn parse_metadata(path: &Path, attribute: &dyn Fn(&str) -> Result<String>) -> Result<RenderMetadata> {
    let bad = |message: String| Error::image(path, message);
    fn number<T: std::str::FromStr>(path: &Path, key: &str, text: &str) -> Result<T> {
        text.parse()
            .map_err(|_| Error::image(path, format!("header attribute {key} is not a number: '{text}'")))
    }
    // `A..B`, as `write_exr` writes a range.
    let range = |text: &str| {
        text.split_once("..")
            .and_then(|(a, b)| Some(a.parse::<u32>().ok()?..b.parse::<u32>().ok()?))
            .filter(|r| r.start <= r.end)
    };
    let samples_text = attribute("pathlight.samples")?;
    let samples = range(&samples_text).ok_or_else(|| {
        bad(format!("header attribute pathlight.samples is not a range A..B: '{samples_text}'"))
    })?;
    // A merge lists the ranges of its parts; a part is its own one range.
    let merged = match attribute("pathlight.mergedRanges") {
        Ok(list) => list.split(',').map(range).collect::<Option<Vec<_>>>().ok_or_else(|| {
            bad(format!("header attribute pathlight.mergedRanges is not a list of ranges: '{list}'"))
        })?,
        Err(_) => vec![samples.clone()],
    };
    let max_depth = match attribute("pathlight.maxDepth")?.as_str() {
        "unlimited" => None,
        d => Some(number(path, "pathlight.maxDepth", d)?),
    };
    let sampler_name = attribute("pathlight.sampler")?;
    let sampler = SamplerKind::from_name(&sampler_name)
        .ok_or_else(|| bad(format!("unknown sampler '{sampler_name}' in pathlight.sampler")))?;
    let integrator = Integrator::from_name(&attribute("pathlight.integrator")?)
        .map_err(|e| bad(format!("pathlight.integrator: {e}")))?;
    let digest_text = attribute("pathlight.sceneDigest")?;
    let scene_digest = u64::from_str_radix(&digest_text, 16).map_err(|_| {
        bad(format!("header attribute pathlight.sceneDigest is not hexadecimal: '{digest_text}'"))
    })?;
    Ok(RenderMetadata {
        scene: attribute("pathlight.scene")?,
        backend: attribute("pathlight.backend")?,
        seed: number(path, "pathlight.seed", &attribute("pathlight.seed")?)?,
        integrator,
        max_depth,
        sampler,
        splits: number(path, "pathlight.splits", &attribute("pathlight.splits")?)?,
        render_seconds: number(path, "pathlight.renderSeconds", &attribute("pathlight.renderSeconds")?)?,
        rejected_samples: number(
            path,
            "pathlight.rejectedSamples",
            &attribute("pathlight.rejectedSamples")?,
        )?,
        samples,
        total_spp: number(path, "pathlight.totalSpp", &attribute("pathlight.totalSpp")?)?,
        light_tracing: attribute("pathlight.lightTracing")? == "on",
        rays: number(path, "pathlight.rays", &attribute("pathlight.rays")?)?,
        scene_digest: Some(scene_digest),
        merged,
        film_state: true,
        adaptive: None,
        // Parts of one render share its cache (its records depend on the seed and the
        // camera, not on the samples), so a merge keeps what the parts say of it.
        irradiance_cache: attribute("pathlight.irradianceCache").ok(),
        mlt: attribute("pathlight.mlt").ok(),
    })
}
