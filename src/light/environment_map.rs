//! An equirectangular HDR environment map, read as Mitsuba 3's `envmap` reads it (bilinear
//! interpolation between texels) and importance-sampled cell by cell.
//!
//! Directions map to the image as Mitsuba 3's `envmap` does, with +Y up: the column is
//! `u = atan2(x, −z) / 2π` (wrapped into [0, 1)), the row from the top `v = acos(y) / π`; the
//! image's centre looks along +Z, its left and right edges along −Z, its top row up. `rotation`
//! turns the map about +Y (right-handed: a positive angle moves the centre from +Z towards +X).
//!
//! **Lookup.** The texels are the corners of a grid over (u, v) and the radiance is bilinear
//! between them, with Mitsuba's placement: texel column `i` of `W` sits at `u = (i + ½)/W` (the
//! texel centres), the grid wraps in u (between the last column and the first, across the seam
//! at u = 0), and texel row `j` of `H` sits at `v = j/(H − 1)`: the first row on the north pole,
//! the last on the south pole (a one-row map is constant in v). So the map is continuous, and a
//! direction between the four texels of a grid *cell* reads their bilinear mix.
//!
//! **Sampling.** A piecewise-constant distribution over the cells that covers the bilinear
//! radiance: a cell is picked with probability proportional to the exact integral of its
//! bilinear radiance over its solid angle `Ω = (2π/W)(cos θ₀ − cos θ₁)` (each texel's channel
//! mean, negative channels read as 0), then a direction uniform over the cell's solid angle (φ
//! uniform, cos θ uniform), so the density per solid angle is `p_cell / Ω`, exactly what
//! [`EnvironmentMap::pdf`] returns, and positive wherever the radiance is (a cell holds light
//! only if one of its corners does, and then its integral is positive, at the poles too).

use crate::texture::ImageMap;
use glam::{DVec3, Vec2, Vec3};
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

/// Where a direction falls on the texel grid: the cell whose corners are the texels
/// `(i, r)`, `(i + 1, r)`, `(i, r + 1)`, `(i + 1, r + 1)` (columns modulo the width, rows
/// clamped to the last), and the position `(s, t)` in [0, 1]² within it (`s` along u, `t` along v).
#[derive(Clone, Copy, Debug, PartialEq)]
struct GridPoint {
    i: usize,
    r: usize,
    s: f32,
    t: f32,
}

/// The number of cell rows of a map `height` texels high: one between each two texel rows, and
/// one (both its edges the single row) for a one-row map.
#[inline]
fn cell_rows(height: usize) -> usize {
    (height - 1).max(1)
}

/// `a + t (b − a)`: `a` at 0, `b` at 1, and exactly `a` when `a = b`.
#[inline]
fn lerp(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t
}

/// `∫ (1 − t) sin θ dθ` and `∫ t sin θ dθ` over θ in [θ₀, θ₁], `t = (θ − θ₀)/(θ₁ − θ₀)`: the
/// weights of a cell's top and bottom texel rows in the integral of its bilinear radiance over
/// its solid angle (per unit of φ).
fn row_weights(theta0: f64, theta1: f64) -> (f64, f64) {
    let slope = (theta1.sin() - theta0.sin()) / (theta1 - theta0);
    (theta0.cos() - slope, slope - theta1.cos())
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
    /// `cos θ` at the edges of the cell rows (one more than the rows: 1 at the top, −1 at the bottom).
    edge_cos: Vec<f64>,
    /// Over cell rows, proportional to each row's summed weights.
    rows: Distribution1D,
    /// Per cell row, over its cells (`None` for a row of zero weight).
    columns: Vec<Option<Distribution1D>>,
    /// Whether every texel is black (nothing to sample).
    black: bool,
    /// The radiance averaged over the sphere of directions.
    mean: Vec3,
}

