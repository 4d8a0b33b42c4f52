//! An uncompressed eight-wide BVH and its traversal: the tree that [`super::convert`] collapses
//! from obvhs's binary BVH (the SAH collapse of Ylitie, Karras and Laine 2017, §3), with each
//! child's box stored exactly in f32, eight children tested at once (Wald, Benthin and Boulos
//! 2008; Ernst and Greiner 2008), visited near to far from a stack that drops entries beyond the
//! closest hit so far.
//!
//! The slab test is conservative (Ize 2013, "Robust BVH ray traversal"): the ray's f32 origin is
//! widened per axis by its own rounding, and every box's exit distance is scaled by `1 + 2γ₃`
//! for the rounding of the test itself, so that a box which the exact f64 segment touches is
//! never culled. Primitives are then tested in f64 ([`super::Bvh`]).
//!
//! The x86-64-v3 copy (AVX2, [`super::cpu`]) tests all eight children in one vector; the
//! portable copy in two SSE halves (or lane by lane off x86-64). Both evaluate the same
//! operations in the same order, without fused multiply-adds, so they visit the same nodes in
//! the same order.

use std::mem::MaybeUninit;

/// Children of a wide node.
pub const WIDTH: usize = 8;

/// A child pointer's flag for a leaf: `LEAF | first << LEAF_SHIFT | count`, the leaf's
/// references being leaf positions `first .. first + count`.
pub const LEAF: u32 = 1 << 31;

/// A leaf pointer's flag for its contents' owner to use (the packets: a leaf with spheres).
pub const LEAF_FLAG: u32 = 1 << 30;

/// Bits of a leaf pointer holding its count (at most 15).
const LEAF_SHIFT: u32 = 4;

/// The most references one leaf may hold.
pub const MAX_LEAF: u32 = (1 << LEAF_SHIFT) - 1;

/// Levels of the trees whose traversal stack lives in a fixed array (deeper trees take one
/// from the heap per query).
const FIXED_DEPTH: usize = 64;

/// Stack entries of the fixed stack: a node pushes at most `WIDTH − 1` children per level.
const FIXED_STACK: usize = FIXED_DEPTH * (WIDTH - 1) + 1;

/// One wide node: the planes of its children's boxes, axis by axis (`lo_x, hi_x, lo_y, hi_y,
/// lo_z, hi_z`, eight children each), and its child pointers (an inner node's index, or a leaf
/// as [`LEAF`] describes). An empty slot's box is inverted (`+∞ … −∞`), so no ray enters it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct WideNode {
    /// Child box planes per axis and side.
    pub planes: [[f32; WIDTH]; 6],
    /// Child pointers.
    pub child: [u32; WIDTH],
}

impl WideNode {
    /// A node with no children.
    pub const EMPTY: Self = {
        let mut planes = [[f32::INFINITY; WIDTH]; 6];
        planes[1] = [f32::NEG_INFINITY; WIDTH];
        planes[3] = [f32::NEG_INFINITY; WIDTH];
        planes[5] = [f32::NEG_INFINITY; WIDTH];
        Self {
            planes,
            child: [0; WIDTH],
        }
    };

    /// Set child `slot` to the box `lo … hi` and pointer `child`.
    pub fn set(&mut self, slot: usize, lo: [f32; 3], hi: [f32; 3], child: u32) {
        for axis in 0..3 {
            self.planes[2 * axis][slot] = lo[axis];
            self.planes[2 * axis + 1][slot] = hi[axis];
        }
        self.child[slot] = child;
    }
}

/// The pointer to a leaf of `count` (1 to [`MAX_LEAF`]) references from leaf position `first`.
pub fn leaf(first: u32, count: u32) -> u32 {
    assert!(
        (1..=MAX_LEAF).contains(&count) && first < 1 << (30 - LEAF_SHIFT),
        "a leaf of 1 to {MAX_LEAF} references below 2^26"
    );
    LEAF | first << LEAF_SHIFT | count
}

