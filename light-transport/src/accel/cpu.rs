//! Runtime CPU dispatch for ray queries. The default build targets baseline x86-64 (SSE2).
//! [`has_v3`] says once per process whether the CPU has the x86-64-v3 features (AVX2, FMA,
//! BMI1/2, LZCNT, POPCNT), and the BVH then runs copies of its queries compiled for them: the
//! wide node test in one AVX vector instead of two SSE halves, and the packet test of a leaf's
//! eight triangles in AVX2 with fused multiply-adds instead of lane by lane.
//!
//! Results are bit-identical either way: both copies visit the same nodes in the same order (the
//! node tests evaluate the same operations), and both packet tests are conservative, so the f64
//! tests of their candidates, which decide every hit, see the same primitives in the same order.
//! Setting `CHARTED_PORTABLE=1` in the environment forces the portable path (for measuring the
//! difference).

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
