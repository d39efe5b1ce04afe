// Twin of src/integrator/roulette.rs: Russian roulette and the bounce limits every
// integrator's paths obey (the CPU twin explains the choices).

const MAX_BOUNCES_GUARD: u32 = 1024u;
const RR_MAX_SURVIVAL: f32 = 0.95;
const RR_ANY_BOUNCE_DEPTH: u32 = 8u;
// Light-path vertices after which roulette may end a light path (the light tracer's and
// bidirectional path tracing's).
const LIGHT_RR_MIN_VERTICES: u32 = 2u;

// The probability that a path of throughput `beta` (with `eta_scale`, the product of η² over
// its refractions) survives roulette.
fn survival_probability(beta: vec3<f32>, eta_scale: f32) -> f32 {
    return min(max_element(beta * eta_scale), RR_MAX_SURVIVAL);
}
