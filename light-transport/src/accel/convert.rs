//! Conversion of a binary BVH into a compressed wide BVH (Ylitie, Karras and Laine 2017, §3:
//! the SAH-based collapse of a binary tree into nodes of up to eight children, with leaves of up
//! to three primitives, and the quantised child boxes of §3.1), producing exactly the tree that
//! obvhs's `bvh2_to_cwbvh(bvh2, max_leaf, true, false)` produces, bit for bit (a test compares
//! them), in a fraction of its memory.
//!
//! The collapse is a dynamic programme: for each binary node `n` and `i = 1 … 7` it finds the
//! cheapest way to turn the subtree under `n` into at most `i` children of a wide node (the node
//! itself as a leaf or an internal wide node, or its slots distributed between its two
//! children's subtrees). obvhs keeps every node's seven costs and decisions in one table of
//! 8-byte entries, 56 bytes per binary node: 118 MB for the benchmarks' 1M-triangle terrain, the
//! largest single allocation of its build. Here a node's costs live only on the recursion's
//! stack until its parent has used them, and each decision is one byte (its kind and the two
//! slot counts it hands to the children), 7 bytes per binary node.

use glam::{Vec3, Vec3A};
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::{CwBvh, node::CwBvhNode};

/// Relative cost of testing one primitive against that of testing one wide node's children
/// (obvhs's value).
const PRIM_COST: f32 = 0.3;

/// One over the largest quantised coordinate: child boxes are stored in 8 bits per plane.
const DENOM: f32 = 1.0 / 255.0;

/// Slots of a wide node's children, and the decisions per binary node (`i = 1 … 7` roots).
const SLOTS: usize = 7;

/// What a binary node becomes when it may take `i` child slots of a wide node.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kind {
    /// A leaf child holding every primitive of the subtree.
    Leaf,
    /// An internal child: a wide node of its own.
    Internal,
    /// No child of its own: its slots go to its two children's subtrees.
    Distribute,
}

/// A decision packed in one byte: the kind in the low two bits, then the slot indices (`0 … 6`,
/// meaning one to seven slots) given to the left and to the right child, three bits each.
#[derive(Clone, Copy, Default)]
struct Decision(u8);

impl Decision {
    fn new(kind: Kind, left: usize, right: usize) -> Self {
        debug_assert!(left < SLOTS && right < SLOTS);
        let kind = match kind {
            Kind::Leaf => 0,
            Kind::Internal => 1,
            Kind::Distribute => 2,
        };
        Self(kind | (left as u8) << 2 | (right as u8) << 5)
    }

    fn kind(self) -> Kind {
        match self.0 & 3 {
            0 => Kind::Leaf,
            1 => Kind::Internal,
            _ => Kind::Distribute,
        }
    }

    fn left(self) -> usize {
        (self.0 >> 2 & 7) as usize
    }

    fn right(self) -> usize {
        (self.0 >> 5) as usize
    }
}

/// The wide BVH of `bvh2`, whose leaves must each hold one primitive, with wide leaves of at
/// most `max_leaf` (1 to 3) primitives and children ordered by octant (obvhs's
/// `order_children`), without exact node boxes.
pub fn to_cwbvh(bvh2: &Bvh2, max_leaf: u32) -> CwBvh {
    assert!(
        (1..=3).contains(&max_leaf),
        "wide leaves hold 1 to 3 primitives"
    );
    if bvh2.nodes.is_empty() {
        return CwBvh::default();
    }
    let mut decisions = vec![Decision::default(); bvh2.nodes.len() * SLOTS];
    cost(bvh2, 0, max_leaf, &mut decisions);
    let mut out = Collapse {
        bvh2,
        decisions: &decisions,
        nodes: Vec::with_capacity(bvh2.primitive_indices.len() / 2 + 1),
        primitive_indices: Vec::with_capacity(bvh2.primitive_indices.len()),
    };
    out.nodes.push(CwBvhNode::default());
    out.node(0, 0);
    let Collapse {
        mut nodes,
        primitive_indices,
        ..
    } = out;
    nodes.shrink_to_fit();
    CwBvh {
        nodes,
        primitive_indices,
        total_aabb: *bvh2.nodes[0].aabb(),
        exact_node_aabbs: None,
        uses_spatial_splits: bvh2.uses_spatial_splits,
    }
}

