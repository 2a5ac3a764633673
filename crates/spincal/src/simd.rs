//! The SIMD kernels' CPU features: the run-time check and the one list of features they are
//! compiled for.
//!
//! The wide kernels (the network's Gram tiles, its Cholesky group update and tanh) are compiled
//! for AVX-512F on top of x86-64-v3 by [`avx512_kernel!`], the one place that list is written,
//! and run only where [`has_avx512`] says so. The rule: every unsafe SIMD entry point is reached
//! only after that check says the CPU has the features. The SSE2 of `input::decimal` is the one
//! exception that needs no check: every x86-64 CPU has it.
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

/// Whether the wide kernels run here: x86-64-v3 and AVX-512F, on an Intel CPU (asked once).
/// AMD's Zen 4 runs a 512-bit operation as two 256-bit halves, so there they would only cost.
#[cfg(target_arch = "x86_64")]
pub(crate) fn has_avx512() -> bool {
    static WIDE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *WIDE.get_or_init(|| {
        pulp::x86::V3::try_new().is_some() && std::arch::is_x86_feature_detected!("avx512f") && is_intel()
    })
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
