//! Disks and annuli.

use std::f32::consts::PI;

use glam::{Mat3, Vec2, Vec3};

use super::{
    azimuth, planar_surface, plane_hit, plane_point, seam_frame, seam_slack, texture_frame, unit_or, Bounds,
    Ray, SurfaceHit,
};

/// Half-extent along each world axis of a circle of `radius` around the unit `normal`:
/// `r·√(1 − n_i²)` along axis i.
#[inline]
pub(crate) fn circle_extent(normal: Vec3, radius: f32) -> Vec3 {
    radius * (Vec3::ONE - normal * normal).max(Vec3::ZERO).sqrt()
}

/// Texture coordinates of the point `q` (relative to the centre) of a disk of `radius` with a hole
/// of `inner_radius`, Mitsuba 3's disk uv: the radial position, 0 at the centre (or on the inner
/// rim) and 1 on the outer rim, and the angle about the normal measured in `frame` ([`texture_frame`]
/// of the normal, or the frame a `seam` gave).
#[inline]
pub fn disk_uv(frame: (Vec3, Vec3), q: Vec3, radius: f32, inner_radius: f32) -> Vec2 {
    let width = radius - inner_radius;
    let u = if width > 0.0 { (q.length() - inner_radius) / width } else { 0.0 };
    Vec2::new(u.clamp(0.0, 1.0), azimuth(frame, q))
}

/// A disk of radius `radius` around `center`, with a hole of `inner_radius` (an annulus if > 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disk {
    pub(crate) center: Vec3,
    pub(crate) normal: Vec3,
    /// The normal as it was given, before normalising: what defines the disk, for an exporter
    /// to write back.
    given_normal: Vec3,
    /// In-plane frame for the angular texture coordinate.
    tangent: (Vec3, Vec3),
    pub(crate) radius: f32,
    pub(crate) inner_radius: f32,
}

impl Disk {
    /// Disk or annulus facing `normal` (normalised); `inner_radius` 0 gives a full disk.
    pub fn new(center: Vec3, normal: Vec3, radius: f32, inner_radius: f32) -> Disk {
        let given = normal;
        let normal = unit_or(given, Vec3::Z);
        // A zero or non-finite one is replaced by the normal it falls back to.
        let given_normal = if given.is_finite() && given.dot(normal) > 0.0 { given } else { normal };
        Disk { center, normal, given_normal, tangent: texture_frame(normal), radius, inner_radius }
    }

    /// This disk, recording `normal` (parallel to its own) as the normal it was given.
    pub fn with_given_normal(self, normal: Vec3) -> Disk {
        Disk { given_normal: normal, ..self }
    }

    /// The normal as given to [`Disk::new`] (or [`Disk::with_given_normal`]), not normalised.
    pub fn given_normal(&self) -> Vec3 {
        self.given_normal
    }

    /// The disk with its texture's angle 0 along `seam` ([`seam_frame`] about the normal);
    /// `None` when `seam` lies along the normal.
    pub fn with_seam(mut self, seam: Vec3) -> Option<Disk> {
        self.tangent = seam_frame(self.normal, seam)?;
        Some(self)
    }

