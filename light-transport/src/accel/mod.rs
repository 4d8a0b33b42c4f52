//! The bounding volume hierarchy over triangles and spheres: obvhs's binary BVH (PLOC with
//! reinsertion) collapsed into an eight-wide tree by the SAH (`convert`), with exact f32 child
//! boxes padded by a relative epsilon (`wide`), and each leaf's primitives as one packet of f32
//! triangles (`packet`). Traversal and the packet test run in f32 and are conservative: a
//! primitive that the f64 test could hit is always reached and always a candidate, so the
//! candidates' f64 tests give the closest f64 hit exactly. Triangles whose bounding box is mostly
//! empty enter the BVH as several references (`split`).
//! Occlusion queries first test the thread's recent occluders (`occluders`). A ray leaving a
//! surface, or a segment between two surfaces, skips the triangles it leaves
//! ([`Bvh::closest_hit_leaving`], [`Bvh::occluded_between`]).

use crate::geometry::{
    Derivatives, Hit, NO_PRIMITIVE, Sphere, SurfacePoint, Triangle, TriangleFrame, TriangleShading,
};
use crate::math::DVec3;
use glam::Vec3A;
mod convert;
#[cfg(target_arch = "x86_64")]
mod cpu;
mod occluders;
mod packet;
mod split;
mod wide;

use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::{Bvh2, node::Bvh2Node};
use obvhs::ploc::PlocBuilder;

/// A primitive of the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// A triangle.
    Triangle(Triangle),
    /// A sphere.
    Sphere(Sphere),
}

impl Primitive {
    /// The boxes under which the BVH references the primitive (see `split`).
    pub fn references(&self, out: &mut Vec<(DVec3, DVec3)>) {
        match self {
            Primitive::Triangle(t) => split::triangle_boxes(t.p, out),
            Primitive::Sphere(_) => out.push(self.bounds()),
        }
    }

    fn bounds(&self) -> (DVec3, DVec3) {
        match self {
            Primitive::Triangle(t) => (
                t.p[0].min(t.p[1]).min(t.p[2]),
                t.p[0].max(t.p[1]).max(t.p[2]),
            ),
            Primitive::Sphere(s) => (
                s.center - DVec3::splat(s.radius),
                s.center + DVec3::splat(s.radius),
            ),
        }
    }

    /// Ray parameter and barycentrics (unused for spheres) of the nearest hit before `t_max`.
    #[inline]
    fn intersect_t(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<(f64, f64, f64)> {
        match self {
            Primitive::Triangle(t) => t.intersect(o, d, t_max),
            Primitive::Sphere(s) => s.intersect(o, d, t_max).map(|th| (th, 0.0, 0.0)),
        }
    }

    /// The differential geometry of `point`, a point on this primitive (`shading`: the scene's
    /// table of triangle shading data). A triangle's always come from its shading table, as a hit's
    /// point does, even where the interpolated normal happens to equal the geometric one (`∂n/∂u`
    /// need not vanish there). A point sampled on a light carries the geometric normal but gets
    /// the same derivatives; manifold chains read `∂n/∂u` only at their interior vertices.
    fn derivatives(&self, point: &SurfacePoint, shading: &[TriangleShading]) -> Derivatives {
        match self {
            Primitive::Triangle(tri) => tri.derivatives(
                point.local[0],
                point.local[1],
                shading.get(tri.shading as usize),
            ),
            Primitive::Sphere(s) => s.derivatives(point.n, s.local(point.n)[0]),
        }
    }

    /// The texture coordinates of `point`, a point on this primitive.
    fn texture_coordinates(&self, point: &SurfacePoint) -> [f64; 2] {
        match self {
            Primitive::Triangle(tri) => tri.texture_coordinates(point.local[0], point.local[1]),
            Primitive::Sphere(s) => Sphere::texture_coordinates(s.local(point.n)),
        }
    }

    /// The flat surface point where the ray first hits this primitive, without the BVH (the
    /// tests' brute force).
    #[cfg(test)]
    fn intersect(&self, o: DVec3, d: DVec3, t_max: f64, index: u32) -> Option<Hit> {
        let (t, b1, b2) = self.intersect_t(o, d, t_max)?;
        let point = match self {
            Primitive::Triangle(tri) => tri.point(b1, b2, index),
            Primitive::Sphere(s) => s.point(o + d * t, index),
        };
        Some(Hit { t, point })
    }

    #[inline(always)]
    fn is_triangle(&self) -> bool {
        matches!(self, Primitive::Triangle(_))
    }

    /// What a packet lane holds of this primitive.
    fn lane(&self) -> packet::Lane {
        match self {
            Primitive::Triangle(t) => packet::Lane::Triangle(t.p),
            Primitive::Sphere(s) => packet::Lane::Sphere(s.center, s.radius),
        }
    }

    #[inline]
    fn hits(&self, o: DVec3, d: DVec3, t_max: f64) -> bool {
        match self {
            Primitive::Triangle(t) => t.intersect(o, d, t_max).is_some(),
            Primitive::Sphere(s) => s.intersect(o, d, t_max).is_some(),
        }
    }
}

/// The boxes of a BVH's references, as the leaves obvhs's PLOC builder starts from: written
/// straight into its working list, so that the boxes never exist twice (obvhs's `build` copies a
/// list of boxes into that list).
struct References {
    leaves: Vec<Bvh2Node>,
    total: Aabb,
}

impl References {
    fn with_capacity(n: usize) -> Self {
        Self {
            leaves: Vec::with_capacity(n),
            total: Aabb::empty(),
        }
    }

    fn len(&self) -> usize {
        self.leaves.len()
    }