/// The costs of the subtree under binary node `n` for `i = 1 … 7` slots (recording the
/// decisions that reach them), and its number of primitives. The arithmetic is obvhs's, in its
/// order, so that ties fall the same way.
fn cost(bvh2: &Bvh2, n: usize, max_leaf: u32, decisions: &mut [Decision]) -> ([f32; SLOTS], u32) {
    let node = &bvh2.nodes[n];
    let half_area = node.aabb().half_area();
    let d = &mut decisions[n * SLOTS..(n + 1) * SLOTS];
    if node.prim_count != 0 {
        assert_eq!(node.prim_count, 1, "one primitive per binary leaf");
        d.fill(Decision::new(Kind::Leaf, 0, 0));
        return ([half_area * PRIM_COST; SLOTS], 1);
    }
    let first = node.first_index as usize;
    let (left, nl) = cost(bvh2, first, max_leaf, decisions);
    let (right, nr) = cost(bvh2, first + 1, max_leaf, decisions);
    let primitives = nl + nr;
    let mut costs = [0.0; SLOTS];
    let mut made = [Decision::default(); SLOTS];
    // One slot: the node is a child of its own, a leaf or a wide node whose eight slots are
    // shared between the children's subtrees (seven ways: one and seven slots, two and six, …).
    let cost_leaf = if primitives <= max_leaf {
        primitives as f32 * half_area * PRIM_COST
    } else {
        f32::INFINITY
    };
    let (mut cost_distribute, mut split) = (f32::INFINITY, None);
    for k in 0..SLOTS {
        let c = left[k] + right[SLOTS - 1 - k];
        if c < cost_distribute {
            cost_distribute = c;
            split = Some(k);
        }
    }
    // With no finite split (boxes whose areas overflow f32), the even one: any choice is a
    // valid tree.
    let k = split.unwrap_or(SLOTS / 2);
    let cost_internal = cost_distribute + half_area;
    (costs[0], made[0]) = if cost_leaf < cost_internal {
        (cost_leaf, Decision::new(Kind::Leaf, k, SLOTS - 1 - k))
    } else {
        (
            cost_internal,
            Decision::new(Kind::Internal, k, SLOTS - 1 - k),
        )
    };
    // `i + 1` slots: as for `i`, or distributed between the children.
    for i in 1..SLOTS {
        let (mut best, mut split) = (costs[i - 1], None);
        for k in 0..i {
            let c = left[k] + right[i - k - 1];
            if c < best {
                best = c;
                split = Some(k);
            }
        }
        costs[i] = best;
        made[i] = match split {
            Some(k) => Decision::new(Kind::Distribute, k, i - k - 1),
            None => made[i - 1],
        };
    }
    decisions[n * SLOTS..(n + 1) * SLOTS].copy_from_slice(&made);
    (costs, primitives)
}

/// The top-down pass: wide nodes from the decisions.
struct Collapse<'a> {
    bvh2: &'a Bvh2,
    decisions: &'a [Decision],
    nodes: Vec<CwBvhNode>,
    primitive_indices: Vec<u32>,
}

