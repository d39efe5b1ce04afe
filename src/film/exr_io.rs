//! OpenEXR output: linear radiance with its own error bars.
//!
//! Channels `R`, `G`, `B` hold the per-pixel mean and `variance.R`, `variance.G`,
//! `variance.B` the estimated variance of that mean (sample variance / n), all f32. Header
//! attributes record how the image was made (`pathlight.*`) and, as
//! `pathlight.predictedRelMSE`, the relMSE the image's own error predicts
//! ([`Film::predicted_relmse`]). Under QMC that figure comes from the sampler's two
//! independent replicates, which the variance channels cannot hold: their sample variance
//! over-states the error (2× for a 4,096-spp Cornell box, `bench/history/sampling.md`), so a file read
//! back without the attribute can only give an upper bound.
//!
//! With `--aov` the AOV channels follow ([`super::aov`]); with `--denoise`, `R`, `G`, `B`
//! hold the denoised image and the raw mean moves to `raw.R`, `raw.G`, `raw.B`
//! (`pathlight.denoiser` names the denoiser). The variance channels and the predicted relMSE
//! always describe the raw mean: a denoised image's error, bias included, can only be
//! measured against a reference.

use std::collections::HashMap;
use std::path::Path;

use exr::prelude::*;

use super::{write_atomically, Film};
use crate::error::{Error, Result};

/// The header attribute holding the image's predicted relMSE (module documentation).
pub const PREDICTED_RELMSE_ATTRIBUTE: &str = "pathlight.predictedRelMSE";

/// How an image was rendered, stored in its EXR header.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderMetadata {
    pub scene: String,
    pub backend: String,
    pub seed: u32,
    /// The estimator that rendered the image (`--integrator`).
    pub integrator: crate::integrator::Integrator,
    /// `None`: unlimited (Russian roulette ends paths).
    pub max_depth: Option<u32>,
    /// The sampler: under `sobol` the variance channels over-state the error of the mean
    /// (see `sampling::sobol`), a conservative z-test.
    pub sampler: crate::sampling::SamplerKind,
    /// Continuations per camera sample (`RenderSettings::splits`): `spp` counts camera
    /// samples.
    pub splits: u32,
    pub render_seconds: f64,
    /// Non-finite samples dropped.
    pub rejected_samples: u64,
    /// The sample indices in the image (`0..spp` unless it is a shard or a merge of some);
    /// their count is the image's samples per pixel ([`RenderMetadata::spp`]).
    pub samples: std::ops::Range<u32>,
    /// The samples per pixel of the whole render these samples belong to (`--spp`).
    pub total_spp: u32,
    /// Was light tracing of the caustics asked for (`RenderSettings::light_tracing`)?
    pub light_tracing: bool,
    /// Rays traced (camera, bounce and shadow rays).
    pub rays: u64,
    /// `crate::session::scene_digest` of the scene rendered: written for the parts of a
    /// render, which `merge` compares; `None` otherwise.
    pub scene_digest: Option<u64>,
    /// The parts' sample ranges a merged image was made of (empty unless merged).
    pub merged: Vec<std::ops::Range<u32>>,
    /// Write the film's whole per-pixel state too (`super::state`), so that the image can be
    /// merged with others of the same render (shards and merges).
    pub film_state: bool,
    /// Adaptive sampling's settings, as `pathlight.adaptive` says them; the EXR then holds
    /// each pixel's sample count in channel `sampleCount`. `None`: every pixel has `spp()`.
    pub adaptive: Option<String>,
    /// The irradiance cache's settings and records, as `pathlight.irradianceCache` says
    /// them; the variance channels then measure the samples' noise given the cache.
    /// `None`: none.
    pub irradiance_cache: Option<String>,
    /// Metropolis's settings and acceptance rate, as `pathlight.mlt` says them; `None`:
    /// another integrator.
    pub mlt: Option<String>,
}