    /// Add reference `len()` with box `aabb`.
    fn push(&mut self, aabb: Aabb) {
        self.total.extend(aabb.min);
        self.total.extend(aabb.max);
        self.leaves
            .push(Bvh2Node::new(aabb, 1, self.leaves.len() as u32));
    }
}

/// The wide BVH over `references` (PLOC, reinsertion, the SAH collapse), with leaves of at
/// most `max_leaf` references, and the reference of each leaf position.
fn build(references: References, max_leaf: u32) -> (wide::WideBvh, Vec<u32>) {
    if references.len() == 0 {
        return (wide::WideBvh::default(), Vec::new());
    }
    convert::to_wide(&binary(references), max_leaf)
}

/// obvhs's binary BVH over `references` (not empty), one per leaf: PLOC and reinsertion with
/// the medium preset, exactly as obvhs's `build_cwbvh` makes it.
fn binary(references: References) -> Bvh2 {
    let params = BvhBuildParams::medium_build();
    let n = references.len();
    let mut bvh2 = Bvh2::zeroed(n);
    bvh2.reset_for_reuse(n, Some((0..n as u32).collect()));
    let mut ploc = PlocBuilder {
        current_nodes: references.leaves,
        ..PlocBuilder::new()
    };
    // The medium preset's search distance.
    debug_assert!(matches!(
        params.ploc_search_distance,
        obvhs::ploc::PlocSearchDistance::Medium
    ));
    ploc.build_ploc_from_leaves::<14, false>(
        &mut bvh2,
        references.total,
        params.sort_precision,
        params.search_depth_threshold,
    );
    drop(ploc);
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    bvh2
}

/// Reorder `items` in place so that `items[k]` becomes the old `items[order[k]]` (`order` a
/// permutation), following its cycles.
fn permute<T>(items: &mut [T], order: &[u32]) {
    let mut done = vec![false; items.len()];
    for start in 0..items.len() {
        if done[start] {
            continue;
        }
        // Position `k` takes the item at `order[k]`; walk the cycle by swapping.
        let mut k = start;
        done[k] = true;
        while order[k] as usize != start {
            let next = order[k] as usize;
            items.swap(k, next);
            done[next] = true;
            k = next;
        }
    }
}

thread_local! {
    static RAYS: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    /// Frames of the triangles this thread hit last (see [`Bvh::frame`]); a key of `u64::MAX` is
    /// an empty slot (no BVH has the id `u32::MAX` and a primitive of that index).
    static FRAMES: std::cell::RefCell<[(u64, TriangleFrame); FRAME_SLOTS]> =
        const { std::cell::RefCell::new([(u64::MAX, TriangleFrame::ZERO); FRAME_SLOTS]) };
}

/// Slots of the per-thread cache of triangle frames.
const FRAME_SLOTS: usize = 256;

/// Rays traced by this thread since the last call (closest-hit and occlusion queries).
pub fn take_ray_count() -> u64 {
    RAYS.with(|c| c.replace(0))
}

#[inline]
fn count_ray() {
    RAYS.with(|c| c.set(c.get() + 1));
}

/// What a closest-hit query finds: the hit's `(t, b1, b2)` ([`Primitive::intersect_t`]) and its
/// primitive; [`Bvh::closest_hit_leaving`] builds the surface point from it.
type RawHit = ((f64, f64, f64), u32);

/// The acceleration structure with its primitives.
pub struct Bvh {
    wide: wide::WideBvh,
    packets: packet::Packets,
    /// Primitives in the order of their first reference in the BVH's leaves, so traversal reads
    /// them mostly sequentially; a primitive's index everywhere in the renderer is its position
    /// here.
    pub primitives: Vec<Primitive>,
    /// `original[i]`: the index primitive `i` had in the list given to [`Bvh::new`].
    pub original: Vec<u32>,
    /// Shading data of the triangles that have vertex normals ([`Triangle::shading`] indexes
    /// it).
    pub shading: Vec<TriangleShading>,
    /// This BVH's key in the per-thread cache of triangle frames ([`Bvh::frame`]): unique per
    /// BVH built in the process.
    id: u32,
    /// How many references the leaves hold.
    references: usize,
}

/// Two consecutive primitives with one box each share a BVH reference when the box around both
/// has at most this multiple of the mean of their half surface areas: the two halves of a quad,
/// neighbours in a strip, whose boxes nearly coincide, so that a ray entering the shared box would
/// mostly have tested both anyway. (The mean, not the larger area: a small primitive inside a large
/// one's box does not pair with it.) Sharing halves the builder's references, and its memory, on
/// such meshes.
const PAIR: f64 = 1.25;

/// Whether a build trades ray speed for memory ([`Bvh::topology`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Compact {
    /// One reference per primitive (several for split triangles): the fastest BVH.
    #[default]
    No,
    /// Neighbouring triangles that fill one box share a reference (`PAIR`). On the
    /// benchmarks' 1M-triangle terrain: peak memory 0.93× (201 → 187 MB), build 0.67–0.74×,
    /// rays/s 0.90–0.97× (docs/performance.md).
    Pairs,
}

/// Flag of a reference (in `Topology`) that stands for two primitives.
const PAIRED: u32 = 1 << 31;

fn to_f32(v: DVec3) -> Vec3A {
    Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
}

/// The tree of a BVH before its primitives are stored ([`Bvh::topology`]): which primitive each
/// leaf reference is, and the order in which [`Bvh::assemble`] wants the primitives.
///
/// Building in two phases lets a caller build the tree from bounding boxes alone and create its
/// primitives afterwards, directly in leaf order, so a large mesh never exists twice in memory
/// (nor alongside the builder's temporary structures).
pub struct Topology {
    wide: wide::WideBvh,
    /// `original[i]`: the caller's index of the primitive that goes to position `i`.
    original: Vec<u32>,
    /// Each leaf reference's (first) position in the final primitive list, with [`PAIRED`] set
    /// when it stands for that primitive and the next.
    leaf: Vec<u32>,
}

impl Topology {
    /// The caller's indices of the primitives, in the order [`Bvh::assemble`] takes them.
    pub fn original(&self) -> &[u32] {
        &self.original
    }
}

/// [`packet::LoosePacket::candidates`] compiled for x86-64-v3 (the shadow cache's filter; see
/// [`cpu`]).
///
/// # Safety
/// The CPU must have the x86-64-v3 features.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,bmi1,bmi2,fma,lzcnt,popcnt")]
unsafe fn filter_occluders_v3(
    packet: &packet::LoosePacket,
    ray: &packet::PacketRay,
    t_max: f32,
) -> u32 {
    packet.candidates::<true>(ray, t_max)
}

/// The f32 box of the reference box `(lo, hi)`, padded by a relative epsilon so that f32
/// traversal cannot lose a hit of the f64 primitive inside.
fn padded(lo: DVec3, hi: DVec3) -> Aabb {
    let pad = (hi - lo)
        .max_element()
        .max(lo.abs().max(hi.abs()).max_element())
        * 1e-6
        + 1e-12;
    Aabb::new(
        to_f32(lo - DVec3::splat(pad)),
        to_f32(hi + DVec3::splat(pad)),
    )
}

impl Bvh {
    /// Build over flat `primitives` (which are then stored in leaf order; see
    /// [`Bvh::original`]).
    pub fn new(primitives: Vec<Primitive>) -> Self {
        Self::with_shading(primitives, Vec::new())
    }

    /// Build over `primitives` whose triangles refer to `shading` data.
    pub fn with_shading(input: Vec<Primitive>, shading: Vec<TriangleShading>) -> Self {
        Self::with_options(input, shading, Compact::No)
    }

    /// Build over `primitives` whose triangles refer to `shading` data, `compact` or not.
    pub fn with_options(
        mut input: Vec<Primitive>,
        shading: Vec<TriangleShading>,
        compact: Compact,
    ) -> Self {
        let topology = Self::topology(input.len(), compact, |i, out| input[i].references(out));
        permute(&mut input, &topology.original);
        Self::assemble(topology, input, shading)
    }

    /// Phase one of a build: the tree over `count` primitives (fewer than 2³¹), whose reference
    /// boxes `references(i, out)` pushes (unpadded): a triangle's from
    /// [`Primitive::references`], one box per sphere; with [`Compact::Pairs`], neighbours that
    /// fill one box share a reference.
    pub fn topology(
        count: usize,
        compact: Compact,
        mut references: impl FnMut(usize, &mut Vec<(DVec3, DVec3)>),
    ) -> Topology {
        // Boxes of the references: one per primitive, several for triangles whose box is
        // mostly empty (`split`), one for two neighbours that fill a box together (`PAIR`);
        // `owner[r]` is the (first) primitive of reference `r`, flagged `PAIRED` for two.
        assert!(count < PAIRED as usize, "at most 2^31 primitives");
        let (mut refs, mut owner) = (References::with_capacity(count), Vec::with_capacity(count));
        let mut boxes = Vec::new();
        // The previous primitive, when it has one box and is not yet entered.
        let mut single: Option<(u32, (DVec3, DVec3))> = None;
        for i in 0..count {
            boxes.clear();
            references(i, &mut boxes);
            debug_assert!(!boxes.is_empty());
            if let Some((j, b)) = single.take() {
                if let (Compact::Pairs, [c]) = (compact, &boxes[..]) {
                    let c = *c;
                    let both = (b.0.min(c.0), b.1.max(c.1));
                    let area = |(lo, hi)| split::half_area(lo, hi);
                    if 2.0 * area(both) <= PAIR * (area(b) + area(c)) {
                        refs.push(padded(both.0, both.1));
                        owner.push(j | PAIRED);
                        continue;
                    }
                }
                refs.push(padded(b.0, b.1));
                owner.push(j);
            }
            if let [c] = boxes[..] {
                single = Some((i as u32, c));
            } else {
                for &(lo, hi) in &boxes {
                    refs.push(padded(lo, hi));
                }
                owner.resize(refs.len(), i as u32);
            }
        }
        if let Some((j, b)) = single {
            refs.push(padded(b.0, b.1));
            owner.push(j);
        }
        // A leaf's packet holds up to eight primitives: eight references, or four pairs.
        let paired = owner.iter().any(|&o| o & PAIRED != 0);
        let max_leaf = if paired {
            packet::LANES / 2
        } else {
            packet::LANES
        } as u32;
        let (wide, leaf_references) = build(refs, max_leaf);
        // Primitives are numbered by their first reference in leaf order, so traversal mostly
        // reads them sequentially (the two of a pair are never split, so they get consecutive
        // numbers).
        let mut canonical = vec![u32::MAX; count];
        let mut original = Vec::with_capacity(count);
        let leaf: Vec<u32> = leaf_references
            .iter()
            .map(|&r| {
                let o = owner[r as usize];
                let (i, n) = ((o & !PAIRED) as usize, 1 + (o >> 31) as usize);
                for k in i..i + n {
                    if canonical[k] == u32::MAX {
                        canonical[k] = original.len() as u32;
                        original.push(k as u32);
                    }
                }
                canonical[i] | (o & PAIRED)
            })
            .collect();
        Topology {
            wide,
            original,
            leaf,
        }
    }

