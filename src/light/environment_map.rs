//! An equirectangular HDR environment map, importance-sampled texel by texel.
//!
//! Directions map to the image as Mitsuba 3's `envmap` does, with +Y up: the column is
//! `u = atan2(x, −z) / 2π` (wrapped into [0, 1)), the row from the top `v = acos(y) / π`; the
//! image's centre looks along +Z, its left and right edges along −Z, its top row up. `rotation`
//! turns the map about +Y (right-handed: a positive angle moves the centre from +Z towards +X).
//!
//! Radiance is the texel a direction falls in (nearest lookup), so the map is piecewise
//! constant over texels, and sampling is exact: a texel is picked with probability proportional
//! to its mean value times its solid angle `Ω = (2π/W)(cos θ₀ − cos θ₁)`, then a direction
//! uniform over its solid angle (φ uniform, cos θ uniform), so the density per solid angle is
//! `p_texel / Ω`, proportional to the radiance wherever the map is not black.

use crate::texture::ImageMap;
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};
use std::sync::Arc;

/// A piecewise-constant distribution over `0..n` with its cumulative sums (in f64, so that maps
/// of millions of texels keep every cell's share).
#[derive(Clone, Debug, PartialEq)]
struct Distribution1D {
    /// `cdf[0] = 0`, `cdf[n] = 1`.
    cdf: Vec<f64>,
}

impl Distribution1D {
    /// The distribution proportional to `weights` (not all zero).
    fn new(weights: &[f64]) -> Distribution1D {
        let total: f64 = weights.iter().sum();
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        cdf.push(0.0);
        let mut sum = 0.0;
        for w in weights {
            sum += w;
            cdf.push(sum / total);
        }
        *cdf.last_mut().unwrap() = 1.0;
        Distribution1D { cdf }
    }

    /// The probability of cell `i`.
    fn probability(&self, i: usize) -> f64 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// The cell `u` in [0, 1) falls in (never one of probability 0) and the position of `u`
    /// within it, in [0, 1).
    fn sample(&self, u: f32) -> (usize, f32) {
        let u = u as f64;
        let n = self.cdf.len() - 1;
        let mut i = (self.cdf.partition_point(|&c| c <= u).max(1) - 1).min(n - 1);
        // Skip cells of probability 0 (a u on the shared edge of an empty cell).
        while self.probability(i) <= 0.0 && i + 1 < n {
            i += 1;
        }
        while self.probability(i) <= 0.0 && i > 0 {
            i -= 1;
        }
        let within = ((u - self.cdf[i]) / self.probability(i)).clamp(0.0, 1.0 - f64::EPSILON);
        (i, within as f32)
    }
}

/// An environment map with its sampling distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMap {
    /// The linear texels, shared with every texture that reads the same file (never copied).
    image: Arc<ImageMap>,
    /// cos and sin of the rotation about +Y.
    rotation: (f32, f32),
    /// The rotation about +Y in degrees, as the scene gives it.
    rotation_degrees: f32,
    /// Over rows, proportional to each row's summed weights.
    rows: Distribution1D,
    /// Per row, over its texels (`None` for a row of zero weight).
    columns: Vec<Option<Distribution1D>>,
    /// Whether every texel is black (nothing to sample).
    black: bool,
    /// The radiance averaged over the sphere of directions.
    mean: Vec3,
}

/// `cos θ` at the top edge of row `j` of `height` rows.
#[inline]
fn row_edge_cos(j: usize, height: usize) -> f32 {
    (PI * j as f32 / height as f32).cos()
}

