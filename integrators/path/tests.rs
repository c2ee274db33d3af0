//! Unit tests of `path`'s wavelength splitting.
use super::*;
use crate::material::Bsdf;
use crate::sampler::{Sampler, SamplerKind};
use crate::spectrum::{Wavelengths, HERO_WAVELENGTHS};

/// A glass slab of dispersive `ior` (two facing quads at z = ±0.5) seen by a camera on +z.
fn slab(ior: &str) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
resolution = [4, 4]
[materials.glass]
type = "dielectric"
ior = "{ior}"
[[objects]]
shape = "quad"
corner = [-50.0, -50.0, 0.5]
u = [100.0, 0.0, 0.0]
v = [0.0, 100.0, 0.0]
material = "glass"
[[objects]]
shape = "quad"
corner = [-50.0, -50.0, -0.5]
u = [0.0, 100.0, 0.0]
v = [100.0, 0.0, 0.0]
material = "glass"
"#
    );
    crate::scene::load_str(&text, "dispersive slab", None).unwrap()
}

#[test]
fn splitting_carries_each_wavelength_by_its_own_fresnel_and_direction() {
    let scene = slab("sf11");
    let w = Wavelengths::sample(0.1);
    let dir = Vec3::new(0.6, 0.0, -0.8);
    let ray = Ray { origin: Vec3::new(-0.75, 0.0, 2.0), dir, time: 0.0 };
    let isect = scene.intersect(&ray, f32::INFINITY).unwrap();
    let material = scene.material_of(isect.primitive);
    let Bsdf::Dielectric { inside, outside, .. } = material.bsdf else { panic!("glass") };
    let wo = -dir;
    let frame = ShadingFrame::at(&isect.hit, wo);
    let wo_local = frame.to_local(wo);
    let eta = |i: usize| inside.ior.at(w.lambda[i]) / outside.ior.at(w.lambda[i]);
    let fresnel = |i: usize| crate::optics::fresnel_dielectric(wo_local.z, eta(i));
    // Over the lobe choice: per channel, the expected reflected and refracted throughput.
    let n = 20_000;
    let (mut reflected, mut refracted) = (Vec3::ZERO, Vec3::ZERO);
    let mut directions = [Vec3::ZERO; HERO_WAVELENGTHS];
    for k in 0..n {
        let uc = (k as f32 + 0.5) / n as f32;
        let mut ctx = PathContext {
            channels: Channels::Spectral(w),
            ..PathContext::new(Sampler::new(SamplerKind::Sobol, 1, 0, 0, 1))
        };
        let path = PathState::new(ray);
        let model = Scattering::at(material, isect.hit.p, isect.hit.uv, &ctx.channels);
        let s = model.sample(wo_local, uc, glam::Vec2::splat(0.5), TransportMode::Radiance).unwrap();
        let factor = ctx.split_wavelengths(&scene, &isect, &s, wo_local, (uc, (0.5, 0.5)), &path, 7);
        let lead = s.f * (s.wi.z.abs() / s.pdf) * factor;
        let mut branches = vec![(s.is_transmission, lead, frame.to_world(s.wi))];
        while let Some(b) = ctx.pending.pop() {
            assert_eq!(b.replay, 7, "a branch replays the numbers after the split");
            assert_eq!(b.state.depth, 1.0);
            branches.push((b.state.dir.dot(isect.hit.n) < 0.0, b.state.beta, b.state.dir));
        }
        assert!(branches.len() == 1 || branches.len() == HERO_WAVELENGTHS, "all on, or one each");
        for (transmitted, beta, d) in branches {
            if transmitted {
                refracted += beta / n as f32;
                for c in 0..HERO_WAVELENGTHS {
                    if beta[c] > 0.0 {
                        directions[c] = d;
                    }
                }
            } else {
                reflected += beta / n as f32;
            }
        }
    }
    let expected_r = Vec3::from_array(std::array::from_fn(fresnel));
    let expected_t = Vec3::from_array(std::array::from_fn(|i| (1.0 - fresnel(i)) / (eta(i) * eta(i))));
    assert!(reflected.abs_diff_eq(expected_r, 2e-4), "reflected {reflected} vs F(λ) {expected_r}");
    assert!(refracted.abs_diff_eq(expected_t, 2e-4), "refracted {refracted} vs (1 − F)/η² {expected_t}");
    // Each refracts at its own index: Snell's law per wavelength.
    for (c, d) in directions.iter().enumerate() {
        let sin_t = d.cross(isect.hit.n).length();
        let sin_i = dir.cross(isect.hit.n).length();
        assert!(
            (sin_i - eta(c) * sin_t).abs() < 1e-5,
            "channel {c}: sin {sin_i} vs η sin {}",
            eta(c) * sin_t
        );
    }
    assert!(directions[0] != directions[1] && directions[1] != directions[2]);
}