    /// Phase two: the BVH of `topology` over `primitives`, given in the order of
    /// [`Topology::original`], whose triangles refer to `shading` data.
    pub fn assemble(
        topology: Topology,
        primitives: Vec<Primitive>,
        shading: Vec<TriangleShading>,
    ) -> Self {
        let Topology {
            mut wide,
            original,
            leaf,
        } = topology;
        assert_eq!(
            primitives.len(),
            original.len(),
            "one primitive per position of the topology"
        );
        let packets = Self::packets(&mut wide, &leaf, &primitives);
        static NEXT_ID: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        Self {
            wide,
            packets,
            primitives,
            original,
            shading,
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            references: leaf.len(),
        }
    }

    /// The leaves' packets: each leaf's primitives (those of its references, `leaf[position]`,
    /// each primitive once: a split triangle's pieces may share a leaf) as one packet, and the
    /// leaf's pointer rewritten to the packet's first lane and lane count. Packets are stored in
    /// the order of the leaves' positions, so that where no triangle is split lane `k` holds
    /// primitive `k` (primitives are numbered in leaf order) and the packets need no index.
    fn packets(
        wide: &mut wide::WideBvh,
        leaf: &[u32],
        primitives: &[Primitive],
    ) -> packet::Packets {
        // Each leaf's primitives, once each.
        let lanes_of = |child: u32, out: &mut Vec<u32>| {
            out.clear();
            let (first, count) = wide::leaf_range(child);
            for &l in &leaf[first as usize..(first + count) as usize] {
                let at = l & !PAIRED;
                for index in at..at + 1 + (l >> 31) {
                    if !out.contains(&index) {
                        out.push(index);
                    }
                }
            }
        };
        let mut indices = Vec::with_capacity(packet::LANES);
        // Lanes in all, to allocate the packets once.
        let mut total = 0;
        wide.visit_leaves(|child| {
            lanes_of(*child, &mut indices);
            total += indices.len();
        });
        let mut packets = packet::Packets::with_capacity(total);
        let mut lanes: Vec<(u32, packet::Lane)> = Vec::with_capacity(packet::LANES);
        wide.visit_leaves(|child| {
            lanes_of(*child, &mut indices);
            lanes.clear();
            lanes.extend(
                indices
                    .iter()
                    .map(|&index| (index, primitives[index as usize].lane())),
            );
            let (at, special) = packets.push(&lanes);
            *child = wide::leaf(at, lanes.len() as u32) | if special { wide::LEAF_FLAG } else { 0 };
        });
        packets
    }

    /// How many references the BVH's leaves hold: one per primitive, more where triangles are
    /// split, fewer where primitives are paired ([`Compact::Pairs`]).
    pub fn references(&self) -> usize {
        self.references
    }

