//! Parallelograms.

use glam::{Vec2, Vec3};

use super::{
    bounds_of, planar_surface, plane_hit, plane_point, seam_slack, unit_or, Bounds, Ray, SurfaceHit,
};

/// The parallelogram `corner + a·u + b·v`, `a, b ∈ [0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quad {
    pub(crate) corner: Vec3,
    u: Vec3,
    v: Vec3,
    /// Unit normal `normalize(u × v)` (zero for a degenerate quad, which is never hit).
    pub(crate) normal: Vec3,
    /// Dual basis `(v × w, w × u)` with `w = (u × v) / |u × v|²`: for an in-plane offset q
    /// from the corner, `q·dual.0` and `q·dual.1` are its coordinates (a, b).
    pub(crate) dual: (Vec3, Vec3),
    /// Reciprocal distances between opposite edges (converts length slack to a and b).
    pub(crate) inv_width: Vec2,
    /// `|u| + |v|`, the size for the seam slack.
    pub(crate) size: f32,
}

impl Quad {
    /// Parallelogram spanned by `u` and `v` from `corner`.
    pub fn new(corner: Vec3, u: Vec3, v: Vec3) -> Quad {
        let cross = u.cross(v);
        let normal = unit_or(cross, Vec3::ZERO);
        let area = cross.dot(normal);
        let (w, inv_width) = if area > 0.0 {
            (normal / area, Vec2::new(v.length(), u.length()) / area)
        } else {
            (Vec3::ZERO, Vec2::ZERO)
        };
        let dual = (v.cross(w), w.cross(u));
        Quad { corner, u, v, normal, dual, inv_width, size: u.length() + v.length() }
    }

    /// Parallelogram coordinates (a, b) of the offset `q` from the corner.
    #[inline]
    fn coords(&self, q: Vec3) -> Vec2 {
        Vec2::new(q.dot(self.dual.0), q.dot(self.dual.1))
    }

