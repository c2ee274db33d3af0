//! Spheres, disks and cylinders under a general affine map (a per-axis scale, a shear, any
//! invertible matrix with positive determinant): ellipsoids, elliptic disks and elliptic
//! cylinders, intersected exactly in the shape's own object space.
//!
//! A world ray `o + t·d` becomes the object-space ray `M⁻¹(o − c) + t·M⁻¹d`, whose direction is
//! deliberately not renormalised: the same `t` then names the same point in both spaces, so the
//! shape's own `intersect` answers in world distances. The hit point is mapped back by `M`, the
//! normal by the inverse transpose `M⁻ᵀ` (then normalised), and the texture coordinates are the
//! object-space ones: the texture frame moves with the shape.

use glam::{Mat3, Vec3};

use super::{gamma, unit_or, Bounds, Ray, Shape, SurfaceHit};

/// An analytic shape (sphere, zone of one, disk, cylinder wall) in its object space, placed in
/// the world by `p ↦ to_world·p + translate`.
#[derive(Clone, Debug)]
pub struct AffineShape {
    /// The shape as written in the scene file (object space).
    object: Shape,
    /// The linear part `M` of the map to the world.
    to_world: Mat3,
    /// `M⁻¹`, which carries world rays into object space.
    to_object: Mat3,
    /// `M⁻ᵀ`, which carries normals to the world.
    normal_to_world: Mat3,
    /// The translation, applied after `M`.
    translate: Vec3,
    /// The Frobenius norm of `M`: at least its largest stretch, the factor by which an
    /// object-space distance can grow in the world.
    stretch: f32,
    /// The row-sum norm of `M` (how much a coordinate's error can grow in one product).
    row_norm: f32,
    /// The row-sum condition number ‖M‖·‖M⁻¹‖ (how much roundoff the round trip into object
    /// space adds, relative to the object-space coordinates).
    condition: f32,
}

impl AffineShape {
    /// `object` (a sphere, disk or cylinder) placed by `p ↦ linear·p + translate`; `None` for
    /// another kind of shape, or a matrix that is singular, mirrors (determinant ≤ 0) or is not
    /// finite.
    pub fn new(object: Shape, linear: Mat3, translate: Vec3) -> Option<AffineShape> {
        let supported = matches!(object, Shape::Sphere(_) | Shape::Disk(_) | Shape::Cylinder(_));
        let det = linear.determinant();
        if !(supported && det > 0.0 && det.is_finite() && translate.is_finite()) {
            return None;
        }
        let to_object = linear.inverse();
        if !to_object.is_finite() {
            return None;
        }
        let row_norm = |m: Mat3| {
            let t = m.transpose();
            [t.x_axis, t.y_axis, t.z_axis].map(|r| r.abs().element_sum()).into_iter().fold(0.0, f32::max)
        };
        let frobenius = (linear.x_axis.length_squared()
            + linear.y_axis.length_squared()
            + linear.z_axis.length_squared())
        .sqrt();
        Some(AffineShape {
            object,
            to_world: linear,
            to_object,
            normal_to_world: to_object.transpose(),
            translate,
            stretch: frobenius,
            row_norm: row_norm(linear),
            condition: row_norm(linear) * row_norm(to_object),
        })
    }

    /// The shape in its object space.
    pub fn object(&self) -> &Shape {
        &self.object
    }

    /// The linear part of the map to the world.
    pub fn linear(&self) -> Mat3 {
        self.to_world
    }

    /// The translation of the map to the world.
    pub fn translation(&self) -> Vec3 {
        self.translate
    }

    /// The world ray in object space, with the same parameter `t` (direction not normalised).
    #[inline]
    fn object_ray(&self, ray: &Ray) -> Ray {
        Ray {
            origin: self.to_object * (ray.origin - self.translate),
            dir: self.to_object * ray.dir,
            time: ray.time,
        }
    }

