//! Shape tests across rays: one shape against [`WIDTH`] rays at once, and a scene's primitives
//! grouped for them or its BVH traversed by them ([`LaneScene`]): the closest hits and shadow rays
//! of the wavefront engine of `path` (`integrators/wavefront.rs`).
//!
//! Rays are stored as structure of arrays ([`RayLanes`]) and every kernel is written once, as
//! plain loops over the lanes that repeat the scalar test's arithmetic operation for operation
//! (the same products, sums, divisions and square roots in the same order, comparisons as
//! selects), so that each lane's result is the scalar [`crate::geometry::Shape::intersect`]'s to
//! the last bit. The loops are compiled three times, for AVX-512, AVX2 and the build's target
//! (`#[target_feature]` wrappers around one `#[inline(always)]` body, chosen once at run time by
//! [`Isa::detect`]): LLVM vectorises them to 16 or 8 lanes per instruction. `std::arch` with
//! runtime detection, not a SIMD crate: the kernels need nothing beyond what the compiler's
//! vectoriser does with plain loops, and the dispatch is three lines.

mod bvh;
mod camera;
mod real;
mod sampler;
mod scene;
mod shapes;
mod wide;

pub use camera::camera_rays;
pub use real::{Mask3, Real, Vector};
pub use sampler::{sobol_firsts, sobol_pairs};
pub use scene::{LaneHits, LaneScene, SurfaceX};
pub use shapes::{cylinder_hits, disk_hits, quad_hits, sphere_hits};
pub use wide::{F32x, Mask, Vec3x};

/// Rays per batch: 16 single-precision lanes fill one AVX-512 register, two AVX2 ones.
pub const WIDTH: usize = 16;

/// One value per lane.
pub type Lanes = [f32; WIDTH];

/// [`WIDTH`] rays in structure-of-arrays form: per axis, the origins' and directions'
/// components of every lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayLanes {
    /// Origins, per axis (x, y, z).
    pub origin: [Lanes; 3],
    /// Directions, per axis.
    pub dir: [Lanes; 3],
}

impl RayLanes {
    /// The rays of `rays` (at most [`WIDTH`]); missing lanes get a zero direction, which hits
    /// nothing.
    pub fn gather(rays: &[crate::geometry::Ray]) -> RayLanes {
        let mut lanes = RayLanes::default();
        for (k, r) in rays.iter().take(WIDTH).enumerate() {
            for axis in 0..3 {
                lanes.origin[axis][k] = r.origin[axis];
                lanes.dir[axis][k] = r.dir[axis];
            }
        }
        lanes
    }
}

/// The vector instruction set the kernels run with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// 16 lanes per instruction (x86-64 `avx512f` with `dq`, `bw` and `vl`: every AVX-512 CPU
    /// since Skylake-SP; the 64-bit products of the sampler's hashes need `dq`).
    Avx512,
    /// 8 lanes per instruction (x86-64 `avx2`). Rust never fuses a product and a sum on its
    /// own, so with `fma` available too the lanes still round as the scalar code does.
    Avx2,
    /// The build's own target: x86-64-v3 (AVX2) under this repository's `.cargo/config.toml`,
    /// SSE2 for a plain x86-64 build.
    Baseline,
}

impl Isa {
    /// The widest set this CPU has, or the narrower one that the environment variable
    /// `VITRUM_ISA` names (`avx512`, `avx2`, `baseline`; for measuring one set against another
    /// on the same machine). Read once.
    pub fn detect() -> Isa {
        static CHOSEN: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *CHOSEN.get_or_init(|| {
            let widest = Isa::available()[0];
            let asked = std::env::var("VITRUM_ISA").ok().and_then(|name| Isa::from_name(&name));
            // A set the CPU lacks is never chosen.
            asked.filter(|isa| isa.runs_here()).unwrap_or(widest)
        })
    }

    /// The set named `name` (`avx512`, `avx2` or `baseline`).
    pub fn from_name(name: &str) -> Option<Isa> {
        match name {
            "avx512" => Some(Isa::Avx512),
            "avx2" => Some(Isa::Avx2),
            "baseline" => Some(Isa::Baseline),
            _ => None,
        }
    }

    /// The set's name, with the lanes one instruction covers.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Avx512 => "AVX-512, 16 lanes",
            Isa::Avx2 => "AVX2, 8 lanes",
            Isa::Baseline => "the build target's vectors",
        }
    }

    /// Every set this CPU can run, widest first (for tests that compare them).
    pub fn available() -> Vec<Isa> {
        [Isa::Avx512, Isa::Avx2, Isa::Baseline].into_iter().filter(|&i| i.runs_here()).collect()
    }

    /// Whether this CPU can run kernels compiled for `self` (the CPU's features are read once).
    pub fn runs_here(self) -> bool {
        static FEATURES: std::sync::OnceLock<[bool; 2]> = std::sync::OnceLock::new();
        let [avx512, avx2] = *FEATURES.get_or_init(|| {
            #[cfg(target_arch = "x86_64")]
            {
                [
                    std::arch::is_x86_feature_detected!("avx512f")
                        && std::arch::is_x86_feature_detected!("avx512dq")
                        && std::arch::is_x86_feature_detected!("avx512bw")
                        && std::arch::is_x86_feature_detected!("avx512vl"),
                    std::arch::is_x86_feature_detected!("avx2"),
                ]
            }
            #[cfg(not(target_arch = "x86_64"))]
            {
                [false, false]
            }
        });
        match self {
            Isa::Baseline => true,
            Isa::Avx512 => avx512,
            Isa::Avx2 => avx2,
        }
    }
}

/// Defines `$name(isa, args…)`, which runs the `#[inline(always)]` kernel `$body` compiled for
/// the instruction set `isa` (falling back to the baseline where the CPU lacks it).
macro_rules! dispatch {
    ($(#[$doc:meta])* $vis:vis fn $name:ident$(<$($lt:lifetime),*>)?($($arg:ident: $ty:ty),*) -> $ret:ty => $body:path) => {
        $(#[$doc])*
        #[allow(clippy::too_many_arguments)]
        $vis fn $name$(<$($lt),*>)?(isa: $crate::lanes::Isa, $($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl")]
                #[allow(clippy::too_many_arguments)]
                unsafe fn avx512$(<$($lt),*>)?($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                #[allow(clippy::too_many_arguments)]
                unsafe fn avx2$(<$($lt),*>)?($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                if isa.runs_here() {
                    match isa {
                        // SAFETY: the CPU has the feature (checked just above).
                        $crate::lanes::Isa::Avx512 => return unsafe { avx512($($arg),*) },
                        // SAFETY: as above.
                        $crate::lanes::Isa::Avx2 => return unsafe { avx2($($arg),*) },
                        $crate::lanes::Isa::Baseline => {}
                    }
                }
            }
            let _ = isa;
            $body($($arg),*)
        }
    };
}
pub(crate) use dispatch;
