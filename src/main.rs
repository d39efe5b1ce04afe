//! The `pathlight` command line.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use pathlight::film::Tonemap;
use pathlight::gpu::{describe_adapter, enumerate_adapters, GpuContext};
use pathlight::scene::LoadOptions;
use pathlight::session::{EnvironmentChoice, Session, SessionOptions};
use pathlight::{Error, RenderSettings};

/// `println!` for the command line's standard output: when the reader has gone away
/// (`pathlight info | head -3`) the process ends quietly with status 141, as a Unix tool
/// ended by SIGPIPE does, instead of panicking; never 0, so a `compare` verdict cannot be
/// misreported.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(141);
            }
            eprintln!("error: cannot write to standard output: {e}");
            std::process::exit(2);
        }
    }};
}

#[derive(Parser)]
#[command(
    name = "pathlight",
    version,
    about = "A physically based Monte Carlo path tracer (GPU megakernel on Vulkan, CPU reference)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a glTF scene to EXR (linear, with per-pixel variance) and/or PNG.
    Render(RenderArgs),
    /// Watch a scene converge in a window (drag to orbit, wheel to zoom, S saves, Esc quits).
    View(ViewArgs),
    /// List the Vulkan adapters with their driver, type and the limits that matter.
    Info,
    /// Measure scene preparation and render throughput; prints markdown tables.
    Bench(BenchArgs),
    /// Compare two images, noise-aware: exit 0 if they match, 1 if they differ, 2 on bad input.
    Compare(CompareArgs),
}

#[derive(clap::Args)]
struct CompareArgs {
    /// The image under test (.exr, ideally a pathlight EXR with variance, or .png).
    test: PathBuf,
    /// The reference image (.exr or .png).
    reference: PathBuf,
    /// Family-wise false-alarm rate of the statistical test.
    #[arg(long, default_value_t = 0.01)]
    alpha: f64,
    /// Edge of the pixel blocks pooled by the statistical test.
    #[arg(long, default_value_t = 4)]
    block: usize,
    /// Also fail when the RMSE exceeds this.
    #[arg(long)]
    max_rmse: Option<f64>,
    /// Also fail when the relMSE (mean of (t − r)² / (r² + 0.01)) exceeds this.
    #[arg(long)]
    max_relmse: Option<f64>,
    /// Also fail when the mean FLIP error exceeds this.
    #[arg(long)]
    max_flip: Option<f64>,
    /// Also fail when any |test − reference| exceeds this.
    #[arg(long)]
    max_abs: Option<f64>,
    /// Print every number as JSON on standard output instead of the text report.
    #[arg(long)]
    json: bool,
    /// Write a heat map of |z| (or of |test − reference| without variance) to this PNG.
    #[arg(long)]
    diff: Option<PathBuf>,
    /// Write the per-pixel z-scores to this EXR.
    #[arg(long)]
    zmap: Option<PathBuf>,
}