impl RenderMetadata {
    /// Samples per pixel completed: the length of [`RenderMetadata::samples`].
    pub fn spp(&self) -> u32 {
        self.samples.end.saturating_sub(self.samples.start)
    }
}

/// Writes a plain linear RGB image (channels `R`, `G`, `B`, f32, no variance): for images
/// that are not a film's mean, such as a comparison's z-scores or one BDPT strategy's
/// contribution.
pub fn write_rgb_exr(width: usize, height: usize, rgb: &[glam::Vec3], path: &Path) -> Result<()> {
    if rgb.len() != width * height {
        return Err(Error::output(path, format!("{} pixels for a {width}×{height} image", rgb.len())));
    }
    let plane = |c: usize| FlatSamples::F32(rgb.iter().map(|v| v[c]).collect());
    let channels = AnyChannels::sort(SmallVec::from_vec(vec![
        AnyChannel::new("R", plane(0)),
        AnyChannel::new("G", plane(1)),
        AnyChannel::new("B", plane(2)),
    ]));
    let layer = Layer::new((width, height), LayerAttributes::default(), Encoding::FAST_LOSSLESS, channels);
    write_atomically(path, |tmp| {
        Image::from_layer(layer)
            .write()
            .to_file(tmp)
            .map_err(|e| Error::output(path, format!("cannot write EXR: {e}")))
    })
}

