//! What this CPU can run beyond the compilation target's baseline, detected at run time.
//!
//! The binary is built for plain x86-64 (SSE2), so that it runs on any kiosk's processor; the
//! hot loops (the RBF kernel sum, the multi-scale features, the box filters) also exist as
//! 256-bit AVX2 variants, chosen here once per call. The variants compile the same Rust code
//! for wider registers and give the same bits: without an explicit `mul_add` the compiler
//! never fuses a multiply and an add, and it keeps the order of every floating-point sum.

/// Whether the CPU has AVX2 and FMA (every x86-64 processor since about 2013-2015; not some
/// low-power Atom and Celeron parts). The standard library caches the answer.
#[cfg(target_arch = "x86_64")]
pub fn has_avx2_fma() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
}