#[derive(clap::Args)]
struct BenchArgs {
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
    /// reference. Its 16 batches must each see a scene's rare paths: at 1,024 (batches of
    /// 64) the glass scene's caustics failed the test against a clean reference, at 8,192
    /// they passed (bench/RESULTS.md). Mitsuba takes about 2 minutes for the Cornell box and
    /// 5 for the glass scene at this count, on 2 cores at 256².
    #[arg(long, default_value_t = 8192)]
    converged_spp: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Peer {
    /// Mitsuba 3 (`pip install mitsuba`), through bench/mitsuba_peer.py.
    Mitsuba,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum SamplerChoice {
    /// Owen-scrambled Sobol points: lower error at the same spp. The EXR's variance
    /// channels then over-state the error (a conservative z-test); the predicted error
    /// comes from two independent replicates and stays right.
    Sobol,
    /// Independent random numbers: the EXR's variance is exactly the mean's.
    Independent,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum BackendChoice {
    /// The fastest present: a hardware GPU if there is one; else (only a software Vulkan
    /// rasteriser such as lavapipe, or no Vulkan at all) the CPU backend, saying why.
    Auto,
    /// The WGSL megakernel on a Vulkan device, software rasterisers included.
    Gpu,
    /// The CPU reference renderer.
    Cpu,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum TonemapChoice {
    Clamp,
    Aces,
}

#[derive(clap::Args)]
struct SceneArgs {
    /// The scene (.gltf or .glb).
    scene: PathBuf,
    /// Image width (default 512; derived from the camera's aspect ratio if only --height is given).
    #[arg(long)]
    width: Option<u32>,
    /// Image height (default 512; derived from the camera's aspect ratio if only --width is given).
    #[arg(long)]
    height: Option<u32>,
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// GPU: use the first Vulkan adapter whose name contains this (case-insensitive).
    #[arg(long)]
    device: Option<String>,
    /// Random seed; the same seed gives the same image.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Most scattering events per path (default: unlimited; Russian roulette ends paths).
    #[arg(long)]
    max_depth: Option<u32>,
    /// Where the paths' random numbers come from.
    #[arg(long, value_enum, default_value_t = SamplerChoice::Sobol)]
    sampler: SamplerChoice,
    // The help names the defaults from the constants that set them, so the two cannot drift.
    #[arg(long, help = splits_help())]
    splits: Option<u32>,
    /// Path trace the caustics too. By default both backends leave them (paths from a
    /// diffuse first hit that reach a light through glass or a mirror) to a light tracer
    /// where the scene allows it.
    #[arg(long)]
    no_light_tracing: bool,
    /// Camera index in the file (default: the first camera, or one framing the scene).
    #[arg(long)]
    camera: Option<usize>,
    /// Let the scene's external files (buffers, images) be anywhere, not only inside its
    /// folder. Only for scenes you trust: see "Untrusted input" in the README.
    #[arg(long)]
    allow_any_path: bool,
    /// Environment light: an equirectangular .hdr or .exr map (+Y up, Mitsuba 3's convention).
    #[arg(long, conflicts_with = "background")]
    env: Option<PathBuf>,
    /// Scale of the environment map's radiance.
    #[arg(long, default_value_t = 1.0, requires = "env")]
    env_intensity: f32,
    /// Rotation of the environment map about +Y, in degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, requires = "env")]
    env_rotation: f32,
    /// A constant environment of this linear radiance, e.g. 0.5,0.5,0.5.
    #[arg(long, value_parser = parse_rgb)]
    background: Option<glam::Vec3>,
}

#[derive(clap::Args)]
struct RenderArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// Output image(s): .exr (linear radiance + variance) or .png (sRGB). Repeat for several.
    #[arg(short, long = "output", required = true)]
    output: Vec<PathBuf>,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// PNG tone curve.
    #[arg(long, value_enum, default_value_t = TonemapChoice::Clamp)]
    tonemap: TonemapChoice,
    /// A reference image (EXR, same size): log RMSE and relMSE against it at 1, 2, 4, … spp.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Write the convergence log (spp, seconds, RMSE, relMSE, predicted relMSE) to this
    /// .csv or .json file.
    #[arg(long)]
    log: Option<PathBuf>,
    /// Stop after the pass that passes this many seconds (the image keeps what it has).
    #[arg(long)]
    time_limit: Option<f64>,
    /// Stop once the relMSE predicted from the image's own variance is at most this.
    #[arg(long)]
    target_error: Option<f64>,
    /// Stream progressive updates to the tev HDR viewer at HOST:PORT (default
    /// 127.0.0.1:14158); a tev that is not running is a warning, not a failed render.
    #[arg(long, num_args = 0..=1, default_missing_value = "", value_name = "HOST:PORT")]
    tev: Option<String>,
}

/// `view`: the scene options of `render`, and the window's own.
#[derive(clap::Args)]
struct ViewArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// Stop accumulating at this many samples per pixel (the window stays open).
    #[arg(long, default_value_t = 4096)]
    spp: u32,
    /// Stop accumulating once the relMSE predicted from the image's own variance is at most this.
    #[arg(long)]
    target_error: Option<f64>,
    /// Render this many frames of one whole pass each (N samples per pixel), write
    /// --screenshot and the outputs, and exit: for tests and pictures.
    #[arg(long)]
    frames: Option<u32>,
    /// With --frames: save what the window shows to this PNG.
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Images written on exit (.exr with variance, .png); also what `S` writes.
    #[arg(short, long = "output")]
    output: Vec<PathBuf>,
    /// Initial exposure in stops (`+`/`-` change it).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Initial tone map (`T` cycles them).
    #[arg(long, value_enum, default_value_t = ViewTonemap::Clamp)]
    tonemap: ViewTonemap,
}

#[derive(Clone, Copy, ValueEnum)]
enum ViewTonemap {
    Clamp,
    Aces,
    /// False colour of each pixel's relative standard error (10⁻³ blue … 1 red).
    RelativeError,
}

/// Parses `R,G,B` (three finite, non-negative numbers).
fn parse_rgb(s: &str) -> Result<glam::Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>().map_err(|e| format!("'{p}': {e}")))
        .collect::<Result<_, _>>()?;
    match parts[..] {
        [r, g, b] if parts.iter().all(|v| v.is_finite() && *v >= 0.0) => Ok(glam::Vec3::new(r, g, b)),
        _ => Err("expected three non-negative numbers R,G,B".into()),
    }
}