impl EnvironmentMap {
    /// The map of `image` (linear radiance) turned by `rotation_degrees` about +Y.
    pub fn new(image: Arc<ImageMap>, rotation_degrees: f32) -> EnvironmentMap {
        let (w, h) = (image.width, image.height);
        let row_solid_angle = |j: usize| (TAU / w as f32) * (row_edge_cos(j, h) - row_edge_cos(j + 1, h));
        let mut row_weights = Vec::with_capacity(h);
        let mut columns = Vec::with_capacity(h);
        let mut mean = Vec3::ZERO;
        for j in 0..h {
            let omega = row_solid_angle(j).max(0.0) as f64;
            let weights: Vec<f64> =
                (0..w).map(|i| image.texel(i, j).element_sum() as f64 / 3.0 * omega).collect();
            let total: f64 = weights.iter().sum();
            mean += (0..w).map(|i| image.texel(i, j)).sum::<Vec3>() * (omega as f32);
            row_weights.push(total);
            columns.push((total > 0.0).then(|| Distribution1D::new(&weights)));
        }
        let black = row_weights.iter().all(|&w| w <= 0.0);
        let rows = if black { Distribution1D::new(&vec![1.0; h]) } else { Distribution1D::new(&row_weights) };
        let r = rotation_degrees.to_radians();
        EnvironmentMap {
            image,
            rotation: (r.cos(), r.sin()),
            rotation_degrees,
            rows,
            columns,
            black,
            mean: mean / (4.0 * PI),
        }
    }

    /// The texels.
    pub fn image(&self) -> &ImageMap {
        &self.image
    }

    /// The rotation about +Y in degrees, as the scene gives it (180 stays 180, 450 stays 450: not
    /// the angle recovered from its cosine and sine, which would print 180 as −180).
    pub fn rotation_degrees(&self) -> f32 {
        self.rotation_degrees
    }

    /// The cosine and sine of the rotation about +Y, as the map applies them.
    pub fn rotation_cos_sin(&self) -> (f32, f32) {
        self.rotation
    }

    /// The radiance averaged over all directions.
    pub fn mean(&self) -> Vec3 {
        self.mean
    }

    /// `dir` in the map's own frame (the rotation undone).
    #[inline]
    fn to_local(&self, d: Vec3) -> Vec3 {
        let (c, s) = self.rotation;
        Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
    }

    /// `d` of the map's frame in the world.
    #[inline]
    fn to_world(&self, d: Vec3) -> Vec3 {
        let (c, s) = self.rotation;
        Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
    }

    /// The equirectangular coordinates `(u, v)` of the unit world direction `dir` (v from the top).
    pub fn coordinates(&self, dir: Vec3) -> Vec2 {
        let d = self.to_local(dir);
        let u = d.x.atan2(-d.z) / TAU;
        let u = if u < 0.0 { u + 1.0 } else { u };
        Vec2::new(u, d.y.clamp(-1.0, 1.0).acos() / PI)
    }

    /// The texel `(column, row)` that `dir` falls in.
    #[inline]
    fn texel_of(&self, dir: Vec3) -> (usize, usize) {
        let uv = self.coordinates(dir);
        let column = ((uv.x * self.image.width as f32) as usize).min(self.image.width - 1);
        let row = ((uv.y * self.image.height as f32) as usize).min(self.image.height - 1);
        (column, row)
    }