impl Collapse<'_> {
    fn decision(&self, n: usize, i: usize) -> Decision {
        self.decisions[n * SLOTS + i]
    }

    /// Fill wide node `w` from binary node `n` (an internal wide node), then its internal
    /// children, depth first.
    fn node(&mut self, w: usize, n: usize) {
        let aabb = *self.bvh2.nodes[n].aabb();
        let mut node = self.nodes[w];
        node.p = Vec3::from(aabb.min);
        // Per axis a power of two, so that 255 steps of it cover the box.
        let e = ((aabb.max - aabb.min).max(Vec3A::splat(1e-20)) * DENOM)
            .log2()
            .ceil()
            .exp2();
        let rcp_e = 1.0 / e;
        node.e = [e.x, e.y, e.z].map(|c| (c.to_bits() >> 23) as u8);

        let mut children = [u32::MAX; 8];
        let mut count = 0;
        self.children(n, &mut children, &mut count, 0);
        self.order(n, &mut children, count);

        node.imask = 0;
        node.primitive_base_idx = self.primitive_indices.len() as u32;
        node.child_base_idx = self.nodes.len() as u32;
        let (mut internal, mut primitives) = (0, 0u32);
        for (slot, &c) in children.iter().enumerate() {
            if c == u32::MAX {
                continue;
            }
            let b = self.bvh2.nodes[c as usize].aabb();
            let lo = ((b.min - aabb.min) * rcp_e)
                .floor()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            let hi = ((b.max - aabb.min) * rcp_e)
                .ceil()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            node.child_min_x[slot] = lo.x as u8;
            node.child_min_y[slot] = lo.y as u8;
            node.child_min_z[slot] = lo.z as u8;
            node.child_max_x[slot] = hi.x as u8;
            node.child_max_y[slot] = hi.y as u8;
            node.child_max_z[slot] = hi.z as u8;
            match self.decision(c as usize, 0).kind() {
                Kind::Leaf => {
                    let count = self.leaf_primitives(c as usize);
                    // The primitive count in unary in the top three bits.
                    node.child_meta[slot] = primitives as u8
                        | match count {
                            1 => 0b0010_0000,
                            2 => 0b0110_0000,
                            _ => 0b1110_0000,
                        };
                    primitives += count;
                }
                Kind::Internal => {
                    node.imask |= 1 << slot;
                    node.child_meta[slot] = (24 + slot as u8) | 0b0010_0000;
                    internal += 1;
                }
                Kind::Distribute => unreachable!("a child slot is a leaf or a wide node"),
            }
        }
        self.nodes
            .resize(self.nodes.len() + internal, CwBvhNode::default());
        self.nodes[w] = node;
        let mut next = node.child_base_idx as usize;
        for (slot, &c) in children.iter().enumerate() {
            if c != u32::MAX && node.imask & (1 << slot) != 0 {
                self.node(next, c as usize);
                next += 1;
            }
        }
    }

    /// Append the primitives under binary node `n` (a wide leaf) and count them.
    fn leaf_primitives(&mut self, n: usize) -> u32 {
        let node = self.bvh2.nodes[n];
        if node.prim_count != 0 {
            self.primitive_indices
                .push(self.bvh2.primitive_indices[node.first_index as usize]);
            return 1;
        }
        let first = node.first_index as usize;
        self.leaf_primitives(first) + self.leaf_primitives(first + 1)
    }

    /// The children of the wide node made of binary node `n` with `i + 1` slots.
    fn children(&self, n: usize, children: &mut [u32; 8], count: &mut usize, i: usize) {
        let node = &self.bvh2.nodes[n];
        if node.prim_count != 0 {
            children[*count] = n as u32;
            *count += 1;
            return;
        }
        let d = self.decision(n, i);
        let first = node.first_index as usize;
        for (child, slots) in [(first, d.left()), (first + 1, d.right())] {
            if self.decision(child, slots).kind() == Kind::Distribute {
                self.children(child, children, count, slots);
            } else {
                children[*count] = child as u32;
                *count += 1;
            }
        }
    }

    /// Place the children in the slots whose octant direction best matches their offset from
    /// the node's centre (greedily, cheapest pair first), so that traversal can visit them near
    /// to far by the ray's octant (Ylitie et al. 2017, §3.2).
    fn order(&self, n: usize, children: &mut [u32; 8], count: usize) {
        let p = self.bvh2.nodes[n].aabb().center();
        let mut cost = [[f32::MAX; 8]; 8];
        for s in 0..8 {
            let sign = |bit: usize| if s & bit != 0 { -1.0 } else { 1.0 };
            let d = Vec3A::new(sign(4), sign(2), sign(1));
            for c in 0..count {
                cost[c][s] = d.dot(self.bvh2.nodes[children[c] as usize].aabb().center() - p);
            }
        }
        let mut assignment = [usize::MAX; 8];
        let mut filled = [false; 8];
        loop {
            let (mut min, mut slot, mut child) = (f32::MAX, usize::MAX, usize::MAX);
            for c in 0..count {
                if assignment[c] == usize::MAX {
                    for s in 0..8 {
                        if !filled[s] && cost[c][s] < min {
                            (min, slot, child) = (cost[c][s], s, c);
                        }
                    }
                }
            }
            if slot == usize::MAX {
                break;
            }
            filled[slot] = true;
            assignment[child] = slot;
        }
        let original = std::mem::replace(children, [u32::MAX; 8]);
        for c in 0..count {
            children[assignment[c]] = original[c];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{References, build};
    use mcmc_core::rng::{stream, uniform};
    use obvhs::aabb::Aabb;
    use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
    use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
    use obvhs::ploc::PlocBuilder;

    /// Sets of random boxes: small and large ones, clustered and spread, with duplicates and
    /// flat boxes.
    fn box_sets() -> Vec<Vec<Aabb>> {
        let mut rng = stream(31, 0);
        let mut r = || uniform(&mut rng) as f32;
        let mut out = Vec::new();
        for (n, spread, size) in [
            (1, 1.0, 0.1),
            (2, 1.0, 0.1),
            (9, 1.0, 0.3),
            (100, 10.0, 0.05),
            (1000, 1.0, 0.01),
            (5000, 100.0, 2.0),
        ] {
            out.push(
                (0..n)
                    .map(|k| {
                        let c = Vec3A::new(r(), r(), r()) * spread;
                        // Every seventh box flat in z, every eleventh a copy of the origin box.
                        let mut h = Vec3A::new(r(), r(), r()) * size;
                        if k % 7 == 0 {
                            h.z = 0.0;
                        }
                        if k % 11 == 0 {
                            return Aabb::new(Vec3A::ZERO, Vec3A::splat(size));
                        }
                        Aabb::new(c - h, c + h)
                    })
                    .collect(),
            );
        }
        out
    }

    /// Our build is obvhs's `build_cwbvh` with the medium preset, bit for bit: every node and
    /// the primitive order, for leaves of one to three primitives. (Changing `PRIM_COST`, or the
    /// PLOC search distance, fails it: checked by hand.)
    #[test]
    fn build_equals_obvhs() {
        let params = obvhs::BvhBuildParams::medium_build();
        for aabbs in box_sets() {
            let n = aabbs.len();
            let mut theirs = PlocBuilder::with_capacity(n).build(
                params.ploc_search_distance,
                &aabbs,
                (0..n as u32).collect(),
                params.sort_precision,
                params.search_depth_threshold,
            );
            ReinsertionOptimizer::default().run(&mut theirs, params.reinsertion_batch_ratio, None);
            for max_leaf in 1..=3 {
                let mut references = References::with_capacity(n);
                for &aabb in &aabbs {
                    references.push(aabb);
                }
                let ours = build(references, max_leaf);
                let theirs = bvh2_to_cwbvh(&theirs, max_leaf, true, false);
                assert_eq!(ours.nodes.len(), theirs.nodes.len(), "{n} boxes");
                assert!(
                    ours.nodes == theirs.nodes,
                    "nodes differ, max_leaf {max_leaf}"
                );
                assert_eq!(ours.primitive_indices, theirs.primitive_indices);
                assert_eq!(ours.total_aabb, theirs.total_aabb);
            }
        }
    }

    #[test]
    fn decisions_pack_into_a_byte() {
        for kind in [Kind::Leaf, Kind::Internal, Kind::Distribute] {
            for left in 0..SLOTS {
                for right in 0..SLOTS {
                    let d = Decision::new(kind, left, right);
                    assert_eq!((d.kind(), d.left(), d.right()), (kind, left, right));
                }
            }
        }
    }
}
