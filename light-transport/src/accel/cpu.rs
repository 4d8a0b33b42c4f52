//! Runtime CPU dispatch for ray queries. The default build targets baseline x86-64, where the
//! compressed wide BVH's traversal (Ylitie et al. 2017) counts child bits without `popcnt` and
//! `lzcnt`. [`has_v3`] says once per process whether the CPU has the x86-64-v3 features (AVX2,
//! FMA, BMI1/2, LZCNT, POPCNT), and the BVH then runs copies of its queries compiled for them.
//!
//! Results are bit-identical either way: Rust never contracts `a·b + c` into a fused
//! multiply-add on its own, and the explicit `mul_add`s round once on both paths. Setting
//! `CHARTED_PORTABLE=1` in the environment forces the portable path (for measuring the
//! difference).

use glam::Vec3A;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray;
use std::sync::OnceLock;

/// Whether this process runs the x86-64-v3 copies of the ray queries: the CPU has the features
/// and `CHARTED_PORTABLE` does not ask for the portable path.
pub fn has_v3() -> bool {
    static V3: OnceLock<bool> = OnceLock::new();
    *V3.get_or_init(|| {
        std::env::var_os("CHARTED_PORTABLE").is_none_or(|v| v.is_empty() || v == "0")
            && cpu_has_v3()
    })
}

/// Whether the CPU has every feature the v3 copies are compiled for.
pub fn cpu_has_v3() -> bool {
    std::arch::is_x86_feature_detected!("avx")
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
        && std::arch::is_x86_feature_detected!("bmi1")
        && std::arch::is_x86_feature_detected!("bmi2")
        && std::arch::is_x86_feature_detected!("lzcnt")
        && std::arch::is_x86_feature_detected!("popcnt")
}

/// The ray against the eight child boxes of a compressed wide BVH node at once, in AVX2:
/// obvhs's `CwBvhNode::intersect_ray` (its SSE version) with each quantised coordinate widened
/// from a byte to a float by one vector instruction for all eight children, where obvhs converts
/// them one at a time, and without the branch per child. Returns the same hit mask, bit for bit:
/// the same products and sums in the same order (no fused multiply-add), the same `max`/`min`
/// operand order (which would decide the result for a NaN, should a product ever overflow) and
/// the same ordered `≤`.
///
/// The mask's high byte holds the hit inner children, shifted by their traversal priority; its
/// low 24 bits the unary-coded primitive counts of the hit leaves (Ylitie et al. 2017, §3).
#[target_feature(enable = "avx,avx2,bmi1,bmi2,fma,lzcnt,popcnt")]
#[inline]
pub fn intersect_node_v3(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    use std::arch::x86_64::*;
    let adj_dir_inv = node.compute_extent() * ray.inv_direction;
    let adj_origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // The eight bytes of one quantised coordinate as floats.
    let q = |bytes: &[u8; 8]| {
        // SAFETY: `bytes` is eight readable bytes; the load has no alignment requirement.
        let v = unsafe { _mm_loadl_epi64(bytes.as_ptr().cast::<__m128i>()) };
        _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(v))
    };
    // The near and far planes of each axis, by the sign of the ray's direction there.
    let axis = |lo: &[u8; 8], hi: &[u8; 8], negative: bool, scale: f32, offset: f32| {
        let (near, far) = if negative { (hi, lo) } else { (lo, hi) };
        let (scale, offset) = (_mm256_set1_ps(scale), _mm256_set1_ps(offset));
        (
            _mm256_add_ps(_mm256_mul_ps(q(near), scale), offset),
            _mm256_add_ps(_mm256_mul_ps(q(far), scale), offset),
        )
    };
    let d = ray.direction;
    let (min_x, max_x) = axis(
        &node.child_min_x,
        &node.child_max_x,
        d.x < 0.0,
        adj_dir_inv.x,
        adj_origin.x,
    );
    let (min_y, max_y) = axis(
        &node.child_min_y,
        &node.child_max_y,
        d.y < 0.0,
        adj_dir_inv.y,
        adj_origin.y,
    );
    let (min_z, max_z) = axis(
        &node.child_min_z,
        &node.child_max_z,
        d.z < 0.0,
        adj_dir_inv.z,
        adj_origin.z,
    );
    let t_min = _mm256_max_ps(min_x, _mm256_max_ps(min_y, min_z));
    let t_max = _mm256_min_ps(max_x, _mm256_min_ps(max_y, max_z));
    let t_min = _mm256_max_ps(t_min, _mm256_set1_ps(OBVHS_EPSILON));
    let t_max = _mm256_min_ps(t_max, _mm256_set1_ps(ray.tmax));
    let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t_min, t_max)) as u64;
    // One byte of ones per hit child, so that missed children contribute no bits.
    let hit_bytes = _pdep_u64(hit, 0x0101_0101_0101_0101) * 0xff;
    let (child_bits, bit_index) = node.get_child_and_index_bits(oct_inv4);
    let child_bits = child_bits & hit_bytes;
    let mut mask = 0u32;
    for j in 0..8 {
        let bits = (child_bits >> (8 * j)) as u32 & 0xff;
        mask |= bits << ((bit_index >> (8 * j)) as u32 & 0x1f);
    }
    mask
}

/// The smallest entry distance obvhs's node test accepts (its `cwbvh::node::EPSILON`, which is
/// private; `node_test_matches_obvhs` would catch a change).
const OBVHS_EPSILON: f32 = 0.0001;
