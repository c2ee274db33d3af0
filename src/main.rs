//! The `vitrum` command line: a thin wrapper over [`vitrum::cli`].

fn main() {
    require_build_features();
    std::process::exit(vitrum::cli::main());
}

/// Stops with a clear message, instead of an illegal instruction mid-render, when this binary
/// was built for a newer x86-64 level (`.cargo/config.toml` asks for x86-64-v3) than the
/// processor it runs on has.
fn require_build_features() {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    if !(std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
        && std::arch::is_x86_feature_detected!("bmi2"))
    {
        eprintln!(
            "vitrum: this build needs an x86-64-v3 processor (AVX2, FMA, BMI2), which this one is not; \
             rebuild for it with: RUSTFLAGS=\"-C target-cpu=x86-64\" cargo build --release"
        );
        std::process::exit(1);
    }
}
