//! The per-sample path allocates nothing: every camera method's `radiance` and every scene query
//! run on the stack, so the heap (and its lock-free but not free allocator) stays out of the
//! inner loop. A counting global allocator checks it on shipped scenes that exercise every
//! material, light and effect.

use glam::Vec2;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use vitrum::integrators::{create, PathContext, RenderParams};
use vitrum::render::camera_for;
use vitrum::sampler::{Sampler, SamplerKind};
use vitrum::scene;
use vitrum::spectrum::{Channels, Wavelengths};

/// The system allocator, counting the allocations and reallocations of each thread (the test
/// harness's own threads allocate while a test runs).
struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

/// One more allocation by this thread.
fn count() {
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

/// The allocations this thread has made so far.
fn allocations() -> u64 {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn camera_samples_allocate_nothing() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scenes =
        ["cornell-glass", "soft-shadows", "frosted-glass", "dispersion", "coloured-glass", "motion-blur"];
    for name in scenes {
        let scene = scene::load(&root.join(format!("{name}.toml"))).unwrap();
        let camera = camera_for(&scene, Some((32, 32)));
        for integrator in ["raycast", "whitted", "distributed", "path"] {
            let method = create(integrator).unwrap();
            let params = RenderParams::with_depth(method.default_max_depth().min(64));
            // The spectral tables are built once per process, on first use: not per sample.
            std::hint::black_box(Wavelengths::sample(0.5));
            let before = allocations();
            let mut samples = 0u64;
            let mut first = None;
            for pixel in 0..32 * 32u32 {
                for s in 0..4 {
                    let mut ctx = PathContext::new(Sampler::new(SamplerKind::Sobol, 3, pixel as u64, s, 4));
                    if scene.effects.has(vitrum::scene::Effect::Dispersion) {
                        ctx.channels = Channels::Spectral(Wavelengths::sample(0.2 * s as f32 + 0.1));
                    }
                    let film = Vec2::new((pixel % 32) as f32 + 0.5, (pixel / 32) as f32 + 0.5);
                    let ray = camera.generate_ray(film);
                    let b = allocations();
                    std::hint::black_box(method.radiance(&scene, &params, &ray, &mut ctx));
                    if first.is_none() && allocations() > b {
                        first = Some((pixel, s));
                    }
                    samples += 1;
                }
            }
            let allocations = allocations() - before;
            assert_eq!(
                allocations, 0,
                "{name}: {integrator}: {allocations} allocations in {samples} samples"
            );
        }
    }
}
