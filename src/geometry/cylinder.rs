//! Open cylinder walls (caps are separate disks).

use std::f32::consts::TAU;

use glam::{Mat3, Vec2, Vec3};

use super::disk::circle_extent;
use super::sphere::radial_roots;
use super::{azimuth, point_error, seam_frame, seam_slack, texture_frame, unit_or, Bounds, Ray, SurfaceHit};

/// The wall of a cylinder between `base` and `base + axis·height`, without caps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    pub(crate) base: Vec3,
    /// Centre of the top circle: as given to [`Cylinder::between`], else `base + axis·height`.
    top: Vec3,
    /// Local frame: `u`, `v` span the cross-section, `w` is the unit axis.
    pub(crate) u: Vec3,
    pub(crate) v: Vec3,
    pub(crate) w: Vec3,
    pub(crate) radius: f32,
    pub(crate) height: f32,
    /// The frame the texture's angle is measured in: `(u, v)`, turned with the cylinder by a
    /// rotation (apart from `u` and `v`, so that intersections do not change).
    uv_frame: (Vec3, Vec3),
    /// Whether the normals point towards the axis (Mitsuba's `flip_normals`) instead of away.
    pub(crate) inward: bool,
}

/// Texture coordinates of a cylinder wall's point: u the angle of its outward normal `outward`
/// in `frame`, v its height `z` above the base as a fraction of `height` (clamped to [0, 1]).
/// The one formula for hits and for an emitting wall's samples.
#[inline]
pub(crate) fn wall_uv(frame: (Vec3, Vec3), outward: Vec3, z: f32, height: f32) -> Vec2 {
    let v = if height > 0.0 { z / height } else { 0.0 };
    Vec2::new(azimuth(frame, outward), v.clamp(0.0, 1.0))
}

impl Cylinder {
    /// Wall of radius `radius` from `base` along `axis` (normalised) for `height`.
    pub fn new(base: Vec3, axis: Vec3, radius: f32, height: f32) -> Cylinder {
        let w = unit_or(axis, Vec3::Z);
        let (u, v) = texture_frame(w);
        Cylinder { base, top: base + w * height, u, v, w, radius, height, uv_frame: (u, v), inward: false }
    }

    /// Wall of radius `radius` from `base` to `top`, which it keeps as given (the axis and
    /// height are derived in double precision), so that an exporter writes the same end points.
    pub fn between(base: Vec3, top: Vec3, radius: f32) -> Cylinder {
        let d = top.as_dvec3() - base.as_dvec3();
        let height = d.length();
        let axis = if height > 0.0 { (d / height).as_vec3() } else { Vec3::Z };
        Cylinder { top, ..Cylinder::new(base, axis, radius, height as f32) }
    }

    /// The same wall with its normals towards the axis (`inward`) or away from it: the side
    /// a one-sided material faces, a one-sided emission leaves from and a dielectric's outside.
    pub fn facing_inwards(self, inward: bool) -> Cylinder {
        Cylinder { inward, ..self }
    }

    /// Whether the normals point towards the axis.
    pub fn inward(&self) -> bool {
        self.inward
    }

    /// The cylinder with its texture's angle 0 along `seam` ([`seam_frame`] about the axis);
    /// `None` when `seam` lies along the axis.
    pub fn with_seam(mut self, seam: Vec3) -> Option<Cylinder> {
        self.uv_frame = seam_frame(self.w, seam)?;
        Some(self)
    }

    /// `x` expressed in the local frame (axial component last).
    #[inline]
    fn local(&self, x: Vec3) -> Vec3 {
        Vec3::new(x.dot(self.u), x.dot(self.v), x.dot(self.w))
    }