fn main() -> ExitCode {
    // Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" on every start
    // when it is unset (headless servers, CI); pathlight uses no display, so point it at the
    // temporary directory. Done first, while the process is single-threaded.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let cli = Cli::parse();
    if let Command::Compare(args) = cli.command {
        return run_compare(args);
    }
    let result = match cli.command {
        Command::Render(args) => run_render(args),
        Command::View(args) => run_view(args),
        Command::Info => run_info(),
        Command::Bench(args) => run_bench(args),
        Command::Compare(_) => unreachable!("handled above"),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// `compare` has its own exit codes: 0 same, 1 different, 2 bad input or usage.
fn run_compare(args: CompareArgs) -> ExitCode {
    use pathlight::film::{compare_images, write_diff_png, write_zmap_exr, CompareOptions, LinearImage};
    let run = || -> Result<bool, Error> {
        let test = LinearImage::read(&args.test)?;
        let reference = LinearImage::read(&args.reference)?;
        let options = CompareOptions {
            alpha: args.alpha,
            block: args.block,
            max_rmse: args.max_rmse,
            max_relmse: args.max_relmse,
            max_flip: args.max_flip,
            max_abs: args.max_abs,
        };
        let report = compare_images(&test, &reference, &options)?;
        if let Some(p) = &args.diff {
            write_diff_png(&report, &test, &reference, p)?;
        }
        if let Some(p) = &args.zmap {
            write_zmap_exr(&report, p)?;
        }
        if args.json {
            out!("{:#}", report.to_json());
        } else {
            out!("{} vs {}: {report}", args.test.display(), args.reference.display());
        }
        Ok(report.same())
    };
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run_bench(args: BenchArgs) -> Result<(), Error> {
    use pathlight::bench::{bench_scene, load_bench_scene, machine_description, prepare};
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
        return run_peer_bench(args, &root, gpu);
    }
    out!(
        "Settings: {}×{}, {} timed spp after 1 warm-up spp, seed 0, unlimited depth\n",
        args.width,
        args.height,
        args.spp
    );
    out!("| scene | triangles | load s | BVH build s | BVH nodes | SAH cost | features |");
    out!("|---|---:|---:|---:|---:|---:|---|");
    let mut flats = Vec::new();
    for name in &args.scenes {
        let start = std::time::Instant::now();
        let scene = load_bench_scene(name, &root, &args.assets)?;
        let load = start.elapsed().as_secs_f64();
        let (flat, p) = prepare(name, &scene, args.width as f64 / args.height as f64, load)?;
        out!(
            "| {} | {} | {:.3} | {:.3} | {} | {:.2} | {} |",
            p.scene,
            p.triangles,
            p.load_seconds,
            p.bvh_seconds,
            p.bvh_nodes,
            p.sah_cost,
            p.features
        );
        flats.push((name.clone(), flat));
    }
    if args.prep_only {
        return Ok(());
    }
    out!("\n| scene | backend | kernel | kernel build s | spp | seconds | Msamples/s | Mrays/s |");
    out!("|---|---|---|---:|---:|---:|---:|---:|");
    let settings =
        RenderSettings { width: args.width, height: args.height, spp: args.spp, ..RenderSettings::default() };
    for (name, flat) in &flats {
        for r in bench_scene(name, flat, &settings, gpu.as_ref(), !args.no_cpu)? {
            out!(
                "| {} | {} | {} | {} | {} | {:.2} | {:.3} | {:.2} |",
                r.scene,
                r.backend,
                r.kernel,
                r.kernel_build_seconds.map(|s| format!("{s:.3}")).unwrap_or_else(|| "-".into()),
                r.spp,
                r.seconds,
                r.samples_per_second / 1e6,
                r.rays_per_second / 1e6
            );
        }
    }
    Ok(())
}

/// `bench --peer`: time to equal error against the peer on every scene, then the table,
/// the CSV series and the plots under `--out`.
fn run_peer_bench(args: BenchArgs, root: &Path, gpu: Option<Arc<GpuContext>>) -> Result<(), Error> {
    use pathlight::bench::peer::{self, PeerOptions};
    use pathlight::bench::BenchScene;
    if !(args.peer_seconds > 0.0 && args.peer_seconds.is_finite()) {
        return Err(Error::Settings("--peer-seconds must be positive and finite".into()));
    }
    let options = PeerOptions {
        width: args.width,
        height: args.height,
        seconds: args.peer_seconds,
        reference_spp: args.reference_spp,
        out: args.out.clone(),
        python: args.python.clone(),
        script: peer::default_script(root),
        variant: args.variant.clone(),
        converged_spp: args.converged_spp,
        run_peer: !args.pathlight_only,
        reuse_series: args.reuse_series,
        cpu: !args.no_cpu,
        gpu,
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
            out!("{}: Mitsuba's converged image vs the reference: {agreement}", r.scene);
        }
        results.push(r);
    }
    let table = peer::markdown(&results);
    out!("\n{table}");
    let summary = args.out.join("summary.md");
    std::fs::write(&summary, &table).map_err(|e| Error::io(&summary, e))?;
    peer::plot(&options, &args.scenes);
    Ok(())
}

fn run_info() -> Result<(), Error> {
    let adapters = enumerate_adapters();
    if adapters.is_empty() {
        out!("no Vulkan adapters found (render falls back to the CPU backend)");
    }
    for (i, a) in adapters.iter().enumerate() {
        out!("[{i}] {}", describe_adapter(a));
    }
    out!("CPU reference: {} threads", rayon::current_num_threads());
    Ok(())
}

/// The image size: 512×512 by default; with only one side given, the other follows the
/// camera's aspect ratio (square if the camera has none).
fn check_output(path: &Path) -> Result<(), Error> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("exr") | Some("png") => {}
        _ => return Err(Error::Settings(format!("{}: output must end in .exr or .png", path.display()))),
    }
    pathlight::film::check_writable(path)
}