    /// The closest hit of the ray `o + t d`, `t ∈ (0, t_max)`.
    pub fn closest_hit(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<Hit> {
        self.closest_hit_leaving(o, d, t_max, NO_PRIMITIVE)
    }

    /// [`Bvh::closest_hit`] of a ray that leaves primitive `leaves` ([`Ray::leaving`]): if that
    /// is a triangle, the ray cannot hit it and it is not tested. (Its origin lies on the
    /// triangle, so traversal always reaches the triangle's leaf: 38–39% of the closest-hit
    /// tests of PT on `veach-bidir`, `door` and `cornell` were of that triangle or another in its
    /// plane.)
    ///
    /// [`Ray::leaving`]: crate::geometry::Ray::leaving
    pub fn closest_hit_leaving(&self, o: DVec3, d: DVec3, t_max: f64, leaves: u32) -> Option<Hit> {
        count_ray();
        if self.primitives.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        let found = if cpu::has_v3() {
            // SAFETY: the CPU has every feature `closest_hit_v3` is compiled for.
            unsafe { self.closest_hit_v3(o, d, t_max, leaves) }
        } else {
            self.closest_hit_in::<false>(o, d, t_max, leaves)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let found = self.closest_hit_in::<false>(o, d, t_max, leaves);
        // The surface point is built here, out of the query, straight into the caller's hit: a
        // query that returned the whole hit had it copied out of its frame, whose wide loads of
        // the point's freshly stored fields stalled (4.5% of the query on `door`).
        found.map(|(h, index)| self.hit_point(o, d, h, index))
    }

    /// [`Bvh::closest_hit_leaving`] compiled for x86-64-v3, with the AVX2 node and packet tests
    /// (see [`cpu`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2,bmi1,bmi2,fma,lzcnt,popcnt")]
    fn closest_hit_v3(&self, o: DVec3, d: DVec3, t_max: f64, leaves: u32) -> Option<RawHit> {
        self.closest_hit_in::<true>(o, d, t_max, leaves)
    }

    /// The query itself, inlined into each copy, traversal and packet tests included, so that
    /// it is compiled with the features of the copy it lands in. (The f64 primitive tests stay
    /// out of line, shared by both copies.) Leaves are visited near to far, and a leaf's
    /// candidates in lane order; a hit is kept only if nearer than the best so far.
    #[inline(always)]
    fn closest_hit_in<const V3: bool>(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        leaves: u32,
    ) -> Option<RawHit> {
        let mut best: Option<RawHit> = None;
        let mut best_t = t_max;
        self.candidates::<V3, true>(o, d, t_max, |index, primitive, bound| {
            if index == leaves && primitive.is_triangle() {
                return false;
            }
            if let Some(h) = primitive.intersect_t(o, d, best_t) {
                best_t = h.0;
                best = Some((h, index));
                *bound = wide::traversal_t_max(h.0);
            }
            false
        });
        best
    }

    /// The surface point of a hit on primitive `index` found by [`Primitive::intersect_t`], with
    /// a triangle's shading data and its cached [`Bvh::frame`].
    #[inline(always)]
    fn hit_point(&self, o: DVec3, d: DVec3, (t, b1, b2): (f64, f64, f64), index: u32) -> Hit {
        let point = match &self.primitives[index as usize] {
            Primitive::Triangle(tri) => tri.point_framed(
                b1,
                b2,
                index,
                self.shading.get(tri.shading as usize),
                &self.frame(tri, index),
            ),
            Primitive::Sphere(s) => s.point(o + d * t, index),
        };
        Hit { t, point }
    }

    /// [`Triangle::frame`] of `tri`, primitive `index` of this BVH, from this thread's cache of
    /// recently hit or sampled triangles' frames (direct-mapped on the index, keyed by BVH and
    /// index), computed and kept there on a miss. Hits come back to the same triangles often (a Metropolis chain's
    /// perturbations most of all), and a frame costs a division and two square roots; keeping one
    /// per triangle instead would add 48 bytes to each (the 1M-triangle terrain's peak 200 →
    /// 245 MB). Exact either way: a frame is a function of its triangle alone.
    #[inline]
    pub fn frame(&self, tri: &Triangle, index: u32) -> TriangleFrame {
        let key = (u64::from(self.id) << 32) | u64::from(index);
        FRAMES.with(|cache| {
            let mut cache = cache.borrow_mut();
            let slot = &mut cache[index as usize % FRAME_SLOTS];
            if slot.0 != key {
                *slot = (key, tri.frame());
            }
            slot.1
        })
    }

    /// The differential geometry of a point on one of the BVH's primitives, which a hit or a
    /// light sample gave; zero for points that lie on none (`SurfacePoint::flat`: lens, point
    /// lights).
    pub fn derivatives(&self, point: &SurfacePoint) -> Derivatives {
        self.primitives
            .get(point.primitive as usize)
            .map_or_else(Derivatives::default, |p| {
                p.derivatives(point, &self.shading)
            })
    }

    /// The texture coordinates of a point on one of the BVH's primitives (a hit's or a light
    /// sample's); `(0, 0)` for points that lie on none. Computed on demand: only materials with
    /// image textures read them.
    pub fn texture_coordinates(&self, point: &SurfacePoint) -> [f64; 2] {
        self.primitives
            .get(point.primitive as usize)
            .map_or([0.0; 2], |p| p.texture_coordinates(point))
    }

    /// Whether anything blocks the open segment `o + t d`, `t ∈ (0, t_max)`.
    ///
    /// The primitives that blocked this thread's latest segments are tested first, before any
    /// traversal (a shadow cache, Haines & Greenberg 1986; module `occluders`): successive shadow
    /// rays from one vertex or towards one light are often blocked by the same triangles. The
    /// answer is exact either way: a primitive that blocks the segment is the proof that it is
    /// blocked, and traversal finds a blocker whenever one exists (its tests are conservative), so
    /// images do not depend on the cache, nor on the thread count. (Any index of this BVH will
    /// do, so the cache needs no reset between scenes.)
    pub fn occluded(&self, o: DVec3, d: DVec3, t_max: f64) -> bool {
        self.occluded_between(o, d, t_max, [NO_PRIMITIVE; 2])
    }

    /// [`Bvh::occluded`] for a segment between two surface points, offset from the primitives
    /// `ends` toward each other, which the segment cannot cross ([`SurfaceEnd`]; an end that it
    /// might cross is given as `NO_PRIMITIVE`): they are not tested, in traversal nor among the
    /// recent occluders. (Traversal reaches both ends'
    /// leaves: 50–96% of PT's occlusion tests on those scenes were of an end's triangle or
    /// another in its plane.)
    ///
    /// [`SurfaceEnd`]: crate::geometry::SurfaceEnd
    pub fn occluded_between(&self, o: DVec3, d: DVec3, t_max: f64, ends: [u32; 2]) -> bool {
        count_ray();
        if self.primitives.is_empty() {
            return false;
        }
        let (fields, blocks) = self.occluder_tests(o, d, t_max, ends);
        occluders::occluded(
            self.id,
            |packet| self.filter_occluders(packet, o, d, t_max),
            fields,
            blocks,
            || self.traverse_occluded(o, d, t_max, ends),
        )
    }

    /// What the shadow cache asks of its primitives for the segment `o + t d`, `t ∈ (0, t_max)`,
    /// between `ends`: primitive `i`'s packet lane, and whether it blocks the segment (`None`:
    /// no such primitive). The ends' triangles, as in traversal, cannot block.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn occluder_tests(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        ends: [u32; 2],
    ) -> (
        impl Fn(u32) -> Option<packet::LaneFields> + '_,
        impl Fn(u32) -> Option<bool> + '_,
    ) {
        (
            |i| {
                self.primitives
                    .get(i as usize)
                    .map(|p| packet::lane_fields(&p.lane()))
            },
            move |i| {
                let p = self.primitives.get(i as usize)?;
                Some(!((i == ends[0] || i == ends[1]) && p.is_triangle()) && p.hits(o, d, t_max))
            },
        )
    }

    /// The lanes of the shadow cache's `packet` that may block the segment (the packet filter
    /// of the CPU's copy).
    #[inline]
    fn filter_occluders(
        &self,
        packet: &packet::LoosePacket,
        o: DVec3,
        d: DVec3,
        t_max: f64,
    ) -> u32 {
        let ray = packet::PacketRay::new(o, d);
        let bound = wide::traversal_t_max(t_max);
        #[cfg(target_arch = "x86_64")]
        if cpu::has_v3() {
            // SAFETY: the CPU has every feature `filter_occluders_v3` is compiled for.
            return unsafe { filter_occluders_v3(packet, &ray, bound) };
        }
        packet.candidates::<false>(&ray, bound)
    }

    /// The blocker [`Bvh::occluded_between`] finds by traversal, if any: the copy of the query
    /// for this CPU.
    #[inline]
    fn traverse_occluded(&self, o: DVec3, d: DVec3, t_max: f64, ends: [u32; 2]) -> Option<u32> {
        #[cfg(target_arch = "x86_64")]
        if cpu::has_v3() {
            // SAFETY: the CPU has every feature `occluded_v3` is compiled for.
            return unsafe { self.occluded_v3(o, d, t_max, ends) };
        }
        self.occluded_in::<false>(o, d, t_max, ends)
    }

    /// [`Bvh::occluded_between`] compiled for x86-64-v3, with the AVX2 node and packet tests
    /// (see [`cpu`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2,bmi1,bmi2,fma,lzcnt,popcnt")]
    fn occluded_v3(&self, o: DVec3, d: DVec3, t_max: f64, ends: [u32; 2]) -> Option<u32> {
        self.occluded_in::<true>(o, d, t_max, ends)
    }

    /// The query itself, inlined into each copy (as [`Bvh::closest_hit_in`]): the index of a
    /// primitive that blocks the segment, if one does. Leaves are visited in any order.
    #[inline(always)]
    fn occluded_in<const V3: bool>(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        ends: [u32; 2],
    ) -> Option<u32> {
        let mut blocker = None;
        self.candidates::<V3, false>(o, d, t_max, |index, p, _| {
            if (index == ends[0] || index == ends[1]) && p.is_triangle() {
                return false;
            }
            let hit = p.hits(o, d, t_max);
            if hit {
                blocker = Some(index);
            }
            hit
        });
        blocker
    }

    /// The walk both queries share: every candidate (its index and primitive) of every leaf the
    /// segment `o + t d`, `t ∈ (0, t_max)`, enters, in lane order per leaf, the leaves near to far
    /// when `ORDERED`, until `test(index, primitive, bound)` returns true. `test` may lower the
    /// traversal distance `bound` (to [`wide::traversal_t_max`] of a hit), which culls farther
    /// leaves and the candidates beyond it. The traversal and packet tests are inlined here, so
    /// they are compiled with the features of the copy of the query that calls it; `test`, with
    /// no vector code, may stay a call.
    #[inline(always)]
    fn candidates<const V3: bool, const ORDERED: bool>(
        &self,
        o: DVec3,
        d: DVec3,
        t_max: f64,
        mut test: impl FnMut(u32, &Primitive, &mut f32) -> bool,
    ) {
        let copies = wide::RayCopies::new(o.to_array(), d.to_array());
        let mut ray = wide::WideRay::from_copies(&copies, wide::traversal_t_max(t_max));
        let packet_ray = packet::PacketRay::from_copies(&copies);
        let (mut fixed, mut heap) = (wide::FIXED, Vec::new());
        let mut traversal = wide::Traversal::<V3, ORDERED>::new(&self.wide, &mut fixed, &mut heap);
        while let Some(leaf) = traversal.next_leaf(&ray) {
            let mut mask = self.packets.candidates::<V3>(leaf, &packet_ray, ray.t_max);
            while mask != 0 {
                let j = mask.trailing_zeros();
                mask &= mask - 1;
                let index = self.packets.index(leaf, j);
                if test(index, &self.primitives[index as usize], &mut ray.t_max) {
                    return;
                }
            }
        }
    }

    /// Bounds of everything.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.primitives.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| {
                let (a, b) = p.bounds();
                (lo.min(a), hi.max(b))
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::NO_SHADING;
    use mcmc_core::rng::{stream, uniform};

    /// A primitive takes 104 bytes (a triangle's f32 texture coordinates; the enum's tag lives in
    /// a spare value of `flip`): a million-triangle mesh holds 25 MB less than at 128.
    #[test]
    fn primitives_are_104_bytes() {
        assert_eq!(std::mem::size_of::<Primitive>(), 104);
    }

    /// `permute` applies a permutation in place: `items[k]` becomes the old `items[order[k]]`, for
    /// random permutations of many cycle structures (and the identity and the empty list).
    #[test]
    fn permute_follows_cycles() {
        let mut rng = stream(5, 0);
        for n in [0usize, 1, 2, 3, 7, 100] {
            for _ in 0..20 {
                let mut order: Vec<u32> = (0..n as u32).collect();
                for i in (1..n).rev() {
                    let j = ((uniform(&mut rng) * (i + 1) as f64) as usize).min(i);
                    order.swap(i, j);
                }
                let mut items: Vec<u64> = (0..n as u64).map(|i| i * 10).collect();
                permute(&mut items, &order);
                let expected: Vec<u64> = order.iter().map(|&i| i as u64 * 10).collect();
                assert_eq!(items, expected, "order {order:?}");
            }
        }
    }

    /// The two-phase build (`topology`, then the primitives in its order) gives the same BVH as
    /// the one-call build, compact or not: same primitive order, same answers to the same rays.
    #[test]
    fn two_phase_build_equals_one_call_build() {
        let mut rng = stream(6, 0);
        let mut r = || uniform(&mut rng);
        let input: Vec<Primitive> = (0..500)
            .map(|i| {
                let c = DVec3::new(r(), r(), r()) * 4.0;
                if i % 10 == 0 {
                    Primitive::Sphere(Sphere {
                        center: c,
                        radius: 0.1 + 0.2 * r(),
                        flip: false,
                    })
                } else {
                    // Some long slivers, so that split references occur.
                    let e = if i % 7 == 0 { 3.0 } else { 0.3 };
                    let mut d = || DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5);
                    let (a, b) = (d() * e, d() * 0.3);
                    Primitive::Triangle(Triangle {
                        p: [c, c + a, c + b],
                        uv: [[0.0; 2]; 3],
                        flip: false,
                        shading: NO_SHADING,
                    })
                }
            })
            .collect();
        // And a grid, whose quads pair under `Compact::Pairs`.
        let mut input = input;
        input.extend(grid(8, 4.0, &mut r));
        let mut references = Vec::new();
        for compact in [Compact::No, Compact::Pairs] {
            let one = Bvh::with_options(input.clone(), Vec::new(), compact);
            references.push(one.references());
            let topology = Bvh::topology(input.len(), compact, |i, out| input[i].references(out));
            let ordered = topology
                .original()
                .iter()
                .map(|&i| input[i as usize])
                .collect();
            let two = Bvh::assemble(topology, ordered, Vec::new());
            assert_eq!(one.original, two.original);
            assert_eq!(one.primitives, two.primitives);
            for _ in 0..2000 {
                let o = DVec3::new(r(), r(), r()) * 6.0 - DVec3::ONE;
                let d = (DVec3::new(r(), r(), r()) - DVec3::splat(0.5)).normalize();
                assert_eq!(
                    one.closest_hit(o, d, f64::INFINITY),
                    two.closest_hit(o, d, f64::INFINITY)
                );
                assert_eq!(one.occluded(o, d, 2.0), two.occluded(o, d, 2.0));
            }
        }
        // Splits (more references than primitives) and pairs (fewer with them) both occur.
        assert!(references[0] > input.len(), "{references:?}");
        assert!(references[1] < references[0], "{references:?}");
    }

