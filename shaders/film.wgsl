// Twin of `film_add_sample` in src/film/mod.rs: Welford's update (Welford 1962); non-finite
// samples are counted and never accumulated.

fn film_add_sample(p_in: FilmPixel, x: vec3<f32>, replicate: u32) -> FilmPixel {
    var p = p_in;
    if (!is_finite_vec3(x)) {
        p.rejected += 1u;
        return p;
    }
    p.count += 1u;
    let n = f32(p.count);
    let delta = x - p.mean;
    p.mean = p.mean + delta / n;
    p.m2 = p.m2 + delta * (x - p.mean);
    if (replicate == 1u) {
        p.odd_count += 1u;
        p.odd_mean = p.odd_mean + (x - p.odd_mean) / f32(p.odd_count);
    }
    return p;
}