/// The eight-wide tree; node 0 is the root.
#[derive(Debug, Default)]
pub struct WideBvh {
    /// Nodes, the root first.
    pub nodes: Vec<WideNode>,
    /// Levels of the deepest path (the root alone is one).
    pub depth: usize,
}

/// The first position and count of a leaf pointer.
#[inline(always)]
pub fn leaf_range(child: u32) -> (u32, u32) {
    (
        (child & !(LEAF | LEAF_FLAG)) >> LEAF_SHIFT,
        child & MAX_LEAF,
    )
}

/// The segment a query traverses, set up once: per axis the plane each box is entered and left
/// through (by the direction's sign), the inverse direction, and the origin moved by its own f32
/// rounding toward the near plane and away from the far one.
#[derive(Clone, Copy, Debug)]
pub struct WideRay {
    near: [usize; 3],
    far: [usize; 3],
    o_near: [f32; 3],
    o_far: [f32; 3],
    rd: [f32; 3],
    /// The traversal distance: boxes entered beyond it are culled.
    pub t_max: f32,
}

/// `1 + 2γ₃` (Ize 2013): the factor on a box's f32 exit distance that covers the rounding of the
/// slab test (a subtraction, a product and the reciprocal of the direction, `γ₃ = 3u / (1 − 3u)`
/// with `u = 2⁻²⁴`), with a margin.
const EXIT_SCALE: f32 = 1.0 + 4.0 * 3.0 * f32::EPSILON;

/// A segment's f32 copies, which the node test ([`WideRay`]) and the packet test
/// (`super::packet::PacketRay`) share: origin, direction and the origin's largest magnitude
/// `|o|∞`, which is the f32 rounding of the f64 one (rounding keeps order and sign).
#[derive(Clone, Copy, Debug)]
pub struct RayCopies {
    /// The origin, rounded to f32.
    pub o: [f32; 3],
    /// The direction, rounded to f32.
    pub d: [f32; 3],
    /// `|o|∞` of the rounded origin.
    pub largest: f32,
}

impl RayCopies {
    /// The copies of `o + t d`.
    #[inline(always)]
    pub fn new(o: [f64; 3], d: [f64; 3]) -> Self {
        let o = o.map(|x| x as f32);
        let a = o.map(f32::abs);
        // Plain comparisons: no NaN arises from a finite origin (and a NaN origin hits nothing
        // in the exact tests, whatever the traversal visits).
        let max = |x: f32, y: f32| if x > y { x } else { y };
        Self {
            o,
            d: d.map(|x| x as f32),
            largest: max(max(a[0], a[1]), a[2]),
        }
    }
}

impl WideRay {
    /// The traversal of the f64 segment `o + t d`, `t ∈ (0, t_max)`, `t_max` already widened to
    /// the traversal distance (`traversal_t_max`). (The queries build theirs from the copies they
    /// share with the packet test: [`WideRay::from_copies`].)
    #[cfg(test)]
    pub fn new(o: [f64; 3], d: [f64; 3], t_max: f32) -> Self {
        Self::from_copies(&RayCopies::new(o, d), t_max)
    }

    /// [`WideRay::new`] from the segment's f32 copies.
    #[inline(always)]
    pub fn from_copies(copies: &RayCopies, t_max: f32) -> Self {
        let mut ray = Self {
            near: [0; 3],
            far: [0; 3],
            o_near: [0.0; 3],
            o_far: [0.0; 3],
            rd: [0.0; 3],
            t_max,
        };
        // How far the f32 origin may lie from the f64 one: half an ulp of its largest
        // coordinate, doubled.
        let slack = copies.largest * f32::EPSILON;
        for axis in 0..3 {
            // `+ 0.0` makes a negative zero positive; a direction this small is clamped so that
            // `1 / d` stays finite (the ray moves by less than 10⁻²⁰ per unit along it, far
            // inside the boxes' padding), so no product is `0 · ∞`.
            let mut di = copies.d[axis] + 0.0;
            if di.abs() < 1e-20 {
                di = 1e-20f32.copysign(di);
            }
            let rd = 1.0 / di;
            let negative = rd < 0.0;
            let oi = copies.o[axis];
            ray.near[axis] = 2 * axis + usize::from(negative);
            ray.far[axis] = 2 * axis + usize::from(!negative);
            // Entering: the box's near plane moved toward the ray, i.e. the origin moved away
            // from the box along the direction; leaving: the reverse.
            let toward = if negative { -slack } else { slack };
            ray.o_near[axis] = oi + toward;
            ray.o_far[axis] = oi - toward;
            ray.rd[axis] = rd;
        }
        ray
    }
}