/// What an EXR holds beside the film's mean and variance ([`write_exr_with`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct ExrExtras<'a> {
    /// AOVs, and which of them to write ([`super::aov`] names their channels).
    pub aovs: Option<(&'a super::Aovs, super::AovSelection)>,
    /// A denoised image and the denoiser that made it: it becomes `R`, `G`, `B` (what a
    /// viewer opens), and the film's raw mean moves to `raw.R`, `raw.G`, `raw.B`, beside
    /// `variance.*`, which still describe that raw mean.
    pub denoised: Option<(&'a [glam::Vec3], crate::denoise::Denoiser)>,
}

pub fn write_exr(film: &Film, meta: &RenderMetadata, path: &Path) -> Result<()> {
    write_exr_with(film, meta, &ExrExtras::default(), path)
}

/// [`write_exr`] with AOVs and a denoised image.
pub fn write_exr_with(film: &Film, meta: &RenderMetadata, extras: &ExrExtras, path: &Path) -> Result<()> {
    let size = (film.width as usize, film.height as usize);
    let mean = film.mean();
    let var = film.variance_of_mean();
    let channel = |name: &str, data: Vec<f32>| AnyChannel::new(name, FlatSamples::F32(data));
    let rgb = |prefix: &str, plane: &[glam::Vec3]| {
        ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(c, n)| channel(&format!("{prefix}{n}"), plane.iter().map(|v| v[c]).collect()))
            .collect::<Vec<_>>()
    };
    let mut list = Vec::new();
    match extras.denoised {
        Some((denoised, _)) => {
            if denoised.len() != mean.len() {
                return Err(Error::output(
                    path,
                    format!("a denoised image of {} pixels for {}", denoised.len(), mean.len()),
                ));
            }
            list.extend(rgb("", denoised));
            list.extend(rgb("raw.", &mean));
        }
        None => list.extend(rgb("", &mean)),
    }
    list.extend(rgb("variance.", &var));
    if let Some((aovs, selection)) = extras.aovs {
        list.extend(super::aov::aov_channels(aovs, selection).into_iter().map(|(n, d)| channel(&n, d)));
    }
    if meta.film_state {
        list.extend(super::state::state_channels(film));
    }
    if meta.adaptive.is_some() {
        list.push(AnyChannel::new(
            "sampleCount",
            FlatSamples::F32(film.pixels.iter().map(|p| p.count as f32).collect()),
        ));
    }
    let channels = AnyChannels::sort(SmallVec::from_vec(list));
    let mut attributes = LayerAttributes {
        software_name: Some(Text::from(concat!("pathlight ", env!("CARGO_PKG_VERSION")))),
        ..LayerAttributes::default()
    };
    let mut put = |k: &str, v: AttributeValue| {
        attributes.other.insert(Text::from(k), v);
    };
    put("pathlight.spp", AttributeValue::I32(meta.spp() as i32));
    put("pathlight.seed", AttributeValue::Text(Text::from(meta.seed.to_string().as_str())));
    put("pathlight.integrator", AttributeValue::Text(Text::from(meta.integrator.name())));
    let variance_meaning = if meta.irradiance_cache.is_some() {
        crate::integrator::irradiance_cache::VARIANCE_MEANING
    } else {
        meta.integrator.variance_meaning()
    };
    put("pathlight.variance", AttributeValue::Text(Text::from(variance_meaning)));
    put("pathlight.backend", AttributeValue::Text(Text::from(meta.backend.as_str())));
    put("pathlight.renderSeconds", AttributeValue::F64(meta.render_seconds));
    put(
        "pathlight.rejectedSamples",
        AttributeValue::Text(Text::from(meta.rejected_samples.to_string().as_str())),
    );
    put(
        "pathlight.maxDepth",
        AttributeValue::Text(Text::from(
            meta.max_depth.map(|d| d.to_string()).unwrap_or_else(|| "unlimited".into()).as_str(),
        )),
    );
    put("pathlight.sampler", AttributeValue::Text(Text::from(meta.sampler.name())));
    put("pathlight.splits", AttributeValue::Text(Text::from(meta.splits.to_string().as_str())));
    put("pathlight.scene", AttributeValue::Text(Text::from(meta.scene.as_str())));
    let text = |v: String| AttributeValue::Text(Text::from(v.as_str()));
    put("pathlight.samples", text(format!("{}..{}", meta.samples.start, meta.samples.end)));
    put("pathlight.totalSpp", text(meta.total_spp.to_string()));
    put("pathlight.lightTracing", text(if meta.light_tracing { "on" } else { "off" }.to_string()));
    put("pathlight.rays", text(meta.rays.to_string()));
    if let Some(digest) = meta.scene_digest {
        put("pathlight.sceneDigest", text(format!("{digest:016x}")));
    }
    if !meta.merged.is_empty() {
        let ranges: Vec<String> = meta.merged.iter().map(|r| format!("{}..{}", r.start, r.end)).collect();
        put("pathlight.mergedRanges", text(ranges.join(",")));
    }
    if let Some(adaptive) = &meta.adaptive {
        put("pathlight.adaptive", text(adaptive.clone()));
    }
    if let Some(cache) = &meta.irradiance_cache {
        put("pathlight.irradianceCache", text(cache.clone()));
    }
    if let Some(mlt) = &meta.mlt {
        put("pathlight.mlt", text(mlt.clone()));
    }
    if let Some((_, denoiser)) = extras.denoised {
        put("pathlight.denoiser", text(denoiser.name().to_string()));
    }
    if extras.aovs.is_some() {
        use crate::integrator::aov::{
            AOV_REFINED_SAMPLES, AOV_SAMPLES, AOV_SILHOUETTE_SAMPLES, AOV_VARYING_SAMPLES,
        };
        put(
            "pathlight.aovSamples",
            text(format!(
                "{AOV_SAMPLES} rays a pixel; {AOV_VARYING_SAMPLES} where its features vary, \
                 {AOV_SILHOUETTE_SAMPLES} on silhouettes, {AOV_REFINED_SAMPLES} on emitters' edges"
            )),
        );
    }
    if let Some(relmse) = film.predicted_relmse() {
        put(PREDICTED_RELMSE_ATTRIBUTE, AttributeValue::F64(relmse));
    }
    let layer = Layer::new(size, attributes, Encoding::FAST_LOSSLESS, channels);
    let image = Image::from_layer(layer);
    write_atomically(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| Error::output(path, format!("cannot write EXR: {e}")))
    })
}

