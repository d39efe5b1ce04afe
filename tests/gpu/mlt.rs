//! Metropolis's WGSL twin (shaders/mlt.wgsl over shaders/bdpt.wgsl's strategies) against
//! the CPU half: the same bootstrap, the same chain starts (drawn on the host from the
//! bootstrap's targets by the same code) and the same mutations from the same streams, so
//! the same chains and the same image to rounding. tests/mlt.rs shows the CPU half agrees
//! with BDPT and the furnace's analytic answer; with the chains equal, so does the GPU.

use super::*;
use pathlight::integrator::mlt::{MltSettings, MltStats};

/// Metropolis at 32×32, 2 passes, seed 9, paths of up to 10 bounces (its default), 64
/// chains (of 32 mutations each: many lanes busy at once, where the default's 2 chains
/// would leave lavapipe's SIMD lanes idle and the test slow).
fn mlt_settings() -> RenderSettings {
    RenderSettings {
        integrator: Integrator::Mlt,
        mlt: MltSettings { chains: Some(64), ..MltSettings::default() },
        ..settings(32, 2, 9)
    }
}

/// One scene per kind of light a Metropolis sample starts from or joins to: emissive
/// triangles (the Cornell box, and the room lit through a slit, where the chains matter
/// most) and delta lights (point, spot and directional). Other feature sets are left out
/// because each is a kernel that lavapipe builds cold in about 40 s; the strategies they
/// add are BDPT's, which tests/gpu/bdpt.rs checks on every scene.
const MLT_SCENES: &[&str] = &["cornell-box.gltf", "slit-room.gltf", "punctual.gltf"];

/// Same seed, same image to rounding (1e-3 relative, as `same_seed_agrees_within` states,
/// in all but 2% of pixels), and the same chains: the same passes, proposals and dropped
/// samples (none), and acceptances and rays within 1%. The second pass's chains weigh their
/// targets by the importance map each backend made from its own film of the first (the
/// default `--mlt-target relative`), which agree to rounding as the films do. The 2% and the 1% are for a chain
/// that rounding parts from its twin: an acceptance decided by a random number within a few
/// ulps of the acceptance ratio goes the other way, and the chain walks elsewhere from then
/// on (at 4 passes, on the Cornell box one pixel of 1,024 differed by more than 1e-3 when
/// this was written, and the acceptances and rays were equal on all three scenes).
#[test]
fn mlt_same_seed_makes_the_same_chains() {
    let Some(ctx) = common::gpu() else { return };
    let s = mlt_settings();
    for file in MLT_SCENES {
        let scene = common::flat_scene(&common::scene(file), 32, 32);
        let mut cpu = CpuBackend::new(&scene, &s);
        let a = common::render(&mut cpu, s.spp);
        let mut gpu = GpuBackend::new(ctx.clone(), &scene, &s).unwrap();
        let b = common::render(&mut gpu, s.spp);
        let disagree = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(x, y)| {
                let (x, y) = (Vec3::from(x.mean), Vec3::from(y.mean));
                let scale = x.max_element().max(y.max_element()).max(1e-6);
                (x - y).abs().max_element() > 1e-3 * scale
            })
            .count();
        eprintln!("{file}: {disagree} of 1024 pixels differ by more than 1e-3 with the same seed");
        assert!(disagree * 100 <= 2 * 1024, "{file}: {disagree} of 1024 pixels differ beyond rounding");
        let (a, b): (MltStats, MltStats) = (cpu.mlt_stats().unwrap(), gpu.mlt_stats().unwrap());
        eprintln!("{file}: cpu {a:?}\n{file}: gpu {b:?}");
        assert_eq!(
            (a.passes, a.proposed, a.passes_without_light),
            (b.passes, b.proposed, b.passes_without_light)
        );
        assert_eq!(b.dropped_samples, 0, "{file}: samples read past the GPU's bound");
        assert!(
            a.accepted.abs_diff(b.accepted) * 100 <= a.accepted,
            "{file}: accepted {} vs {}",
            a.accepted,
            b.accepted
        );
        assert!(
            b.rays > 0 && a.rays.abs_diff(b.rays) * 100 <= a.rays,
            "{file}: rays {} vs {}",
            a.rays,
            b.rays
        );
    }
}

/// The viewer's way (each pass in bands of rows: the whole pass traced for its first band,
/// each band then resolved alone) gives the very same film as whole passes: the chains'
/// state and the splats' fixed-point sums do not depend on how the work was cut.
#[test]
fn mlt_banded_passes_equal_whole_passes() {
    let Some(ctx) = common::gpu() else { return };
    let s = mlt_settings();
    let scene = common::flat_scene(&common::scene("cornell-box.gltf"), 32, 32);
    let whole = common::render(&mut GpuBackend::new(ctx.clone(), &scene, &s).unwrap(), s.spp);
    let mut banded = GpuBackend::new(ctx, &scene, &s).unwrap();
    for k in 0..s.spp {
        for rows in [0..8, 8..16, 16..24, 24..32] {
            banded.render_rows(k, rows).unwrap();
        }
    }
    let banded = banded.film().unwrap();
    for (i, (a, b)) in whole.pixels.iter().zip(&banded.pixels).enumerate() {
        assert_eq!(a.mean, b.mean, "pixel {i}: whole passes vs bands");
    }
}