/// The traversal distance of a segment parameter `t` (an f64 hit or bound): slightly larger,
/// so that the f32 entry distance of a box holding that point is never beyond it.
#[inline(always)]
pub fn traversal_t_max(t: f64) -> f32 {
    if t.is_finite() {
        (t * (1.0 + 1e-6)) as f32
    } else {
        f32::INFINITY
    }
}

/// The ray against a node's eight children: the hit mask and each child's entry distance.
/// Lane by lane, in the order the vector copies use (the copy off x86-64, and the tests' model).
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline(always)]
fn node_test_lanes(node: &WideNode, ray: &WideRay) -> (u32, [f32; WIDTH]) {
    let mut t_near = [0.0; WIDTH];
    let mut mask = 0;
    for c in 0..WIDTH {
        let t = |axis: usize, plane: usize, o: &[f32; 3]| {
            (node.planes[plane][c] - o[axis]) * ray.rd[axis]
        };
        let nx = t(0, ray.near[0], &ray.o_near);
        let ny = t(1, ray.near[1], &ray.o_near);
        let nz = t(2, ray.near[2], &ray.o_near);
        let fx = t(0, ray.far[0], &ray.o_far);
        let fy = t(1, ray.far[1], &ray.o_far);
        let fz = t(2, ray.far[2], &ray.o_far);
        let near = max(max(nx, ny), max(nz, 0.0));
        let far = min(min(min(fx, fy), fz) * EXIT_SCALE, ray.t_max);
        t_near[c] = near;
        if near <= far {
            mask |= 1 << c;
        }
    }
    (mask, t_near)
}

/// `maxps`' rule: the second operand unless the first is larger (no NaN arises here).
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// `minps`' rule: the second operand unless the first is smaller.
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// The vector operations the slab test needs, for SSE's four lanes and AVX's eight, so that
/// both copies of the node test are one function ([`slab`]).
#[cfg(target_arch = "x86_64")]
trait Lanes: Copy {
    /// Lanes per vector.
    const N: usize;
    /// # Safety
    /// `p` points at `N` readable floats, and the CPU has the vector's features.
    unsafe fn load(p: *const f32) -> Self;
    /// # Safety
    /// The CPU has the vector's features (the same for the others).
    unsafe fn splat(x: f32) -> Self;
    unsafe fn sub(a: Self, b: Self) -> Self;
    unsafe fn mul(a: Self, b: Self) -> Self;
    unsafe fn max(a: Self, b: Self) -> Self;
    unsafe fn min(a: Self, b: Self) -> Self;
    /// # Safety
    /// `p` points at `N` writable floats, and the CPU has the vector's features.
    unsafe fn store(p: *mut f32, a: Self);
    /// The lanes where `a ≤ b` (ordered), as bits.
    unsafe fn le_mask(a: Self, b: Self) -> u32;
}

