//! The bidirectional engine (`bpt`, `ppm`, `bpm`, `vcm`) and `light` trace their shadow rays 16
//! at a time and walk their camera sub-paths 16 side by side where the scene has a lane form;
//! `--engine scalar` traces every ray on its own. Both must give the same bits.

mod common;

use common::render_opts;
use std::path::Path;
use vitrum::image::Image;
use vitrum::integrators::{create, EngineOption};
use vitrum::render::RenderOptions;
use vitrum::scene::load;

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

#[test]
fn lanes_and_one_ray_at_a_time_give_the_same_bits() {
    // cornell-glass: every primitive tested across lanes; smooth-glass: a mesh, the BVH
    // traversed across lanes; glass-in-sky: an environment map; textured-box: textures;
    // motion-blur: no lane form (both forms trace one ray at a time, a check of the queue).
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in ["cornell-glass", "smooth-glass", "glass-in-sky", "textured-box", "motion-blur"] {
        let scene = load(&root.join(format!("{name}.toml"))).unwrap();
        for method in ["bpt", "ppm", "bpm", "vcm", "light"] {
            let integrator = create(method).unwrap();
            let [scalar, lanes] = [EngineOption::Scalar, EngineOption::Auto].map(|engine| {
                let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 2);
                opts.resolution = Some((24, 20));
                opts.params.engine = engine;
                render_opts(&scene, method, &opts)
            });
            let (a, b) = (bits(&scalar.image), bits(&lanes.image));
            let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            assert_eq!(differing, 0, "{name}, {method}: {differing} of {} pixels differ", a.len());
            assert_eq!(scalar.rays, lanes.rays, "{name}, {method}: ray counts");
            assert_eq!(scalar.non_finite_samples, lanes.non_finite_samples, "{name}, {method}");
            // The renders trace rays (shadow rays where the method connects) and see light, so
            // the comparison means something.
            assert!(scalar.rays.total() > 1000, "{name}, {method}: {} rays", scalar.rays.total());
            if matches!(method, "bpt" | "vcm" | "light") {
                assert!(scalar.rays.shadow >= 50, "{name}, {method}: {} shadow rays", scalar.rays.shadow);
            }
            let lit = a.iter().filter(|p| p.iter().any(|&c| f32::from_bits(c) > 0.0)).count();
            // (Photon mapping's merges and light tracing's splats at 2 samples light a few
            // pixels only.)
            let least = if matches!(method, "bpt" | "vcm") { a.len() / 4 } else { 1 };
            assert!(lit >= least, "{name}, {method}: {lit} of {} pixels lit", a.len());
        }
    }
}

#[test]
fn wavelengths_split_at_dispersive_glass_give_the_same_bits() {
    // Spectral glass-of-water (quads, a cylinder and disks: every primitive tested across lanes):
    // sub-paths split their wavelengths at its glass and water, and a camera path's branches walk
    // on in its lane where it ends, in the order of the walk one ray at a time.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = load(&root.join("glass-of-water.toml")).unwrap();
    for method in ["bpt", "ppm", "bpm", "vcm"] {
        let integrator = create(method).unwrap();
        let [scalar, lanes] = [EngineOption::Scalar, EngineOption::Auto].map(|engine| {
            let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 2);
            opts.resolution = Some((32, 32));
            opts.spectral = vitrum::scene::SpectralMode::On;
            opts.params.engine = engine;
            render_opts(&scene, method, &opts)
        });
        assert!(scalar.spectral, "{method}");
        let (a, b) = (bits(&scalar.image), bits(&lanes.image));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert_eq!(differing, 0, "{method}: {differing} of {} pixels differ", a.len());
        assert_eq!(scalar.rays, lanes.rays, "{method}: ray counts");
        assert!(scalar.rays.refracted > 1000, "{method}: {} refracted rays", scalar.rays.refracted);
    }
}

#[test]
fn light_paths_cut_at_a_chunks_vertex_bound_give_the_same_bits() {
    // A closed room of bright walls: a light path stores about 10 vertices, so the first round's
    // chunks (sized for 3 per path) stop at their vertex bound partway through their paths, and
    // an iteration takes several batches, whose camera paths walk again 16 side by side. The
    // paths after the cut are dropped and traced again in the next round: the same bits as one
    // ray at a time.
    let scene = vitrum::scene::load_str(common::BRIGHT_ROOM, "bright room", None).unwrap();
    for method in ["bpt", "vcm"] {
        let integrator = create(method).unwrap();
        let [scalar, lanes] = [EngineOption::Scalar, EngineOption::Auto].map(|engine| {
            let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 1);
            opts.params.engine = engine;
            render_opts(&scene, method, &opts)
        });
        let (a, b) = (bits(&scalar.image), bits(&lanes.image));
        let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert_eq!(differing, 0, "{method}: {differing} of {} pixels differ", a.len());
        assert_eq!(scalar.rays, lanes.rays, "{method}: ray counts");
        assert!(scalar.rays.shadow > 50_000, "{method}: {} shadow rays", scalar.rays.shadow);
    }
}
