//! The restart trail's bit arithmetic (Laine 2010, "Restart Trail for Stackless BVH
//! Traversal", HPG, §3): the twins of `trail_bit`, `trail_through`, `trail_pop` and
//! `trail_depth` in shaders/bvh.wgsl, which spell the u64 operations out on two 32-bit
//! words (tests/gpu/kernel_variants.rs holds them to these).

use super::build::MAX_DEPTH;

// The trail holds one bit per depth below the root: MAX_DEPTH counts the root as depth 1, so
// the deepest child is at depth MAX_DEPTH − 1 here, where the root is depth 0.
const _: () = assert!(MAX_DEPTH - 1 <= 64, "the restart trail is 64 bits");

/// The trail's bit for depth `depth` (1 ..= 64): bit 64 − depth, so that deeper levels are
/// less significant and marking a node done is one addition, whose carry moves up past the
/// levels that are finished too (Laine 2010 §3).
#[inline(always)]
pub fn trail_bit(depth: u32) -> u64 {
    1u64 << (64 - depth)
}

/// `trail`'s bits for depths 1 ..= `depth` (1 ..= 64).
#[inline(always)]
pub fn trail_through(trail: u64, depth: u32) -> u64 {
    trail & (!0u64 << (64 - depth))
}

/// The trail once the node at `depth` (≥ 1) is done: its deeper bits cleared and its own
/// bit added, carrying into its ancestors whose last child it was. Zero when the carry
/// leaves the top: the whole tree is done.
#[inline(always)]
pub fn trail_pop(trail: u64, depth: u32) -> u64 {
    trail_through(trail, depth).wrapping_add(trail_bit(depth))
}

/// The depth of `trail`'s lowest set bit (`trail` ≠ 0): where traversal goes on after a pop.
#[inline(always)]
pub fn trail_depth(trail: u64) -> u32 {
    64 - trail.trailing_zeros()
}

/// Does a tree `max_depth` levels deep (the root counted as 1, as [`super::BvhStats`] counts)
/// need the trail's second 32-bit word in the kernel (`FEATURE_DEEP_TREE`)? The first holds
/// depths 1 ..= 32 below the root, and the deepest child lies at `max_depth − 1`.
pub fn needs_second_word(max_depth: usize) -> bool {
    max_depth.saturating_sub(1) > 32
}