    /// A flat quad is hit by rays along its normal whatever the sign of their zero components
    /// (a direction of `(−0.0, −1, −0.0)` used to slip through).
    #[test]
    fn axis_aligned_rays_with_negative_zeros_hit_flat_geometry() {
        let quad = |a: DVec3, b: DVec3, c: DVec3| {
            Primitive::Triangle(Triangle {
                p: [a, b, c],
                uv: [[0.0; 2]; 3],
                flip: false,
                shading: NO_SHADING,
            })
        };
        let (p0, p1, p2, p3) = (
            DVec3::new(-2.0, 0.0, -2.0),
            DVec3::new(-2.0, 0.0, 2.0),
            DVec3::new(2.0, 0.0, 2.0),
            DVec3::new(2.0, 0.0, -2.0),
        );
        let bvh = Bvh::new(vec![quad(p0, p1, p2), quad(p0, p2, p3)]);
        let o = DVec3::new(0.3, 0.5, 0.7);
        for d in [
            DVec3::new(0.0, -1.0, 0.0),
            DVec3::new(-0.0, -1.0, -0.0),
            -DVec3::Y,
        ] {
            let hit = bvh.closest_hit(o, d, f64::INFINITY).expect("hits the quad");
            assert!((hit.t - 0.5).abs() < 1e-12);
            assert!(bvh.occluded(o, d, 1.0));
        }
    }

    /// The BVH finds exactly what brute force finds, split triangles included.
    #[test]
    fn agrees_with_brute_force() {
        let mut rng = stream(3, 0);
        let mut r = || uniform(&mut rng);
        let mut prims = Vec::new();
        for _ in 0..300 {
            let c = DVec3::new(r(), r(), r()) * 10.0;
            let p = [
                c,
                c + DVec3::new(r(), r(), r()),
                c + DVec3::new(r(), r(), r()),
            ];
            prims.push(Primitive::Triangle(Triangle {
                p,
                uv: [[0.0; 2]; 3],
                flip: false,
                shading: NO_SHADING,
            }));
        }
        // Long diagonal slivers, which enter the BVH as several references each.
        for _ in 0..100 {
            let c = DVec3::new(r(), r(), r()) * 10.0;
            let d = DVec3::new(r(), r(), r()) - DVec3::splat(0.5);
            prims.push(Primitive::Triangle(Triangle {
                p: [
                    c,
                    c + d * 8.0,
                    c + d * 8.0 + DVec3::new(r(), r(), r()) * 0.3,
                ],
                uv: [[0.0; 2]; 3],
                flip: false,
                shading: NO_SHADING,
            }));
        }
        for _ in 0..20 {
            prims.push(Primitive::Sphere(Sphere {
                center: DVec3::new(r(), r(), r()) * 10.0,
                radius: 0.3 * r() + 0.01,
                flip: false,
            }));
        }
        let bvh = Bvh::new(prims.clone());
        let references = bvh.references();
        assert!(references > prims.len() + 100, "{references} references");
        agrees_on_random_rays(&prims, &bvh, 4000, &mut r, 12.0);
    }

