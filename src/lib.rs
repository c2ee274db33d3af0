//! vitrum: a research renderer for scenes with transparent objects.
//!
//! One scene description, one BVH, every classic method: ray casting, Whitted ray tracing and the
//! methods that follow. Data flow: `scene::desc` (TOML) → `scene::compile` → [`scene::Scene`] →
//! an [`integrators::Integrator`] driven by [`render`] → [`output`] (EXR, PNG, JSON).

pub mod bsdf;
pub mod camera;
pub mod cli;
pub mod commands;
pub mod conductor;
pub mod dispersion;
pub mod export;
pub mod figure;
pub mod flip;
pub mod geometry;
pub mod image;
pub mod interrupt;
pub mod lanes;
pub mod light;
pub mod lighting;
pub mod manifold;
pub mod material;
pub mod memory;
pub mod methods;
pub mod metrics;
pub mod optics;
pub mod output;
pub mod params;
pub mod parts;
pub mod pixel_filter;
pub mod reference;
pub mod render;
pub mod report;
pub mod sampler;
pub mod scene;
pub mod spectrum;
pub mod stats;
pub mod texture;

// The integrators live in the top-level `integrators/` folder, one file per method (docs/architecture.md).
#[path = "../integrators/mod.rs"]
pub mod integrators;

/// The crate version, written into every output file.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
