//! Error against time: one renderer's series of (spp, seconds, relMSE), the time it takes
//! to reach an error and the error it has at a time (interpolated in log–log, where Monte
//! Carlo error falls as 1/t), and the peer benchmark's summary table built from them.

use super::peer::PeerResult;
use crate::integrator::Integrator;
use crate::sampling::SamplerKind;

/// One renderer's error against time: (spp, seconds, relMSE) at each checkpoint.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(u32, f64, f64)>,
    /// What rendered it, for a pathlight series (`None` for a peer's).
    pub key: Option<SeriesKey>,
}

impl Series {
    /// `session` rendered progressively until `seconds` have passed, its relMSE against
    /// `reference` taken at 1, 2, 4, … samples per pixel (the time spent measuring the
    /// error left out of the series' times), and printed as it goes under `label`. The
    /// session's spp bounds the render.
    pub fn of_session(
        session: &mut crate::session::Session,
        label: &str,
        seconds: f64,
        reference: &crate::film::LinearImage,
    ) -> crate::Result<Series> {
        let mut s = Series { label: label.to_string(), points: Vec::new(), key: None };
        let start = std::time::Instant::now();
        let mut excluded = 0.0;
        let spp = session.settings.spp;
        session.render_to(spp, &std::sync::atomic::AtomicBool::new(false), |backend, done| {
            let elapsed = start.elapsed().as_secs_f64() - excluded;
            if done.is_power_of_two() {
                let t = std::time::Instant::now();
                let film = backend.film()?;
                let e = crate::film::error_against(&crate::film::LinearImage::from_film(&film), reference).1;
                excluded += t.elapsed().as_secs_f64();
                s.points.push((done, elapsed, e));
                eprintln!("{label}: {done} spp, {elapsed:.2} s, relMSE {e:.3e}");
            }
            Ok(elapsed > seconds && done.is_power_of_two())
        })?;
        Ok(s)
    }
}

/// A pathlight series' backend, integrator and sampler: the integrator table pairs series
/// that differ in the integrator alone.
#[derive(Clone, Debug, PartialEq)]
pub struct SeriesKey {
    /// `cpu` or `gpu` (not the backend's name, which also says what its integrator does).
    pub backend: String,
    pub integrator: Integrator,
    pub sampler: SamplerKind,
}

impl Series {
    /// Seconds to reach relMSE `error`, interpolated log–log between the checkpoints around
    /// it (relMSE falls as 1/t for an unbiased renderer, a line on log–log axes); `None`
    /// if the series never gets there.
    pub fn time_to_error(&self, error: f64) -> Option<f64> {
        let p = &self.points;
        let i = p.iter().position(|&(_, _, e)| e <= error)?;
        if i == 0 {
            // Reached at the first checkpoint: scale its time by the 1/t law.
            let (_, t, e) = p[0];
            return Some(t * e / error);
        }
        let ((_, t0, e0), (_, t1, e1)) = (p[i - 1], p[i]);
        Some(log_lerp(e0, t0, e1, t1, error))
    }

    /// relMSE after `seconds`, interpolated log–log; `None` outside the series.
    pub fn error_at_time(&self, seconds: f64) -> Option<f64> {
        let p = &self.points;
        let i = p.iter().position(|&(_, t, _)| t >= seconds)?;
        if i == 0 {
            return None;
        }
        let ((_, t0, e0), (_, t1, e1)) = (p[i - 1], p[i]);
        Some(log_lerp(t0, e0, t1, e1, seconds))
    }

    /// Seconds to reach relMSE `error`, and whether that was extrapolated past the series'
    /// end by the 1/t law of an unbiased renderer (it ended before getting there); `None`
    /// for an empty series.
    pub fn time_to_error_or_extrapolated(&self, error: f64) -> Option<(f64, bool)> {
        if let Some(t) = self.time_to_error(error) {
            return Some((t, false));
        }
        let (e, t) = self.last()?;
        Some((t * e / error, true))
    }

