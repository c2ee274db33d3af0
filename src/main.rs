//! The `vitrum` command line: a thin wrapper over [`vitrum::cli`].

fn main() {
    require_build_features();
    std::process::exit(vitrum::cli::main());
}

/// Stops with a clear message, instead of an illegal instruction mid-render, when this binary
/// was built for x86-64-v3 (`.cargo/config.toml` asks for it) and the processor lacks AVX2, FMA,
/// BMI1 or BMI2. The flags are read with `cpuid` itself: `is_x86_feature_detected!` answers
/// `true` at compile time for every feature the build enables.
fn require_build_features() {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    if !x86_64_v3::supported() {
        use std::io::Write;
        let _ = std::io::stderr().write_all(
            b"vitrum: this build needs an x86-64-v3 processor (AVX2, FMA, BMI1, BMI2), which this one \
              is not; rebuild for it with: RUSTFLAGS=\"-C target-cpu=x86-64\" cargo build --release\n",
        );
        std::process::exit(1);
    }
}

/// The processor check of an x86-64-v3 build.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod x86_64_v3 {
    use std::arch::x86_64::{__cpuid, __cpuid_count, _xgetbv};

    /// Whether the processor and the operating system support what x86-64-v3 code uses.
    #[inline(never)]
    pub fn supported() -> bool {
        let bit = |value: u32, n: u32| value >> n & 1 == 1;
        // Leaf 1: FMA (ECX 12), OSXSAVE (ECX 27), AVX (ECX 28). Leaf 7: BMI1 (EBX 3), AVX2
        // (EBX 5), BMI2 (EBX 8). XCR0 bits 1 and 2: the OS saves the SSE and AVX registers.
        let leaf1 = __cpuid(1);
        if !(bit(leaf1.ecx, 12) && bit(leaf1.ecx, 27) && bit(leaf1.ecx, 28)) {
            return false;
        }
        // SAFETY: OSXSAVE is set, so XGETBV is available.
        let xcr0 = unsafe { _xgetbv(0) };
        let leaf7 = __cpuid_count(7, 0);
        xcr0 & 6 == 6 && bit(leaf7.ebx, 3) && bit(leaf7.ebx, 5) && bit(leaf7.ebx, 8)
    }

    #[cfg(test)]
    mod tests {
        #[test]
        fn the_machine_running_this_build_supports_it() {
            // This test binary is x86-64-v3 code and it runs: a wrong bit in the check fails here.
            assert!(super::supported());
        }
    }
}