fn run_render(args: RenderArgs) -> Result<(), Error> {
    // Every output is checked before any work: a missing folder or a read-only target must
    // not cost a whole render.
    for o in &args.output {
        check_output(o)?;
    }
    if let Some(log) = &args.log {
        match log.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("csv") | Some("json") => pathlight::film::check_writable(log)?,
            _ => return Err(Error::Settings(format!("{}: --log must end in .csv or .json", log.display()))),
        }
    }
    if args.time_limit.is_some_and(|t| !(t > 0.0 && t.is_finite()))
        || args.target_error.is_some_and(|e| !(e > 0.0 && e.is_finite()))
    {
        return Err(Error::Settings("--time-limit and --target-error must be positive and finite".into()));
    }
    let mut session = Session::open(&session_options(&args.common, args.spp))?;
    for w in &session.warnings {
        eprintln!("warning: {}: {w}", args.common.scene.display());
    }
    eprintln!("{}", session.describe());
    for note in session.backend_note.iter().chain(&session.backend_detail) {
        eprintln!("{note}");
    }
    let (width, height) = (session.settings.width, session.settings.height);
    let reference = match &args.reference {
        Some(path) => {
            let image = pathlight::film::LinearImage::read(path)?;
            if (image.width, image.height) != (width as usize, height as usize) {
                return Err(Error::Settings(format!(
                    "{}: the reference is {}×{}, the render {width}×{height}",
                    path.display(),
                    image.width,
                    image.height
                )));
            }
            Some(image)
        }
        None => None,
    };
    let mut tev = args.tev.as_ref().map(|address| {
        let address = if address.is_empty() { pathlight::tev::DEFAULT_ADDRESS } else { address.as_str() };
        pathlight::tev::TevStream::connect(address, &tev_image_name(&args.common.scene), width, height)
    });
    if let Some(Err(e)) = &tev {
        eprintln!("warning: --tev: {e}; rendering without it");
    }
    let mut tev = tev.take().and_then(|t| t.ok());

    // Ctrl-C stops after the pass in flight and still writes what was rendered; a second
    // Ctrl-C exits at once.
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!(
                "\ninterrupted: finishing the current pass and writing the image (Ctrl-C again to abort)"
            );
        });
    }
    let bar = ProgressBar::new(args.spp as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} spp  {elapsed_precise} elapsed  ETA {eta_precise}",
        )
        .expect("static template"),
    );
    // Checkpoints: a log row at 1, 2, 4, … spp when asked for one, the predicted error after
    // every pass when --target-error may stop the render, and a tev update.
    let mut rows: Vec<pathlight::film::ConvergenceRow> = Vec::new();
    let logging = reference.is_some() || args.log.is_some();
    let start = std::time::Instant::now();
    let mut last_tev = None::<std::time::Instant>;
    let rendered = session.render_to(args.spp, &stop, |b, done| {
        let seconds = start.elapsed().as_secs_f64();
        bar.set_position(done as u64);
        let mut stop_now = args.time_limit.is_some_and(|t| seconds >= t);
        let log_here = logging && (done.is_power_of_two() || done == args.spp);
        if log_here || args.target_error.is_some() {
            let image = pathlight::film::LinearImage::from_film(&b.film()?);
            let row = pathlight::film::ConvergenceRow::new(&image, reference.as_ref(), done, seconds);
            stop_now |= args.target_error.is_some_and(|e| row.predicted_relmse <= e);
            if log_here || (stop_now && logging) {
                if reference.is_some() {
                    bar.suspend(|| {
                        eprintln!(
                            "{done:>6} spp {seconds:>9.3} s  RMSE {:.5}  relMSE {:.5}  predicted relMSE {:.5}",
                            row.rmse.unwrap_or(f64::NAN),
                            row.relmse.unwrap_or(f64::NAN),
                            row.predicted_relmse
                        )
                    });
                }
                rows.push(row);
            }
        }
        // tev: at most a few updates a second (each sends the whole image).
        if let Some(t) = tev.as_mut() {
            if last_tev.is_none_or(|l: std::time::Instant| l.elapsed().as_secs_f64() >= 0.25) || done == args.spp {
                if let Err(e) = t.update(&b.film()?) {
                    bar.suspend(|| eprintln!("warning: --tev: {e}; no more updates"));
                    tev = None;
                }
                last_tev = Some(std::time::Instant::now());
            }
        }
        Ok(stop_now)
    });
    bar.finish_and_clear();
    let tonemap = match args.tonemap {
        TonemapChoice::Clamp => Tonemap::Clamp,
        TonemapChoice::Aces => Tonemap::Aces,
    };
    let stats = match rendered {
        Ok(stats) => stats,
        // A failed pass (a GPU fault or timeout): the passes before it are in the film;
        // write them where they can still be read back, then report the failure.
        Err(e) => {
            let outputs: Vec<String> = args.output.iter().map(|o| o.display().to_string()).collect();
            return Err(match session.write(&args.output, tonemap, args.exposure) {
                Ok(()) => Error::Gpu(format!(
                    "{e}; the {} spp completed before it were written to {}",
                    session.spp(),
                    outputs.join(", ")
                )),
                Err(w) => {
                    Error::Gpu(format!("{e}; the samples rendered before it could not be read back ({w})"))
                }
            });
        }
    };
    if let Some(log) = &args.log {
        let text = if log.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
            format!("{:#}\n", pathlight::film::convergence_json(&rows))
        } else {
            pathlight::film::convergence_csv(&rows)
        };
        pathlight::film::write_atomically(log, |tmp| {
            std::fs::write(tmp, &text).map_err(|e| Error::io(log, e))
        })?;
    }
    let film = session.film()?;
    if let Some(t) = tev.as_mut() {
        // The final image, then the connection closes (the image stays open in tev).
        if let Err(e) = t.update(&film) {
            eprintln!("warning: --tev: {e}");
        }
    }
    session.write(&args.output, tonemap, args.exposure)?;
    let rejected = film.total_rejected();
    let samples = film.total_samples() + rejected;
    let rays = session.rays_traced()?;
    eprintln!(
        "{}{} spp at {width}×{height} in {:.2} s: {:.3} Msamples/s, {:.2} Mrays/s, {rejected} rejected sample(s), backend {}",
        if stats.interrupted { "interrupted after " } else { "" },
        stats.spp,
        stats.seconds,
        samples as f64 / stats.seconds.max(1e-9) / 1e6,
        rays as f64 / stats.seconds.max(1e-9) / 1e6,
        session.backend_name()
    );
    Ok(())
}