/// [`Lanes`] for one vector type, from its intrinsics.
#[cfg(target_arch = "x86_64")]
macro_rules! lanes {
    ($v:ident, $n:expr, $load:ident, $set1:ident, $sub:ident, $mul:ident, $max:ident, $min:ident,
     $store:ident, $movemask:ident, $le:expr) => {
        impl Lanes for std::arch::x86_64::$v {
            const N: usize = $n;
            #[inline(always)]
            unsafe fn load(p: *const f32) -> Self {
                unsafe { std::arch::x86_64::$load(p) }
            }
            #[inline(always)]
            unsafe fn splat(x: f32) -> Self {
                unsafe { std::arch::x86_64::$set1(x) }
            }
            #[inline(always)]
            unsafe fn sub(a: Self, b: Self) -> Self {
                unsafe { std::arch::x86_64::$sub(a, b) }
            }
            #[inline(always)]
            unsafe fn mul(a: Self, b: Self) -> Self {
                unsafe { std::arch::x86_64::$mul(a, b) }
            }
            #[inline(always)]
            unsafe fn max(a: Self, b: Self) -> Self {
                unsafe { std::arch::x86_64::$max(a, b) }
            }
            #[inline(always)]
            unsafe fn min(a: Self, b: Self) -> Self {
                unsafe { std::arch::x86_64::$min(a, b) }
            }
            #[inline(always)]
            unsafe fn store(p: *mut f32, a: Self) {
                unsafe { std::arch::x86_64::$store(p, a) }
            }
            #[inline(always)]
            unsafe fn le_mask(a: Self, b: Self) -> u32 {
                unsafe { std::arch::x86_64::$movemask($le(a, b)) as u32 }
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
lanes!(
    __m128,
    4,
    _mm_loadu_ps,
    _mm_set1_ps,
    _mm_sub_ps,
    _mm_mul_ps,
    _mm_max_ps,
    _mm_min_ps,
    _mm_storeu_ps,
    _mm_movemask_ps,
    std::arch::x86_64::_mm_cmple_ps
);

#[cfg(target_arch = "x86_64")]
lanes!(
    __m256,
    8,
    _mm256_loadu_ps,
    _mm256_set1_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    _mm256_max_ps,
    _mm256_min_ps,
    _mm256_storeu_ps,
    _mm256_movemask_ps,
    std::arch::x86_64::_mm256_cmp_ps::<{ std::arch::x86_64::_CMP_LE_OQ }>
);

/// The slab test of the node's children `first .. first + L::N` in one vector: their hit bits
/// (shifted to `first`) into the mask, their entry distances into `t_near`, in the operations
/// and order of [`node_test_lanes`].
///
/// # Safety
/// The CPU has `L`'s features (and `first + L::N ≤ WIDTH`, checked in debug builds).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn slab<L: Lanes>(
    node: &WideNode,
    ray: &WideRay,
    first: usize,
    t_near: &mut [f32; WIDTH],
) -> u32 {
    debug_assert!(first + L::N <= WIDTH);
    // SAFETY: `p` is one of the ray's plane indices (below 6), and each load reads `L::N` of
    // its plane's eight floats from `first`; the store writes `L::N` of `t_near`'s.
    unsafe {
        let plane = |p: usize| L::load(node.planes.get_unchecked(p).as_ptr().add(first));
        let t = |axis: usize, p: usize, o: &[f32; 3]| {
            L::mul(L::sub(plane(p), L::splat(o[axis])), L::splat(ray.rd[axis]))
        };
        let nx = t(0, ray.near[0], &ray.o_near);
        let ny = t(1, ray.near[1], &ray.o_near);
        let nz = t(2, ray.near[2], &ray.o_near);
        let fx = t(0, ray.far[0], &ray.o_far);
        let fy = t(1, ray.far[1], &ray.o_far);
        let fz = t(2, ray.far[2], &ray.o_far);
        let near = L::max(L::max(nx, ny), L::max(nz, L::splat(0.0)));
        let far = L::min(
            L::mul(L::min(L::min(fx, fy), fz), L::splat(EXIT_SCALE)),
            L::splat(ray.t_max),
        );
        L::store(t_near.as_mut_ptr().add(first), near);
        L::le_mask(near, far) << first
    }
}

/// The node test in two SSE halves (baseline x86-64).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn node_test_sse(node: &WideNode, ray: &WideRay) -> (u32, [f32; WIDTH]) {
    use std::arch::x86_64::__m128;
    let mut t_near = [0.0f32; WIDTH];
    // SAFETY: SSE is part of baseline x86-64; the halves are children 0–3 and 4–7.
    let mask = unsafe {
        slab::<__m128>(node, ray, 0, &mut t_near) | slab::<__m128>(node, ray, 4, &mut t_near)
    };
    (mask, t_near)
}

/// The node test in one AVX vector (the x86-64-v3 copies). Not a `target_feature` function of
/// its own, so that it is inlined into the copy that calls it, which has the features.
///
/// # Safety
/// The CPU must have AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn node_test_v3(node: &WideNode, ray: &WideRay) -> (u32, [f32; WIDTH]) {
    let mut t_near = [0.0f32; WIDTH];
    // SAFETY: the caller guarantees the features; one vector holds all eight children.
    let mask = unsafe { slab::<std::arch::x86_64::__m256>(node, ray, 0, &mut t_near) };
    (mask, t_near)
}

/// The node test of the copy `V3` names.
#[inline(always)]
fn node_test<const V3: bool>(node: &WideNode, ray: &WideRay) -> (u32, [f32; WIDTH]) {
    #[cfg(target_arch = "x86_64")]
    {
        if V3 {
            // SAFETY: `V3` is set only by the x86-64-v3 copies of the queries, which run only
            // when the CPU has their features (`cpu::has_v3`).
            return unsafe { node_test_v3(node, ray) };
        }
        node_test_sse(node, ray)
    }
    #[cfg(not(target_arch = "x86_64"))]
    node_test_lanes(node, ray)
}

/// A stack entry: the entry distance's bits above the child pointer (non-negative floats order
/// as their bits do).
#[inline(always)]
fn entry(t: f32, child: u32) -> u64 {
    (u64::from(t.to_bits()) << 32) | u64::from(child)
}

/// A traversal's fixed stack, for trees of at most [`FIXED_DEPTH`] levels (deeper ones take
/// one from the heap). Declared by the query itself, so that it is never moved.
pub type FixedStack = [MaybeUninit<u64>; FIXED_STACK];

/// An uninitialised [`FixedStack`].
pub const FIXED: FixedStack = [const { MaybeUninit::uninit() }; FIXED_STACK];

/// A traversal in progress: [`Traversal::next_leaf`] gives the leaves the segment enters, near to
/// far when `ORDERED`, skipping those entered beyond the ray's current `t_max` (which the caller
/// lowers as it finds hits). No closure: the caller's loop and the traversal compile into one
/// function, with the features of the copy it is in.
pub struct Traversal<'a, const V3: bool, const ORDERED: bool> {
    nodes: &'a [WideNode],
    stack: &'a mut [MaybeUninit<u64>],
    sp: usize,
    current: u32,
    pop: bool,
}