    /// Nearest hit distance in the open interval (`tmin`, `tmax`).
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        let (t, f, q) = plane_hit(self.normal, self.corner, ray, tmin, tmax)?;
        let ab = self.coords(q);
        let slack = seam_slack(self.size, self.corner, f) * self.inv_width;
        (ab.cmpge(-slack).all() && ab.cmple(Vec2::ONE + slack).all()).then_some(t)
    }

    /// Full hit record for a hit at `t`; uv = (a, b).
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        let q = plane_point(self.normal, self.corner, ray, t);
        let uv = self.coords(q).clamp(Vec2::ZERO, Vec2::ONE);
        planar_surface(self.normal, self.corner, q, t, uv)
    }

    /// The corner at (a, b) = (0, 0).
    pub fn corner(&self) -> Vec3 {
        self.corner
    }

    /// First edge.
    pub fn u(&self) -> Vec3 {
        self.u
    }

    /// Second edge.
    pub fn v(&self) -> Vec3 {
        self.v
    }

    /// Unit normal `normalize(u × v)`.
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// Bounds of the four corners.
    pub fn bounds(&self) -> Bounds {
        let c = self.corner;
        bounds_of(&[c, c + self.u, c + self.v, c + self.u + self.v])
    }

    /// Area `|u × v|`.
    pub fn area(&self) -> f32 {
        self.u.cross(self.v).length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::test_support::{random_point, random_unit, ray, spawned_rays};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    /// Unit square in z = 0 from the origin, normal +Z.
    fn square() -> Quad {
        Quad::new(Vec3::ZERO, Vec3::X, Vec3::Y)
    }

    #[test]
    fn head_on_hit() {
        let q = square();
        let r = ray([0.25, 0.75, 2.0], [0.0, 0.0, -1.0]);
        let t = q.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 2.0);
        let h = q.surface(&r, t);
        assert_eq!(h.n, Vec3::Z);
        assert_eq!(h.p, Vec3::new(0.25, 0.75, 0.0));
        assert_eq!(h.uv, Vec2::new(0.25, 0.75));
        // A skewed, scaled parallelogram: uv = (a, b) of the hit.
        let q = Quad::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 3.0));
        let target =
            Vec3::new(1.0, 2.0, 3.0) + 0.5 * Vec3::new(2.0, 0.0, 0.0) + 0.25 * Vec3::new(1.0, 0.0, 3.0);
        let r = Ray::new(target + Vec3::Y * 4.0, -Vec3::Y);
        let t = q.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 4.0);
        let h = q.surface(&r, t);
        assert_eq!(h.n, -Vec3::Y);
        assert!((h.uv - Vec2::new(0.5, 0.25)).length() < 1e-6);
        assert!((q.area() - 6.0).abs() < 1e-6);
    }

    #[test]
    fn miss_and_open_interval() {
        let q = square();
        assert_eq!(q.intersect(&ray([1.25, 0.5, 1.0], [0.0, 0.0, -1.0]), 0.0, 10.0), None);
        assert_eq!(q.intersect(&ray([0.5, -0.01, 1.0], [0.0, 0.0, -1.0]), 0.0, 10.0), None);
        assert_eq!(q.intersect(&ray([0.5, 0.5, 1.0], [1.0, 0.0, 0.0]), 0.0, 10.0), None);
        let r = ray([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]);
        assert_eq!(q.intersect(&r, 0.0, 1.0), None);
        assert_eq!(q.intersect(&r, 1.0, 2.0), None);
        assert_eq!(q.intersect(&r, 0.5, 1.5), Some(1.0));
        let degenerate = Quad::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0);
        assert_eq!(degenerate.intersect(&r, 0.0, 10.0), None);
        assert_eq!(degenerate.area(), 0.0);
    }

    #[test]
    fn corners_and_edges_hit() {
        let q = square();
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.0), (1.0, 0.5)] {
            let r = ray([x, y, 1.0], [0.0, 0.0, -1.0]);
            assert_eq!(q.intersect(&r, 0.0, 10.0), Some(1.0), "corner ({x}, {y})");
            assert_eq!(q.surface(&r, 1.0).uv, Vec2::new(x, y));
        }
        let b = q.bounds();
        assert_eq!((b.min, b.max), (Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
    }

    #[test]
    fn closed_box_of_quads_has_no_edge_gap() {
        let mut rng = Pcg32::seed_from_u64(23);
        for case in 0..20_000 {
            let lo = random_point(&mut rng, 10.0);
            let size = Vec3::new(rng.random(), rng.random(), rng.random()) * 3.0 + 0.1;
            let (x, y, z) = (Vec3::X * size.x, Vec3::Y * size.y, Vec3::Z * size.z);
            let hi = lo + size;
            let faces = [
                Quad::new(lo, y, x),
                Quad::new(lo, x, z),
                Quad::new(lo, z, y),
                Quad::new(hi, -x, -y),
                Quad::new(hi, -z, -x),
                Quad::new(hi, -y, -z),
            ];
            // A point on a random edge of the box.
            let s = rng.random::<f32>();
            let axis = case % 3;
            let mut target = lo
                + size
                    * Vec3::new(
                        rng.random::<bool>() as u8 as f32,
                        rng.random::<bool>() as u8 as f32,
                        rng.random::<bool>() as u8 as f32,
                    );
            target[axis] = lo[axis] + s * size[axis];
            let o = if case % 2 == 0 {
                lo + size * Vec3::new(rng.random(), rng.random(), rng.random())
            } else {
                lo + 0.5 * size + random_unit(&mut rng) * size.length() * (1.0 + 20.0 * rng.random::<f32>())
            };
            let r = Ray::new(o, (target - o).normalize());
            let expect = (target - o).length();
            let hit = faces
                .iter()
                .filter_map(|f| f.intersect(&r, 0.0, f32::INFINITY))
                .any(|t| (t - expect).abs() <= 1e-3 * expect);
            assert!(hit, "case {case}: edge ray missed every face");
        }
    }

    #[test]
    fn spawned_rays_do_not_self_intersect() {
        let mut rng = Pcg32::seed_from_u64(29);
        let mut checked = 0;
        while checked < 2_000 {
            let corner = random_point(&mut rng, 100.0);
            let u = random_unit(&mut rng) * (0.01 + 10.0 * rng.random::<f32>());
            let v = random_unit(&mut rng) * (0.01 + 10.0 * rng.random::<f32>());
            let q = Quad::new(corner, u, v);
            let target = corner + rng.random::<f32>() * u + rng.random::<f32>() * v;
            let o = target + random_unit(&mut rng) * (0.1 + 20.0 * rng.random::<f32>());
            let r = Ray::new(o, (target - o).normalize());
            let Some(t) = q.intersect(&r, 0.0, f32::INFINITY) else { continue };
            let hit = q.surface(&r, t);
            for spawned in spawned_rays(&hit, r.dir, &mut rng) {
                assert_eq!(q.intersect(&spawned, 0.0, f32::INFINITY), None, "self-hit {hit:?}");
            }
            checked += 1;
        }
    }
}