    /// Nearest hit distance in the open interval (`tmin`, `tmax`); rays in the plane miss.
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        let (t, f, q) = plane_hit(self.normal, self.center, ray, tmin, tmax)?;
        // The out-of-plane part of q is roundoff, negligible once squared.
        let dist2 = q.length_squared();
        let slack = seam_slack(self.radius, self.center, f);
        let (outer, inner) = (self.radius + slack, (self.inner_radius - slack).max(0.0));
        (dist2 <= outer * outer && dist2 >= inner * inner).then_some(t)
    }

    /// Full hit record for a hit at `t`, with the point projected onto the plane.
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        self.surface_uv(ray, t, true)
    }

    /// [`Disk::surface`], with texture coordinates only where `with_uv` (else zero: the angle
    /// costs an `atan2`).
    #[inline]
    pub fn surface_uv(&self, ray: &Ray, t: f32, with_uv: bool) -> SurfaceHit {
        let q = plane_point(self.normal, self.center, ray, t);
        let uv = if with_uv { disk_uv(self.tangent, q, self.radius, self.inner_radius) } else { Vec2::ZERO };
        planar_surface(self.normal, self.center, q, t, uv)
    }

    /// Centre.
    pub fn center(&self) -> Vec3 {
        self.center
    }

    /// Unit normal (the side the interface calls outside).
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// Outer radius.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Radius of the hole (0 for a full disk).
    pub fn inner_radius(&self) -> f32 {
        self.inner_radius
    }

    /// Bounds of the rim circle.
    pub fn bounds(&self) -> Bounds {
        let extent = circle_extent(self.normal, self.radius);
        Bounds { min: self.center - extent, max: self.center + extent }
    }

    /// The in-plane texture frame the angle is measured in ([`texture_frame`] of the normal,
    /// unless turned by [`Disk::turn_texture_frame`]).
    pub fn texture_frame(&self) -> (Vec3, Vec3) {
        self.tangent
    }

    /// Sets the texture frame to `unplaced`'s turned by `rotation` (the disk is `unplaced`
    /// placed by a similarity with that rotation): the image turns with the disk.
    pub fn turn_texture_frame(&mut self, unplaced: &Disk, rotation: Mat3) {
        self.tangent = (rotation * unplaced.tangent.0, rotation * unplaced.tangent.1);
    }

    /// Area π(r² − r_inner²).
    pub fn area(&self) -> f32 {
        PI * (self.radius * self.radius - self.inner_radius * self.inner_radius)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::test_support::{random_point, random_unit, ray, spawned_rays};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;
    use std::f32::consts::TAU;

    #[test]
    fn head_on_hit() {
        let d = Disk::new(Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 2.0, 0.0);
        let r = ray([0.5, 4.0, 0.5], [0.0, -1.0, 0.0]);
        let t = d.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 3.0);
        let h = d.surface(&r, t);
        assert_eq!(h.n, Vec3::Y);
        assert_eq!(h.p, Vec3::new(0.5, 1.0, 0.5));
        // From behind: same surface, same (given) normal.
        let r = ray([0.5, -1.0, 0.5], [0.0, 1.0, 0.0]);
        let t = d.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 2.0);
        assert_eq!(d.surface(&r, t).n, Vec3::Y);
        // Oblique, tilted disk: t = distance to the centre.
        let n = Vec3::new(1.0, 2.0, 3.0).normalize();
        let d = Disk::new(Vec3::new(4.0, 5.0, 6.0), n, 1.0, 0.0);
        let r = Ray::new(Vec3::new(4.0, 5.0, 6.0) + n * 7.0, -n);
        let t = d.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert!((t - 7.0).abs() < 1e-5);
    }

    #[test]
    fn miss_open_interval_and_parallel() {
        let d = Disk::new(Vec3::ZERO, Vec3::Z, 1.0, 0.0);
        assert_eq!(d.intersect(&ray([1.5, 0.0, 1.0], [0.0, 0.0, -1.0]), 0.0, f32::INFINITY), None);
        let r = ray([0.0, 0.0, 2.0], [0.0, 0.0, -1.0]);
        assert_eq!(d.intersect(&r, 0.0, 2.0), None);
        assert_eq!(d.intersect(&r, 2.0, 3.0), None);
        assert_eq!(d.intersect(&r, 1.999, 2.001), Some(2.0));
        // Ray in the plane of the disk, and behind it.
        assert_eq!(d.intersect(&ray([-5.0, 0.0, 0.0], [1.0, 0.0, 0.0]), 0.0, f32::INFINITY), None);
        assert_eq!(d.intersect(&ray([0.0, 0.0, 2.0], [0.0, 0.0, 1.0]), 0.0, f32::INFINITY), None);
        let zero = Ray { origin: Vec3::ZERO, dir: Vec3::ZERO, time: 0.0 };
        assert_eq!(d.intersect(&zero, 0.0, f32::INFINITY), None);
    }

    #[test]
    fn annulus_hole_and_edges() {
        let d = Disk::new(Vec3::ZERO, Vec3::Z, 2.0, 1.0);
        let down = |x: f32| d.intersect(&ray([x, 0.0, 3.0], [0.0, 0.0, -1.0]), 0.0, f32::INFINITY);
        assert_eq!(down(0.0), None);
        assert_eq!(down(0.999), None);
        assert_eq!(down(1.0), Some(3.0));
        assert_eq!(down(1.5), Some(3.0));
        assert_eq!(down(2.0), Some(3.0));
        assert_eq!(down(2.001), None);
        let h = d.surface(&ray([1.5, 0.0, 3.0], [0.0, 0.0, -1.0]), 3.0);
        assert!((h.uv.x - 0.5).abs() < 1e-6);
        assert!((d.area() - 3.0 * PI).abs() < 1e-5);
        let b = Disk::new(Vec3::ZERO, Vec3::Z, 2.0, 0.0).bounds();
        assert_eq!((b.min, b.max), (Vec3::new(-2.0, -2.0, 0.0), Vec3::new(2.0, 2.0, 0.0)));
    }

    #[test]
    fn spawned_rays_do_not_self_intersect() {
        let mut rng = Pcg32::seed_from_u64(19);
        let mut checked = 0;
        while checked < 2_000 {
            let center = random_point(&mut rng, 100.0);
            let normal = random_unit(&mut rng);
            let radius = 0.01 + rng.random::<f32>() * 10.0;
            let d = Disk::new(center, normal, radius, radius * 0.3);
            let (e0, e1) = normal.any_orthonormal_pair();
            let phi = TAU * rng.random::<f32>();
            let rho = radius * (0.3 + 0.7 * rng.random::<f32>());
            let target = center + rho * (phi.cos() * e0 + phi.sin() * e1);
            let o = target + random_unit(&mut rng) * radius * (0.1 + 20.0 * rng.random::<f32>());
            let r = Ray::new(o, (target - o).normalize());
            let Some(t) = d.intersect(&r, 0.0, f32::INFINITY) else { continue };
            let hit = d.surface(&r, t);
            for spawned in spawned_rays(&hit, r.dir, &mut rng) {
                // A plane is never hit again by a ray leaving it.
                assert_eq!(d.intersect(&spawned, 0.0, f32::INFINITY), None, "self-hit {hit:?}");
            }
            checked += 1;
        }
    }
}
