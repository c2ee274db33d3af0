//! Unit tests of `path`'s wavelength splitting and of hero-wavelength MIS at rough glass.
use super::*;
use crate::material::Bsdf;
use crate::sampler::{Sampler, SamplerKind};
use crate::spectrum::{Wavelengths, HERO_WAVELENGTHS};

/// A glass slab of dispersive `ior` and `roughness` (two facing quads at z = ±0.5) seen by a
/// camera on +z.
fn slab(ior: &str, roughness: f32) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
resolution = [4, 4]
[materials.glass]
type = "dielectric"
ior = "{ior}"
roughness = {roughness}
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
    let scene = slab("sf11", 0.0);
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

/// Asserts that two renders of [`render`] (32×32) estimate the same image: each 8×8 block's
/// means (16 blocks × 3 channels), and the whole image's, within 4.5 standard errors of their
/// difference. Returns the variance of `a` over that of `b` (summed over pixels and channels).
fn assert_same_image(a: &[(glam::DVec3, glam::DVec3)], b: &[(glam::DVec3, glam::DVec3)], what: &str) -> f64 {
    let block = |image: &[(glam::DVec3, glam::DVec3)], b: usize| {
        let pixels = (0..64).map(move |k| (b / 4 * 8 + k / 8) * 32 + b % 4 * 8 + k % 8);
        pixels.fold((glam::DVec3::ZERO, glam::DVec3::ZERO), |(m, v), i| {
            (m + image[i].0 / 64.0, v + image[i].1 / (64.0 * 64.0))
        })
    };
    let (mut worst, mut all) = (0.0f64, [(glam::DVec3::ZERO, glam::DVec3::ZERO); 2]);
    for k in 0..16 {
        let ((ma, va), (mb, vb)) = (block(a, k), block(b, k));
        for c in 0..3 {
            let z = (ma[c] - mb[c]) / (va[c] + vb[c]).sqrt();
            assert!(z.abs() < 4.5, "{what}: block {k} channel {c}: {} vs {} (z = {z:.2})", ma[c], mb[c]);
            worst = worst.max(z.abs());
        }
        all[0] = (all[0].0 + ma / 16.0, all[0].1 + va / 256.0);
        all[1] = (all[1].0 + mb / 16.0, all[1].1 + vb / 256.0);
    }
    let z = (all[0].0 - all[1].0) / (all[0].1 + all[1].1).map(f64::sqrt);
    let variance =
        |image: &[(glam::DVec3, glam::DVec3)]| image.iter().map(|p| p.1.element_sum()).sum::<f64>();
    let ratio = variance(a) / variance(b);
    eprintln!(
        "{what}: {} vs {} (z {z}), worst block |z| {worst:.2}; variance ratio {ratio:.3}",
        all[0].0, all[1].0
    );
    assert!(z.abs().max_element() < 4.5, "{what}: image means {} vs {} (z {z})", all[0].0, all[1].0);
    ratio
}

#[test]
fn splitting_and_the_hero_alone_estimate_the_same_glass_of_water() {
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass-of-water.toml");
    let scene = crate::scene::load(&file).unwrap();
    let spp = 96;
    let (split, hero) = (render(&scene, spp, 1, false), render(&scene, spp, 2, true));
    let ratio = assert_same_image(&split, &hero, "glass of water, split vs hero alone");
    // And splitting lowers the variance (measured 0.89× here, the light seen directly included).
    assert!(ratio < 1.0);
}

#[test]
fn mis_at_rough_dispersive_glass_and_the_hero_alone_estimate_the_same_image() {
    // frosted-glass with its rough sphere (roughness 0.3) and cylinder (0.1) made of bk7.
    let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/frosted-glass.toml");
    let text = std::fs::read_to_string(&file).unwrap().replace("ior = 1.52", "ior = \"bk7\"");
    let scene = crate::scene::load_str(&text, "frosted-glass in bk7", None).unwrap();
    assert!(scene.effects.names().contains("dispersion"));
    let spp = 128;
    let (mis, hero) = (render(&scene, spp, 1, false), render(&scene, spp, 2, true));
    let ratio = assert_same_image(&mis, &hero, "frosted bk7, MIS vs hero alone");
    // The secondaries that survive lower the variance (measured 0.68× here, seeds 1 and 2).
    assert!(ratio < 0.8, "MIS over the wavelengths costs {ratio:.2}× the hero alone's variance");
}

/// Per channel, sums (and sums of squares, over samples) of the throughput times five functions
/// of the local direction: reflected, transmitted, and the transmitted z², x and reflected z².
#[derive(Default)]
struct Moments {
    sum: [[f64; 5]; HERO_WAVELENGTHS],
    squares: [[f64; 5]; HERO_WAVELENGTHS],
    n: f64,
}