impl<'a, const V3: bool, const ORDERED: bool> Traversal<'a, V3, ORDERED> {
    /// A traversal of `bvh` from its root.
    #[inline(always)]
    pub fn new(
        bvh: &'a WideBvh,
        fixed: &'a mut FixedStack,
        heap: &'a mut Vec<MaybeUninit<u64>>,
    ) -> Self {
        let stack: &mut [MaybeUninit<u64>] = if bvh.depth > FIXED_DEPTH {
            heap.resize(bvh.depth * (WIDTH - 1) + 1, MaybeUninit::uninit());
            heap
        } else {
            fixed
        };
        Self {
            nodes: &bvh.nodes,
            stack,
            sp: 0,
            current: 0,
            pop: bvh.nodes.is_empty(),
        }
    }

    /// The next leaf `ray` enters (its pointer: [`leaf_range`], [`LEAF_FLAG`]), or `None` at the
    /// end.
    #[inline(always)]
    pub fn next_leaf(&mut self, ray: &WideRay) -> Option<u32> {
        loop {
            if self.pop {
                // The nearest entry not beyond the traversal distance.
                loop {
                    if self.sp == 0 {
                        return None;
                    }
                    self.sp -= 1;
                    // SAFETY: entries below `sp` were written.
                    let e = unsafe { self.stack[self.sp].assume_init() };
                    if ORDERED && f32::from_bits((e >> 32) as u32) > ray.t_max {
                        continue;
                    }
                    self.current = e as u32;
                    break;
                }
                self.pop = false;
            }
            if self.current & LEAF != 0 {
                self.pop = true;
                return Some(self.current);
            }
            let node = &self.nodes[self.current as usize];
            let (mask, t_near) = node_test::<V3>(node, ray);
            if mask == 0 {
                self.pop = true;
                continue;
            }
            let first = mask.trailing_zeros() as usize;
            let rest = mask & (mask - 1);
            if rest == 0 {
                self.current = node.child[first];
                continue;
            }
            let stack = &mut *self.stack;
            let mut sp = self.sp;
            if ORDERED {
                // Push every hit child, keeping the pushed entries sorted far to near, and take
                // the nearest off the top.
                let base = sp;
                let mut m = mask;
                while m != 0 {
                    let c = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let e = entry(t_near[c], node.child[c]);
                    let mut k = sp;
                    while k > base {
                        // SAFETY: entries `base .. sp` were written above.
                        let below = unsafe { stack[k - 1].assume_init() };
                        if below >= e {
                            break;
                        }
                        stack[k] = MaybeUninit::new(below);
                        k -= 1;
                    }
                    stack[k] = MaybeUninit::new(e);
                    sp += 1;
                }
                sp -= 1;
                // SAFETY: written above.
                self.current = unsafe { stack[sp].assume_init() } as u32;
            } else {
                let mut m = rest;
                while m != 0 {
                    let c = m.trailing_zeros() as usize;
                    m &= m - 1;
                    stack[sp] = MaybeUninit::new(u64::from(node.child[c]));
                    sp += 1;
                }
                self.current = node.child[first];
            }
            self.sp = sp;
        }
    }
}