/// `path` on `scene` at 32×32 and `spp` samples per pixel of the independent sampler with
/// `seed`, spectrally, splitting the wavelengths or keeping the hero alone: per pixel the
/// mean RGB estimate and the variance of that mean.
fn render(scene: &Scene, spp: u32, seed: u64, hero_alone: bool) -> Vec<(glam::DVec3, glam::DVec3)> {
    let size = 32;
    let camera = crate::render::camera_for(scene, Some((size, size)));
    let params = RenderParams::with_depth(DEFAULT_PATH_DEPTH);
    (0..size * size)
        .map(|pixel| {
            let (mut sum, mut squares) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
            for s in 0..spp {
                let sampler = Sampler::new(SamplerKind::Independent, seed, pixel as u64, s, spp);
                let mut ctx = PathContext { hero_alone, ..PathContext::new(sampler) };
                let u = ctx.sampler.get_2d(Dim::Pixel);
                let film = glam::Vec2::new((pixel % size) as f32, (pixel / size) as f32) + u;
                ctx.channels = Channels::Spectral(Wavelengths::sample(ctx.sampler.get_1d(Dim::Wavelength)));
                let l = Path.radiance(scene, &params, &camera.generate_ray(film), &mut ctx);
                assert!(ctx.pending.pop().is_none(), "every branch ran");
                let rgb = ctx.rgb(l).as_dvec3();
                (sum, squares) = (sum + rgb, squares + rgb * rgb);
            }
            let n = spp as f64;
            let mean = sum / n;
            (mean, (squares / n - mean * mean) / (n - 1.0))
        })
        .collect()
}

#[test]
fn splitting_and_the_hero_alone_estimate_the_same_glass_of_water() {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass-of-water.toml");
    let scene = crate::scene::load(&file).unwrap();
    let spp = 96;
    let (split, hero) = (render(&scene, spp, 1, false), render(&scene, spp, 2, true));
    // Both unbiased: each 8×8 block's means (16 blocks × 3 channels), and the whole image's,
    // within 4.5 standard errors of their difference.
    let block = |image: &[(glam::DVec3, glam::DVec3)], b: usize| {
        let pixels = (0..64).map(move |k| (b / 4 * 8 + k / 8) * 32 + b % 4 * 8 + k % 8);
        pixels.fold((glam::DVec3::ZERO, glam::DVec3::ZERO), |(m, v), i| {
            (m + image[i].0 / 64.0, v + image[i].1 / (64.0 * 64.0))
        })
    };
    let (mut worst, mut all) = (0.0f64, [(glam::DVec3::ZERO, glam::DVec3::ZERO); 2]);
    for b in 0..16 {
        let ((ms, vs), (mh, vh)) = (block(&split, b), block(&hero, b));
        for c in 0..3 {
            let z = (ms[c] - mh[c]) / (vs[c] + vh[c]).sqrt();
            assert!(z.abs() < 4.5, "block {b} channel {c}: split {} vs hero {} (z = {z:.2})", ms[c], mh[c]);
            worst = worst.max(z.abs());
        }
        all[0] = (all[0].0 + ms / 16.0, all[0].1 + vs / 256.0);
        all[1] = (all[1].0 + mh / 16.0, all[1].1 + vh / 256.0);
    }
    let z = (all[0].0 - all[1].0) / (all[0].1 + all[1].1).map(f64::sqrt);
    let variance =
        |image: &[(glam::DVec3, glam::DVec3)]| image.iter().map(|p| p.1.element_sum()).sum::<f64>();
    eprintln!(
        "glass of water: split {} vs hero alone {} (z {z}), worst block |z| {worst:.2}; variance split/hero {:.3}",
        all[0].0,
        all[1].0,
        variance(&split) / variance(&hero)
    );
    assert!(z.abs().max_element() < 4.5);
    // And splitting lowers the variance (measured 0.89× here, the light seen directly included).
    assert!(variance(&split) < variance(&hero));
}