    /// Nearest hit distance in the open interval (`tmin`, `tmax`); rays parallel to the axis miss.
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        let f = self.local(ray.origin - self.base);
        let d = self.local(ray.dir);
        let (t0, t1) = radial_roots(f.truncate().extend(0.0), d.truncate().extend(0.0), self.radius)?;
        if t0 >= tmax || t1 <= tmin {
            return None;
        }
        let slack = seam_slack(self.radius + self.height, self.base, f);
        [t0, t1].into_iter().find(|&t| {
            let z = f.z + t * d.z;
            t > tmin && t < tmax && z >= -slack && z <= self.height + slack
        })
    }

    /// Full hit record for a hit at `t`, with the radial component reprojected onto the wall.
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        self.surface_uv(ray, t, true)
    }

    /// [`Cylinder::surface`], with texture coordinates only where `with_uv` (else zero: the
    /// azimuth costs an `atan2`).
    #[inline]
    pub fn surface_uv(&self, ray: &Ray, t: f32, with_uv: bool) -> SurfaceHit {
        let q = (ray.origin - self.base) + t * ray.dir;
        let z = q.dot(self.w);
        let n = unit_or(q - z * self.w, self.u);
        let p = self.base + (z * self.w + self.radius * n);
        let facing = if self.inward { -n } else { n };
        SurfaceHit {
            t,
            p,
            n: facing,
            shading_n: facing,
            uv: if with_uv { wall_uv(self.uv_frame, n, z, self.height) } else { Vec2::ZERO },
            // Radially, as for the sphere, n·r is within γ(6)·r of the wall (roundoff of
            // `q − z·w` only tilts n, moving p along the wall); z·w carries the roundoff of the
            // dot product, γ(4)·|z|, along the axis; summing the two rounds twice more: γ(8)
            // on r + |z|. Adding the base point: γ(2)·|p|.
            p_error: point_error(p, self.radius + z.abs(), 8),
        }
    }

    /// Centre of the bottom circle.
    pub fn base(&self) -> Vec3 {
        self.base
    }

    /// Centre of the top circle.
    pub fn top(&self) -> Vec3 {
        self.top
    }

    /// Unit axis from the bottom circle to the top one.
    pub fn axis(&self) -> Vec3 {
        self.w
    }

    /// Radius.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Length along the axis.
    pub fn height(&self) -> f32 {
        self.height
    }

    /// Bounds of the two end circles (the top one where the wall ends, `base + axis·height`,
    /// and where it was given, which may differ in the last bits).
    pub fn bounds(&self) -> Bounds {
        let end = self.base + self.w * self.height;
        let extent = circle_extent(self.w, self.radius);
        Bounds {
            min: self.base.min(end).min(self.top) - extent,
            max: self.base.max(end).max(self.top) + extent,
        }
    }

    /// The cross-section frame the texture's angle is measured in ([`texture_frame`] of the
    /// axis, unless turned by [`Cylinder::turn_texture_frame`]).
    pub fn texture_frame(&self) -> (Vec3, Vec3) {
        self.uv_frame
    }

    /// Sets the texture frame to `unplaced`'s turned by `rotation` (the cylinder is `unplaced`
    /// placed by a similarity with that rotation): the image turns with the cylinder.
    pub fn turn_texture_frame(&mut self, unplaced: &Cylinder, rotation: Mat3) {
        self.uv_frame = (rotation * unplaced.uv_frame.0, rotation * unplaced.uv_frame.1);
    }

    /// Wall area 2πrh.
    pub fn area(&self) -> f32 {
        TAU * self.radius * self.height
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::test_support::{random_point, random_unit, ray, spawned_rays};
    use crate::geometry::Disk;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    /// Radius 1, from y = 0 to y = 2.
    fn unit_y() -> Cylinder {
        Cylinder::new(Vec3::ZERO, Vec3::Y, 1.0, 2.0)
    }

    #[test]
    fn head_on_hit_in_the_middle() {
        let c = unit_y();
        let r = ray([-5.0, 1.0, 0.0], [1.0, 0.0, 0.0]);
        let t = c.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 4.0);
        let h = c.surface(&r, t);
        assert_eq!(h.n, -Vec3::X);
        assert_eq!(h.p, Vec3::new(-1.0, 1.0, 0.0));
        assert_eq!(h.uv.y, 0.5);
        // Oblique axis: head-on through the middle of a cylinder along (1,1,1).
        let axis = Vec3::ONE.normalize();
        let c = Cylinder::new(Vec3::new(1.0, 2.0, 3.0), axis, 0.5, 4.0);
        let side = axis.any_orthonormal_pair().0;
        let r = Ray::new(Vec3::new(1.0, 2.0, 3.0) + axis * 2.0 + side * 3.0, -side);
        let t = c.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert!((t - 2.5).abs() < 1e-5, "t = {t}");
        assert!((c.surface(&r, t).n - side).length() < 1e-6);
    }

    #[test]
    fn miss_and_open_interval() {
        let c = unit_y();
        assert_eq!(c.intersect(&ray([-5.0, 1.0, 1.5], [1.0, 0.0, 0.0]), 0.0, f32::INFINITY), None);
        let r = ray([-5.0, 1.0, 0.0], [1.0, 0.0, 0.0]);
        // Roots at exactly 4 and 6.
        assert_eq!(c.intersect(&r, 0.0, 4.0), None);
        assert_eq!(c.intersect(&r, 4.0, 10.0), Some(6.0));
        assert_eq!(c.intersect(&r, 4.0, 6.0), None);
        assert_eq!(c.intersect(&r, 6.0, f32::INFINITY), None);
    }

    #[test]
    fn ray_from_inside_hits_far_wall() {
        let c = unit_y();
        let r = ray([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        let t = c.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 1.0);
        assert_eq!(c.surface(&r, t).n, Vec3::Z);
    }

    #[test]
    fn rays_along_the_axis_miss_without_nan() {
        let c = unit_y();
        // Inside, on the axis, on the wall line and outside; both directions.
        for o in [[0.0, -1.0, 0.0], [0.5, 1.0, 0.0], [1.0, -1.0, 0.0], [3.0, -1.0, 0.0]] {
            for d in [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]] {
                assert_eq!(c.intersect(&ray(o, d), 0.0, f32::INFINITY), None);
            }
        }
        // Almost parallel: no hit within the height range, nothing NaN.
        let r = Ray::new(Vec3::new(0.5, -1.0, 0.0), Vec3::new(1e-20, 1.0, 0.0));
        assert_eq!(c.intersect(&r, 0.0, f32::INFINITY), None);
        let r = Ray::new(Vec3::new(0.5, -1.0, 0.0), Vec3::new(1e-7, 1.0, 0.0).normalize());
        assert_eq!(c.intersect(&r, 0.0, f32::INFINITY), None);
        let zero = Ray { origin: Vec3::ZERO, dir: Vec3::ZERO, time: 0.0 };
        assert_eq!(c.intersect(&zero, 0.0, f32::INFINITY), None);
    }

    #[test]
    fn grazing_ray() {
        let c = unit_y();
        let r = ray([-5.0, 1.0, 1.0], [1.0, 0.0, 0.0]);
        let t = c.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 5.0);
        assert_eq!(c.surface(&r, t).n, Vec3::Z);
        // Oblique grazing rays: either a hit at the tangent point or a miss, never NaN.
        let mut rng = Pcg32::seed_from_u64(5);
        for _ in 0..10_000 {
            let axis = random_unit(&mut rng);
            let base = Vec3::new(1.0, -2.0, 3.0);
            let c = Cylinder::new(base, axis, 0.7, 5.0);
            let (e0, e1) = axis.any_orthonormal_pair();
            let phi = TAU * rng.random::<f32>();
            let radial = phi.cos() * e0 + phi.sin() * e1;
            let tangent = (axis.cross(radial) + axis * (rng.random::<f32>() - 0.5)).normalize();
            let touch = base + axis * 2.5 + radial * 0.7;
            let r = Ray::new(touch - tangent * 10.0, tangent);
            if let Some(t) = c.intersect(&r, 0.0, f32::INFINITY) {
                assert!((t - 10.0).abs() < 0.05, "t = {t}");
                let h = c.surface(&r, t);
                assert!(h.n.is_finite() && h.p.is_finite() && h.uv.is_finite());
            }
        }
    }

    #[test]
    fn height_range() {
        let c = unit_y();
        let eps = 1e-4;
        let across = |y: f32| c.intersect(&ray([-5.0, y, 0.0], [1.0, 0.0, 0.0]), 0.0, 100.0);
        assert_eq!(across(2.0 + eps), None);
        assert_eq!(across(-eps), None);
        assert_eq!(across(2.0 - eps), Some(4.0));
        assert_eq!(across(eps), Some(4.0));
        // Exactly on the rim circles.
        assert_eq!(across(2.0), Some(4.0));
        assert_eq!(across(0.0), Some(4.0));
        // Passing over the near rim into the open end: the far wall is hit.
        let r = ray([-5.0, 3.0, 0.0], [1.0, -0.2, 0.0]);
        let t = c.intersect(&r, 0.0, 100.0).unwrap();
        assert!((r.at(t).x - 1.0).abs() < 1e-5, "{:?}", r.at(t));
    }

    /// Exact (f64) test of the f32 ray against the f32-parameterised closed cylinder: whether the
    /// wall or a cap is hit with t in [lo, hi].
    fn exact_closed_cylinder(
        r: &Ray,
        base: Vec3,
        axis: Vec3,
        radius: f32,
        height: f32,
        lo: f32,
        hi: f32,
    ) -> bool {
        let (o, d) = (r.origin.as_dvec3() - base.as_dvec3(), r.dir.as_dvec3());
        let (w, radius, height) = (axis.as_dvec3().normalize(), f64::from(radius), f64::from(height));
        let in_range = |t: f64| t >= f64::from(lo) && t <= f64::from(hi);
        let (op, dp) = (o - o.dot(w) * w, d - d.dot(w) * w);
        let (a, b, c) = (dp.length_squared(), op.dot(dp), op.length_squared() - radius * radius);
        let disc = b * b - a * c;
        let wall = a > 0.0
            && disc >= 0.0
            && [(-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a].into_iter().any(|t| {
                let z = (o + t * d).dot(w);
                in_range(t) && z >= 0.0 && z <= height
            });
        let cap = [0.0, height].into_iter().any(|z| {
            let t = (z - o.dot(w)) / d.dot(w);
            let p = o + t * d;
            in_range(t) && (p - p.dot(w) * w).length() <= radius
        });
        wall || cap
    }

    #[test]
    fn wall_and_caps_have_no_seam_gap() {
        let mut rng = Pcg32::seed_from_u64(13);
        let mut tested = 0;
        for case in 0..20_000 {
            let base = random_point(&mut rng, 10.0);
            let axis = if case % 4 == 0 { Vec3::Y } else { random_unit(&mut rng).normalize() };
            let radius = 0.1 + rng.random::<f32>() * 3.0;
            let height = 0.1 + rng.random::<f32>() * 6.0;
            let wall = Cylinder::new(base, axis, radius, height);
            let top = Disk::new(base + axis * height, axis, radius, 0.0);
            let bottom = Disk::new(base, -axis, radius, 0.0);
            let (e0, e1) = axis.any_orthonormal_pair();
            let phi = TAU * rng.random::<f32>();
            let end = if rng.random::<bool>() { height } else { 0.0 };
            let target = base + axis * end + radius * (phi.cos() * e0 + phi.sin() * e1);
            let center = base + axis * (height * 0.5);
            let o = match case % 3 {
                0 => center + random_unit(&mut rng) * (radius + height) * (1.0 + 30.0 * rng.random::<f32>()),
                1 => base + axis * (height * rng.random::<f32>()) + 0.95 * radius * rng.random::<f32>() * e0,
                _ => center,
            };
            let r = Ray::new(o, (target - o).normalize());
            let expect = (target - o).length();
            // Only the hit at the rim matters, not an earlier crossing. The f32 target is only
            // near the rim, so the exact answer decides whether a hit is due at all.
            let (lo, hi) = (expect * (1.0 - 1e-3), expect * (1.0 + 1e-3));
            if !exact_closed_cylinder(&r, base, axis, radius, height, lo, hi) {
                continue;
            }
            tested += 1;
            let hits = [wall.intersect(&r, lo, hi), top.intersect(&r, lo, hi), bottom.intersect(&r, lo, hi)];
            assert!(hits.iter().any(Option::is_some), "case {case}: rim ray {r:?} missed wall and caps");
        }
        assert!(tested > 16_000, "only {tested} rays reach the seam");
    }

    #[test]
    fn spawned_rays_do_not_self_intersect() {
        let mut rng = Pcg32::seed_from_u64(17);
        let mut checked = 0;
        while checked < 2_000 {
            let base = random_point(&mut rng, 100.0);
            let axis = random_unit(&mut rng);
            let radius = 0.01 + rng.random::<f32>() * 5.0;
            let height = 0.01 + rng.random::<f32>() * 50.0;
            let c = Cylinder::new(base, axis, radius, height);
            let (e0, e1) = axis.any_orthonormal_pair();
            let phi = TAU * rng.random::<f32>();
            let target =
                base + axis * (height * rng.random::<f32>()) + radius * (phi.cos() * e0 + phi.sin() * e1);
            let o = if checked % 3 == 0 {
                base + axis * (height * rng.random::<f32>()) + 0.9 * radius * rng.random::<f32>() * e1
            } else {
                target + random_unit(&mut rng) * (radius + height) * (0.5 + 5.0 * rng.random::<f32>())
            };
            let r = Ray::new(o, (target - o).normalize());
            let Some(t) = c.intersect(&r, 0.0, f32::INFINITY) else { continue };
            let hit = c.surface(&r, t);
            for spawned in spawned_rays(&hit, r.dir, &mut rng) {
                // A far second hit from inside is legitimate; one within 1e-3·size is not.
                let again = c.intersect(&spawned, 0.0, 1e-3 * radius.min(height));
                assert_eq!(again, None, "self-hit from {hit:?} along {}", spawned.dir);
            }
            checked += 1;
        }
    }

    #[test]
    fn bounds_and_area() {
        let b = unit_y().bounds();
        assert_eq!((b.min, b.max), (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0)));
        assert!((unit_y().area() - 2.0 * TAU).abs() < 1e-5);
    }

    #[test]
    fn a_cylinder_between_two_points_keeps_them_and_reaches_them() {
        let mut rng = Pcg32::seed_from_u64(17);
        for _ in 0..200 {
            let (base, top) = (random_point(&mut rng, 3.0), random_point(&mut rng, 3.0));
            let c = Cylinder::between(base, top, 0.25);
            assert_eq!((c.base(), c.top()), (base, top));
            // Axis and height from the double-precision difference: base + axis·height is the
            // top to within a few ulps of the coordinates, and the bounds hold both end circles.
            let end = c.base() + c.axis() * c.height();
            let scale = base.abs().max(top.abs()).max_element().max(c.height());
            assert!((end - top).abs().max_element() <= 4.0 * f32::EPSILON * scale, "{end} {top}");
            assert!((c.axis().length() - 1.0).abs() <= 2.0 * f32::EPSILON);
            let b = c.bounds();
            for p in [base, top, end] {
                assert!(p.cmpge(b.min).all() && p.cmple(b.max).all(), "{p} outside {b:?}");
            }
        }
        // Built from an axis and a height, the top is where the wall ends.
        let c = Cylinder::new(Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.0, 2.0, 2.0), 0.5, 1.5);
        assert_eq!(c.top(), c.base() + c.axis() * c.height());
    }
}