impl Moments {
    /// Adds one sample: the (direction, throughput) pairs it went on with.
    fn add(&mut self, paths: &[(Vec3, Vec3)]) {
        let mut one = [[0.0f64; 5]; HERO_WAVELENGTHS];
        for (d, beta) in paths {
            let t = d.z < 0.0;
            let g = [
                f32::from(!t),
                f32::from(t),
                f32::from(t) * d.z * d.z,
                f32::from(t) * d.x,
                f32::from(!t) * d.z * d.z,
            ];
            for (row, b) in one.iter_mut().zip(beta.to_array()) {
                for (x, gm) in row.iter_mut().zip(g) {
                    *x += f64::from(b * gm);
                }
            }
        }
        for ((sum, squares), row) in self.sum.iter_mut().zip(&mut self.squares).zip(one) {
            for ((s, q), x) in sum.iter_mut().zip(squares.iter_mut()).zip(row) {
                *s += x;
                *q += x * x;
            }
        }
        self.n += 1.0;
    }

    /// The mean and the variance of the mean of function `m` for channel `c`.
    fn mean(&self, c: usize, m: usize) -> (f64, f64) {
        let mean = self.sum[c][m] / self.n;
        (mean, (self.squares[c][m] / self.n - mean * mean) / (self.n - 1.0))
    }
}

#[test]
fn mis_at_rough_dispersive_glass_keeps_every_wavelength_unbiased() {
    use rand::{RngExt, SeedableRng};
    let scene = slab("sf11", 0.5);
    let w = Wavelengths::sample(0.1);
    let dir = Vec3::new(0.6, 0.0, -0.8);
    let ray = Ray { origin: Vec3::new(-0.75, 0.0, 2.0), dir, time: 0.0 };
    let isect = scene.intersect(&ray, f32::INFINITY).unwrap();
    let material = scene.material_of(isect.primitive);
    let frame = ShadingFrame::at(&isect.hit, -dir);
    let wo_local = frame.to_local(-dir);
    let spectral = Channels::Spectral(w);
    let new_ctx = || PathContext {
        channels: spectral,
        ..PathContext::new(Sampler::new(SamplerKind::Sobol, 1, 0, 0, 1))
    };
    let mut rng = rand_pcg::Pcg32::seed_from_u64(35);
    let n = 200_000;
    // MIS over the wavelengths, the branches of multiple scattering included.
    let (mut mis, mut together, mut branches) = (Moments::default(), 0, 0);
    for _ in 0..n {
        let (uc, u): (f32, (f32, f32)) = (rng.random(), (rng.random(), rng.random()));
        let mut ctx = new_ctx();
        assert!(ctx.mixes_wavelengths(material, &isect.hit));
        let path = PathState::new(ray);
        let Some(s) = ctx.sample_wavelengths(material, &isect.hit, wo_local, uc, u, TransportMode::Radiance)
        else {
            mis.add(&[]);
            continue;
        };
        let factor = ctx.split_wavelengths(&scene, &isect, &s, wo_local, (uc, u), &path, 7);
        let mut paths = vec![(s.wi, s.f * (s.wi.z.abs() / s.pdf) * factor)];
        together += usize::from(s.is_evaluable() && factor == Vec3::ONE);
        while let Some(b) = ctx.pending.pop() {
            assert_eq!(b.replay, 7, "a branch replays the numbers after the split");
            paths.push((frame.to_local(b.state.dir), b.state.beta));
            branches += 1;
        }
        mis.add(&paths);
    }
    // Each wavelength's own walk, with numbers of its own.
    let mut own = Moments::default();
    for _ in 0..n {
        let (uc, u): (f32, glam::Vec2) = (rng.random(), glam::Vec2::new(rng.random(), rng.random()));
        let paths: Vec<(Vec3, Vec3)> = (0..HERO_WAVELENGTHS)
            .filter_map(|c| {
                let model =
                    Scattering::at(material, isect.hit.p, isect.hit.uv, &Channels::Spectral(w.led_by(c)));
                let s = model.sample(wo_local, uc, u, TransportMode::Radiance)?;
                let channel = Vec3::from_array(std::array::from_fn(|k| f32::from(k == c)));
                Some((s.wi, s.f * (s.wi.z.abs() / s.pdf) * channel))
            })
            .collect();
        own.add(&paths);
    }
    let mut worst = 0.0f64;
    for c in 0..HERO_WAVELENGTHS {
        for m in 0..5 {
            let ((a, va), (b, vb)) = (mis.mean(c, m), own.mean(c, m));
            let z = (a - b) / (va + vb).sqrt();
            assert!(z.abs() < 4.5, "channel {c}, moment {m}: MIS {a} vs own walk {b} (z = {z:.2})");
            worst = worst.max(z.abs());
        }
    }
    eprintln!("rough sf11: worst |z| {worst:.2}; {together} of {n} on together, {branches} branches");
    // Both halves ran: most samples left after one facet with all three wavelengths, and the
    // multiply scattered ones split.
    assert!(together > n / 2 && branches > n / 50, "{together} together, {branches} branches");
}