/// An EXR read back: every channel as f32, every attribute as text.
#[derive(Clone, Debug)]
pub struct ExrImage {
    pub width: usize,
    pub height: usize,
    pub channels: HashMap<String, Vec<f32>>,
    pub attributes: HashMap<String, String>,
}

/// The first layer of the EXR at `path`, every channel and attribute, as the exr crate reads
/// it.
pub(super) fn read_first_layer(path: &Path) -> exr::error::Result<Image<Layer<AnyChannels<FlatSamples>>>> {
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
}

/// An attribute's value as text (numbers in Rust's shortest round-trip form).
pub(super) fn attribute_text(value: &AttributeValue) -> String {
    match value {
        AttributeValue::Text(t) => t.to_string(),
        AttributeValue::I32(i) => i.to_string(),
        AttributeValue::F32(f) => f.to_string(),
        AttributeValue::F64(f) => f.to_string(),
        other => format!("{other:?}"),
    }
}

pub fn read_exr(path: &Path) -> Result<ExrImage> {
    let image = read_first_layer(path).map_err(|e| Error::output(path, format!("cannot read EXR: {e}")))?;
    let layer = &image.layer_data;
    let mut attributes = HashMap::new();
    for (k, v) in layer.attributes.other.iter().chain(image.attributes.other.iter()) {
        attributes.insert(k.to_string(), attribute_text(v));
    }
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    Ok(ExrImage { width: layer.size.width(), height: layer.size.height(), channels, attributes })
}

/// The prefix of the film-state channels (`super::state`), which a denoised copy drops: its
/// `R`, `G`, `B` are no longer the film's mean, so it cannot be merged.
const FILM_STATE_PREFIX: &str = "film.";

/// Writes `dst`: the EXR at `src` with `denoised` as its `R`, `G`, `B` (made by `denoiser`),
/// the mean it was made from as `raw.R`, `raw.G`, `raw.B` (kept when `src` was itself
/// denoised), every other channel and attribute as they were, and no film-state channels.
pub fn write_denoised_copy(src: &Path, denoised: &[glam::Vec3], denoiser: &str, dst: &Path) -> Result<()> {
    let mut image = read_first_layer(src).map_err(|e| Error::output(src, format!("cannot read EXR: {e}")))?;
    let layer = &mut image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    if denoised.len() != width * height {
        return Err(Error::output(
            dst,
            format!("a denoised image of {} pixels for {width}×{height}", denoised.len()),
        ));
    }
    let names: Vec<String> = layer.channel_data.list.iter().map(|c| c.name.to_string()).collect();
    let already_denoised = names.iter().any(|n| n == "raw.R");
    let mut list: Vec<AnyChannel<FlatSamples>> = Vec::new();
    for channel in std::mem::take(&mut layer.channel_data.list) {
        let name = channel.name.to_string();
        if name.starts_with(FILM_STATE_PREFIX) {
            continue;
        }
        match name.as_str() {
            "R" | "G" | "B" if already_denoised => {}
            "R" | "G" | "B" => {
                list.push(AnyChannel::new(format!("raw.{name}").as_str(), channel.sample_data))
            }
            _ => list.push(channel),
        }
    }
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        list.push(AnyChannel::new(*name, FlatSamples::F32(denoised.iter().map(|v| v[c]).collect())));
    }
    layer.channel_data = AnyChannels::sort(SmallVec::from_vec(list));
    layer
        .attributes
        .other
        .insert(Text::from("pathlight.denoiser"), AttributeValue::Text(Text::from(denoiser)));
    layer.attributes.other.remove(&Text::from("pathlight.sceneDigest"));
    write_atomically(dst, |tmp| {
        image.write().to_file(tmp).map_err(|e| Error::output(dst, format!("cannot write EXR: {e}")))
    })
}
