//! `pathlight bench`: scene preparation and throughput tables, or time to equal error
//! against a peer renderer (`--peer`); the measurements are [`pathlight::bench`]'s.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use clap::ValueEnum;

use pathlight::bench::peer::{self, PeerOptions};
use pathlight::bench::{
    bench_scene, load_bench_scene, machine_description, prepare, BenchRow, BenchScene, PrepRow,
};
use pathlight::gpu::GpuContext;
use pathlight::integrator::Integrator;
use pathlight::{Error, RenderSettings};

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Scenes: names in scenes/ (e.g. cornell-box), paths, or `bunny-in-cornell` (the
    /// Stanford bunny from the shared assets in the Cornell box).
    #[arg(default_values_t = ["cornell-box".to_string(), "bunny-in-cornell".to_string()])]
    scenes: Vec<String>,
    #[arg(long, default_value_t = 512)]
    width: u32,
    #[arg(long, default_value_t = 512)]
    height: u32,
    /// Timed samples per pixel (after one warm-up sample).
    #[arg(long, default_value_t = 8)]
    spp: u32,
    /// The estimators measured (`render --integrator`), comma-separated: each gets its own
    /// rows, and with --peer its own error series (compared with the path tracer's).
    #[arg(long, default_value = "path", value_delimiter = ',', value_parser = super::parse_integrator())]
    integrator: Vec<Integrator>,
    /// With --peer: the integrator that renders a missing reference (the fastest to
    /// converge on the scene; the z-test against the peer's converged image checks it).
    #[arg(long, default_value = "path", value_parser = super::parse_integrator(), requires = "peer")]
    reference_integrator: Integrator,
    /// Skip the CPU backend.
    #[arg(long)]
    no_cpu: bool,
    /// Skip the GPU backend.
    #[arg(long)]
    no_gpu: bool,
    /// Only load and build the BVH (for very large meshes).
    #[arg(long)]
    prep_only: bool,
    /// GPU adapter name substring.
    #[arg(long)]
    device: Option<String>,
    /// The shared assets folder.
    #[arg(long, default_value = "../shared/assets")]
    assets: PathBuf,
    /// Measure time to equal error against a peer renderer in the same run (see
    /// bench/README.md): pathlight's backends and the peer each render every scene against
    /// one reference until --peer-seconds have passed.
    #[arg(long, value_enum)]
    peer: Option<Peer>,
    /// Seconds each renderer's error series runs for, per scene.
    #[arg(long, default_value_t = 60.0)]
    peer_seconds: f64,
    /// Samples per pixel of a reference rendered in this run, with the backend's default
    /// splitting and light tracing (OUT/<scene>/reference.exr is reused when present; render
    /// it on a fast GPU with --references-only). Give it about ten times the series' time:
    /// the summary says how noisy it is.
    #[arg(long, default_value_t = 4096)]
    reference_spp: u32,
    /// With --peer: only render the missing references, then stop.
    #[arg(long, requires = "peer")]
    references_only: bool,
    /// With --peer: render the references and pathlight's series but not the peer's (a
    /// machine without it, e.g. a GPU measured beside the peer's machine; no comparison).
    #[arg(long, requires = "peer")]
    pathlight_only: bool,
    /// With --peer: read the series already under --out instead of rendering them (redo
    /// the table and plots).
    #[arg(long, requires = "peer")]
    reuse_series: bool,
    /// With --peer: where references, error series, plots and the summary go.
    #[arg(long, default_value = "bench/peer")]
    out: PathBuf,
    /// With --peer: the Python interpreter that has Mitsuba 3 installed.
    #[arg(long, default_value = "python3")]
    python: String,
    /// With --peer: the Mitsuba 3 variant (scalar_rgb where LLVM is missing).
    #[arg(long, default_value = "llvm_ad_rgb")]
    variant: String,
    /// With --peer: samples per pixel of the peer's converged image, z-tested against the
    /// reference. Its 16 batches must each see a scene's rare paths (the glass scene's
    /// caustics need 8,192: bench/history/peers.md).
    #[arg(long, default_value_t = 8192)]
    converged_spp: u32,
    /// With --peer pbrt: the pbrt executable.
    #[arg(long, default_value = "pbrt")]
    pbrt: PathBuf,
    /// With --peer pbrt: pbrt's integrator (bdpt, path, …).
    #[arg(long, default_value = "bdpt")]
    pbrt_integrator: String,
    /// The most scattering events of every path: pathlight's series and reference, and with
    /// --peer pbrt pbrt's `maxdepth` (default: unbounded with roulette; pbrt 100). Metropolis
    /// (`--integrator mlt`) renders to depth 10 unless told otherwise.
    #[arg(long)]
    max_depth: Option<u32>,
    /// With --peer pbrt: the integrator of pbrt's converged image (default: --pbrt-integrator).
    /// For a biased one such as sppm, `path` measures its bias as pathlight's is measured.
    #[arg(long)]
    pbrt_converged_integrator: Option<String>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Peer {
    /// Mitsuba 3 (`pip install mitsuba`), through bench/mitsuba_peer.py.
    Mitsuba,
    /// pbrt-v4 (../shared/peers/pbrt-v4/build_pbrt.sh), scenes converted by
    /// bench/pbrt_peer.py; each renderer measured against its own converged image.
    Pbrt,
}

pub fn run(args: BenchArgs) -> Result<(), Error> {
    let root = std::env::current_dir().map_err(|e| Error::io(Path::new("."), e))?;
    let gpu = if args.no_gpu || args.prep_only {
        None
    } else {
        Some(Arc::new(GpuContext::new(args.device.as_deref())?))
    };
    out!("Machine: {}", machine_description());
    if let Some(g) = &gpu {
        out!("GPU: {}", g.name());
    }
    if args.peer.is_some() {
        return run_peer(args, &root, gpu);
    }
    out!(
        "Settings: {}×{}, {} timed spp after 1 warm-up spp, seed 0, unlimited depth, integrator {}\n",
        args.width,
        args.height,
        args.spp,
        args.integrator.iter().map(|i| i.name()).collect::<Vec<_>>().join(", ")
    );
    out!("{}", PrepRow::MARKDOWN_HEADER);
    let mut flats = Vec::new();
    for name in &args.scenes {
        let start = std::time::Instant::now();
        let scene = load_bench_scene(name, &root, &args.assets)?;
        let load = start.elapsed().as_secs_f64();
        let (flat, prep) = prepare(name, &scene, args.width as f64 / args.height as f64, load)?;
        out!("{}", prep.markdown());
        flats.push((name.clone(), flat));
    }
    if args.prep_only {
        return Ok(());
    }
    out!("\n{}", BenchRow::MARKDOWN_HEADER);
    for &integrator in &args.integrator {
        let settings = RenderSettings {
            integrator,
            width: args.width,
            height: args.height,
            spp: args.spp,
            ..RenderSettings::default()
        };
        // Only the integrators with a GPU kernel are measured there.
        let gpu = gpu.as_ref().filter(|_| integrator.has_gpu_kernel());
        for (name, flat) in &flats {
            for row in bench_scene(name, flat, &settings, gpu, !args.no_cpu)? {
                out!("{}", row.markdown());
            }
        }
    }
    Ok(())
}

/// `bench --peer`: time to equal error against the peer on every scene, then the table,
/// the CSV series and the plots under `--out`.
fn run_peer(args: BenchArgs, root: &Path, gpu: Option<Arc<GpuContext>>) -> Result<(), Error> {
    if !(args.peer_seconds > 0.0 && args.peer_seconds.is_finite()) {
        return Err(Error::Settings("--peer-seconds must be positive and finite".into()));
    }
    if args.max_depth.is_some() && args.peer == Some(Peer::Mitsuba) && !args.pathlight_only {
        return Err(Error::Settings(
            "--max-depth: the Mitsuba peer's paths are unbounded; bound them with --peer pbrt, or run --pathlight-only"
                .into(),
        ));
    }
    if args.integrator.contains(&Integrator::Mlt) && args.max_depth.is_none() {
        return Err(Error::Settings(
            "--integrator mlt renders paths up to depth 10 unless told otherwise: give --max-depth, so that the reference and the peer are bounded alike"
                .into(),
        ));
    }
    let peer = match args.peer.expect("checked by the caller") {
        Peer::Mitsuba => peer::PeerKind::Mitsuba,
        Peer::Pbrt => peer::PeerKind::Pbrt(pathlight::bench::pbrt::PbrtOptions {
            binary: args.pbrt.clone(),
            integrator: args.pbrt_integrator.clone(),
            converged_integrator: args
                .pbrt_converged_integrator
                .clone()
                .unwrap_or_else(|| args.pbrt_integrator.clone()),
        }),
    };
    let options = PeerOptions {
        peer,
        width: args.width,
        height: args.height,
        seconds: args.peer_seconds,
        reference_spp: args.reference_spp,
        max_depth: args.max_depth,
        out: args.out.clone(),
        python: args.python.clone(),
        script: peer::default_script(root),
        variant: args.variant.clone(),
        converged_spp: args.converged_spp,
        run_peer: !args.pathlight_only,
        reuse_series: args.reuse_series,
        cpu: !args.no_cpu,
        gpu,
        integrators: args.integrator.clone(),
        reference_integrator: args.reference_integrator,
    };
    let scenes: Vec<BenchScene> =
        args.scenes.iter().map(|n| BenchScene::resolve(n, root, &args.assets)).collect();
    if args.references_only {
        for scene in &scenes {
            let flat = peer::flat_scene(scene, &options)?;
            let reference = peer::reference(scene, &flat, &options)?;
            out!("{}: {}", scene.name, reference.note);
        }
        return Ok(());
    }
    out!(
        "Peer: {:?} ({}), {}×{}, each series {} s, references at {} spp unless reused\n",
        args.peer.expect("checked by the caller"),
        args.variant,
        args.width,
        args.height,
        args.peer_seconds,
        args.reference_spp
    );
    let mut results = Vec::new();
    for scene in &scenes {
        let r = peer::run_scene(scene, &options)?;
        out!("{}: reference {}", r.scene, r.reference_note);
        if let Some(agreement) = &r.agreement {
            out!("{}: the peer's converged image vs the reference: {agreement}", r.scene);
        }
        results.push(r);
    }
    let mut table = peer::markdown(&results);
    if let Some(integrators) = peer::integrator_markdown(&results) {
        table +=
            &format!("\nIntegrators against the path tracer, same backend and sampler:\n\n{integrators}");
    }
    out!("\n{table}");
    let summary = args.out.join("summary.md");
    std::fs::write(&summary, &table).map_err(|e| Error::io(&summary, e))?;
    peer::plot(&options, &args.scenes);
    Ok(())
}
