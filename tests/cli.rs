//! The `pathlight` command line, end to end.

mod common;

use std::process::Command;

fn pathlight() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pathlight"));
    c.env("XDG_RUNTIME_DIR", "/tmp");
    c
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("pathlight-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Renders the Cornell box on the CPU, 8 spp, 64 px wide, seed 5, to each output.
fn render_cornell_cpu(outputs: &[&std::path::Path]) -> std::process::Output {
    let scene = common::scene("cornell-box.gltf");
    let mut c = pathlight();
    c.args([
        "render",
        scene.to_str().unwrap(),
        "--backend",
        "cpu",
        "--spp",
        "8",
        "--width",
        "64",
        "--seed",
        "5",
    ]);
    for o in outputs {
        c.arg("-o").arg(o);
    }
    c.output().unwrap()
}

#[test]
fn renders_cornell_box_to_exr_and_png() {
    let dir = temp_dir("cornell");
    let (exr, png) = (dir.join("c.exr"), dir.join("c.png"));
    let out = render_cornell_cpu(&[&exr, &png]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "render failed: {stderr}");
    assert!(stderr.contains("8 spp at 64×64"), "summary line missing: {stderr}");
    assert!(stderr.contains("Msamples/s") && stderr.contains("rejected"), "{stderr}");

    let image = pathlight::film::read_exr(&exr).unwrap();
    assert_eq!((image.width, image.height), (64, 64), "width given, height from the camera's aspect ratio 1");
    for c in ["R", "G", "B", "variance.R", "variance.G", "variance.B"] {
        let data = &image.channels[c];
        assert_eq!(data.len(), 64 * 64, "{c}");
        assert!(data.iter().all(|v| v.is_finite() && *v >= 0.0), "{c}");
    }
    let mean_r = image.channels["R"].iter().sum::<f32>() / 4096.0;
    assert!(mean_r > 0.05, "the Cornell box is lit (mean R {mean_r})");
    assert!(image.channels["variance.R"].iter().any(|v| *v > 0.0), "noisy pixels carry variance");
    assert_eq!(image.attributes["pathlight.spp"], "8");
    assert_eq!(image.attributes["pathlight.seed"], "5");
    assert!(image.attributes["pathlight.backend"].starts_with("cpu"));
    // The CPU backend's default splitting, recorded: `spp` counts camera samples.
    assert_eq!(image.attributes["pathlight.splits"], pathlight::render::CPU_DEFAULT_SPLITS.to_string());
    assert!(image.attributes["pathlight.renderSeconds"].parse::<f64>().unwrap() > 0.0);
    // The image's own predicted relMSE, from the Sobol sampler's two replicates. The variance
    // channels hold the samples' spread, which under QMC over-states the error of the mean:
    // the relMSE they predict bounds the recorded one from above.
    let recorded: f64 = image.attributes[pathlight::film::PREDICTED_RELMSE_ATTRIBUTE].parse().unwrap();
    let from_channels =
        pathlight::film::predicted_relmse(&pathlight::film::LinearImage::read(&exr).unwrap()).unwrap();
    assert!(
        recorded > 0.0 && recorded < from_channels,
        "recorded {recorded}, from the channels {from_channels}"
    );

    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (64, 64));
    assert!(buf[..info.buffer_size()].iter().any(|&b| b > 50), "PNG is not black");

    // Same seed, same image: the CPU reference is deterministic.
    let exr2 = dir.join("c2.exr");
    let out = render_cornell_cpu(&[&exr2]);
    assert!(out.status.success());
    assert_eq!(pathlight::film::read_exr(&exr2).unwrap().channels["R"], image.channels["R"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Both photon integrators render from the command line: `auto` says it renders them on
/// the CPU, the summary reports the photons, and the EXR names the integrator and says what
/// its variance channels measure.
#[test]
fn photon_mapping_renders_say_what_their_variance_means() {
    let dir = temp_dir("photon");
    let scene = common::scene("cornell-box.gltf");
    for (integrator, report) in
        [("sppm", "sppm: 4 passes"), ("photon", "photons stored in the global and caustic maps")]
    {
        let exr = dir.join(format!("{integrator}.exr"));
        let out = pathlight()
            .args([
                "render",
                scene.to_str().unwrap(),
                "--integrator",
                integrator,
                "--spp",
                "4",
                "--width",
                "16",
            ])
            .arg("-o")
            .arg(&exr)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{integrator}: {stderr}");
        assert!(stderr.contains(report), "{integrator}: {stderr}");
        let image = pathlight::film::read_exr(&exr).unwrap();
        assert_eq!(image.attributes["pathlight.integrator"], integrator);
        assert!(
            image.attributes["pathlight.variance"].contains("noise only"),
            "{integrator}: {:?}",
            image.attributes
        );
        let mean = image.channels["G"].iter().sum::<f32>() / image.channels["G"].len() as f32;
        assert!(mean > 0.05, "{integrator}: the Cornell box is lit (mean G {mean})");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--irradiance-cache` renders from the command line, reports its records, says in the EXR what the cache was and what the variance measures,
/// and `--ic-show-records` marks one red pixel per record.
#[test]
fn irradiance_cache_renders_report_and_show_their_records() {
    let dir = temp_dir("irradiance-cache");
    let scene = common::scene("cornell-box.gltf");
    let (exr, png) = (dir.join("cached.exr"), dir.join("records.png"));
    let out = pathlight()
        .args(["render", scene.to_str().unwrap(), "--irradiance-cache", "--spp", "2", "--width", "48"])
        .args(["--backend", "cpu", "-o"])
        .arg(&exr)
        .arg("--ic-show-records")
        .arg(&png)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let records: usize = stderr
        .split("irradiance cache: ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no record count in: {stderr}"));
    assert!(records > 0, "{stderr}");
    let image = pathlight::film::read_exr(&exr).unwrap();
    assert!(
        image.attributes["pathlight.variance"].contains("given the irradiance cache"),
        "{:?}",
        image.attributes
    );
    let cache = &image.attributes["pathlight.irradianceCache"];
    assert!(cache.contains("accuracy 1") && cache.contains(&format!("{records} records")), "{cache}");
    let marked = pathlight::film::LinearImage::read(&png).unwrap();
    // The marker is pure red after the sRGB curve; the darkened image never is.
    let red = marked.rgb.iter().filter(|c| c[0] > 0.99 && c[1] == 0.0 && c[2] == 0.0).count();
    // The overture visits each pixel once and places at most one record there.
    assert_eq!(red, records, "red pixels in {}", png.display());

    // Parts of a render place the same records (they depend on the seed and the camera
    // alone), so its shards merge to the whole render, and the merge still says what the
    // cache was.
    let parts: Vec<_> = (0..2).map(|i| dir.join(format!("part{i}.exr"))).collect();
    for (i, part) in parts.iter().enumerate() {
        let o = pathlight()
            .args(["render", scene.to_str().unwrap(), "--irradiance-cache", "--spp", "2", "--width", "48"])
            .args(["--backend", "cpu", "--shard", &format!("{i}/2"), "-o"])
            .arg(part)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let merged = dir.join("merged.exr");
    let o = pathlight().arg("merge").args(&parts).arg("-o").arg(&merged).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let merged = pathlight::film::read_exr(&merged).unwrap();
    assert_eq!(merged.attributes["pathlight.irradianceCache"], *cache);
    for c in ["R", "G", "B"] {
        for (a, b) in merged.channels[c].iter().zip(&image.channels[c]) {
            // The merge combines the parts' running statistics: the same mean up to rounding.
            assert!((a - b).abs() <= 1e-5 * b.abs().max(1e-3), "{c}: merged {a}, whole {b}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_gets_a_clear_error() {
    let dir = temp_dir("errors");
    let run = |args: &[&str]| {
        let out = pathlight().args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} should fail");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let out = dir.join("x.exr");
    let out = out.to_str().unwrap();
    let e = run(&["render", "/nonexistent/scene.gltf", "--backend", "cpu", "-o", out]);
    assert!(e.contains("/nonexistent/scene.gltf"), "{e}");
    let garbage = dir.join("garbage.glb");
    std::fs::write(&garbage, b"glTF\x02\x00\x00\x00garbage").unwrap();
    let e = run(&["render", garbage.to_str().unwrap(), "--backend", "cpu", "-o", out]);
    assert!(e.contains("garbage.glb") && e.contains("not a valid glTF"), "{e}");
    let cornell = common::scene("cornell-box.gltf");
    let e = run(&["render", cornell.to_str().unwrap(), "--backend", "cpu", "--camera", "3", "-o", out]);
    assert!(e.contains("--camera 3") && e.contains("1 camera"), "{e}");
    let e = run(&[
        "render",
        cornell.to_str().unwrap(),
        "--backend",
        "cpu",
        "--width",
        "100000",
        "--height",
        "100000",
        "-o",
        out,
    ]);
    assert!(e.contains("100000×100000") && e.contains("at most"), "{e}");
    for splits in ["0", "65"] {
        let e =
            run(&["render", cornell.to_str().unwrap(), "--backend", "cpu", "--splits", splits, "-o", out]);
        assert!(e.contains(&format!("--splits must be between 1 and 64, not {splits}")), "{e}");
    }
    let e = run(&["render", cornell.to_str().unwrap(), "--backend", "cpu", "-o", "image.jpg"]);
    assert!(e.contains("image.jpg") && e.contains(".exr or .png"), "{e}");
    let e = run(&[
        "render",
        cornell.to_str().unwrap(),
        "--backend",
        "cpu",
        "--spp",
        "4",
        "--width",
        "8",
        "-o",
        "/nonexistent-dir/x.exr",
    ]);
    assert!(e.contains("/nonexistent-dir/x.exr"), "{e}");
    // An integrator that does not exist is refused, listing the ones that do.
    let e = run(&["render", cornell.to_str().unwrap(), "--integrator", "vcm", "-o", out]);
    assert!(e.contains("'vcm'") && e.contains("[possible values: path, bdpt, sppm, photon, mlt]"), "{e}");
    // A photon-mapping option without photon mapping is refused, naming both.
    let e = run(&["render", cornell.to_str().unwrap(), "--backend", "cpu", "--photons", "1000", "-o", out]);
    assert!(
        e.contains("--photons is an option of --integrator sppm and photon, not of --integrator path"),
        "{e}"
    );
    // A bidirectional option without the bidirectional integrator is refused, naming both.
    let e =
        run(&["render", cornell.to_str().unwrap(), "--backend", "cpu", "--bdpt-strategy", "2,2", "-o", out]);
    assert!(e.contains("--bdpt-strategy") && e.contains("--integrator bdpt"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Metropolis renders from the command line: `auto` renders it on the CPU and says so, the
/// summary gives the acceptance rate, the EXR records its settings, its depth bound and what
/// its variance channels measure; its options are refused by name where they do not apply,
/// and bad values are refused with what they must be.
#[test]
fn metropolis_renders_and_its_options_are_checked() {
    let dir = temp_dir("mlt");
    let scene = common::scene("cornell-box.gltf");
    let exr = dir.join("mlt.exr");
    let out = pathlight()
        .args(["render", scene.to_str().unwrap(), "--integrator", "mlt", "--spp", "4", "--width", "16"])
        .args(["--mutations-per-pixel", "8", "--large-step", "0.5", "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("mlt: 4 passes, acceptance rate"), "{stderr}");
    let image = pathlight::film::read_exr(&exr).unwrap();
    assert_eq!(image.attributes["pathlight.integrator"], "mlt");
    assert!(image.attributes["pathlight.backend"].starts_with("cpu"), "{:?}", image.attributes);
    assert_eq!(image.attributes["pathlight.maxDepth"], "10");
    let mlt = &image.attributes["pathlight.mlt"];
    assert!(
        mlt.contains("8 mutations per pixel per pass")
            && mlt.contains("large-step probability 0.5")
            && mlt.contains("target relative"),
        "{mlt}"
    );
    assert!(image.attributes["pathlight.variance"].contains("across passes"), "{:?}", image.attributes);
    let mean = image.channels["G"].iter().sum::<f32>() / image.channels["G"].len() as f32;
    assert!(mean > 0.05, "the Cornell box is lit (mean G {mean})");

    let run = |args: &[&str]| {
        let out = pathlight().args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} should fail");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let (s, o) = (scene.to_str().unwrap(), dir.join("x.exr"));
    let o = o.to_str().unwrap();
    let e = run(&["render", s, "--backend", "cpu", "--chains", "4", "-o", o]);
    assert!(e.contains("options of --integrator mlt, not of --integrator path"), "{e}");
    let e = run(&["render", s, "--backend", "cpu", "--mlt-target", "luminance", "-o", o]);
    assert!(e.contains("options of --integrator mlt, not of --integrator path"), "{e}");
    let e = run(&["render", s, "--integrator", "mlt", "--mlt-target", "brightness", "-o", o]);
    assert!(e.contains("--mlt-target") && e.contains("relative") && e.contains("luminance"), "{e}");
    let e = run(&["render", s, "--integrator", "mlt", "--large-step", "0", "-o", o]);
    assert!(e.contains("--large-step") && e.contains("(0, 1]"), "{e}");
    let e = run(&["render", s, "--integrator", "mlt", "--chains", "0", "-o", o]);
    assert!(e.contains("--chains must be between 1 and"), "{e}");
    let e = run(&["render", s, "--integrator", "mlt", "--max-depth", "40", "-o", o]);
    assert!(e.contains("--max-depth 40 with --integrator mlt"), "{e}");
    let e = run(&["render", s, "--integrator", "mlt", "--adaptive", "-o", o]);
    assert!(e.contains("--adaptive renders with --integrator path only"), "{e}");
    // With the plain luminance target passes are independent renders, so parts of a render
    // merge to the whole render. (With the default relative target a part's importance map
    // comes from its own passes, so parts merge to an image of the same expectation, which
    // tests/mlt.rs's z-tests check of every render, but not to the whole render's bits.)
    let part = |range: &str, file: &str| {
        let out = pathlight()
            .args([
                "render",
                s,
                "--integrator",
                "mlt",
                "--spp",
                "4",
                "--width",
                "16",
                "--samples",
                range,
                "--mlt-target",
                "luminance",
                "-o",
            ])
            .arg(dir.join(file))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    };
    part("0..2", "a.exr");
    part("2..4", "b.exr");
    let out = pathlight()
        .arg("merge")
        .args([dir.join("a.exr"), dir.join("b.exr")])
        .arg("-o")
        .arg(dir.join("merged.exr"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let whole = pathlight()
        .args(["render", s, "--integrator", "mlt", "--spp", "4", "--width", "16"])
        .args(["--mlt-target", "luminance", "-o"])
        .arg(dir.join("whole.exr"))
        .output()
        .unwrap();
    assert!(whole.status.success());
    let (merged, whole) = (
        pathlight::film::read_exr(&dir.join("merged.exr")).unwrap(),
        pathlight::film::read_exr(&dir.join("whole.exr")).unwrap(),
    );
    for (a, b) in merged.channels["G"].iter().zip(&whole.channels["G"]) {
        // The merge averages the parts' means: the same sums in another order, to rounding.
        assert!((a - b).abs() <= 1e-6 * b.abs().max(1e-3), "merged {a} vs whole {b}");
    }
    // The sealed room: no light to find, a black image and a warning.
    let sealed = common::scene("hard/sealed-room.gltf");
    let out = pathlight()
        .args(["render", sealed.to_str().unwrap(), "--integrator", "mlt", "--spp", "2", "--width", "8", "-o"])
        .arg(dir.join("sealed.exr"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("found no path that carries light"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bdpt_strategies_are_written_one_exr_each_and_sum_to_the_render() {
    let dir = temp_dir("strategies");
    let (exr, strategies) = (dir.join("bdpt.exr"), dir.join("strategies"));
    let scene = common::scene("cornell-box.gltf");
    let out = pathlight()
        .args(["render", scene.to_str().unwrap(), "--backend", "cpu", "--integrator", "bdpt"])
        .args(["--spp", "4", "--width", "16", "--max-depth", "2", "-o"])
        .arg(&exr)
        .arg("--bdpt-strategies")
        .arg(&strategies)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    // Depth ≤ 2: paths of 2 to 4 vertices, every strategy of those lengths but (1, 1).
    let mut names: Vec<String> = std::fs::read_dir(&strategies)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "s0-t2.exr",
            "s0-t3.exr",
            "s0-t4.exr",
            "s1-t2.exr",
            "s1-t3.exr",
            "s2-t1.exr",
            "s2-t2.exr",
            "s3-t1.exr"
        ],
        "{stderr}"
    );
    let image = pathlight::film::read_exr(&exr).unwrap();
    let mut sum = vec![0.0f64; image.width * image.height * 3];
    for name in &names {
        let part = pathlight::film::read_exr(&strategies.join(name)).unwrap();
        assert_eq!((part.width, part.height), (image.width, image.height), "{name}");
        for (c, channel) in ["R", "G", "B"].iter().enumerate() {
            for (i, v) in part.channels[*channel].iter().enumerate() {
                sum[3 * i + c] += *v as f64;
            }
        }
    }
    for (c, channel) in ["R", "G", "B"].iter().enumerate() {
        for (i, v) in image.channels[*channel].iter().enumerate() {
            // Both are sums of the same f32 contributions in another order: a few ulps of
            // the pixel's value.
            let s = sum[3 * i + c];
            assert!(
                (s - *v as f64).abs() <= 1e-5 * (1.0 + s.abs()),
                "pixel {i} {channel}: strategies sum to {s}, the render is {v}"
            );
        }
    }
    // Asked of the path tracer, the option is refused.
    let out = pathlight()
        .args(["render", scene.to_str().unwrap(), "--backend", "cpu", "--spp", "1", "--width", "8", "-o"])
        .arg(&exr)
        .arg("--bdpt-strategies")
        .arg(&strategies)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("--bdpt-strategies") && stderr.contains("--integrator bdpt"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn auto_backend_prefers_hardware_and_says_why_it_does_not() {
    let dir = temp_dir("auto");
    let exr = dir.join("g.exr");
    let scene = common::scene("cornell-box.gltf");
    let render = |extra: &[&str], no_vulkan: bool| {
        let mut c = pathlight();
        c.args(["render", scene.to_str().unwrap(), "--spp", "2", "--width", "16", "-o"])
            .arg(&exr)
            .args(extra);
        if no_vulkan {
            c.env("VK_DRIVER_FILES", "/nonexistent/icd.json")
                .env("VK_ICD_FILENAMES", "/nonexistent/icd.json");
        }
        let out = c.output().unwrap();
        (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    if let Some(ctx) = common::gpu() {
        // The default: a hardware GPU renders; a software rasteriser (lavapipe in CI) does
        // not, and the message says so.
        let (ok, stderr) = render(&[], false);
        assert!(ok, "{stderr}");
        if ctx.info.device_type == wgpu::DeviceType::Cpu {
            assert!(
                stderr.contains("is a software rasteriser") && stderr.contains("backend cpu"),
                "{stderr}"
            );
            assert!(
                pathlight::film::read_exr(&exr).unwrap().attributes["pathlight.backend"].starts_with("cpu")
            );
        } else {
            assert!(stderr.contains("backend gpu"), "{stderr}");
        }
        // --backend gpu forces the Vulkan device, software or not.
        let (ok, stderr) = render(&["--backend", "gpu"], false);
        assert!(ok && stderr.contains("backend gpu") && stderr.contains("kernel specialised to"), "{stderr}");
        let attributes = pathlight::film::read_exr(&exr).unwrap().attributes;
        assert!(attributes["pathlight.backend"].starts_with("gpu"));
        // Its default splitting is the device kind's (`render::default_splits`).
        let device = pathlight::render::RenderDevice::of(Some(&ctx));
        assert_eq!(attributes["pathlight.splits"], pathlight::render::default_splits(device).to_string());
    }
    // No Vulkan driver visible: auto renders on the CPU and says so ...
    let (ok, stderr) = render(&[], true);
    assert!(ok, "{stderr}");
    assert!(stderr.contains("no Vulkan adapter found; rendering on the CPU backend"), "{stderr}");
    assert!(stderr.contains("backend cpu"), "{stderr}");
    // ... while an explicit GPU request is an error, not a silent fallback.
    let (ok, stderr) = render(&["--backend", "gpu"], true);
    assert!(!ok && stderr.contains("no Vulkan adapter found"), "{stderr}");
    let (ok, stderr) = render(&["--device", "no-such-gpu"], false);
    assert!(!ok);
    assert!(stderr.contains("no-such-gpu") || stderr.contains("no Vulkan adapter"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn info_lists_adapters() {
    let out = pathlight().arg("info").output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(stdout.contains("CPU reference"), "{stdout}");
    if common::gpu().is_some() {
        assert!(stdout.contains("driver:") && stdout.contains("max storage buffer binding"), "{stdout}");
    }
}

#[test]
fn a_closed_stdout_ends_quietly() {
    // The reader goes away before `info` writes (it enumerates Vulkan adapters first, tens
    // of milliseconds): no panic, and status 141 (SIGPIPE's) — or 0 if it won the race.
    let mut child = pathlight()
        .arg("info")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(matches!(out.status.code(), Some(141) | Some(0)), "status {:?}: {stderr}", out.status);
}

#[test]
fn unwritable_outputs_fail_before_rendering() {
    let dir = temp_dir("unwritable");
    let scene = common::scene("cornell-box.gltf");
    // A huge render that would take minutes: the check must come first, so this is quick.
    let run = |output: &std::path::Path| {
        let start = std::time::Instant::now();
        let out = pathlight()
            .args(["render", scene.to_str().unwrap(), "--backend", "cpu", "--spp", "100000"])
            .arg("-o")
            .arg(output)
            .output()
            .unwrap();
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned(), start.elapsed())
    };
    let missing = dir.join("missing/folder/out.exr");
    let (code, stderr, took) = run(&missing);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("missing/folder") && stderr.contains("does not exist"), "{stderr}");
    assert!(took.as_secs() < 30, "failed only after {took:?}: it rendered first");
    let folder = dir.join("a-folder.png");
    std::fs::create_dir_all(&folder).unwrap();
    let (code, stderr, _) = run(&folder);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("is a folder"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `bench --peer` on the Cornell box at 8×8, a 4-spp reference and series of one
/// checkpoint, into `dir`, with `extra` options: (succeeded, stderr).
fn tiny_peer_bench(dir: &std::path::Path, extra: &[&str]) -> (bool, String) {
    let out = pathlight()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["bench", "--no-gpu", "--width", "8", "--height", "8", "--reference-spp", "4"])
        .args(["--peer-seconds", "0.001", "--out"])
        .arg(dir)
        .args(extra)
        .arg("cornell-box")
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn peer_bench_without_the_peer_is_a_clear_error() {
    // `bench --peer` renders the reference, then pathlight's series, then runs the peer's
    // script; a Python without Mitsuba (here: none at all) must end in an error that says
    // what could not run, after the reference and the series were written.
    let dir = temp_dir("peer");
    let (ok, stderr) = tiny_peer_bench(&dir, &["--peer", "mitsuba", "--python", "/nonexistent/python3"]);
    assert!(!ok, "{stderr}");
    assert!(stderr.contains("could not run /nonexistent/python3"), "{stderr}");
    assert!(dir.join("cornell-box/reference.exr").exists(), "no reference written");
    let series = std::fs::read_to_string(dir.join("cornell-box/pathlight-cpu.csv")).unwrap();
    assert!(series.starts_with("spp,seconds,relmse\n1,"), "{series}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn pbrt_peer_bench_without_pbrt_is_a_clear_error_after_each_integrators_series() {
    // `bench --peer pbrt --integrator path,bdpt`: the reference, a series per integrator,
    // then the scene converted (bench/pbrt_peer.py, which needs numpy) and pbrt run; a
    // missing pbrt must be named, after the series were written.
    let dir = temp_dir("pbrt-peer");
    let (ok, stderr) = tiny_peer_bench(
        &dir,
        &["--peer", "pbrt", "--integrator", "path,bdpt", "--pbrt", "/nonexistent/pbrt"],
    );
    assert!(!ok, "{stderr}");
    for file in ["pathlight-cpu.csv", "pathlight-cpu-bdpt.csv"] {
        let series = std::fs::read_to_string(dir.join("cornell-box").join(file)).unwrap();
        assert!(series.starts_with("spp,seconds,relmse\n1,"), "{file}: {series}");
    }
    // Which step fails depends on this machine's Python, and the message must say which.
    let numpy = Command::new("python3").args(["-c", "import numpy"]).status().is_ok_and(|s| s.success());
    if numpy {
        assert!(stderr.contains("could not run pbrt (/nonexistent/pbrt)"), "{stderr}");
        assert!(dir.join("cornell-box/pbrt-bdpt.pbrt").exists(), "the converted scene is missing");
    } else {
        assert!(stderr.contains("pbrt_peer.py: converting cornell-box failed"), "{stderr}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_max_depth_bounds_pbrt_and_metropolis_asks_for_it() {
    // Metropolis renders to depth 10 by default: without a bound the reference would be
    // unbounded, so the bench asks for one before rendering anything.
    let dir = temp_dir("bench-depth");
    let (ok, stderr) = tiny_peer_bench(&dir, &["--peer", "pbrt", "--integrator", "mlt"]);
    assert!(!ok && stderr.contains("--integrator mlt") && stderr.contains("--max-depth"), "{stderr}");
    assert!(!dir.join("cornell-box/reference.exr").exists(), "rendered before refusing");
    let (ok, stderr) = tiny_peer_bench(&dir, &["--peer", "mitsuba", "--max-depth", "7"]);
    assert!(!ok && stderr.contains("--max-depth: the Mitsuba peer"), "{stderr}");
    // With pbrt the bound reaches the converted scene (where numpy lets it be converted).
    let (ok, stderr) =
        tiny_peer_bench(&dir, &["--peer", "pbrt", "--max-depth", "7", "--pbrt", "/nonexistent/pbrt"]);
    assert!(!ok, "{stderr}");
    let numpy = Command::new("python3").args(["-c", "import numpy"]).status().is_ok_and(|s| s.success());
    if numpy {
        let converted = std::fs::read_to_string(dir.join("cornell-box/pbrt-bdpt.pbrt")).unwrap();
        assert!(converted.contains(r#""integer maxdepth" [7]"#), "{converted}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn shards_render_and_merge_from_the_command_line() {
    let dir = temp_dir("shards");
    let scene = common::scene("cornell-box.gltf");
    let render = |extra: &[&str], out: &std::path::Path| {
        let mut c = pathlight();
        c.args([
            "render",
            scene.to_str().unwrap(),
            "--backend",
            "cpu",
            "--spp",
            "6",
            "--width",
            "24",
            "--height",
            "16",
        ]);
        c.args(extra).arg("-o").arg(out);
        c.output().unwrap()
    };
    let parts: Vec<_> = (0..3).map(|i| dir.join(format!("part{i}.exr"))).collect();
    for (i, p) in parts.iter().enumerate() {
        let o = render(&["--shard", &format!("{i}/3")], p);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(String::from_utf8_lossy(&o.stderr).contains(&format!(
            "rendering samples {}..{} of 6",
            2 * i,
            2 * i + 2
        )));
    }
    let merged = dir.join("merged.exr");
    let o = pathlight().arg("merge").args(&parts).arg("-o").arg(&merged).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("merged 3 part(s): samples 0..6 of the render's 6"));
    // Bad shards and ranges are refused before any work, naming what is wrong.
    for (args, message) in [
        (&["--shard", "3/3"][..], "I must be below N"),
        (&["--shard", "1/0"][..], "I must be below N"),
        (&["--shard", "0/7"][..], "leave part 0 none"),
        (&["--samples", "4..2"][..], "START must be below END"),
        (&["--samples", "0..9"][..], "A < B ≤ --spp (6)"),
        (&["--samples", "0..3", "--time-limit", "5"][..], "renders its whole range"),
    ] {
        let o = render(args, &dir.join("bad.exr"));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(message), "{args:?}: {err}");
    }
    let o = render(&["--shard", "0/3"], &dir.join("part.png"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("needs an .exr output"), "{err}");
    // A gap: parts 0 and 2 only.
    let o = pathlight()
        .arg("merge")
        .arg(&parts[0])
        .arg(&parts[2])
        .arg("-o")
        .arg(dir.join("gap.exr"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("samples 2..4 are missing"), "{err}");
}

/// `render --denoise` writes the denoised image as R, G, B with the raw mean, its variance
/// and the AOVs beside it; `pathlight denoise` of that file (which reads `raw.*`) makes the
/// same image; `render --aov` alone leaves R, G, B raw.
#[test]
fn denoised_renders_and_the_denoise_command_agree() {
    let dir = temp_dir("denoise");
    let scene = common::scene("cornell-box.gltf");
    let render = |extra: &[&str], out: &std::path::Path| {
        let mut c = pathlight();
        c.args([
            "render",
            scene.to_str().unwrap(),
            "--backend",
            "cpu",
            "--spp",
            "8",
            "--width",
            "48",
            "--seed",
            "2",
        ])
        .args(extra)
        .arg("-o")
        .arg(out);
        let out = c.output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let (plain, aov, denoised) = (dir.join("plain.exr"), dir.join("aov.exr"), dir.join("denoised.exr"));
    render(&[], &plain);
    render(&["--aov", "albedo,normal"], &aov);
    let stderr = render(&["--denoise"], &denoised);
    assert!(stderr.contains("denoised by atrous"), "{stderr}");
    let (plain, aov, den) = (
        pathlight::film::read_exr(&plain).unwrap(),
        pathlight::film::read_exr(&aov).unwrap(),
        pathlight::film::read_exr(&denoised).unwrap(),
    );
    // The same samples: --aov leaves the image alone, --denoise moves it to raw.*.
    assert_eq!(plain.channels["R"], aov.channels["R"]);
    assert!(aov.channels.contains_key("albedo.R") && aov.channels.contains_key("normal.Z"));
    assert!(!aov.channels.contains_key("depth.Z"), "only the AOVs asked for");
    assert_eq!(plain.channels["R"], den.channels["raw.R"]);
    assert_eq!(plain.channels["variance.G"], den.channels["variance.G"]);
    assert_ne!(den.channels["R"], den.channels["raw.R"]);
    assert_eq!(den.attributes["pathlight.denoiser"], "atrous");
    for c in ["albedo.R", "normal.X", "depth.Z", "emission.R", "coverage.Y"] {
        assert!(den.channels.contains_key(c), "--denoise writes {c}");
    }
    // Denoising the file again from its raw mean gives the same image.
    let again = dir.join("again.exr");
    let out = pathlight().arg("denoise").arg(&denoised).arg("-o").arg(&again).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let again = pathlight::film::read_exr(&again).unwrap();
    assert_eq!(again.channels["R"], den.channels["R"]);
    assert_eq!(again.channels["raw.R"], den.channels["raw.R"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// What denoising cannot work from is a clear error naming the file and what is missing.
#[test]
fn denoising_bad_input_is_a_clear_error() {
    let dir = temp_dir("denoise-bad");
    let plain = dir.join("plain.exr");
    assert!(render_cornell_cpu(&[&plain]).status.success());
    let run = |args: &[&str]| {
        let out = pathlight().args(args).output().unwrap();
        assert!(!out.status.success(), "{args:?} should fail");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let out = dir.join("out.exr");
    let (plain_s, out_s) = (plain.to_str().unwrap(), out.to_str().unwrap());
    let e = run(&["denoise", plain_s, "-o", out_s]);
    assert!(e.contains("plain.exr") && e.contains("albedo.R") && e.contains("--aov"), "{e}");
    let e = run(&["denoise", "no-such-file.exr", "-o", out_s]);
    assert!(e.contains("no-such-file.exr"), "{e}");
    let e = run(&["denoise", plain_s, "-o", out_s, "--denoiser", "nlm"]);
    assert!(e.contains("atrous") && e.contains("oidn"), "the choices are listed: {e}");
    let scene = common::scene("cornell-box.gltf");
    let e = run(&["render", scene.to_str().unwrap(), "-o", out_s, "--aov", "albedo,shadow"]);
    assert!(e.contains("shadow") && e.contains("emission"), "{e}");
    let e = run(&["render", scene.to_str().unwrap(), "-o", out_s, "--denoiser", "atrous"]);
    assert!(e.contains("--denoise"), "--denoiser needs --denoise: {e}");
    if !cfg!(feature = "oidn") {
        let e = run(&["render", scene.to_str().unwrap(), "-o", out_s, "--denoise", "--denoiser", "oidn"]);
        assert!(e.contains("without Open Image Denoise"), "{e}");
        assert!(!out.exists(), "refused before rendering");
    }
    let e = run(&["render", scene.to_str().unwrap(), "-o", out_s, "--adaptive", "--spp", "4"]);
    assert!(e.contains("--adaptive-min-spp 16 exceeds --spp 4"), "{e}");
    let e = run(&["render", scene.to_str().unwrap(), "-o", out_s, "--adaptive-threshold", "0.1"]);
    assert!(e.contains("--adaptive"), "the threshold needs --adaptive: {e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `render --adaptive` says what it decided and records the counts.
#[test]
fn adaptive_renders_report_their_counts() {
    let dir = temp_dir("adaptive");
    let exr = dir.join("a.exr");
    let scene = common::scene("cornell-box.gltf");
    let out = pathlight()
        .args(["render", scene.to_str().unwrap(), "--backend", "cpu", "--spp", "128", "--width", "32"])
        .args(["--adaptive", "--adaptive-threshold", "0.1", "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("adaptive: pilot of 16 spp") && stderr.contains("of pixels at --spp 128"),
        "{stderr}"
    );
    let image = pathlight::film::read_exr(&exr).unwrap();
    let counts = &image.channels["sampleCount"];
    assert!(counts.iter().all(|&c| (8.0..=128.0).contains(&c)), "counts within the bounds");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `compare` reads a denoised EXR's raw mean, the one its variance describes: a denoised
/// render compares as the same image as the plain render of the same samples.
#[test]
fn compare_reads_the_raw_mean_of_a_denoised_exr() {
    let dir = temp_dir("compare-denoised");
    let scene = common::scene("cornell-box.gltf");
    let (plain, denoised) = (dir.join("plain.exr"), dir.join("denoised.exr"));
    for (path, extra) in [(&plain, None), (&denoised, Some("--denoise"))] {
        let mut c = pathlight();
        c.args([
            "render",
            scene.to_str().unwrap(),
            "--backend",
            "cpu",
            "--spp",
            "8",
            "--width",
            "32",
            "--seed",
            "4",
        ]);
        c.args(extra).arg("-o").arg(path);
        assert!(c.output().unwrap().status.success());
    }
    let a = pathlight::film::LinearImage::read(&plain).unwrap();
    let b = pathlight::film::LinearImage::read(&denoised).unwrap();
    assert_eq!(a.rgb, b.rgb);
    assert_eq!(a.variance, b.variance);
    let _ = std::fs::remove_dir_all(&dir);
}
