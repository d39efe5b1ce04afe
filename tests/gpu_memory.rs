//! The GPU backend runs in constant memory: after warm-up, more passes (and film readbacks)
//! do not grow the process. Its own test binary, so no other test's allocations share the
//! process whose memory it measures.
//!
//! Mesa 22.3's lavapipe JIT-compiled and kept a new kernel variant every time a uniform
//! buffer whose values steer control flow was re-bound: about 1.2 MB per submit while
//! `camera` and `frame` were uniforms (issue 6; see shaders/bindings.wgsl).

mod common;

use pathlight::gpu::GpuBackend;
use pathlight::{Backend, RenderSettings};

/// This process's resident set and its high-water mark, in KiB, from /proc/self/status.
fn rss_and_peak_kib() -> (u64, u64) {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    let field = |name: &str| -> u64 {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no {name} in /proc/self/status"))
    };
    (field("VmRSS:"), field("VmHWM:"))
}

#[test]
fn gpu_memory_is_constant_across_passes() {
    let Some(ctx) = common::gpu() else { return };
    let size = 48;
    let scene = common::flat_scene(&common::scene("cornell-box.gltf"), size, size);
    let settings = RenderSettings { width: size, height: size, spp: 1, ..RenderSettings::default() };
    let mut backend = GpuBackend::new(ctx, &scene, &settings).unwrap();
    // One sample per pass, so every pass is at least one submit; a readback now and then, as
    // the viewer and progress reporting do.
    let mut pass = 0u32;
    let mut run = |passes: u32, backend: &mut GpuBackend| {
        for _ in 0..passes {
            backend.render(pass, 1).unwrap();
            pass += 1;
            if pass % 20 == 0 {
                backend.film().unwrap();
            }
        }
    };
    // Warm-up: the kernel is built, the submit size settles, pools and arenas reach their
    // working size.
    run(30, &mut backend);
    let (rss_before, peak_before) = rss_and_peak_kib();
    let measured = 200;
    run(measured, &mut backend);
    let (rss_after, peak_after) = rss_and_peak_kib();
    let film = backend.film().unwrap();
    assert_eq!(film.total_samples() + film.total_rejected(), (size * size * pass) as u64);

    let growth = rss_after.saturating_sub(rss_before).max(peak_after.saturating_sub(peak_before));
    eprintln!(
        "{measured} passes after warm-up: VmRSS {rss_before} → {rss_after} KiB, VmHWM {peak_before} → {peak_after} KiB"
    );
    // Bound: the steady-state loop keeps nothing alive past a pass, so only allocator noise
    // remains: glibc grows and trims its arenas in steps of 128 KiB (M_TOP_PAD) and wgpu's
    // pools touch pages they already reserved. 8 MiB is tens of such steps, yet a leak of
    // 40 KiB per pass would exceed it; the lavapipe recompile leak added ~240 MB here.
    let bound_kib = 8 * 1024;
    assert!(
        growth <= bound_kib,
        "memory grew by {growth} KiB over {measured} passes (bound {bound_kib} KiB): VmRSS {rss_before} → {rss_after}, VmHWM {peak_before} → {peak_after}"
    );
}