    /// Primitives very close to a segment's origin (closer than obvhs's smallest box entry
    /// distance, 10⁻⁴, which its traversal, used before the wide BVH, never entered) are found, by closest hit and occlusion, on the portable and the v3 path: a room's floor
    /// and back wall (two triangles each, among other geometry so the BVH has depth), and
    /// segments leaving the floor at distances `δ` from the wall, toward it. (With obvhs's
    /// traversal from the origin itself, every segment with `δ` below about 10⁻⁴ went through the
    /// wall.)
    #[test]
    fn primitives_at_the_origin_are_found() {
        let quad = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| {
            [[a, b, c], [a, c, d]].map(|p| {
                Primitive::Triangle(Triangle {
                    p,
                    uv: [[0.0; 2]; 3],
                    flip: false,
                    shading: NO_SHADING,
                })
            })
        };
        let (x0, x1) = (-2.0, 2.0);
        let mut prims = Vec::new();
        // Floor y = 0 and back wall z = −2.
        prims.extend(quad(
            DVec3::new(x0, 0.0, -2.0),
            DVec3::new(x1, 0.0, -2.0),
            DVec3::new(x1, 0.0, 2.0),
            DVec3::new(x0, 0.0, 2.0),
        ));
        prims.extend(quad(
            DVec3::new(x0, 0.0, -2.0),
            DVec3::new(x0, 3.0, -2.0),
            DVec3::new(x1, 3.0, -2.0),
            DVec3::new(x1, 0.0, -2.0),
        ));
        let mut rng = stream(12, 0);
        let mut r = || uniform(&mut rng);
        for _ in 0..60 {
            let c = DVec3::new(r() * 4.0 - 2.0, r() * 3.0, r() * 4.0 - 2.0);
            prims.extend(quad(
                c,
                c + DVec3::X * 0.1,
                c + DVec3::new(0.1, 0.1, 0.0),
                c + DVec3::Y * 0.1,
            ));
        }
        let bvh = Bvh::new(prims.clone());
        let mut tested = 0;
        for delta in [3e-5, 5e-5, 9e-5, 2e-4, 1e-3] {
            for k in 0..20 {
                let o = DVec3::new(-1.9 + 0.18 * k as f64, 2e-9, -2.0 + delta);
                let d = DVec3::new(0.1, 0.7, -0.7).normalize();
                let brute = prims
                    .iter()
                    .enumerate()
                    .filter_map(|(i, p)| p.intersect(o, d, f64::INFINITY, i as u32))
                    .min_by(|a, b| a.t.total_cmp(&b.t))
                    .expect("the wall");
                assert!(brute.t < 2.0 * delta, "the wall is first");
                let hit = bvh.closest_hit(o, d, f64::INFINITY).expect("a hit");
                assert_eq!(hit.t, brute.t, "delta {delta}, o {o}");
                assert!(
                    bvh.occluded_in::<false>(o, d, 1.0, [NO_PRIMITIVE; 2])
                        .is_some(),
                    "delta {delta}"
                );
                #[cfg(target_arch = "x86_64")]
                if cpu::cpu_has_v3() {
                    // SAFETY: the CPU has the v3 features.
                    unsafe {
                        assert!(
                            bvh.occluded_v3(o, d, 1.0, [NO_PRIMITIVE; 2]).is_some(),
                            "delta {delta}"
                        );
                        assert_eq!(
                            bvh.closest_hit_v3(o, d, f64::INFINITY, NO_PRIMITIVE)
                                .map(|((t, _, _), _)| t),
                            Some(brute.t)
                        );
                    }
                }
                tested += 1;
            }
        }
        assert_eq!(tested, 100);
    }

    /// The triangle `(0, X, Y)` with texture coordinates `uv` and shading entry `shading`, which
    /// rays along `−z` from `z = 1` hit (the on-demand tests below).
    fn corner_triangle(uv: [[f32; 2]; 3], shading: u32) -> Triangle {
        Triangle {
            p: [DVec3::ZERO, DVec3::X, DVec3::Y],
            uv,
            flip: false,
            shading,
        }
    }

    /// A ball of radius 0.5 under [`corner_triangle`] (centre `(0.3, 0.3, −3)`), which rays along
    /// `−z` from `z = −1` hit.
    fn ball_below(flip: bool) -> Sphere {
        Sphere {
            center: DVec3::new(0.3, 0.3, -3.0),
            radius: 0.5,
            flip,
        }
    }

    /// The derivatives the BVH computes on demand for a hit are its primitive's at the hit's
    /// barycentrics (a triangle's with its vertex normals from the shading table, a sphere's at
    /// its normal); a point sampled on the same triangle gets the same; a point on no primitive
    /// gets none. A hit where the interpolated normal equals the geometric one still gets the
    /// shading field's `∂n/∂u`.
    #[test]
    fn derivatives_on_demand_are_the_primitives() {
        let mut rng = stream(10, 0);
        let mut r = || uniform(&mut rng);
        let tri = corner_triangle([[0.0, 0.0], [2.0, 0.5], [0.3, 1.5]], 0);
        let normals = TriangleShading {
            n: [
                DVec3::new(0.3, 0.1, 1.0).normalize(),
                DVec3::new(-0.2, 0.2, 1.0).normalize(),
                DVec3::new(0.1, -0.3, 1.0).normalize(),
            ],
            s: None,
        };
        let ball = ball_below(true);
        let bvh = Bvh::with_shading(
            vec![Primitive::Triangle(tri), Primitive::Sphere(ball)],
            vec![normals],
        );
        for _ in 0..50 {
            let (x, y) = (0.4 * r(), 0.4 * r());
            let hit = bvh
                .closest_hit(DVec3::new(x, y, 1.0), -DVec3::Z, f64::INFINITY)
                .expect("the triangle");
            let [b1, b2] = hit.point.local;
            assert!(hit.point.shaded());
            let d = bvh.derivatives(&hit.point);
            assert_eq!(d, tri.derivatives(b1, b2, Some(&normals)));
            assert_ne!(d.dndu, DVec3::ZERO);
            let sampled = tri.point(b1, b2, hit.point.primitive);
            assert!(!sampled.shaded());
            assert_eq!(bvh.derivatives(&sampled), d);
            let below = bvh
                .closest_hit(
                    DVec3::new(0.3 + 0.8 * x, 0.3 - 0.8 * y, -1.0),
                    -DVec3::Z,
                    f64::INFINITY,
                )
                .expect("the sphere");
            assert_eq!(
                bvh.derivatives(&below.point),
                ball.derivatives(below.point.n, ball.local(below.point.n)[0])
            );
        }
        let lens = SurfacePoint::flat(DVec3::ZERO, DVec3::Z, u32::MAX);
        assert_eq!(bvh.derivatives(&lens), Derivatives::default());

        // Vertex normals tilted ±x at the first two corners interpolate to exactly the geometric
        // normal wherever b0 = b1: the point reads as unshaded, yet its normal turns along u.
        let tilted = TriangleShading {
            n: [
                DVec3::new(0.3, 0.0, 1.0).normalize(),
                DVec3::new(-0.3, 0.0, 1.0).normalize(),
                DVec3::Z,
            ],
            s: None,
        };
        let bvh = Bvh::with_shading(vec![Primitive::Triangle(tri)], vec![tilted]);
        let level = tri.point_shaded(0.25, 0.5, 0, Some(&tilted));
        assert!(!level.shaded());
        let d = bvh.derivatives(&level);
        assert_eq!(d, tri.derivatives(0.25, 0.5, Some(&tilted)));
        assert!(d.dndu.x.abs() > 0.1, "{:?}", d.dndu);
    }

    /// The texture coordinates the BVH computes on demand for a hit are its triangle's vertex
    /// coordinates interpolated in f64 at the hit's own barycentrics (the ray's, from the
    /// triangle's intersection alone), and a sphere's `(φ/2π, θ/π)` at its normal, bit for bit: a
    /// point that carried them rounded (to f32, as it once did) changes every textured image in
    /// its last bits, and fails here. A point on no primitive gets `(0, 0)`.
    #[test]
    fn texture_coordinates_on_demand_are_exact() {
        let mut rng = stream(12, 0);
        let mut r = || uniform(&mut rng);
        let tri = corner_triangle([[0.1, 0.7], [2.3, 0.5], [0.3, 1.9]], NO_SHADING);
        let ball = ball_below(false);
        let bvh = Bvh::new(vec![Primitive::Triangle(tri), Primitive::Sphere(ball)]);
        for _ in 0..200 {
            let (x, y) = (0.45 * r(), 0.45 * r());
            let (o, d) = (DVec3::new(x, y, 1.0), -DVec3::Z);
            let hit = bvh.closest_hit(o, d, f64::INFINITY).expect("the triangle");
            let (_, b1, b2) = tri.intersect(o, d, f64::INFINITY).expect("the triangle");
            let b0 = 1.0 - b1 - b2;
            let uv = tri.uv.map(|[u, v]| [f64::from(u), f64::from(v)]);
            let exact = [0, 1].map(|c| uv[0][c] * b0 + uv[1][c] * b1 + uv[2][c] * b2);
            let got = bvh.texture_coordinates(&hit.point);
            assert_eq!(
                got.map(f64::to_bits),
                exact.map(f64::to_bits),
                "at {x}, {y}"
            );

            let o = DVec3::new(0.3 + 0.8 * (x - 0.2), 0.3 - 0.8 * (y - 0.2), -1.0);
            let below = bvh.closest_hit(o, d, f64::INFINITY).expect("the sphere");
            let n = below.point.n;
            let exact = [
                crate::math::phi(n) / (2.0 * std::f64::consts::PI),
                n.z.clamp(-1.0, 1.0).acos() / std::f64::consts::PI,
            ];
            let got = bvh.texture_coordinates(&below.point);
            assert_eq!(
                got.map(f64::to_bits),
                exact.map(f64::to_bits),
                "at {x}, {y}"
            );
        }
        let lens = SurfacePoint::flat(DVec3::ZERO, DVec3::Z, u32::MAX);
        assert_eq!(bvh.texture_coordinates(&lens), [0.0; 2]);
    }