    /// The radiance arriving from the unit direction `dir` (pointing away from the scene).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (i, j) = self.texel_of(dir);
        self.image.texel(i, j)
    }

    /// The solid-angle density with which [`sample`](Self::sample) returns `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        if self.black {
            return 0.0;
        }
        let (i, j) = self.texel_of(dir);
        self.texel_pdf(i, j)
    }

    /// The solid-angle density inside texel `(i, j)`: its probability over its solid angle.
    fn texel_pdf(&self, i: usize, j: usize) -> f32 {
        let Some(columns) = &self.columns[j] else { return 0.0 };
        let (w, h) = (self.image.width, self.image.height);
        let omega = (TAU / w as f32) * (row_edge_cos(j, h) - row_edge_cos(j + 1, h));
        let p = self.rows.probability(j) * columns.probability(i);
        if omega > 0.0 {
            (p / omega as f64) as f32
        } else {
            0.0
        }
    }

    /// A direction towards the environment for the uniform numbers `u`, with its solid-angle
    /// density (`None` for a black map).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        if self.black {
            return None;
        }
        let (j, fy) = self.rows.sample(u.y);
        let (i, fx) = self.columns[j].as_ref()?.sample(u.x);
        let (w, h) = (self.image.width, self.image.height);
        let phi = TAU * (i as f32 + fx) / w as f32;
        let (c0, c1) = (row_edge_cos(j, h), row_edge_cos(j + 1, h));
        let cos_theta = (c0 - fy * (c0 - c1)).clamp(-1.0, 1.0);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let local = Vec3::new(phi.sin() * sin_theta, cos_theta, -phi.cos() * sin_theta);
        let pdf = self.texel_pdf(i, j);
        (pdf > 0.0).then(|| (self.to_world(local), pdf))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2;
    use crate::texture::ColorSpace;
    use rand::{RngExt, SeedableRng};

    /// The χ² cases of this module (part of the family-wise level of `bsdf::chi2`).
    pub(crate) const CHI2_CASES: usize = 2;

    fn map(width: usize, height: usize, f: impl Fn(usize, usize) -> Vec3) -> Arc<ImageMap> {
        let texels =
            (0..height).flat_map(|j| (0..width).map(move |i| (i, j))).map(|(i, j)| f(i, j)).collect();
        Arc::new(ImageMap { width, height, texels, file: "test".into(), colorspace: ColorSpace::Linear })
    }

    #[test]
    fn directions_map_to_mitsubas_equirectangular_coordinates() {
        let m = EnvironmentMap::new(map(4, 2, |_, _| Vec3::ONE), 0.0);
        let close = |a: Vec2, b: Vec2| (a - b).abs().max_element() < 1e-6;
        assert!(close(m.coordinates(Vec3::Z), Vec2::new(0.5, 0.5)));
        assert!(close(m.coordinates(Vec3::X), Vec2::new(0.25, 0.5)));
        assert!(close(m.coordinates(-Vec3::X), Vec2::new(0.75, 0.5)));
        assert!(close(m.coordinates(-Vec3::Z), Vec2::new(0.0, 0.5)));
        assert_eq!(m.coordinates(Vec3::Y).y, 0.0);
        assert_eq!(m.coordinates(-Vec3::Y).y, 1.0);
        // A rotation of 90° brings the centre (+Z) to +X.
        let r = EnvironmentMap::new(map(4, 2, |_, _| Vec3::ONE), 90.0);
        assert!(close(r.coordinates(Vec3::X), Vec2::new(0.5, 0.5)));
        assert_eq!(r.rotation_degrees(), 90.0);
    }

    #[test]
    fn the_rotation_reads_back_as_the_scene_gives_it() {
        // Recovered from its cosine and sine, 180 would read −180 and 450 would read 90.
        for degrees in [0.0, 90.0, 180.0, -180.0, 270.0, -90.0, 450.0, 720.0] {
            let m = EnvironmentMap::new(map(4, 2, |_, _| Vec3::ONE), degrees);
            assert_eq!(m.rotation_degrees(), degrees);
            let (c, s) = m.rotation_cos_sin();
            let r = f32::to_radians(degrees);
            assert_eq!((c, s), (r.cos(), r.sin()), "{degrees}");
        }
    }

    #[test]
    fn samples_land_in_their_texel_with_its_density() {
        let m = EnvironmentMap::new(map(8, 4, |i, j| Vec3::splat((i + 2 * j) as f32)), 30.0);
        let mut rng = rand_pcg::Pcg32::new(7, 11);
        for _ in 0..2000 {
            let u = Vec2::new(rng.random(), rng.random());
            let (dir, pdf) = m.sample(u).unwrap();
            assert!((dir.length() - 1.0).abs() < 1e-5);
            assert!((m.pdf(dir) - pdf).abs() <= 1e-3 * pdf, "{} vs {pdf}", m.pdf(dir));
            assert!(m.radiance(dir) != Vec3::ZERO, "black texels are never sampled");
        }
    }

    #[test]
    fn a_constant_map_is_sampled_uniformly_and_its_density_integrates_to_one() {
        let m = EnvironmentMap::new(map(16, 8, |_, _| Vec3::splat(2.0)), 0.0);
        let uniform = 1.0 / (4.0 * PI);
        for dir in [Vec3::X, Vec3::Y, -Vec3::Z, Vec3::new(1.0, -2.0, 0.5).normalize()] {
            assert!((m.pdf(dir) - uniform).abs() < 1e-5 * uniform * 100.0, "{}", m.pdf(dir));
        }
        assert!((m.mean() - Vec3::splat(2.0)).abs().max_element() < 1e-5);
        // Σ pdf·Ω over texels is 1 for an uneven map.
        let m = EnvironmentMap::new(map(16, 8, |i, j| Vec3::new(i as f32, j as f32, 1.0)), 0.0);
        let mut total = 0.0f64;
        for j in 0..8 {
            let omega = (TAU / 16.0) * (row_edge_cos(j, 8) - row_edge_cos(j + 1, 8));
            for i in 0..16 {
                total += (m.texel_pdf(i, j) * omega) as f64;
            }
        }
        assert!((total - 1.0).abs() < 1e-5, "{total}");
    }

    #[test]
    fn a_black_map_has_no_samples() {
        let m = EnvironmentMap::new(map(4, 2, |_, _| Vec3::ZERO), 0.0);
        assert!(m.sample(Vec2::splat(0.5)).is_none());
        assert_eq!(m.pdf(Vec3::Y), 0.0);
    }

    /// A sky gradient brighter towards the horizon with a sun 100× as bright in two texels.
    fn sky(width: usize, height: usize) -> Arc<ImageMap> {
        map(width, height, |i, j| {
            if (i == 5 || i == 6) && j == 3 {
                Vec3::splat(100.0)
            } else {
                Vec3::new(0.3, 0.5, 1.0) * (0.2 + j as f32 / height as f32)
            }
        })
    }

    /// Texels of random brightness, a quarter of them black.
    fn random(width: usize, height: usize) -> Arc<ImageMap> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
        let texels: Vec<Vec3> = (0..width * height)
            .map(|_| {
                let x: f32 = rng.random();
                if x < 0.25 {
                    Vec3::ZERO
                } else {
                    Vec3::new(x, rng.random(), 0.5)
                }
            })
            .collect();
        map(width, height, |i, j| texels[j * width + i])
    }

    /// χ² of 2²⁰ sampled directions against the density: every texel is cut into 2 × 2 cells,
    /// halves in φ and in cos θ, each expecting a quarter of the texel's probability (its density
    /// times its solid angle, exactly: the density is constant over the texel), so that the test
    /// judges both the choice of texel and the uniformity within it. The directions are read back
    /// through the rotation, which the sampler applies.
    #[test]
    fn chi2_map_sampling_matches_its_density() {
        let cases = [
            ("sky, turned 40°", EnvironmentMap::new(sky(32, 16), 40.0)),
            ("random with black texels, turned −75°", EnvironmentMap::new(random(24, 12), -75.0)),
        ];
        let mut results = Vec::new();
        for (k, (name, m)) in cases.iter().enumerate() {
            let (w, h) = (m.image.width, m.image.height);
            let samples = 1usize << 20;
            let mut observed = vec![0u64; w * h * 4];
            let mut rng = rand_pcg::Pcg32::new(600 + k as u64, 3);
            for _ in 0..samples {
                let (dir, _) = m.sample(Vec2::new(rng.random(), rng.random())).unwrap();
                let uv = m.coordinates(dir);
                let x = uv.x * w as f32;
                let i = (x as usize).min(w - 1);
                let j = ((uv.y * h as f32) as usize).min(h - 1);
                let (c0, c1) = (row_edge_cos(j, h), row_edge_cos(j + 1, h));
                let half_phi = ((x - i as f32) >= 0.5) as usize;
                let half_cos = ((c0 - dir_cos(m, dir)) / (c0 - c1) >= 0.5) as usize;
                observed[((j * w + i) * 2 + half_phi) * 2 + half_cos] += 1;
            }
            let expected: Vec<f64> = (0..w * h * 4)
                .map(|c| {
                    let (i, j) = ((c / 4) % w, c / 4 / w);
                    let omega = (TAU / w as f32) * (row_edge_cos(j, h) - row_edge_cos(j + 1, h));
                    (m.texel_pdf(i, j) * omega) as f64 / 4.0 * samples as f64
                })
                .collect();
            results.push((name.to_string(), chi2::outcome_of_counts(&expected, &observed)));
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }

    /// cos θ of `dir` in the map's frame (its y: the rotation is about y).
    fn dir_cos(m: &EnvironmentMap, dir: Vec3) -> f32 {
        m.to_local(dir).y
    }
}
