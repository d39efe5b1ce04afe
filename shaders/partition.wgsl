// Twin of src/integrator/partition.rs: the rule by which the path tracer leaves a caustic
// path to the light tracer (the CPU twin explains the partition of path space).

fn caustic_is_light_traced(prev_delta: bool, first_vertex_smooth: bool, emitter: u32) -> bool {
    return prev_delta && first_vertex_smooth && emitter != INVALID_INDEX;
}
