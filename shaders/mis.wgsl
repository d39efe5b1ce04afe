// Twin of src/integrator/mis.rs: multiple importance sampling weights.

// Power heuristic, β = 2 (Veach 1997, §9.2.4), through the ratio of the smaller density to
// the larger so nothing is squared past f32's range.
fn power_heuristic(pdf_this: f32, pdf_other: f32) -> f32 {
    if (pdf_this <= 0.0) {
        return 0.0;
    }
    if (pdf_this >= pdf_other) {
        let r = pdf_other / pdf_this;
        return 1.0 / (1.0 + r * r);
    }
    let r = pdf_this / pdf_other;
    return r * r / (1.0 + r * r);
}
