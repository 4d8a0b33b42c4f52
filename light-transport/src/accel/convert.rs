//! Conversion of a binary BVH into an eight-wide one: the SAH collapse of Ylitie, Karras and
//! Laine (2017, §3), which turns obvhs's binary tree into nodes of up to eight children with
//! leaves of up to `max_leaf` primitives, each child's box its binary node's exact f32 box.
//!
//! The collapse is a dynamic programme: for each binary node `n` and `i = 1 … 7` it finds the
//! cheapest way to turn the subtree under `n` into at most `i` children of a wide node (the node
//! itself as a leaf or an internal wide node, or its slots distributed between its two
//! children's subtrees). A node's costs live only on the recursion's stack until its parent has
//! used them, and each decision is one byte (its kind and the two slot counts it hands to the
//! children), 7 bytes per binary node. (obvhs's own conversion keeps a table of 56 bytes per
//! binary node: 118 MB for the benchmarks' 1M-triangle terrain.)
//!
//! The costs are those of our traversal: an internal child costs its box's half area (one node
//! test, for eight boxes at once), a leaf its half area times [`LEAF_COST`] plus [`LANE_COST`] per
//! primitive (one packet test for all its lanes, `packet`, and the exact tests of its
//! candidates).

use obvhs::bvh2::Bvh2;

use super::wide::{self, WideBvh, WideNode};

/// A leaf's cost per unit of half area, against an internal node's 1: one packet test. Chosen
/// with [`LANE_COST`] by timing BDPT on `veach-bidir` (512×288, 2 runs each): `1.0 + 0.05 n`
/// and `0.3 + 0.1 n` were 1–3% slower, obvhs's `0.3 n` 7% slower, and leaves of at most 3 or 4
/// primitives 5–8% slower.
const LEAF_COST: f32 = 0.5;

/// A leaf's further cost per primitive, for the exact tests of its candidates.
const LANE_COST: f32 = 0.05;

/// The cost of a leaf of `n` primitives per unit of its half area.
fn leaf_cost(n: u32) -> f32 {
    LEAF_COST + LANE_COST * n as f32
}

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
/// most `max_leaf` (1 to [`wide::MAX_LEAF`]) primitives, and the binary tree's primitive of each
/// leaf position (a wide leaf's positions are `first .. first + count` of its pointer).
pub fn to_wide(bvh2: &Bvh2, max_leaf: u32) -> (WideBvh, Vec<u32>) {
    assert!(
        (1..=wide::MAX_LEAF).contains(&max_leaf),
        "wide leaves hold 1 to {} primitives",
        wide::MAX_LEAF
    );
    if bvh2.nodes.is_empty() {
        return (WideBvh::default(), Vec::new());
    }
    let mut decisions = vec![Decision::default(); bvh2.nodes.len() * SLOTS];
    cost(bvh2, 0, max_leaf, &mut decisions);
    let mut out = Collapse {
        bvh2,
        decisions: &decisions,
        nodes: Vec::with_capacity(bvh2.primitive_indices.len() / 8 + 1),
        primitive_indices: Vec::with_capacity(bvh2.primitive_indices.len()),
    };
    out.nodes.push(WideNode::EMPTY);
    let depth = out.node(0, 0);
    let Collapse {
        mut nodes,
        primitive_indices,
        ..
    } = out;
    nodes.shrink_to_fit();
    (WideBvh { nodes, depth }, primitive_indices)
}