    /// A hit's surface point, with its triangle's frame from the per-thread cache, is the one its
    /// triangle gives from scratch, on two BVHs queried in turn on one thread (same indices,
    /// other triangles: a cache keyed by index alone fails) whose 300 triangles share the cache's
    /// 256 slots (a cache that kept the first frame in a slot fails).
    #[test]
    fn cached_triangle_frames_are_the_triangles() {
        let mut rng = stream(11, 0);
        let mut r = || uniform(&mut rng);
        let strip = |tilt: f64, uv: [[f32; 2]; 3]| -> Vec<Primitive> {
            (0..300)
                .map(|i| {
                    let x = 2.0 * f64::from(i);
                    Primitive::Triangle(Triangle {
                        p: [
                            DVec3::new(x, 0.0, 0.0),
                            DVec3::new(x + 1.5, 0.0, tilt),
                            DVec3::new(x, 1.5, -tilt),
                        ],
                        uv,
                        flip: i % 3 == 0,
                        shading: NO_SHADING,
                    })
                })
                .collect()
        };
        let a = Bvh::new(strip(0.0, [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]));
        let b = Bvh::new(strip(0.4, [[0.0, 0.0], [0.3, 2.0], [-1.0, 0.5]]));
        assert_ne!(a.id, b.id);
        for _ in 0..3000 {
            let o = DVec3::new(2.0 * (300.0 * r()).floor() + 0.3, 0.3, 5.0);
            for bvh in [&a, &b] {
                let hit = bvh
                    .closest_hit(o, -DVec3::Z, f64::INFINITY)
                    .expect("a triangle");
                let Primitive::Triangle(tri) = bvh.primitives[hit.point.primitive as usize] else {
                    panic!("only triangles");
                };
                let [b1, b2] = hit.point.local;
                assert_eq!(hit.point, tri.point(b1, b2, hit.point.primitive));
            }
        }
    }

    /// Occlusion with the recent occluders tested first agrees with brute force, on bundles of
    /// segments from one origin in nearby directions and of random lengths, so that the kept
    /// primitives block many of them (which the test counts) and lie beyond the end of others.
    #[test]
    fn recent_occluders_answer_exactly() {
        let mut rng = stream(9, 0);
        let mut r = || uniform(&mut rng);
        let prims = grid_slivers_and_spheres(16, &mut r);
        let bvh = Bvh::new(prims.clone());
        let (mut blocked, mut by_cache) = (0, 0);
        for _ in 0..500 {
            let o = DVec3::new(r(), r(), r()) * 12.0 - DVec3::splat(1.0);
            let axis = (DVec3::new(r(), r(), r()) - DVec3::splat(0.5)).normalize();
            for _ in 0..8 {
                let d = (axis + (DVec3::new(r(), r(), r()) - DVec3::splat(0.5)) * 0.05).normalize();
                let t = 20.0 * r();
                by_cache += occluders::kept().iter().any(|&i| {
                    bvh.primitives
                        .get(i as usize)
                        .is_some_and(|p| p.hits(o, d, t))
                }) as usize;
                let brute = prims.iter().any(|p| p.hits(o, d, t));
                blocked += brute as usize;
                assert_eq!(bvh.occluded(o, d, t), brute, "o {o} d {d} t {t}");
            }
        }
        assert!(
            by_cache > 200 && blocked > by_cache + 200,
            "{by_cache} of {blocked} blocked"
        );
    }

    /// The shadow cache's f32 filter skips only f64 tests that would fail: on bundles of
    /// segments (as in `recent_occluders_answer_exactly`) and on segments between the scene's
    /// own triangles (their ends excluded), a cache that filters and one that tests every
    /// occluder in f64 give the same answers and keep the same occluders in the same order after
    /// every query. Where the older occluders are tested (the filter's use) the filter skips
    /// over 90% of the f64 tests that fail (97.2% in 1233 such queries when written). Run with
    /// the CPU's filter and the portable one; a filter that wrongly rules out one lane makes the
    /// two caches part (checked here too, so the comparison is shown able to fail).
    #[test]
    fn filtered_occluders_keep_the_unfiltered_order() {
        let mut rng = stream(10, 0);
        let mut r = || uniform(&mut rng);
        let prims = grid_slivers_and_spheres(16, &mut r);
        let bvh = Bvh::new(prims);
        let mut segments = Vec::new();
        for _ in 0..600 {
            let o = DVec3::new(r(), r(), r()) * 12.0 - DVec3::splat(1.0);
            let axis = (DVec3::new(r(), r(), r()) - DVec3::splat(0.5)).normalize();
            for _ in 0..8 {
                let d = (axis + (DVec3::new(r(), r(), r()) - DVec3::splat(0.5)) * 0.05).normalize();
                segments.push((o, d, 20.0 * r(), [NO_PRIMITIVE; 2]));
            }
        }
        // Between points of two triangles, the ends excluded as `occluded_between` is told.
        let n = bvh.primitives.len() as u32;
        for _ in 0..2000 {
            let (a, b) = (
                (r() * f64::from(n)) as u32 % n,
                (r() * f64::from(n)) as u32 % n,
            );
            let (Primitive::Triangle(ta), Primitive::Triangle(tb)) =
                (&bvh.primitives[a as usize], &bvh.primitives[b as usize])
            else {
                continue;
            };
            let (pa, pb) = (
                (ta.p[0] + ta.p[1] + ta.p[2]) / 3.0,
                (tb.p[0] + tb.p[1] + tb.p[2]) / 3.0,
            );
            let v = pb - pa;
            if a == b || v.length() < 1e-3 {
                continue;
            }
            segments.push((pa, v.normalize(), v.length(), [a, b]));
        }
        // Runs both caches over the segments: (queries where they differ, and over the queries
        // where the older occluders are tested (the filter's use): their count, the f64 tests
        // skipped, the f64 tests of the unfiltered cache that failed, which alone it may skip).
        let compare = |filter: &dyn Fn(&packet::LoosePacket, DVec3, DVec3, f64) -> u32| {
            let mut filtered = occluders::RecentOccluders::testing_older();
            let mut every = occluders::RecentOccluders::testing_older();
            let (mut differ, mut queries, mut skipped, mut all) = (0, 0, 0, 0);
            for &(o, d, t, ends) in &segments {
                let tests = std::cell::Cell::new(0usize);
                let (fields, test) = bvh.occluder_tests(o, d, t, ends);
                let blocks = |i: u32| {
                    tests.set(tests.get() + 1);
                    test(i)
                };
                let tested = filtered.tests_older();
                let a = filtered.blocked(bvh.id, |p| filter(p, o, d, t), &fields, blocks);
                let filtered_tests = tests.replace(0);
                let b = every.blocked(bvh.id, |_| u32::MAX, &fields, blocks);
                if tested {
                    queries += 1;
                    skipped += tests.get() - filtered_tests;
                    // The unfiltered cache's last test blocked when `b`; the others failed.
                    all += tests.get() - usize::from(b);
                }
                for (cache, hit) in [(&mut filtered, a), (&mut every, b)] {
                    if !hit {
                        cache.traversed(bvh.traverse_occluded(o, d, t, ends));
                    }
                }
                differ += usize::from(a != b || filtered.slots() != every.slots());
            }
            (differ, queries, skipped, all)
        };
        let cpu = |p: &packet::LoosePacket, o, d, t| bvh.filter_occluders(p, o, d, t);
        let portable = |p: &packet::LoosePacket, o, d, t| {
            p.candidates::<false>(&packet::PacketRay::new(o, d), wide::traversal_t_max(t))
        };
        for (name, filter) in [
            ("cpu", &cpu as &dyn Fn(&_, _, _, _) -> u32),
            ("portable", &portable),
        ] {
            let (differ, queries, skipped, all) = compare(filter);
            assert_eq!(
                differ, 0,
                "{name}: the filtered cache parted from the unfiltered one"
            );
            assert!(
                queries > 500,
                "{name}: the older occluders tested in {queries} queries"
            );
            assert!(
                10 * skipped > 9 * all,
                "{name}: {skipped} of {all} failing f64 tests skipped"
            );
        }
        // The test of the test: a filter that drops lane 0 whatever it holds.
        let broken = |p: &packet::LoosePacket, o, d, t| cpu(p, o, d, t) & !1;
        let (differ, ..) = compare(&broken);
        assert!(differ > 0, "a broken filter went unnoticed");
    }

