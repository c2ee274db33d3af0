//! Conductors (`type = "conductor"`) through every method: `scenes/metals.toml` (a rough gold
//! sphere in Beckmann, a smooth copper plate, a rough aluminium sphere in GGX, under a quad
//! light) renders finite images everywhere, and `bpt` and `vcm` agree with `path` on it.

mod common;

use common::{block_chi2, render_opts, render_with_variance};
use vitrum::integrators::{create, names};
use vitrum::material::Bsdf;
use vitrum::render::RenderOptions;
use vitrum::scene::{load, load_str, Scene};

fn metals() -> Scene {
    load(std::path::Path::new("scenes/metals.toml")).unwrap()
}

#[test]
fn every_method_renders_the_metals_without_nan() {
    let scene = metals();
    for method in names() {
        let integrator = create(method).unwrap();
        let mut opts = RenderOptions::for_method(&scene, integrator.as_ref(), 4);
        opts.resolution = Some((24, 24));
        let out = render_opts(&scene, method, &opts);
        assert_eq!(out.non_finite_samples, 0, "{method}: non-finite samples");
        let mean = out.image.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>();
        assert!(mean.is_finite() && mean > 0.0, "{method}: image sum {mean}");
        // The spectral mode reads the metals' measured spectra.
        opts.spectral = vitrum::scene::SpectralMode::On;
        let out = render_opts(&scene, method, &opts);
        assert_eq!(out.non_finite_samples, 0, "{method} --spectral: non-finite samples");
    }
}

#[test]
fn bpt_and_vcm_match_path_on_the_metals() {
    // As for soft-shadows in tests/bidirectional.rs: χ² of the 16 8×8 block means against a
    // `path` render below its 99.99% quantile (about 42).
    let scene = metals();
    let reference = render_with_variance(&scene, "path", 32, 1024, 71);
    for method in ["bpt", "vcm"] {
        let render = render_with_variance(&scene, method, 32, 256, 5);
        let (chi2, blocks) = block_chi2(&render, &reference);
        println!("metals, {method}: χ² {chi2:.1} over {blocks} blocks");
        assert_eq!(blocks, 16);
        assert!(chi2 < 42.0, "metals, {method}: block χ² {chi2} over {blocks} blocks against path");
    }
}

#[test]
fn the_scene_format_reads_and_checks_conductors() {
    let scene = |material: &str| {
        let text = format!(
            "[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\n\
             [materials.m]\ntype = \"conductor\"\n{material}\n\
             [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n\
             [[lights]]\ntype = \"point\"\nposition = [0.0, 2.0, 2.0]\nintensity = 1.0\n"
        );
        load_str(&text, "conductor.toml", None)
    };
    let conductor = |s: &Scene| match &s.materials[0].bsdf {
        Bsdf::Conductor(c) => *c,
        other => panic!("{other:?}"),
    };
    // Defaults: a perfect smooth conductor (`none`), Beckmann, outside index 1, factor 1.
    let c = conductor(&scene("").unwrap());
    assert_eq!((c.index.eta.x, c.index.k.x, c.alpha, c.ior_outside), (0.0, 1.0, 0.0, 1.0));
    assert_eq!(c.distribution, vitrum::conductor::Distribution::Beckmann);
    assert!(!scene("").unwrap().effects.names().contains("glossy"));
    let gold = conductor(&scene("metal = \"Au\"\nalpha = 0.1\ndistribution = \"ggx\"").unwrap());
    assert_eq!(gold.index.metal.unwrap().name, "Au");
    assert!(gold.normal_reflectance().x > gold.normal_reflectance().z);
    let s =
        scene("eta = [0.2, 0.9, 1.1]\nk = 3.0\nior_outside = 1.33\nspecular_reflectance = 0.3\nalpha = 0.05")
            .unwrap();
    assert!(s.effects.names().contains("glossy"), "{}", s.effects.names());
    let c = conductor(&s);
    assert_eq!((c.index.k.y, c.ior_outside, c.specular_reflectance.z), (3.0, 1.33, 0.3));
    // Mistakes name the field.
    for (bad, field) in [
        ("metal = \"Gold\"", "metal"),
        ("metal = \"Au\"\neta = 1.0\nk = 1.0", "metal"),
        ("eta = 1.0", "k"),
        ("eta = 0.0\nk = 0.0", "eta"),
        ("alpha = 1.5", "alpha"),
        ("ior_outside = 0.0", "ior_outside"),
        ("specular_reflectance = 1.2", "specular_reflectance"),
        ("distribution = \"phong\"", "distribution"),
    ] {
        let e = scene(bad).err().unwrap_or_else(|| panic!("`{bad}` was accepted")).to_string();
        assert!(e.contains(field), "`{bad}`: {e}");
    }
}