    /// The last checkpoint's relMSE and seconds.
    pub fn last(&self) -> Option<(f64, f64)> {
        self.points.last().map(|&(_, t, e)| (e, t))
    }

    pub fn csv(&self) -> String {
        let mut s = String::from("spp,seconds,relmse\n");
        for (spp, t, e) in &self.points {
            s += &format!("{spp},{t:.6},{e:.8e}\n");
        }
        s
    }
}

/// y at x on the line through (x0, y0) and (x1, y1) in log–log coordinates.
fn log_lerp(x0: f64, y0: f64, x1: f64, y1: f64, x: f64) -> f64 {
    if x0 == x1 {
        return y1;
    }
    let f = (x.ln() - x0.ln()) / (x1.ln() - x0.ln());
    (y0.ln() + f * (y1.ln() - y0.ln())).exp()
}

/// The results as Markdown: one row per pathlight backend and scene.
pub fn markdown(results: &[PeerResult]) -> String {
    let mut s = String::new();
    if let Some(peer) = results.iter().find_map(|r| r.peer.as_ref()) {
        s += &format!("Peer: {}\n\n", peer.label);
    }
    s += "| scene | same image as the peer? | pathlight series | relMSE compared | pathlight s | peer s | speed vs the peer (time to equal error) | at equal time | relMSE pathlight | relMSE peer | speed vs the peer's low-discrepancy sampler |\n";
    s += "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for r in results {
        let same = match &r.agreement {
            Some(a) if a.same() => "yes (z-test passes)".to_string(),
            Some(a) => format!("**no**: {}", a.failures.join("; ")),
            None => "(peer not run)".into(),
        };
        for p in &r.pathlight {
            // Pairwise with the peer: the lower error both series reached, the shorter time.
            let error = compared_error(p, r.peer.as_ref());
            let time = [p]
                .into_iter()
                .chain(&r.peer)
                .map(|s| s.last().map(|l| l.1))
                .try_fold(f64::INFINITY, |m, t| t.map(|t| m.min(t)));
            let t_pl = error.and_then(|e| p.time_to_error(e));
            let t_mi = error.zip(r.peer.as_ref()).and_then(|(e, peer)| peer.time_to_error(e));
            let e_pl = time.and_then(|t| p.error_at_time(t));
            let e_mi = time.zip(r.peer.as_ref()).and_then(|(t, peer)| peer.error_at_time(t));
            let f = |v: Option<f64>, d: usize| v.map_or("-".into(), |v| format!("{v:.d$}"));
            let g = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3e}"));
            let ratio = match (t_pl, t_mi) {
                (Some(a), Some(b)) => format!("{:.2}×", b / a),
                _ => "-".into(),
            };
            let ratio_low_discrepancy = r
                .peer_low_discrepancy
                .as_ref()
                .and_then(|peer| speed_ratio(p, peer))
                .map_or("-".into(), |x| format!("{x:.2}×"));
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.scene,
                same,
                p.label.trim_start_matches("pathlight "),
                g(error),
                f(t_pl, 2),
                f(t_mi, 2),
                ratio,
                time.map_or("-".into(), |t| format!("{t:.1} s")),
                g(e_pl),
                g(e_mi),
                ratio_low_discrepancy,
            );
        }
    }
    s += &reference_noise_lines(results);
    s
}