    /// Nearest hit distance in the open interval (`tmin`, `tmax`), in world units.
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        self.object.intersect(&self.object_ray(ray), tmin, tmax)
    }

    /// Full hit record for a hit at `t`, with texture coordinates only where `with_uv`.
    pub fn surface_uv(&self, ray: &Ray, t: f32, with_uv: bool) -> SurfaceHit {
        let local = self.object.surface_with(&self.object_ray(ray), t, None, with_uv);
        let p = self.to_world * local.p + self.translate;
        let n = unit_or(self.normal_to_world * local.n, self.to_world * local.n);
        let local_size = local.p.abs().max_element();
        // The spawned ray must leave the object-space surface by more than the object-space
        // bound after its origin is carried back: a world distance d along the normal is at
        // least d/‖M‖_F in object space, and carrying the origin (subtraction, product) rounds
        // it by about γ(4)·‖M⁻¹‖·|o − c| ≤ γ(4)·κ·|p_obj|, so the world bound is ‖M‖_F times
        // the object-space bound plus that roundoff. Mapping the point out rounds γ(3)·‖M‖·
        // |p_obj| in the product and γ(1)·|p| in the translation.
        let p_error = self.stretch * (local.p_error + gamma(5) * self.condition * local_size)
            + gamma(4) * self.row_norm * local_size
            + gamma(2) * p.abs().max_element();
        SurfaceHit { t, p, n, shading_n: n, uv: local.uv, p_error }
    }

    /// Full hit record for a hit at `t`.
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        self.surface_uv(ray, t, true)
    }

    /// The exact box of the placed shape (of the whole sphere for a zone), widened by the
    /// roundoff of computing it.
    pub fn bounds(&self) -> Bounds {
        let m = self.to_world;
        let rows = m.transpose();
        // The circle `centre + r(cos φ·e1 + sin φ·e2)` reaches r·√((M e1)ᵢ² + (M e2)ᵢ²) along axis i.
        let ellipse = |centre: Vec3, normal: Vec3, radius: f32| {
            let (e1, e2) = normal.any_orthonormal_pair();
            let (a, b) = (m * e1, m * e2);
            (m * centre + self.translate, radius * (a * a + b * b).sqrt())
        };
        let boxes: Vec<(Vec3, Vec3)> = match &self.object {
            Shape::Sphere(s) => {
                let lengths = Vec3::new(rows.x_axis.length(), rows.y_axis.length(), rows.z_axis.length());
                vec![(m * s.center + self.translate, s.radius * lengths)]
            }
            Shape::Disk(d) => vec![ellipse(d.center, d.normal, d.radius)],
            Shape::Cylinder(c) => {
                vec![ellipse(c.base, c.w, c.radius), ellipse(c.base + c.w * c.height, c.w, c.radius)]
            }
            other => unreachable!("AffineShape::new refuses a {}", other.kind()),
        };
        boxes.into_iter().fold(
            Bounds { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY },
            |b, (centre, half)| {
                let pad = half * gamma(6) + centre.abs() * gamma(4);
                Bounds { min: b.min.min(centre - half - pad), max: b.max.max(centre + half + pad) }
            },
        )
    }

    /// Surface area by Nanson's formula, an element dA of the object's surface with normal N
    /// becoming det(M)·|M⁻ᵀN|·dA: exact for a disk, by the midpoint rule in the angles
    /// (and the height, for a sphere) otherwise.
    pub fn area(&self) -> f32 {
        let det = f64::from(self.to_world.determinant());
        let stretch = |n: Vec3| det * f64::from((self.normal_to_world * n).length());
        const STEPS: usize = 512;
        let angle = |k: usize| std::f64::consts::TAU * (k as f64 + 0.5) / STEPS as f64;
        let ring = |e1: Vec3, e2: Vec3, k: usize| {
            let (s, c) = angle(k).sin_cos();
            (e1.as_dvec3() * c + e2.as_dvec3() * s).as_vec3()
        };
        let area = match &self.object {
            Shape::Disk(d) => stretch(d.normal) * f64::from(d.area()),
            Shape::Cylinder(c) => {
                let (e1, e2) = (c.u, c.v);
                let mean = (0..STEPS).map(|k| stretch(ring(e1, e2, k))).sum::<f64>() / STEPS as f64;
                mean * f64::from(c.area())
            }
            Shape::Sphere(s) => {
                // Archimedes: on the unit sphere dA = dz·dφ, z the height along the axis.
                let (e1, e2) = s.axis.any_orthonormal_pair();
                let r = f64::from(s.radius);
                let lo = (f64::from(s.min_height) / r).clamp(-1.0, 1.0);
                let hi = (f64::from(s.max_height) / r).clamp(-1.0, 1.0);
                let mut sum = 0.0;
                for i in 0..STEPS {
                    let z = lo + (hi - lo) * (i as f64 + 0.5) / STEPS as f64;
                    let rho = (1.0 - z * z).max(0.0).sqrt();
                    for k in 0..STEPS {
                        let n = ring(e1, e2, k).as_dvec3() * rho + s.axis.as_dvec3() * z;
                        sum += stretch(n.as_vec3());
                    }
                }
                sum / (STEPS * STEPS) as f64 * (hi - lo) * std::f64::consts::TAU * r * r
            }
            other => unreachable!("AffineShape::new refuses a {}", other.kind()),
        };
        area as f32
    }

    /// Short name of the placed shape.
    pub fn kind(&self) -> &'static str {
        match self.object {
            Shape::Sphere(_) => "ellipsoid",
            Shape::Disk(_) => "elliptic disk",
            _ => "elliptic cylinder",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::test_support::{random_unit, spawned_rays};
    use crate::geometry::{Cylinder, Disk, Sphere};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    /// A sheared, unevenly scaled map with a translation.
    fn shear() -> (Mat3, Vec3) {
        let m =
            Mat3::from_cols(Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.5, 1.0, 0.0), Vec3::new(0.0, 0.25, 0.5));
        (m, Vec3::new(1.0, -2.0, 3.0))
    }

    fn ellipsoid() -> AffineShape {
        let (m, t) = shear();
        AffineShape::new(Shape::Sphere(Box::new(Sphere::new(Vec3::ZERO, 1.0))), m, t).unwrap()
    }

    /// The implicit value of the ellipsoid at `p`: |M⁻¹(p − t)|² − 1 (0 on the surface).
    fn implicit(e: &AffineShape, p: Vec3) -> f32 {
        (e.to_object * (p - e.translate)).length_squared() - 1.0
    }

    #[test]
    fn refuses_what_it_cannot_place() {
        let sphere = || Shape::Sphere(Box::new(Sphere::new(Vec3::ZERO, 1.0)));
        assert!(AffineShape::new(sphere(), Mat3::ZERO, Vec3::ZERO).is_none());
        assert!(
            AffineShape::new(sphere(), Mat3::from_diagonal(Vec3::new(-1.0, 1.0, 1.0)), Vec3::ZERO).is_none()
        );
        assert!(AffineShape::new(sphere(), Mat3::IDENTITY, Vec3::NAN).is_none());
        let quad = Shape::Quad(Box::new(crate::geometry::Quad::new(Vec3::ZERO, Vec3::X, Vec3::Y)));
        assert!(AffineShape::new(quad, Mat3::IDENTITY, Vec3::ZERO).is_none());
    }

    #[test]
    fn hits_lie_on_the_ellipsoid_with_world_distances_and_normals_by_the_inverse_transpose() {
        let e = ellipsoid();
        let mut rng = Pcg32::seed_from_u64(3);
        let mut hits = 0;
        for _ in 0..4000 {
            let o = e.translate + random_unit(&mut rng) * 6.0;
            let target = e.translate + random_unit(&mut rng) * 1.5;
            let ray = Ray::new(o, (target - o).normalize());
            let Some(t) = e.intersect(&ray, 0.0, f32::INFINITY) else { continue };
            hits += 1;
            let h = e.surface(&ray, t);
            assert!((h.p - ray.at(t)).length() < 1e-4, "t is a world distance: {} vs {}", h.p, ray.at(t));
            assert!(implicit(&e, h.p).abs() < 1e-5, "on the surface: {}", implicit(&e, h.p));
            assert!((h.n.length() - 1.0).abs() < 1e-6);
            // The normal is the gradient of the implicit function, by finite differences.
            let eps = 1e-3;
            let grad = Vec3::new(
                implicit(&e, h.p + Vec3::X * eps) - implicit(&e, h.p - Vec3::X * eps),
                implicit(&e, h.p + Vec3::Y * eps) - implicit(&e, h.p - Vec3::Y * eps),
                implicit(&e, h.p + Vec3::Z * eps) - implicit(&e, h.p - Vec3::Z * eps),
            )
            .normalize();
            assert!((grad - h.n).length() < 2e-3, "normal {} vs gradient {grad}", h.n);
            assert!(h.uv.is_finite() && h.p_error > 0.0 && h.p_error < 1e-4);
        }
        assert!(hits > 1000, "{hits}");
    }

    #[test]
    fn bounds_are_the_exact_box() {
        let e = ellipsoid();
        let b = e.bounds();
        // Per axis √(Σ_j M_ij²): rows (2, 0.5, 0), (0, 1, 0.25), (0, 0, 0.5).
        let half = Vec3::new(4.25f32.sqrt(), 1.0625f32.sqrt(), 0.5);
        assert!((b.max - (e.translate + half)).abs().max_element() < 1e-5, "{b:?}");
        assert!((b.min - (e.translate - half)).abs().max_element() < 1e-5, "{b:?}");
        assert!(b.min.cmple(e.translate - half).all() && b.max.cmpge(e.translate + half).all());
        // Every hit lies inside, for discs and cylinders too.
        let (m, t) = shear();
        let shapes = [
            AffineShape::new(
                Shape::Disk(Box::new(Disk::new(Vec3::X, Vec3::new(1.0, 2.0, 3.0), 1.0, 0.0))),
                m,
                t,
            ),
            AffineShape::new(
                Shape::Cylinder(Box::new(Cylinder::new(Vec3::Y, Vec3::new(1.0, 1.0, 0.0), 0.5, 2.0))),
                m,
                t,
            ),
            Some(e),
        ];
        let mut rng = Pcg32::seed_from_u64(5);
        for s in shapes.into_iter().map(Option::unwrap) {
            let b = s.bounds();
            let mut hits = 0;
            for _ in 0..3000 {
                let o = t + random_unit(&mut rng) * 8.0;
                let ray = Ray::new(o, (t + random_unit(&mut rng) * 2.0 - o).normalize());
                if let Some(time) = s.intersect(&ray, 0.0, f32::INFINITY) {
                    let p = s.surface(&ray, time).p;
                    assert!(
                        p.cmpge(b.min).all() && p.cmple(b.max).all(),
                        "{} at {p} outside {b:?}",
                        s.kind()
                    );
                    hits += 1;
                }
            }
            assert!(hits > 100, "{}: {hits}", s.kind());
        }
    }

    #[test]
    fn area_follows_nanson() {
        // A sphere scaled by (a, a, a) has area 4πa²; an elliptic disk det·|M⁻ᵀn|·πr².
        let s = AffineShape::new(
            Shape::Sphere(Box::new(Sphere::new(Vec3::ZERO, 1.0))),
            Mat3::from_diagonal(Vec3::splat(2.0)),
            Vec3::ZERO,
        )
        .unwrap();
        assert!((s.area() / (16.0 * std::f32::consts::PI) - 1.0).abs() < 1e-4, "{}", s.area());
        // A prolate spheroid (2, 1, 1): 2π(1 + 2·asin(e)/e), e = √3/2.
        let p = AffineShape::new(
            Shape::Sphere(Box::new(Sphere::new(Vec3::ZERO, 1.0))),
            Mat3::from_diagonal(Vec3::new(2.0, 1.0, 1.0)),
            Vec3::ZERO,
        )
        .unwrap();
        let ecc = 0.75f64.sqrt();
        let exact = std::f64::consts::TAU * (1.0 + 2.0 * ecc.asin() / ecc);
        assert!((f64::from(p.area()) / exact - 1.0).abs() < 1e-4, "{} vs {exact}", p.area());
        let d = AffineShape::new(
            Shape::Disk(Box::new(Disk::new(Vec3::ZERO, Vec3::Z, 1.0, 0.0))),
            Mat3::from_diagonal(Vec3::new(2.0, 3.0, 5.0)),
            Vec3::ZERO,
        )
        .unwrap();
        assert!((d.area() / (6.0 * std::f32::consts::PI) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn grazing_and_spawned_rays_do_not_hit_their_own_surface() {
        let e = ellipsoid();
        let mut rng = Pcg32::seed_from_u64(11);
        let mut checked = 0;
        for i in 0..20_000 {
            // Grazing: aimed at a point of the surface along a tangent, from far away.
            let n_obj = random_unit(&mut rng);
            let p = e.to_world * n_obj + e.translate;
            let n = (e.normal_to_world * n_obj).normalize();
            let tangent = n.any_orthonormal_pair().0;
            let tilt = if i % 2 == 0 { 0.0 } else { rng.random::<f32>() * 0.02 };
            let dir = (tangent - n * tilt).normalize();
            let ray = Ray::new(p - dir * (1.0 + rng.random::<f32>() * 50.0), dir);
            let Some(t) = e.intersect(&ray, 0.0, f32::INFINITY) else { continue };
            let h = e.surface(&ray, t);
            assert!(h.p.is_finite() && h.n.is_finite() && h.uv.is_finite());
            for spawned in spawned_rays(&h, ray.dir, &mut rng) {
                let cos = spawned.dir.dot(h.n);
                match e.intersect(&spawned, 0.0, f32::INFINITY) {
                    // Leaving outwards, a convex surface is never met again.
                    Some(t2) if cos > 0.0 => panic!("self-hit at {t2} from {h:?}"),
                    // Going inside (not along a tangent, where the chord is short), the next
                    // hit is the far side, not the start point.
                    Some(t2) => assert!(cos > -0.01 || t2 > 1e-3, "self-hit at {t2} from {h:?}"),
                    None => assert!(cos > -0.01, "an inward ray from {h:?} found no far side"),
                }
                checked += 1;
            }
        }
        assert!(checked > 10_000, "{checked}");
    }
}