    /// Asserts that `bvh` (built over `prims`) finds exactly what brute force finds, closest hit
    /// and occlusion just before and after it, for `rays` random rays from the cube
    /// `[−1, size − 1]³`.
    fn agrees_on_random_rays(
        prims: &[Primitive],
        bvh: &Bvh,
        rays: usize,
        r: &mut impl FnMut() -> f64,
        size: f64,
    ) {
        for _ in 0..rays {
            let o = DVec3::new(r(), r(), r()) * size - DVec3::splat(1.0);
            let d = (DVec3::new(r(), r(), r()) - DVec3::splat(0.5)).normalize();
            let brute = prims
                .iter()
                .enumerate()
                .filter_map(|(i, p)| p.intersect(o, d, f64::INFINITY, i as u32))
                .min_by(|a, b| a.t.total_cmp(&b.t));
            let fast = bvh.closest_hit(o, d, f64::INFINITY);
            match (brute, fast) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    assert_eq!(a.point.primitive, bvh.original[b.point.primitive as usize]);
                    assert!((a.t - b.t).abs() < 1e-12);
                    assert!(bvh.occluded(o, d, a.t * 1.0001));
                    assert!(!bvh.occluded(o, d, a.t * 0.9999));
                }
                (a, b) => panic!("brute {a:?} vs bvh {b:?}"),
            }
        }
    }

    /// A bumpy grid of quads, each two consecutive triangles, over `[0, size]²`.
    fn grid(n: usize, size: f64, r: &mut impl FnMut() -> f64) -> Vec<Primitive> {
        let h: Vec<f64> = (0..(n + 1) * (n + 1)).map(|_| r() * 0.1).collect();
        let p = |i: usize, j: usize| {
            DVec3::new(i as f64, 0.0, j as f64) * (size / n as f64)
                + DVec3::Y * (size * 0.4 + h[i * (n + 1) + j])
        };
        let tri = |p: [DVec3; 3]| {
            Primitive::Triangle(Triangle {
                p,
                uv: [[0.0; 2]; 3],
                flip: false,
                shading: NO_SHADING,
            })
        };
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..n {
                out.push(tri([p(i, j), p(i + 1, j), p(i + 1, j + 1)]));
                out.push(tri([p(i, j), p(i + 1, j + 1), p(i, j + 1)]));
            }
        }
        out
    }

    /// `n` long slivers (split into several references each) alternating with `n` small spheres,
    /// in `[0, 10]³`.
    fn slivers_and_spheres(n: usize, r: &mut impl FnMut() -> f64) -> Vec<Primitive> {
        let mut out = Vec::with_capacity(2 * n);
        for _ in 0..n {
            let c = DVec3::new(r(), r(), r()) * 10.0;
            let d = DVec3::new(r(), r(), r()) - DVec3::splat(0.5);
            out.push(Primitive::Triangle(Triangle {
                p: [c, c + d * 8.0, c + d * 8.0 + DVec3::splat(0.2)],
                uv: [[0.0; 2]; 3],
                flip: false,
                shading: NO_SHADING,
            }));
            out.push(Primitive::Sphere(Sphere {
                center: DVec3::new(r(), r(), r()) * 10.0,
                radius: 0.3 * r() + 0.01,
                flip: false,
            }));
        }
        out
    }

    /// With `Compact::Pairs`, the two triangles of a quad share one reference (`PAIR`; without it
    /// they do not), and the BVH still finds exactly what brute force finds: on a grid alone (`Leaves::Ranges`) and on a grid with split
    /// slivers and spheres (`Leaves::Copies`). Dropping a pair's second triangle fails both.
    #[test]
    fn paired_triangles_agree_with_brute_force() {
        let mut rng = stream(4, 0);
        let mut r = || uniform(&mut rng);
        let prims = grid(24, 10.0, &mut r);
        assert_eq!(Bvh::new(prims.clone()).references(), prims.len());
        let bvh = Bvh::with_options(prims.clone(), Vec::new(), Compact::Pairs);
        // Every quad is a pair (edge quads included): one reference per two triangles.
        assert_eq!(bvh.references(), prims.len() / 2);
        agrees_on_random_rays(&prims, &bvh, 3000, &mut r, 12.0);

        let mut mixed = prims;
        mixed.extend(slivers_and_spheres(40, &mut r));
        let bvh = Bvh::with_options(mixed.clone(), Vec::new(), Compact::Pairs);
        // The grid's quads pair (576 references for 1152 triangles) and the 40 slivers split
        // (more references than slivers).
        let grid_alone = 24 * 24;
        let others = mixed.len() - 2 * grid_alone;
        assert!(
            bvh.references() > grid_alone + others && bvh.references() < mixed.len(),
            "{} references",
            bvh.references()
        );
        agrees_on_random_rays(&mixed, &bvh, 3000, &mut r, 12.0);
    }

    /// Whether the CPU has the x86-64-v3 features (a v3 test prints that it is skipped if not).
    #[cfg(target_arch = "x86_64")]
    fn v3_or_skip() -> bool {
        let has = cpu::cpu_has_v3();
        if !has {
            println!("skipped: this CPU lacks an x86-64-v3 feature");
        }
        has
    }

    /// An `n × n` grid over 10 units, with split slivers and spheres among its cells.
    #[cfg(target_arch = "x86_64")]
    fn grid_slivers_and_spheres(n: usize, r: &mut impl FnMut() -> f64) -> Vec<Primitive> {
        let mut prims = grid(n, 10.0, r);
        prims.extend(slivers_and_spheres(30, r));
        prims
    }

    /// The x86-64-v3 copies of the ray queries (`cpu`) answer exactly as the portable ones, hit
    /// for hit, on a scene with pairs, split slivers and spheres. (Skipped on CPUs without v3.)
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn v3_queries_equal_portable_queries() {
        if !v3_or_skip() {
            return;
        }
        let mut rng = stream(7, 0);
        let mut r = || uniform(&mut rng);
        let prims = grid_slivers_and_spheres(16, &mut r);
        for bvh in [
            Bvh::new(prims.clone()),
            Bvh::with_options(prims.clone(), Vec::new(), Compact::Pairs),
        ] {
            let mut hits = 0;
            for _ in 0..3000 {
                let o = DVec3::new(r(), r(), r()) * 12.0 - DVec3::splat(1.0);
                let d = (DVec3::new(r(), r(), r()) - DVec3::splat(0.5)).normalize();
                let t = 20.0 * r();
                // SAFETY: `cpu_has_v3` said the CPU has the features.
                let (hit, blocked) = unsafe {
                    (
                        bvh.closest_hit_v3(o, d, t, NO_PRIMITIVE),
                        bvh.occluded_v3(o, d, t, [NO_PRIMITIVE; 2]),
                    )
                };
                hits += hit.is_some() as usize;
                assert_eq!(hit, bvh.closest_hit_in::<false>(o, d, t, NO_PRIMITIVE));
                assert_eq!(
                    blocked,
                    bvh.occluded_in::<false>(o, d, t, [NO_PRIMITIVE; 2])
                );
            }
            assert!(hits > 300, "{hits} hits");
        }
    }
}
