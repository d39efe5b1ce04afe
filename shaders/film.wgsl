// Twin of `film_add_sample` in src/film/mod.rs: Welford's update (Welford 1962); non-finite
// samples are counted and never accumulated.

fn film_add_sample(p_in: FilmPixel, x: vec3<f32>) -> FilmPixel {
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
    return p;
}
