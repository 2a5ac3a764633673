//! The SIMD kernels' CPU features: the run-time check and the one list of features they are
//! compiled for.
//!
//! The wide kernels (the network's Gram tiles, its Cholesky group update and tanh) are compiled
//! for AVX-512F on top of x86-64-v3 by [`avx512_kernel!`], the one place that list is written.
//! Two questions, kept apart: [`has_avx512`] is whether the CPU *can* run them (the safety
//! precondition, and what the tests ask, so that the kernels are tested on every CPU that has the
//! instructions, AMD's included), [`wide_kernels_chosen`] whether the dispatch *does* (a speed
//! choice). The rule: every unsafe SIMD entry point is reached only after [`has_avx512`] says the
//! CPU has the features. The SSE2 of `input::decimal` is the one exception that needs no check:
//! every x86-64 CPU has it.
//!
//! A kernel is an `unsafe fn` only when it has a precondition besides the features (pointers it
//! reads); one that only computes on registers is a safe `#[target_feature]` fn, which is unsafe
//! to call from code compiled without the features.

/// Compiles the wrapped functions for AVX-512F and x86-64-v3 (pulp's `V3` set), on x86-64 only.
/// Call them only where [`has_avx512`] is true.
macro_rules! avx512_kernel {
    ($($kernel:item)*) => {$(
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx,avx2,fma,bmi1,bmi2,lzcnt,popcnt,sse3,ssse3,sse4.1,sse4.2")]
        $kernel
    )*};
}
pub(crate) use avx512_kernel;

/// Whether this CPU has the wide kernels' features: x86-64-v3 and AVX-512F (asked once). The
/// precondition of every wide kernel, whoever the CPU's maker.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512() -> bool {
    static HAS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *HAS.get_or_init(|| pulp::x86::V3::try_new().is_some() && std::arch::is_x86_feature_detected!("avx512f"))
}

/// Whether the dispatch runs the wide kernels: where the CPU has them ([`has_avx512`]) and is
/// Intel's (asked once). The measurement behind it: on a 2-vCPU Intel Xeon with AVX-512F (KVM)
/// the 512-bit Gram tile took an LM epoch from 2.52–2.57 to 2.22–2.24 ms at 3,000 samples
/// (−12 %) and −13 % at 30,000 (bench/ann/RESULTS.md, "A 512-bit tile on Intel CPUs"). On AMD
/// it is not measured: the CI kind (AMD EPYC with AVX-512) keeps the four-lane kernels because
/// Zen 4 runs a 512-bit operation as two 256-bit halves, where the tile's two inserts per step
/// would only add work. Measure the A/B there (`ann_epoch time`) before widening this.
#[cfg(target_arch = "x86_64")]
pub(crate) fn wide_kernels_chosen() -> bool {
    static CHOSEN: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *CHOSEN.get_or_init(|| has_avx512() && is_intel())
}

/// Whether the CPU's vendor string is Intel's.
#[cfg(target_arch = "x86_64")]
fn is_intel() -> bool {
    let vendor = std::arch::x86_64::__cpuid(0);
    // "GenuineIntel" as cpuid returns it, in EBX, EDX, ECX.
    (vendor.ebx, vendor.edx, vendor.ecx) == (0x756e_6547, 0x4965_6e69, 0x6c65_746e)
}

#[cfg(test)]
mod tests {
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_dispatch_chooses_the_wide_kernels_only_where_the_cpu_has_them() {
        assert!(!super::wide_kernels_chosen() || super::has_avx512());
        assert_eq!(
            super::wide_kernels_chosen(),
            super::has_avx512() && super::is_intel()
        );
        // Printed so that a CI log says which kernels the tests beside them ran.
        eprintln!(
            "AVX-512F here: {}; the dispatch's wide kernels: {}",
            super::has_avx512(),
            super::wide_kernels_chosen()
        );
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn intel_is_read_from_the_vendor_string() {
        let vendor = std::arch::x86_64::__cpuid(0);
        let mut name = Vec::new();
        for register in [vendor.ebx, vendor.edx, vendor.ecx] {
            name.extend_from_slice(&register.to_le_bytes());
        }
        assert_eq!(
            super::is_intel(),
            name == b"GenuineIntel",
            "{}",
            String::from_utf8_lossy(&name)
        );
    }
}