impl EnvironmentMap {
    /// The map of `image` (linear radiance) turned by `rotation_degrees` about +Y.
    pub fn new(image: Arc<ImageMap>, rotation_degrees: f32) -> EnvironmentMap {
        let (w, h) = (image.width, image.height);
        let rows_n = cell_rows(h);
        let theta = |r: usize| std::f64::consts::PI * r as f64 / rows_n as f64;
        let edge_cos: Vec<f64> = (0..=rows_n).map(|r| theta(r).cos()).collect();
        let d_phi = std::f64::consts::TAU / w as f64;
        // The sampling weight of a texel: its channel mean, negative channels as 0 (positive
        // wherever a channel is).
        let weight = |i: usize, j: usize| image.texel(i, j).max(Vec3::ZERO).element_sum() as f64 / 3.0;
        let mut row_totals = Vec::with_capacity(rows_n);
        let mut columns = Vec::with_capacity(rows_n);
        let mut integral = DVec3::ZERO;
        for r in 0..rows_n {
            let (top, bottom) = row_weights(theta(r), theta(r + 1));
            let (j0, j1) = (r, (r + 1).min(h - 1));
            // ∫ over a cell of its bilinear radiance: the mean of each row's two corners (the
            // integral over φ of a linear ramp) weighted by the row's θ integral.
            let cell = |f: &dyn Fn(usize, usize) -> DVec3, i: usize| {
                let i1 = (i + 1) % w;
                d_phi * (0.5 * (f(i, j0) + f(i1, j0)) * top + 0.5 * (f(i, j1) + f(i1, j1)) * bottom)
            };
            let texel = |i: usize, j: usize| image.texel(i, j).as_dvec3();
            let scalar = |i: usize, j: usize| DVec3::splat(weight(i, j));
            let weights: Vec<f64> = (0..w).map(|i| cell(&scalar, i).x).collect();
            integral += (0..w).map(|i| cell(&texel, i)).sum::<DVec3>();
            let total: f64 = weights.iter().sum();
            row_totals.push(total);
            columns.push((total > 0.0).then(|| Distribution1D::new(&weights)));
        }
        let black = row_totals.iter().all(|&w| w <= 0.0);
        let rows =
            if black { Distribution1D::new(&vec![1.0; rows_n]) } else { Distribution1D::new(&row_totals) };
        let r = rotation_degrees.to_radians();
        EnvironmentMap {
            image,
            rotation: (r.cos(), r.sin()),
            rotation_degrees,
            edge_cos,
            rows,
            columns,
            black,
            mean: (integral / (4.0 * std::f64::consts::PI)).as_vec3(),
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

    /// The radiance averaged over all directions (of the bilinear map, exactly integrated).
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

    /// The grid cell `dir` falls in and its position there, as Mitsuba 3's `envmap` finds them:
    /// u shifted back by half a texel and wrapped, v scaled to the rows, the cell clamped to the
    /// last one (so that u = 1 and v = 1 land on the far edges).
    #[inline]
    fn grid_point(&self, dir: Vec3) -> GridPoint {
        let (w, rows) = (self.image.width, cell_rows(self.image.height));
        let uv = self.coordinates(dir);
        let u = uv.x - 0.5 / w as f32;
        let x = (u - u.floor()) * w as f32;
        let y = uv.y * rows as f32;
        let (i, r) = ((x as usize).min(w - 1), (y as usize).min(rows - 1));
        GridPoint { i, r, s: x - i as f32, t: y - r as f32 }
    }

    /// The radiance arriving from the unit direction `dir` (pointing away from the scene): the
    /// bilinear mix of the four texels around it.
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (w, h) = (self.image.width, self.image.height);
        let g = self.grid_point(dir);
        let (i1, r1) = ((g.i + 1) % w, (g.r + 1).min(h - 1));
        let texel = |i, j| self.image.texel(i, j);
        let top = lerp(texel(g.i, g.r), texel(i1, g.r), g.s);
        let bottom = lerp(texel(g.i, r1), texel(i1, r1), g.s);
        lerp(top, bottom, g.t)
    }

    /// The solid-angle density with which [`sample`](Self::sample) returns `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        if self.black {
            return 0.0;
        }
        let g = self.grid_point(dir);
        self.cell_pdf(g.i, g.r)
    }

    /// The solid angle of a cell in row `r`.
    #[inline]
    fn cell_solid_angle(&self, r: usize) -> f64 {
        std::f64::consts::TAU / self.image.width as f64 * (self.edge_cos[r] - self.edge_cos[r + 1])
    }

    /// The solid-angle density inside cell `(i, r)`: its probability over its solid angle.
    fn cell_pdf(&self, i: usize, r: usize) -> f32 {
        let Some(columns) = &self.columns[r] else { return 0.0 };
        let omega = self.cell_solid_angle(r);
        let p = self.rows.probability(r) * columns.probability(i);
        if omega > 0.0 {
            (p / omega) as f32
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
        let (r, fy) = self.rows.sample(u.y);
        let (i, fx) = self.columns[r].as_ref()?.sample(u.x);
        let w = self.image.width;
        // The cell spans u from texel centre i to texel centre i + 1.
        let phi = TAU * (i as f32 + 0.5 + fx) / w as f32;
        let (c0, c1) = (self.edge_cos[r], self.edge_cos[r + 1]);
        let cos_theta = ((c0 - fy as f64 * (c0 - c1)) as f32).clamp(-1.0, 1.0);
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let local = Vec3::new(phi.sin() * sin_theta, cos_theta, -phi.cos() * sin_theta);
        let pdf = self.cell_pdf(i, r);
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

    /// The unit direction at azimuth `phi` (from −Z towards +X) and polar angle `theta` from +Y,
    /// in the map's own frame: equirectangular `(u, v) = (φ/2π, θ/π)`.
    fn direction(phi: f32, theta: f32) -> Vec3 {
        Vec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin())
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() <= 1e-5 * b.abs().max_element().max(1.0)
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
    fn the_lookup_is_bilinear_between_texel_centres_wrapping_in_u() {
        // Two texels side by side: centres at u = 1/4 (+X) and u = 3/4 (−X); halfway between
        // them (u = 1/2, +Z; and u = 0, −Z, across the seam) their mean; one row: the same at
        // every height.
        let (a, b) = (Vec3::new(1.0, 2.0, 4.0), Vec3::new(3.0, 0.5, 0.0));
        let m = EnvironmentMap::new(map(2, 1, |i, _| if i == 0 { a } else { b }), 0.0);
        for theta in [0.3, PI / 2.0, 2.5] {
            let at = |u: f32| m.radiance(direction(TAU * u, theta));
            assert!(close(at(0.25), a), "{theta}: {}", at(0.25));
            assert!(close(at(0.75), b), "{theta}: {}", at(0.75));
            assert!(close(at(0.5), 0.5 * (a + b)), "{theta}: {}", at(0.5));
            assert!(close(at(0.0), 0.5 * (a + b)), "{theta}: {}", at(0.0));
            assert!(close(at(0.375), 0.75 * a + 0.25 * b), "{theta}: {}", at(0.375));
            assert!(close(at(0.125), 0.75 * a + 0.25 * b), "{theta}: across the seam: {}", at(0.125));
        }
        assert!(close(m.radiance(Vec3::Z), 0.5 * (a + b)));
        assert!(close(m.radiance(-Vec3::Z), 0.5 * (a + b)));
        // Three rows: on the north pole, the equator and the south pole (v = j/(H − 1)).
        let (p, q, s) = (Vec3::new(4.0, 0.0, 1.0), Vec3::new(0.0, 2.0, 1.0), Vec3::new(1.0, 1.0, 8.0));
        let m = EnvironmentMap::new(map(1, 3, |_, j| [p, q, s][j]), 0.0);
        assert_eq!(m.radiance(Vec3::Y), p);
        assert_eq!(m.radiance(-Vec3::Y), s);
        assert!(close(m.radiance(Vec3::X), q));
        assert!(close(m.radiance(direction(1.0, PI / 4.0)), 0.5 * (p + q)));
        assert!(close(m.radiance(direction(1.0, 3.0 * PI / 8.0)), 0.25 * p + 0.75 * q));
        assert!(close(m.radiance(direction(1.0, 7.0 * PI / 8.0)), 0.25 * q + 0.75 * s));
        // A constant map reads its constant exactly everywhere.
        let c = Vec3::new(0.1, 0.7, 3.3);
        let m = EnvironmentMap::new(map(5, 4, |_, _| c), 20.0);
        let mut rng = rand_pcg::Pcg32::new(3, 5);
        for _ in 0..1000 {
            let d = crate::light::uniform_sphere(Vec2::new(rng.random(), rng.random()));
            assert_eq!(m.radiance(d), c, "{d}");
        }
    }

    #[test]
    fn the_mean_is_the_bilinear_maps_exact_average() {
        // Rows 1, 0, 0 on the poles and the equator: the radiance is 1 − 2θ/π over the northern
        // hemisphere, whose average over the sphere is ½ ∫₀^{π/2} (1 − 2θ/π) sin θ dθ = (1 − 2/π)/2.
        let m = EnvironmentMap::new(map(3, 3, |_, j| Vec3::splat((j == 0) as u8 as f32)), 0.0);
        let expected = (1.0 - 2.0 / PI) / 2.0;
        assert!((m.mean().x - expected).abs() < 1e-6, "{} vs {expected}", m.mean());
        let m = EnvironmentMap::new(map(16, 8, |_, _| Vec3::splat(2.0)), 0.0);
        assert!((m.mean() - Vec3::splat(2.0)).abs().max_element() < 1e-5, "{}", m.mean());
    }

    #[test]
    fn samples_land_in_their_cell_with_its_density() {
        let m = EnvironmentMap::new(map(8, 4, |i, j| Vec3::splat((i + 2 * j) as f32)), 30.0);
        let mut rng = rand_pcg::Pcg32::new(7, 11);
        for _ in 0..2000 {
            let u = Vec2::new(rng.random(), rng.random());
            let (dir, pdf) = m.sample(u).unwrap();
            assert!((dir.length() - 1.0).abs() < 1e-5);
            assert!((m.pdf(dir) - pdf).abs() <= 1e-3 * pdf, "{} vs {pdf}", m.pdf(dir));
            assert!(m.radiance(dir) != Vec3::ZERO, "black cells are never sampled");
        }
    }

    #[test]
    fn the_density_is_positive_wherever_the_radiance_is() {
        // Light only on the poles and in one texel: cells with one lit corner of four, the pole
        // rows among them (where a density ∝ the texels times sin θ at the texel rows would be 0).
        let m = EnvironmentMap::new(
            map(6, 5, |i, j| {
                if j == 0 || j == 4 || (i, j) == (5, 2) {
                    Vec3::new(0.0, 0.0, 3.0)
                } else {
                    Vec3::ZERO
                }
            }),
            -40.0,
        );
        let mut rng = rand_pcg::Pcg32::new(17, 1);
        let (mut lit, mut dark) = (0, 0);
        for _ in 0..100_000 {
            let d = crate::light::uniform_sphere(Vec2::new(rng.random(), rng.random()));
            if m.radiance(d).max_element() > 0.0 {
                assert!(m.pdf(d) > 0.0, "{d}: radiance {} with density 0", m.radiance(d));
                lit += 1;
            } else {
                dark += 1;
            }
        }
        assert!(lit > 10_000 && dark > 10_000, "{lit} {dark}");
    }

    #[test]
    fn a_constant_map_is_sampled_uniformly() {
        let m = EnvironmentMap::new(map(16, 8, |_, _| Vec3::splat(2.0)), 0.0);
        let uniform = 1.0 / (4.0 * PI);
        for dir in [Vec3::X, Vec3::Y, -Vec3::Z, Vec3::new(1.0, -2.0, 0.5).normalize()] {
            assert!((m.pdf(dir) - uniform).abs() < 1e-5 * uniform * 100.0, "{}", m.pdf(dir));
        }
    }

    /// ∫ pdf dω over the sphere through [`EnvironmentMap::pdf`] itself: a grid of 4 × 4 patches a
    /// cell (φ in steps aligned with the cells, which start at texel centres; θ in steps aligned
    /// with the cell rows), each weighing the density at its centre by its exact solid angle.
    /// The density is constant over a cell, so the sum is exact up to rounding, and it is 1 only
    /// if `pdf` finds the cell each direction lies in.
    #[test]
    fn the_density_integrates_to_one_over_the_sphere() {
        for (w, h, degrees) in [(16usize, 8usize, 0.0f32), (12, 7, 65.0), (5, 1, -20.0)] {
            let m = EnvironmentMap::new(
                map(w, h, |i, j| Vec3::new(i as f32, (j * j) as f32, 1.0 + (i * j % 3) as f32)),
                degrees,
            );
            let (k, rows) = (4usize, cell_rows(h));
            let (nphi, ntheta) = (k * w, k * rows);
            let mut total = 0.0f64;
            for b in 0..ntheta {
                let (t0, t1) = (PI * b as f32 / ntheta as f32, PI * (b + 1) as f32 / ntheta as f32);
                let omega = (TAU / nphi as f32) as f64 * (t0.cos() as f64 - t1.cos() as f64);
                for a in 0..nphi {
                    // Patches start at the first texel centre, u = 1/(2W).
                    let u = (0.5 + (a as f32 + 0.5) / k as f32) / w as f32;
                    let d = m.to_world(direction(TAU * u, 0.5 * (t0 + t1)));
                    total += m.pdf(d) as f64 * omega;
                }
            }
            assert!((total - 1.0).abs() < 1e-5, "{w}x{h}, {degrees}°: {total}");
        }
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

    /// χ² of 2²⁰ sampled directions against the density: every cell is cut into 2 × 2 patches,
    /// halves in φ and in cos θ, each expecting a quarter of the cell's probability (its density
    /// times its solid angle, exactly: the density is constant over the cell), so that the test
    /// judges both the choice of cell and the uniformity within it. The directions are read back
    /// through the rotation, which the sampler applies, and through the lookup's own grid.
    #[test]
    fn chi2_map_sampling_matches_its_density() {
        let cases = [
            ("sky, turned 40°", EnvironmentMap::new(sky(32, 16), 40.0)),
            ("random with black texels, turned −75°", EnvironmentMap::new(random(24, 12), -75.0)),
        ];
        let mut results = Vec::new();
        for (k, (name, m)) in cases.iter().enumerate() {
            let (w, rows) = (m.image.width, cell_rows(m.image.height));
            let samples = 1usize << 20;
            let mut observed = vec![0u64; w * rows * 4];
            let mut rng = rand_pcg::Pcg32::new(600 + k as u64, 3);
            for _ in 0..samples {
                let (dir, _) = m.sample(Vec2::new(rng.random(), rng.random())).unwrap();
                let g = m.grid_point(dir);
                let (c0, c1) = (m.edge_cos[g.r], m.edge_cos[g.r + 1]);
                let half_phi = (g.s >= 0.5) as usize;
                let half_cos = ((c0 - m.to_local(dir).y as f64) / (c0 - c1) >= 0.5) as usize;
                observed[((g.r * w + g.i) * 2 + half_phi) * 2 + half_cos] += 1;
            }
            let expected: Vec<f64> = (0..w * rows * 4)
                .map(|c| {
                    let (i, r) = ((c / 4) % w, c / 4 / w);
                    m.cell_pdf(i, r) as f64 * m.cell_solid_angle(r) / 4.0 * samples as f64
                })
                .collect();
            results.push((name.to_string(), chi2::outcome_of_counts(&expected, &observed)));
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }
}