impl WideBvh {
    /// Call `visit` on every leaf pointer, in the order of the leaves' positions: the order in
    /// which [`super::convert`] numbers them (a node's leaf children in slot order, then its
    /// inner children's subtrees in slot order).
    pub fn visit_leaves(&mut self, mut visit: impl FnMut(&mut u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut pending = vec![0u32];
        while let Some(n) = pending.pop() {
            let node = &mut self.nodes[n as usize];
            for child in &mut node.child {
                if *child & LEAF != 0 {
                    visit(child);
                }
            }
            let inner = node
                .child
                .iter()
                .enumerate()
                .filter(|&(slot, &c)| c & LEAF == 0 && node.planes[0][slot] != f32::INFINITY);
            let first = pending.len();
            pending.extend(inner.map(|(_, &c)| c));
            pending[first..].reverse();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mcmc_core::rng::{stream, uniform};

    /// A node of random boxes (flat ones, point-sized ones, far ones, empty slots) and its boxes
    /// in f64.
    fn random_node(
        r: &mut impl FnMut() -> f64,
        k: usize,
    ) -> (WideNode, Vec<Option<[[f64; 3]; 2]>>) {
        let mut node = WideNode::EMPTY;
        let mut boxes = Vec::new();
        for slot in 0..WIDTH {
            if (k + slot).is_multiple_of(9) {
                boxes.push(None);
                continue;
            }
            let scale = [1e-3, 1.0, 1e3][(k + slot) % 3];
            let c = [r(), r(), r()].map(|x| ((x - 0.5) * 10.0 * scale) as f32);
            let mut h = [r(), r(), r()].map(|x| (x * scale) as f32);
            if slot % 4 == 1 {
                h[slot % 3] = 0.0;
            }
            if slot % 7 == 3 {
                h = [0.0; 3];
            }
            let lo = [0, 1, 2].map(|a| c[a] - h[a]);
            let hi = [0, 1, 2].map(|a| c[a] + h[a]);
            node.set(slot, lo, hi, slot as u32);
            boxes.push(Some([lo.map(f64::from), hi.map(f64::from)]));
        }
        (node, boxes)
    }

    /// The SSE, AVX and lane-by-lane node tests agree bit for bit (masks and entry distances),
    /// on random nodes and rays of every octant, axis-parallel ones with zeros of either sign
    /// among them.
    #[test]
    fn node_test_copies_agree() {
        let mut rng = stream(41, 0);
        let mut r = || uniform(&mut rng);
        let v3 = cfg!(target_arch = "x86_64") && crate::accel::cpu::cpu_has_v3();
        let mut bits = 0;
        for k in 0..20_000 {
            let (node, boxes) = random_node(&mut r, k);
            let o = [r(), r(), r()].map(|x| (x - 0.5) * 20.0);
            // Toward a point near one of the boxes.
            let aim = boxes[k % WIDTH].map_or([0.0; 3], |[lo, hi]| {
                [0, 1, 2].map(|a| lo[a] + (hi[a] - lo[a]) * (1.2 * r() - 0.1))
            });
            let mut d = [0, 1, 2].map(|a| aim[a] - o[a]);
            for axis in 0..3 {
                if (k >> axis) % 5 == 0 {
                    d[axis] = if k % 2 == 0 { 0.0 } else { -0.0 };
                }
            }
            let t = [0.1, 5.0, f64::INFINITY][k % 3];
            let ray = WideRay::new(o, d, traversal_t_max(t));
            let lanes = node_test_lanes(&node, &ray);
            let bits_of = |(m, t): (u32, [f32; WIDTH])| (m, t.map(f32::to_bits));
            assert_eq!(
                bits_of(node_test::<false>(&node, &ray)),
                bits_of(lanes),
                "case {k}"
            );
            if v3 {
                assert_eq!(
                    bits_of(node_test::<true>(&node, &ray)),
                    bits_of(lanes),
                    "case {k}"
                );
            }
            bits += lanes.0.count_ones();
        }
        assert!(bits > 5_000, "{bits} hits");
    }

    /// A segment that reaches a box (its end inside the box, on a face, an edge or a corner) is
    /// never culled: from origins near and far (10⁴ away from boxes of size 10⁻³), along
    /// directions nearly parallel to the faces too. Without the widened origin
    /// (`WideRay::o_near`/`o_far`) or the exit scale, far origins lose grazing hits.
    #[test]
    fn segments_that_reach_a_box_enter_it() {
        let mut rng = stream(42, 0);
        let mut r = || uniform(&mut rng);
        let mut tested = 0;
        for k in 0..30_000 {
            let (node, boxes) = random_node(&mut r, k);
            let slot = k % WIDTH;
            let Some([lo, hi]) = boxes[slot] else {
                continue;
            };
            // A point of the box: inside, or on its boundary (clamped coordinates).
            let q = [0, 1, 2].map(|a| {
                let x = lo[a] + (hi[a] - lo[a]) * (1.4 * r() - 0.2);
                x.clamp(lo[a], hi[a])
            });
            let far = [1.0, 100.0, 1e4][k % 3];
            let mut o = [0, 1, 2].map(|a| q[a] + (r() - 0.5) * far);
            if k % 4 == 0 {
                // Grazing: the origin in the plane of a face through `q`.
                let a = k / 4 % 3;
                o[a] = q[a];
            }
            let v = [0, 1, 2].map(|a| q[a] - o[a]);
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if len == 0.0 {
                continue;
            }
            let d = v.map(|x| x / len);
            let ray = WideRay::new(o, d, traversal_t_max(len));
            let (mask, _) = node_test_lanes(&node, &ray);
            assert!(
                mask & (1 << slot) != 0,
                "case {k}: o {o:?} q {q:?} box {lo:?} {hi:?}"
            );
            tested += 1;
        }
        assert!(tested > 20_000);
    }
}
