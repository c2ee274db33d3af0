//! A scene whose light paths store more vertices than a batch holds (a closed room of bright
//! walls): the bidirectional engine traces each iteration's light paths in several batches of
//! bounded memory, and the estimate stays unbiased and independent of the thread count.

mod common;

use std::process::Command;
use vitrum::integrators::create;
use vitrum::output::exr::read_exr;
use vitrum::render::{render, RenderOptions};
use vitrum::sampler::SamplerKind;
use vitrum::scene::{load_str, Scene};

/// Pixels per side of the bright room: 96² light paths per iteration.
const SIDE: u32 = 96;

/// The bright room's cap on light paths per iteration: 9216, the pixel count.
const CAP: u32 = SIDE * SIDE;

/// The closed bright room ([`common::BRIGHT_ROOM`]). A light path stores about 10 vertices
/// (measured: 42 000 for 4096 paths), so the 9216 paths of an iteration store about 94 000, more
/// than a batch holds at the cap of 9216 paths (49 152: 3 per path of the cap, at least of 2¹⁴
/// paths).
fn scene() -> Scene {
    load_str(common::BRIGHT_ROOM, "bright room", None).unwrap()
}

#[test]
fn a_bright_closed_room_takes_several_batches_and_stays_unbiased() {
    // The image mean of k independent renders is 1 within 4 standard errors (of the spread of
    // the renders' means). More primary rays than one camera path per pixel and one light path
    // per pixel and iteration show that camera paths were walked again for later batches.
    let scene = scene();
    let pixels = (SIDE * SIDE) as u64;
    let (spp, k) = (2, 12);
    for method in ["bpt", "vcm"] {
        let integrator = create(method).unwrap();
        let means: Vec<f64> = (0..k)
            .map(|seed| {
                let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), spp);
                assert_eq!(opts.params.merging.max_light_paths, CAP);
                opts.sampler = SamplerKind::Independent;
                opts.seed = 500 + seed;
                let out = render(&scene, integrator.as_ref(), &opts, &|_, _| {});
                assert_eq!(out.non_finite_samples, 0, "{method}: non-finite samples");
                let one_batch = (pixels + pixels) * spp as u64;
                assert!(
                    out.rays.primary > one_batch,
                    "{method}: {} primary rays, one batch makes {one_batch}",
                    out.rays.primary
                );
                let image = out.image;
                image.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>()
                    / (3 * image.pixels.len()) as f64
            })
            .collect();
        let mean = means.iter().sum::<f64>() / k as f64;
        let var = means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / (k - 1) as f64;
        let error = (var / k as f64).sqrt();
        println!("{method}, bright closed room in batches: mean {mean:.5} ± {error:.5}");
        assert!((mean - 1.0).abs() <= 4.0 * error, "{method}: mean {mean} ± {error}, expected 1");
    }
}

#[test]
fn batches_are_independent_of_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("room.toml");
    std::fs::write(&scene, common::BRIGHT_ROOM).unwrap();
    for method in ["vcm", "ppm"] {
        let render = |threads: &str| {
            let out_file = dir.path().join(format!("{method}-{threads}.exr"));
            let out = Command::new(env!("CARGO_BIN_EXE_vitrum"))
                .arg("render")
                .arg(&scene)
                .args(["-i", method, "--spp", "2", "--threads", threads, "--quiet", "-o"])
                .arg(&out_file)
                .output()
                .unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            let (image, meta) = read_exr(&out_file).unwrap();
            let bits: Vec<[u32; 3]> = image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
            (bits, meta["vitrum:rays"].clone())
        };
        let (one, two) = (render("1"), render("2"));
        assert!(one.0 == two.0, "{method}: pixels differ between 1 and 2 threads");
        assert_eq!(one.1, two.1, "{method}: ray counts differ between 1 and 2 threads");
    }
}
