//! An emitting triangle mesh as one light: its triangles sampled uniformly by area (a triangle
//! picked by its share of the total area, then a uniform point in it), so that the area density
//! of every point is `1/area`, the density the other strategies assume when a ray meets it.

use crate::geometry::Triangle;
use glam::{Vec2, Vec3};

/// The triangles of an emitting mesh with their cumulative areas.
#[derive(Clone, Debug, PartialEq)]
pub struct EmitterMesh {
    /// The triangles' corners, in the mesh's order.
    corners: Vec<[Vec3; 3]>,
    /// The triangles' areas summed up to and including each one, divided by the total (the last
    /// is exactly 1).
    cumulative: Vec<f32>,
    /// Total area.
    area: f32,
    /// The area-weighted centroid.
    centre: Vec3,
    /// The largest absolute coordinate of a corner (the scale of a sampled point's roundoff).
    extent: f32,
}

impl EmitterMesh {
    /// The emitter of `triangles`; `None` when they have no area.
    pub fn new(triangles: &[Triangle]) -> Option<EmitterMesh> {
        let corners: Vec<[Vec3; 3]> = triangles.iter().map(Triangle::vertices).collect();
        let areas: Vec<f64> = triangles.iter().map(|t| f64::from(t.area())).collect();
        let total: f64 = areas.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut running = 0.0;
        let mut cumulative: Vec<f32> = areas
            .iter()
            .map(|a| {
                running += a;
                (running / total) as f32
            })
            .collect();
        *cumulative.last_mut()? = 1.0;
        let centre = corners
            .iter()
            .zip(&areas)
            .fold(glam::DVec3::ZERO, |sum, (c, a)| sum + (c[0] + c[1] + c[2]).as_dvec3() * (a / 3.0))
            / total;
        let extent = corners.iter().flatten().fold(0.0f32, |m, p| m.max(p.abs().max_element()));
        Some(EmitterMesh { corners, cumulative, area: total as f32, centre: centre.as_vec3(), extent })
    }

    /// Total area.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// Whether the mesh has no triangles (never, for a mesh [`new`](Self::new) made).
    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// The triangles' corners, in the mesh's order.
    pub fn corners(&self) -> &[[Vec3; 3]] {
        &self.corners
    }

    /// The area-weighted centroid.
    pub fn centre(&self) -> Vec3 {
        self.centre
    }

    /// The largest absolute coordinate of a corner.
    pub fn extent(&self) -> f32 {
        self.extent
    }

    /// A point uniformly distributed over the area with its triangle's unit (winding) normal:
    /// `u.x` picks the triangle by its share of the area and is reused, rescaled, inside it.
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3) {
        let k = self.cumulative.partition_point(|&c| c <= u.x).min(self.corners.len() - 1);
        let low = if k == 0 { 0.0 } else { self.cumulative[k - 1] };
        let width = self.cumulative[k] - low;
        let reused = if width > 0.0 { ((u.x - low) / width).clamp(0.0, 1.0) } else { 0.5 };
        let [a, b, c] = self.corners[k];
        // Uniform on the triangle: b1 = 1 − √s, b2 = t·√s.
        let s = reused.sqrt();
        let p = a + (b - a) * (s * (1.0 - u.y)) + (c - a) * (s * u.y);
        let n = (b - a).cross(c - a).normalize();
        (p, n)
    }

    /// The mesh's projected area seen from the unit direction `d`: `Σ A_i·|n_i·d|` over the
    /// triangles, both sides counted once, or with `one_sided` only the triangles whose
    /// (winding) normal faces `d`, `Σ A_i·max(n_i·d, 0)` (the intensity of a Lambertian emitter
    /// of unit radiance in that direction, emitting on both sides or on its front).
    pub fn projected_area(&self, d: Vec3, one_sided: bool) -> f32 {
        self.corners
            .iter()
            .map(|[a, b, c]| {
                let cos_area = 0.5 * (*b - *a).cross(*c - *a).dot(d);
                if one_sided {
                    cos_area.max(0.0)
                } else {
                    cos_area.abs()
                }
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangles_are_picked_by_their_area_and_points_are_uniform_in_them() {
        // Three triangles of areas 0.5, 2 and 0.125 (z = 0, 1, 2 tell them apart).
        let t = [
            Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y),
            Triangle::new(Vec3::new(0.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 1.0), Vec3::new(0.0, 2.0, 1.0)),
            Triangle::new(Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.5, 0.0, 2.0), Vec3::new(0.0, 0.5, 2.0)),
        ];
        let mesh = EmitterMesh::new(&t).unwrap();
        assert!((mesh.area() - 2.625).abs() < 1e-6);
        let n = 200_000;
        let mut counts = [0usize; 3];
        // Within each triangle, the share below its diagonal's midline x + y < half the legs
        // (a quarter of the area): a uniform point lands there with probability ¼.
        let mut inner = [0usize; 3];
        let legs = [1.0, 2.0, 0.5];
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        for _ in 0..n {
            let (p, normal) = mesh.sample(Vec2::new(rng.random(), rng.random()));
            let k = p.z.round() as usize;
            assert!(normal.abs_diff_eq(Vec3::Z, 1e-6));
            assert!(p.x >= -1e-6 && p.y >= -1e-6 && p.x + p.y <= legs[k] * (1.0 + 1e-6), "{p}");
            counts[k] += 1;
            inner[k] += usize::from(p.x + p.y < 0.5 * legs[k]);
        }
        for k in 0..3 {
            let share = t[k].area() / mesh.area();
            let expected = n as f32 * share;
            let se = (n as f32 * share * (1.0 - share)).sqrt();
            assert!((counts[k] as f32 - expected).abs() < 5.0 * se, "triangle {k}: {counts:?}");
            let m = counts[k] as f32;
            let se = (m * 0.25 * 0.75).sqrt();
            assert!((inner[k] as f32 - 0.25 * m).abs() < 5.0 * se, "triangle {k}: {} of {m}", inner[k]);
        }
        // The projected area of a flat mesh is its area times |cos|, from either side; one-sided,
        // from its front only.
        let d = Vec3::new(0.0, 0.6, -0.8);
        assert!((mesh.projected_area(d, false) - 0.8 * mesh.area()).abs() < 1e-5);
        assert!((mesh.projected_area(-d, false) - 0.8 * mesh.area()).abs() < 1e-5);
        assert!((mesh.projected_area(-d, true) - 0.8 * mesh.area()).abs() < 1e-5);
        assert_eq!(mesh.projected_area(d, true), 0.0);
    }

    #[test]
    fn a_mesh_without_area_is_refused() {
        assert!(EmitterMesh::new(&[]).is_none());
    }
}