/// pathlight's integrators against its path tracer, on each scene and backend: time to
/// equal error and relMSE at equal time (issue 43's goals are read off this table). Each
/// series that is not the path tracer's is paired with the path tracer's series of the same
/// backend and sampler; `None` when no scene has such a pair.
pub fn integrator_markdown(results: &[PeerResult]) -> Option<String> {
    let mut s = String::new();
    s += "| scene | backend | integrator | vs path: time to equal error | relMSE compared | at equal time | relMSE path | relMSE integrator | path ÷ integrator at equal time |\n";
    s += "|---|---|---|---:|---:|---:|---:|---:|---:|\n";
    let mut rows = 0;
    for r in results {
        for p in &r.pathlight {
            let Some(key) = p.key.as_ref().filter(|k| k.integrator != Integrator::Path) else { continue };
            let path_key = SeriesKey { integrator: Integrator::Path, ..key.clone() };
            let Some(path) = r.pathlight.iter().find(|q| q.key.as_ref() == Some(&path_key)) else { continue };
            let error = p.last().zip(path.last()).map(|(a, b)| a.0.max(b.0));
            let time = p.last().zip(path.last()).map(|(a, b)| a.1.min(b.1));
            let e_path = time.and_then(|t| path.error_at_time(t));
            let e_p = time.and_then(|t| p.error_at_time(t));
            let g = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3e}"));
            let x = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.2}×"));
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.scene,
                key.backend,
                key.integrator,
                x(speed_ratio(p, path)),
                g(error),
                time.map_or("-".into(), |t| format!("{t:.1} s")),
                g(e_path),
                g(e_p),
                x(e_path.zip(e_p).map(|(a, b)| a / b)),
            );
            rows += 1;
        }
    }
    (rows > 0).then_some(s)
}

/// How many times faster `a` reaches the lower error both series reached than `b` does
/// (time to equal error, `b`'s time over `a`'s).
fn speed_ratio(a: &Series, b: &Series) -> Option<f64> {
    let error = a.last()?.0.max(b.last()?.0);
    Some(b.time_to_error(error)? / a.time_to_error(error)?)
}

/// The error a row reads time to equal error at: the larger of the last errors of the
/// pathlight series and the peer's, the lowest both reached (`None` if either is empty).
fn compared_error(pathlight: &Series, peer: Option<&Series>) -> Option<f64> {
    [pathlight]
        .into_iter()
        .chain(peer)
        .map(|s| s.last().map(|l| l.0))
        .try_fold(0.0f64, |m, e| e.map(|e| m.max(e)))
}

/// Under the table, a line per scene on its reference's own error against the smallest
/// error compared (what each row's time to equal error is read at), with a warning where
/// the reference's noise is more than a tenth of it ([`super::peer::ReferenceNoise`]).
fn reference_noise_lines(results: &[PeerResult]) -> String {
    let mut s = String::new();
    for r in results {
        let Some(noise) = r.reference_noise else { continue };
        let compared = r
            .pathlight
            .iter()
            .filter_map(|p| compared_error(p, r.peer.as_ref()))
            .fold(f64::INFINITY, f64::min);
        s += &format!(
            "\n{}: the reference's own relMSE is {:.2e} ({})",
            r.scene,
            noise.relmse,
            noise.describe()
        );
        if compared.is_finite() && compared > 0.0 {
            let share = noise.relmse / compared;
            s += &format!(", {:.1}% of the smallest relMSE compared", 100.0 * share);
            if share > REFERENCE_NOISE_WARNING {
                s += ". **More than a tenth: the ratios read near it are uncertain; render a longer \
                      reference (`--reference-spp`).**";
            }
        }
        s += "\n";
    }
    s
}