/// The costs of the subtree under binary node `n` for `i = 1 … 7` slots (recording the
/// decisions that reach them), and its number of primitives.
fn cost(bvh2: &Bvh2, n: usize, max_leaf: u32, decisions: &mut [Decision]) -> ([f32; SLOTS], u32) {
    let node = &bvh2.nodes[n];
    let half_area = node.aabb().half_area();
    let d = &mut decisions[n * SLOTS..(n + 1) * SLOTS];
    if node.prim_count != 0 {
        assert_eq!(node.prim_count, 1, "one primitive per binary leaf");
        d.fill(Decision::new(Kind::Leaf, 0, 0));
        return ([half_area * leaf_cost(1); SLOTS], 1);
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
        half_area * leaf_cost(primitives)
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
    nodes: Vec<WideNode>,
    primitive_indices: Vec<u32>,
}

impl Collapse<'_> {
    fn decision(&self, n: usize, i: usize) -> Decision {
        self.decisions[n * SLOTS + i]
    }

    /// Fill wide node `w` from binary node `n` (an internal wide node), then its internal
    /// children, depth first; returns the levels of the subtree.
    fn node(&mut self, w: usize, n: usize) -> usize {
        let mut children = [u32::MAX; 8];
        let mut count = 0;
        self.children(n, &mut children, &mut count, 0);
        let mut node = WideNode::EMPTY;
        let mut internal = Vec::new();
        let first_child = self.nodes.len();
        for (slot, &c) in children[..count].iter().enumerate() {
            let b = self.bvh2.nodes[c as usize].aabb();
            let (lo, hi) = (b.min.to_array(), b.max.to_array());
            match self.decision(c as usize, 0).kind() {
                Kind::Leaf => {
                    let first = self.primitive_indices.len() as u32;
                    let count = self.leaf_primitives(c as usize);
                    node.set(slot, lo, hi, wide::leaf(first, count));
                }
                Kind::Internal => {
                    let index = (first_child + internal.len()) as u32;
                    node.set(slot, lo, hi, index);
                    internal.push(c as usize);
                }
                Kind::Distribute => unreachable!("a child slot is a leaf or a wide node"),
            }
        }
        self.nodes
            .resize(self.nodes.len() + internal.len(), WideNode::EMPTY);
        self.nodes[w] = node;
        let mut depth = 1;
        for (k, c) in internal.into_iter().enumerate() {
            depth = depth.max(1 + self.node(first_child + k, c));
        }
        depth
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{References, build};
    use glam::Vec3A;
    use mcmc_core::rng::{stream, uniform};
    use obvhs::aabb::Aabb;
    use std::collections::HashSet;

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

    /// Every box of a subtree lies inside its child box, bit for bit (the boxes are unions of
    /// the references' f32 boxes); every reference sits in exactly one leaf of at most
    /// `max_leaf`; empty slots are inverted; `depth` is the deepest path.
    #[test]
    fn wide_trees_are_valid() {
        for aabbs in box_sets() {
            let n = aabbs.len();
            for max_leaf in [1, 3, 8] {
                let mut references = References::with_capacity(n);
                for &aabb in &aabbs {
                    references.push(aabb);
                }
                let (tree, positions) = build(references, max_leaf);
                let mut seen = HashSet::new();
                assert_eq!(positions.len(), n);
                assert!(
                    positions.iter().all(|&p| seen.insert(p)),
                    "each reference once"
                );
                // Returns the subtree's box and depth.
                fn check(
                    tree: &WideBvh,
                    positions: &[u32],
                    aabbs: &[Aabb],
                    max_leaf: u32,
                    w: usize,
                    leaves: &mut usize,
                ) -> usize {
                    let node = &tree.nodes[w];
                    let mut depth = 1;
                    for slot in 0..wide::WIDTH {
                        let lo = [0, 2, 4].map(|p| node.planes[p][slot]);
                        let hi = [1, 3, 5].map(|p| node.planes[p][slot]);
                        if lo[0] == f32::INFINITY {
                            assert!(hi.iter().all(|&h| h == f32::NEG_INFINITY), "empty slot");
                            continue;
                        }
                        let inside =
                            |b: &Aabb| (0..3).all(|a| lo[a] <= b.min[a] && b.max[a] <= hi[a]);
                        let child = node.child[slot];
                        if child & wide::LEAF != 0 {
                            let (first, count) = wide::leaf_range(child);
                            assert!((1..=max_leaf).contains(&count));
                            for p in first..first + count {
                                assert!(inside(&aabbs[positions[p as usize] as usize]));
                            }
                            *leaves += count as usize;
                        } else {
                            let sub = &tree.nodes[child as usize];
                            for s in 0..wide::WIDTH {
                                if sub.planes[0][s] != f32::INFINITY {
                                    let b = Aabb::new(
                                        [0, 2, 4].map(|p| sub.planes[p][s]).into(),
                                        [1, 3, 5].map(|p| sub.planes[p][s]).into(),
                                    );
                                    assert!(inside(&b), "child box inside its parent's slot");
                                }
                            }
                            depth = depth.max(
                                1 + check(tree, positions, aabbs, max_leaf, child as usize, leaves),
                            );
                        }
                    }
                    depth
                }
                let mut leaves = 0;
                let depth = check(&tree, &positions, &aabbs, max_leaf, 0, &mut leaves);
                assert_eq!(leaves, n, "{n} boxes, max_leaf {max_leaf}");
                assert_eq!(depth, tree.depth);
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