/// The image name tev shows: the scene's file name.
fn tev_image_name(scene: &Path) -> String {
    format!("pathlight: {}", scene.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default())
}

/// The session `render` and `view` ask for.
fn session_options(args: &SceneArgs, spp: u32) -> SessionOptions {
    SessionOptions {
        scene: args.scene.clone(),
        load: LoadOptions { allow_any_path: args.allow_any_path },
        environment: match (&args.env, args.background) {
            (Some(path), _) => EnvironmentChoice::Map {
                path: path.clone(),
                intensity: args.env_intensity,
                rotation_degrees: args.env_rotation,
            },
            (None, Some(rgb)) => EnvironmentChoice::Constant(rgb),
            (None, None) => EnvironmentChoice::None,
        },
        camera: args.camera,
        width: args.width,
        height: args.height,
        spp,
        seed: args.seed,
        max_depth: args.max_depth,
        splits: args.splits,
        light_tracing: !args.no_light_tracing,
        sampler: match args.sampler {
            SamplerChoice::Sobol => pathlight::sampling::SamplerKind::Sobol,
            SamplerChoice::Independent => pathlight::sampling::SamplerKind::Independent,
        },
        backend: match args.backend {
            BackendChoice::Auto => pathlight::session::BackendChoice::Auto,
            BackendChoice::Gpu => pathlight::session::BackendChoice::Gpu,
            BackendChoice::Cpu => pathlight::session::BackendChoice::Cpu,
        },
        device: args.device.clone(),
    }
}