/// The share of the compared error above which a reference's noise is called out. For
/// series of the form a/t + R read where R is this share of the error, the log–log slope is
/// −0.9 instead of −1, and a time read between checkpoints 4× apart (Mitsuba's `ldsampler`
/// series) comes out 2.5% long, between checkpoints 2× apart 0.6%: below the peer runs'
/// spread from run to run (`bench/history/peers.md`).
const REFERENCE_NOISE_WARNING: f64 = 0.1;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::peer::ReferenceNoise;

    fn series(points: &[(u32, f64, f64)]) -> Series {
        Series { label: "s".into(), points: points.to_vec(), key: None }
    }

    #[test]
    fn time_to_error_follows_the_one_over_t_law() {
        // relMSE = 0.1 / t exactly: log–log interpolation is exact.
        let s = series(&[(1, 1.0, 0.1), (2, 2.0, 0.05), (4, 4.0, 0.025)]);
        assert!((s.time_to_error(0.04).unwrap() - 2.5).abs() < 1e-12);
        assert!((s.error_at_time(3.0).unwrap() - 0.1 / 3.0).abs() < 1e-12);
        // Reached at once: scaled back along 1/t.
        assert!((s.time_to_error(0.2).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(s.time_to_error(0.01), None);
        assert_eq!(s.error_at_time(5.0), None);
        assert_eq!(s.error_at_time(0.5), None);
    }

    fn result(noise: Option<ReferenceNoise>) -> PeerResult {
        PeerResult {
            scene: "box".into(),
            reference_note: String::new(),
            reference_noise: noise,
            // Ends at 2e-4 and 1e-4: the smaller of the two rows' compared errors is 1e-4
            // (each row compares at the larger last error of its series and the peer's).
            pathlight: vec![
                series(&[(1, 1.0, 4e-4), (2, 2.0, 2e-4)]),
                series(&[(1, 1.0, 2e-4), (2, 2.0, 5e-5)]),
            ],
            peer: Some(series(&[(1, 1.0, 2e-4), (2, 2.0, 1e-4)])),
            peer_low_discrepancy: None,
            agreement: None,
        }
    }

    #[test]
    fn a_noisy_reference_is_called_out_under_the_table() {
        let quiet = reference_noise_lines(&[result(Some(ReferenceNoise { relmse: 5e-6, measured: true }))]);
        assert!(quiet.contains("box: the reference's own relMSE is 5.00e-6 (measured), 5.0% of"), "{quiet}");
        assert!(!quiet.contains("More than a tenth"), "{quiet}");
        let noisy =
            reference_noise_lines(&[result(Some(ReferenceNoise { relmse: 2.5e-5, measured: false }))]);
        assert!(
            noisy.contains("2.50e-5 (an upper bound from the file's variance channels), 25.0% of"),
            "{noisy}"
        );
        assert!(noisy.contains("More than a tenth"), "{noisy}");
        assert_eq!(reference_noise_lines(&[result(None)]), "");
    }

    #[test]
    fn integrators_are_compared_with_the_path_tracer_of_their_backend_and_sampler() {
        let key =
            |integrator| Some(SeriesKey { backend: "cpu".into(), integrator, sampler: SamplerKind::Sobol });
        // relMSE 0.1/t for the path tracer, 0.01/t for BDPT: 10× at equal time and error.
        let path = Series {
            key: key(Integrator::Path),
            ..series(&[(1, 1.0, 0.1), (2, 2.0, 0.05), (4, 4.0, 0.025)])
        };
        let bdpt = Series { key: key(Integrator::Bdpt), ..series(&[(1, 1.0, 0.01), (2, 2.0, 0.005)]) };
        let other_sampler = Series {
            key: Some(SeriesKey { sampler: SamplerKind::Independent, ..key(Integrator::Path).unwrap() }),
            ..series(&[(1, 1.0, 0.2)])
        };
        let r = PeerResult { pathlight: vec![path.clone(), other_sampler, bdpt], ..result(None) };
        let table = integrator_markdown(&[r]).unwrap();
        let row = table.lines().find(|l| l.contains("| bdpt |")).unwrap();
        assert!(row.starts_with("| box | cpu | bdpt | 10.00× |"), "{row}");
        assert!(row.ends_with("| 2.0 s | 5.000e-2 | 5.000e-3 | 10.00× |"), "{row}");
        assert_eq!(table.lines().filter(|l| l.starts_with("| box")).count(), 1, "{table}");
        // No pair: no table.
        assert!(integrator_markdown(&[PeerResult { pathlight: vec![path], ..result(None) }]).is_none());
    }
}