fn run_view(args: ViewArgs) -> Result<(), Error> {
    if args.target_error.is_some_and(|e| !(e > 0.0 && e.is_finite())) {
        return Err(Error::Settings("--target-error must be positive and finite".into()));
    }
    for o in &args.output {
        check_output(o)?;
    }
    if args.frames == Some(0) {
        return Err(Error::Settings("--frames must be at least 1".into()));
    }
    pathlight::viewer::run(pathlight::viewer::ViewOptions {
        session: session_options(&args.common, args.spp),
        target_error: args.target_error,
        frames: args.frames,
        screenshot: args.screenshot,
        outputs: args.output,
        exposure: args.exposure,
        tonemap: match args.tonemap {
            ViewTonemap::Clamp => pathlight::scene::layout::DISPLAY_CLAMP,
            ViewTonemap::Aces => pathlight::scene::layout::DISPLAY_ACES,
            ViewTonemap::RelativeError => pathlight::scene::layout::DISPLAY_RELATIVE_ERROR,
        },
    })
}

/// `--splits`' help, with the backends' defaults read from the constants that set them.
fn splits_help() -> String {
    format!(
        "Continuations per camera sample, split at its first vertex with a non-delta lobe \
         (trajectory splitting; 1: none). --spp counts camera samples. Default: the backend's, \
         chosen by measured efficiency ({} on the CPU, {} on a software GPU such as lavapipe, {} on \
         a hardware GPU)",
        pathlight::render::CPU_DEFAULT_SPLITS,
        pathlight::render::SOFTWARE_GPU_DEFAULT_SPLITS,
        pathlight::render::HARDWARE_GPU_DEFAULT_SPLITS
    )
}
