//! Mesh triangles with watertight intersection (Woop, Benthin & Wald 2013).

use glam::{Vec2, Vec3};

use super::{bounds_of, gamma, point_error, try_unit, unit_or, Bounds, Ray, SurfaceHit, MACHINE_EPSILON};
use crate::lanes::{Mask3, Real, Vector};

/// Per-vertex data of a mesh triangle (OBJ `vt` and `vn`), interpolated at a hit by its
/// barycentrics. Kept apart from [`Triangle`], which stays small for traversal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexAttributes {
    /// Texture coordinates of the three vertices.
    pub uv: Option<[Vec2; 3]>,
    /// Normals of the three vertices (unit, or zero where the file's is zero).
    pub normals: Option<[Vec3; 3]>,
}

impl VertexAttributes {
    /// Whether there is anything to interpolate.
    pub fn is_empty(&self) -> bool {
        self.uv.is_none() && self.normals.is_none()
    }

    /// `hit`, a hit record of the triangle (whose uv holds its barycentrics (b1, b2)), with the
    /// interpolated uv and the interpolated, normalised shading normal turned to the side of the
    /// geometric normal (where the vertex normals cancel, the shading normal stays the
    /// geometric one).
    #[inline]
    pub fn apply(&self, hit: &mut SurfaceHit) {
        let (b1, b2) = (hit.uv.x, hit.uv.y);
        let b0 = 1.0 - b1 - b2;
        if let Some([n0, n1, n2]) = self.normals {
            if let Some(ns) = try_unit(b0 * n0 + b1 * n1 + b2 * n2) {
                hit.shading_n = if ns.dot(hit.n) < 0.0 { -ns } else { ns };
            }
        }
        if let Some([t0, t1, t2]) = self.uv {
            hit.uv = b0 * t0 + b1 * t1 + b2 * t2;
        }
    }
}

/// A triangle counter-clockwise around its normal `normalize((p1 − p0) × (p2 − p0))`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    p: [Vec3; 3],
}

/// The per-ray constants of the watertight triangle test: the axis permutation that makes the
/// dominant direction component z, and the shear that turns the direction into +z. For one ray
/// (`V` = glam's `Vec3`) or one per lane (`V` = [`Vec3x`](crate::lanes::Vec3x)).
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay<V: Vector = Vec3> {
    /// The dominant axis of the direction, which the permutation makes z ([`Vector::permute`]).
    axis: V::Axis,
    /// −d_x/d_z, −d_y/d_z and 1/d_z of the permuted direction.
    shear: V,
    origin: V,
    dir: V,
}

impl ShearedRay {
    /// The constants for `ray`; `None` for a zero direction.
    #[inline]
    pub fn new(ray: &Ray) -> Option<ShearedRay> {
        let (valid, sheared) = ShearedRay::of(ray.origin, ray.dir);
        valid.then_some(sheared)
    }
}

impl<V: Vector> ShearedRay<V> {
    /// The constants for the rays from `origin` along `dir`, and where they are valid (not for
    /// a zero direction).
    #[inline(always)]
    pub fn of(origin: V, dir: V) -> (Mask3<V>, ShearedRay<V>) {
        let axis = dir.abs().max_axis();
        let d = dir.permute(axis);
        let (dx, dy, dz) = (d.x(), d.y(), d.z());
        let shear = V::new(-dx / dz, -dy / dz, V::Real::splat(1.0) / dz);
        (dz.ne(V::Real::splat(0.0)), ShearedRay { axis, shear, origin, dir })
    }

    /// A vertex relative to the origin, permuted and sheared.
    #[inline(always)]
    fn transform(&self, v: V) -> V {
        let v = (v - self.origin).permute(self.axis);
        let (x, y, z) = (v.x(), v.y(), v.z());
        V::new(x + self.shear.x() * z, y + self.shear.y() * z, z * self.shear.z())
    }
}

/// Where a triangle test hits (one truth value per lane), and there the distances and the
/// barycentrics `[b0, b1, b2]`.
pub type TriangleHits<V> = (Mask3<V>, <V as Vector>::Real, [<V as Vector>::Real; 3]);

/// The Woop–Benthin–Wald watertight test of the triangle `p` (counter-clockwise) against `ray`
/// where `active`, written once for one ray and for lanes (each lane's result is the one-ray
/// result to the bit; lanes may hold one triangle or one each): where it hits within (0,
/// `tmax`], the distance (conservatively positive) and barycentrics `[b0, b1, b2]`; `None` where
/// no lane hits. Points on an edge or vertex count as inside for every triangle sharing it, and
/// the sign of an edge function depends only on the edge's two (sheared) vertices, so shared
/// edges never leave a crack.
#[inline(always)]
fn watertight<V: Vector>(
    p: &[V; 3],
    ray: &ShearedRay<V>,
    active: Mask3<V>,
    tmax: V::Real,
) -> Option<TriangleHits<V>> {
    let zero = V::Real::splat(0.0);
    let (a, b, c) = (ray.transform(p[0]), ray.transform(p[1]), ray.transform(p[2]));

    // Edge functions: plain products (no FMA) so that the edge shared by two triangles gets
    // exactly negated values; exact zeros are re-evaluated in f64, where the products are exact
    // and only the difference rounds (sign-preserving).
    let edge = |p: V, q: V| p.x() * q.y() - p.y() * q.x();
    let (mut e0, mut e1, mut e2) = (edge(b, c), edge(c, a), edge(a, b));
    let exact_zero = e0.eq(zero) | e1.eq(zero) | e2.eq(zero);
    if V::Real::any(exact_zero) {
        let edge64 = |p: V, q: V| V::Real::products_difference_f64(p.x(), q.y(), p.y(), q.x());
        e0 = V::Real::select(exact_zero, edge64(b, c), e0);
        e1 = V::Real::select(exact_zero, edge64(c, a), e1);
        e2 = V::Real::select(exact_zero, edge64(a, b), e2);
    }
    // Edge functions of both signs: outside. (The positive ones only looked at where a negative
    // one is: for one ray, the branches of `||` and `&&`.)
    let mut hit = active;
    let negative = e0.lt(zero) | e1.lt(zero) | e2.lt(zero);
    if V::Real::any(negative) {
        let positive = e0.gt(zero) | e1.gt(zero) | e2.gt(zero);
        hit = hit & !(negative & positive);
        if !V::Real::any(hit) {
            return None;
        }
    }
    let det = e0 + e1 + e2;
    hit = hit & det.ne(zero);
    if !V::Real::any(hit) {
        return None;
    }
    let t_scaled = e0 * a.z() + e1 * b.z() + e2 * c.z();
    let bound = tmax * det;
    let outside_negative = det.lt(zero) & (t_scaled.ge(zero) | t_scaled.lt(bound));
    let outside_positive = det.gt(zero) & (t_scaled.le(zero) | t_scaled.gt(bound));
    hit = hit & !outside_negative & !outside_positive;
    if !V::Real::any(hit) {
        return None;
    }
    let inv_det = V::Real::splat(1.0) / det;
    let mut t = t_scaled * inv_det;

    // pbrt-v4's conservative bound on the error of t: a hit this close may lie behind the
    // origin. (Products written with γ on the right: the same roundings, as × commutes.)
    let max_abs = |f: fn(V) -> V::Real| f(a).abs().max(f(b).abs()).max(f(c).abs());
    let max_zt = max_abs(|v| v.z());
    let max_xt = max_abs(|v| v.x());
    let max_yt = max_abs(|v| v.y());
    let delta_z = max_zt * gamma(3);
    let delta_x = (max_xt + max_zt) * gamma(5);
    let delta_y = (max_yt + max_zt) * gamma(5);
    let delta_e = (max_xt * gamma(2) * max_yt + delta_y * max_xt + delta_x * max_yt) * 2.0;
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = (max_e * gamma(3) * max_zt + delta_e * max_zt + delta_z * max_e) * 3.0 * inv_det.abs();
    let near = hit & !t.gt(delta_t);
    if V::Real::any(near) {
        t = t.lanes_where(near, |k| {
            let vertices = [p[0].lane(k), p[1].lane(k), p[2].lane(k)];
            plane_distance_f64(vertices, ray.origin.lane(k), ray.dir.lane(k)).unwrap_or(0.0)
        });
        hit = hit & (!near | t.gt(zero));
        if !V::Real::any(hit) {
            return None;
        }
    }
    Some((hit, t, [e0 * inv_det, e1 * inv_det, e2 * inv_det]))
}

/// The distance along the ray from `origin` along `dir` to the plane of the triangle `p`,
/// evaluated in f64, when it is positive: for hits within pbrt's error bound δt of the origin.
/// Rejecting those outright (as pbrt does) loses the neighbouring face of a concave edge to a
/// ray spawned a hair from the edge, and the ray leaves a closed mesh through it. In f64 the
/// vertex differences and their products are nearly exact, so the sign of t is right for any
/// origin farther from the plane than about 1e-15 of the scene's size; a spawned origin is
/// farther than its hit point's error bound (about 1e-7), so its own triangle stays behind it.
#[cold]
fn plane_distance_f64(p: [Vec3; 3], origin: Vec3, dir: Vec3) -> Option<f32> {
    let [p0, p1, p2] = p.map(|p| p.as_dvec3());
    let normal = (p1 - p0).cross(p2 - p0);
    let t = (p0 - origin.as_dvec3()).dot(normal) / dir.as_dvec3().dot(normal);
    // Not `t > 0.0` alone: a NaN (a ray in the plane) is no hit either; a positive t is at
    // least the smallest normal float (so 0 can stand for no hit).
    (t > 0.0).then(|| (t as f32).max(f32::MIN_POSITIVE))
}

impl Triangle {
    /// Triangle through the three vertices.
    pub fn new(p0: Vec3, p1: Vec3, p2: Vec3) -> Triangle {
        Triangle { p: [p0, p1, p2] }
    }

    /// Unit geometric normal (zero for an exactly degenerate triangle). Computed when asked (for
    /// a hit record), not stored: a mesh's triangles stay small for traversal.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        let [p0, p1, p2] = self.p;
        unit_or((p1 - p0).cross(p2 - p0), Vec3::ZERO)
    }

    /// True when the area is zero or indistinguishable from zero: `|e0 × e1|` at most 8 ulps of
    /// the longest edge squared (the roundoff level of the cross product itself), or not finite.
    pub fn is_degenerate(&self) -> bool {
        let [p0, p1, p2] = self.p;
        let longest =
            (p1 - p0).length_squared().max((p2 - p0).length_squared()).max((p2 - p1).length_squared());
        let twice_area = (p1 - p0).cross(p2 - p0).length();
        twice_area <= 8.0 * MACHINE_EPSILON * longest || twice_area.is_nan()
    }

    /// [`watertight`] for one ray: the hit distance (in (0, `tmax`], conservatively positive)
    /// and barycentrics `[b0, b1, b2]`.
    #[inline]
    fn watertight(&self, ray: &Ray, tmax: f32) -> Option<(f32, [f32; 3])> {
        let (_, t, bary) = watertight(&self.p, &ShearedRay::new(ray)?, true, tmax)?;
        Some((t, bary))
    }

    /// [`Triangle::hits`] for one ray. Not inlined (as the compiler chose before the test was
    /// written over lanes): the traversals that call it stay small, and run fewer instructions
    /// so (measured with callgrind).
    #[inline(never)]
    fn hit_within(&self, sheared: &ShearedRay, tmin: f32, tmax: f32) -> Option<(f32, [f32; 3])> {
        let (_, t, bary) = Triangle::hits(&self.p, sheared, true, tmin, tmax)?;
        Some((t, bary))
    }

    /// Nearest hit distance in the open interval (`tmin`, `tmax`), watertight across shared edges.
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        self.intersect_sheared(&ShearedRay::new(ray)?, ray, tmin, tmax)
    }

    /// [`Triangle::intersect`] with the ray's shear precomputed (`sheared` must be `ray`'s).
    #[inline]
    pub fn intersect_sheared(&self, sheared: &ShearedRay, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        self.hit_sheared(sheared, ray, tmin, tmax).map(|(t, _)| t)
    }

    /// [`Triangle::intersect_sheared`] with the hit's barycentrics, for [`Triangle::surface_at`]
    /// (`sheared` holds the ray: `_ray` is its ray).
    #[inline]
    pub fn hit_sheared(
        &self,
        sheared: &ShearedRay,
        _ray: &Ray,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, [f32; 3])> {
        self.hit_within(sheared, tmin, tmax)
    }

    /// The watertight test of the triangle with the vertices `p` (as [`Triangle::vertices`]
    /// gives them) against `ray` where `active`, written once for one ray (`V` = `Vec3`: what
    /// [`Triangle::hit_sheared`] runs) and for lanes (`V` = [`Vec3x`](crate::lanes::Vec3x), one
    /// triangle splatted or one per lane), each lane's result the one-ray result to the bit:
    /// where it hits within the open interval (`tmin`, `tmax`), the distance and barycentrics;
    /// `None` where no lane hits.
    #[inline(always)]
    pub fn hits<V: Vector>(
        p: &[V; 3],
        ray: &ShearedRay<V>,
        active: Mask3<V>,
        tmin: V::Real,
        tmax: V::Real,
    ) -> Option<TriangleHits<V>> {
        let (hit, t, bary) = watertight(p, ray, active, tmax)?;
        let hit = hit & t.gt(tmin) & t.lt(tmax);
        V::Real::any(hit).then_some((hit, t, bary))
    }

    /// Full hit record for the hit at `t` with barycentrics `[b0, b1, b2]` (as
    /// [`Triangle::hit_sheared`] found it); uv = (b1, b2).
    #[inline]
    pub fn surface_at(&self, ray: &Ray, t: f32, [b0, b1, b2]: [f32; 3]) -> SurfaceHit {
        let normal = self.normal();
        let n = if normal == Vec3::ZERO { -ray.dir } else { normal };
        let [p0, p1, p2] = self.p;
        let p = b0 * p0 + b1 * p1 + b2 * p2;
        // pbrt-v4's bound for a barycentric interpolation: γ(7)·Σ|b_i·p_i|.
        let abs_sum = (b0 * p0).abs() + (b1 * p1).abs() + (b2 * p2).abs();
        SurfaceHit { t, p, n, shading_n: n, uv: Vec2::new(b1, b2), p_error: gamma(7) * abs_sum.max_element() }
    }

    /// Full hit record for a hit at `t`; uv = barycentrics (b1, b2).
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        let normal = self.normal();
        let n = if normal == Vec3::ZERO { -ray.dir } else { normal };
        let [p0, p1, p2] = self.p;
        match self.watertight(ray, f32::INFINITY) {
            Some((_, bary)) => self.surface_at(ray, t, bary),
            // Only reachable for a `t` that intersect() did not produce: use the ray point, with
            // the roundoff of o + t·d on magnitudes up to the largest vertex coordinate.
            None => {
                let p = ray.at(t);
                let largest = p0.abs().max(p1.abs()).max(p2.abs()).max_element();
                SurfaceHit { t, p, n, shading_n: n, uv: Vec2::ZERO, p_error: point_error(p, largest, 8) }
            }
        }
    }

    /// The three vertices, counter-clockwise around the normal.
    pub fn vertices(&self) -> [Vec3; 3] {
        self.p
    }

    /// Bounds of the three vertices.
    pub fn bounds(&self) -> Bounds {
        bounds_of(&self.p)
    }

    /// Area `½|(p1 − p0) × (p2 − p0)|`.
    pub fn area(&self) -> f32 {
        let [p0, p1, p2] = self.p;
        0.5 * (p1 - p0).cross(p2 - p0).length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::spawn_origin;
    use crate::geometry::test_support::{random_point, random_unit, ray, spawned_rays};
    use crate::lanes::{dispatch, F32x, Isa, Mask, Vec3x, WIDTH};
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;
    use std::f64::consts::PI;

    /// Right triangle in z = 0: (0,0,0), (1,0,0), (0,1,0), normal +Z.
    fn unit() -> Triangle {
        Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)
    }

    #[test]
    fn head_on_hit() {
        let tri = unit();
        let r = ray([0.25, 0.5, 3.0], [0.0, 0.0, -1.0]);
        let t = tri.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert_eq!(t, 3.0);
        let h = tri.surface(&r, t);
        assert_eq!(h.n, Vec3::Z);
        assert_eq!(h.p, Vec3::new(0.25, 0.5, 0.0));
        assert_eq!(h.uv, Vec2::new(0.25, 0.5));
        assert!(h.p_error > 0.0 && h.p_error < 1e-6);
        // From behind: same normal (the geometric one), oblique direction.
        let r =
            Ray::new(Vec3::new(0.25, 0.25, -2.0) - Vec3::new(1.0, 2.0, 0.0), Vec3::new(1.0, 2.0, 2.0) / 3.0);
        let t = tri.intersect(&r, 0.0, f32::INFINITY).unwrap();
        assert!((t - 3.0).abs() < 1e-6, "t = {t}");
        assert_eq!(tri.surface(&r, t).n, Vec3::Z);
        assert_eq!(tri.area(), 0.5);
        let b = tri.bounds();
        assert_eq!((b.min, b.max), (Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)));
    }

    #[test]
    fn miss_and_open_interval() {
        let tri = unit();
        assert_eq!(tri.intersect(&ray([0.6, 0.6, 1.0], [0.0, 0.0, -1.0]), 0.0, 10.0), None);
        assert_eq!(tri.intersect(&ray([-0.1, 0.5, 1.0], [0.0, 0.0, -1.0]), 0.0, 10.0), None);
        assert_eq!(tri.intersect(&ray([0.2, 0.2, 1.0], [1.0, 0.0, 0.0]), 0.0, 10.0), None);
        assert_eq!(tri.intersect(&ray([0.2, 0.2, 1.0], [0.0, 0.0, 1.0]), 0.0, 10.0), None);
        let r = ray([0.2, 0.2, 1.0], [0.0, 0.0, -1.0]);
        assert_eq!(tri.intersect(&r, 0.0, 1.0), None);
        assert_eq!(tri.intersect(&r, 1.0, 2.0), None);
        assert_eq!(tri.intersect(&r, 0.5, 1.5), Some(1.0));
        let zero = Ray { origin: Vec3::Z, dir: Vec3::ZERO, time: 0.0 };
        assert_eq!(tri.intersect(&zero, 0.0, 10.0), None);
    }

    #[test]
    fn vertices_and_edges_hit() {
        let tri = unit();
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.5), (0.5, 0.0), (0.0, 0.5)] {
            let r = ray([x, y, 1.0], [0.0, 0.0, -1.0]);
            assert_eq!(tri.intersect(&r, 0.0, 10.0), Some(1.0), "at ({x}, {y})");
            assert_eq!(tri.surface(&r, 1.0).p, Vec3::new(x, y, 0.0));
        }
    }

    #[test]
    fn degenerate_triangles() {
        let line = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0);
        assert!(line.is_degenerate());
        assert!(Triangle::new(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO).is_degenerate());
        assert!(Triangle::new(Vec3::ZERO, Vec3::X, Vec3::new(2.0, 1e-9, 0.0)).is_degenerate());
        assert!(!unit().is_degenerate());
        assert!(!Triangle::new(Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1e-3, 0.0)).is_degenerate());
        for d in [[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 1.0]] {
            let r = ray([0.5, -1.0, 1.0], d);
            assert_eq!(line.intersect(&r, 0.0, f32::INFINITY), None);
            let h = line.surface(&r, 1.0);
            assert!(h.n.is_finite() && h.p.is_finite() && h.n != Vec3::ZERO);
        }
    }

    /// Closed UV sphere with shared vertices; axis-aligned and 45° directions from the centre
    /// pass exactly through vertices (coordinates computed in f64 and snapped to exact zeros).
    fn uv_sphere(center: Vec3, radius: f32, n_lat: usize, n_lon: usize) -> (Vec<Vec3>, Vec<Triangle>) {
        let snap = |x: f64| if x.abs() < 1e-12 { 0.0 } else { x };
        let mut verts = vec![center + Vec3::Y * radius];
        for i in 1..n_lat {
            let theta = PI * i as f64 / n_lat as f64;
            for j in 0..n_lon {
                let phi = 2.0 * PI * j as f64 / n_lon as f64;
                let unit = [theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()];
                verts.push(center + radius * Vec3::from(unit.map(|x| snap(x) as f32)));
            }
        }
        verts.push(center - Vec3::Y * radius);
        let south = verts.len() - 1;
        let ring = |i: usize, j: usize| 1 + (i - 1) * n_lon + j % n_lon;
        let mut idx = Vec::new();
        for j in 0..n_lon {
            idx.push([0, ring(1, j + 1), ring(1, j)]);
            idx.push([south, ring(n_lat - 1, j), ring(n_lat - 1, j + 1)]);
            for i in 1..n_lat - 1 {
                let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
                idx.push([a, b, c]);
                idx.push([b, d, c]);
            }
        }
        let tris = idx.iter().map(|&[a, b, c]| Triangle::new(verts[a], verts[b], verts[c])).collect();
        (verts, tris)
    }

    #[test]
    fn closed_mesh_is_watertight() {
        let mut rng = Pcg32::seed_from_u64(37);
        let mut total = 0;
        for (center, radius) in [(Vec3::ZERO, 1.0), (Vec3::new(3.0, -2.0, 5.0), 2.5)] {
            let (verts, tris) = uv_sphere(center, radius, 24, 48);
            assert_eq!(tris.len(), 2 * 48 * 23);
            let mut origins = vec![center];
            for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
                origins.push(center + axis * radius * 0.5);
                origins.push(center - axis * radius * 0.25);
            }
            while origins.len() < 40 {
                origins.push(center + random_unit(&mut rng) * radius * 0.95 * rng.random::<f32>());
            }
            // Targets: every vertex, every edge midpoint, the 26 lattice directions.
            let mut targets: Vec<Vec3> = verts.clone();
            for t in &tris {
                targets.extend([0.5 * (t.p[0] + t.p[1]), 0.5 * (t.p[1] + t.p[2]), 0.5 * (t.p[2] + t.p[0])]);
            }
            for x in -1..=1_i32 {
                for y in -1..=1_i32 {
                    for z in -1..=1_i32 {
                        if (x, y, z) != (0, 0, 0) {
                            targets.push(center + Vec3::new(x as f32, y as f32, z as f32).normalize());
                        }
                    }
                }
            }
            let mut rays = Vec::new();
            for (k, &o) in origins.iter().enumerate() {
                // The centre shoots at every target, other origins at a random subset; all
                // shoot some random directions too.
                if k == 0 {
                    rays.extend(
                        targets.iter().filter_map(|&p| (p - o).try_normalize()).map(|d| Ray::new(o, d)),
                    );
                } else {
                    for _ in 0..150 {
                        let p = targets[rng.random_range(0..targets.len())];
                        rays.extend((p - o).try_normalize().map(|d| Ray::new(o, d)));
                    }
                }
                rays.extend((0..50).map(|_| Ray::new(o, random_unit(&mut rng))));
            }
            for r in &rays {
                let hit = tris.iter().any(|t| t.intersect(r, 0.0, f32::INFINITY).is_some());
                assert!(hit, "{r:?} escaped the closed mesh");
            }
            total += rays.len();
        }
        assert!(total >= 20_000, "only {total} rays");
    }

    /// The 12 triangles of the closed cube [-1, 1]³, wound outwards.
    fn cube() -> Vec<Triangle> {
        let v = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        };
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3]];
        quads
            .iter()
            .flat_map(|&[a, b, c, d]| [Triangle::new(v(a), v(b), v(c)), Triangle::new(v(a), v(c), v(d))])
            .collect()
    }

    #[test]
    fn rays_leaving_a_face_near_a_concave_edge_hit_the_neighbouring_face() {
        // Inside a closed cube, a ray spawned from a face close to an edge and heading towards the
        // neighbouring face meets it a tiny distance away. pbrt's conservative "t > δt" rejection
        // (δt was about 3e-5 of the triangle size here) dropped such hits, and the ray left the
        // closed mesh through its edge: light leaked out of closed rooms (about 5 rays in a
        // million in a random walk inside a cube).
        let cube = cube();
        let mut rng = Pcg32::seed_from_u64(43);
        for k in 0..20_000 {
            // A point of the +x face within 1e-4 of its edge with the -z face, hit from inside.
            let target =
                Vec3::new(1.0, 1.8 * rng.random::<f32>() - 0.9, -1.0 + 1e-4 * rng.random::<f32>().max(0.01));
            let o = random_point(&mut rng, 0.5);
            let r = Ray::new(o, (target - o).normalize());
            let (tri, t) = cube
                .iter()
                .filter_map(|tri| tri.intersect(&r, 0.0, f32::INFINITY).map(|t| (tri, t)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .expect("a ray from inside hits the closed cube");
            let hit = tri.surface(&r, t);
            // Leave towards the -z face (back into the cube: -x, and -z).
            let mut w = random_unit(&mut rng);
            w = Vec3::new(-w.x.abs(), w.y, -w.z.abs().max(0.05)).normalize();
            if hit.p.z <= -1.0 || w.dot(hit.n) * r.dir.dot(hit.n) >= 0.0 {
                // On the edge itself (or the -z face), the point is also on the -z face and a ray
                // towards -z leaves the cube at t = 0: geometry, not roundoff.
                continue;
            }
            let spawned = Ray::new(spawn_origin(&hit, w), w);
            let next = cube
                .iter()
                .filter_map(|tri| tri.intersect(&spawned, 0.0, f32::INFINITY))
                .min_by(f32::total_cmp);
            assert!(
                next.is_some(),
                "ray {k} escaped the closed cube through its edge: {spawned:?} from {hit:?}"
            );
        }
    }

    /// [`Triangle::hits`] across 16 lanes, each lane's triangle and ray its own.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)]
    fn lane_hits(
        p: &[[Vec3; 3]; WIDTH],
        rays: &[Ray; WIDTH],
        tmax: &[f32; WIDTH],
    ) -> Option<(Mask, F32x, [F32x; 3])> {
        let gather = |i: usize| {
            let mut v = Vec3x::ZERO;
            for k in 0..WIDTH {
                v.set_lane(k, p[k][i]);
            }
            v
        };
        let (mut origin, mut dir) = (Vec3x::ZERO, Vec3x::ZERO);
        for k in 0..WIDTH {
            origin.set_lane(k, rays[k].origin);
            dir.set_lane(k, rays[k].dir);
        }
        let (valid, sheared) = ShearedRay::of(origin, dir);
        Triangle::hits(&[gather(0), gather(1), gather(2)], &sheared, valid, F32x::ZERO, F32x(*tmax))
    }

    dispatch! {
        fn hits_across(p: &[[Vec3; 3]; WIDTH], rays: &[Ray; WIDTH], tmax: &[f32; WIDTH]) -> Option<(Mask, F32x, [F32x; 3])> => lane_hits
    }

    /// One lane's case: a triangle, a ray and its limit, of one of the awkward kinds the
    /// watertight test branches on.
    fn awkward_case(rng: &mut Pcg32, sphere: &[Triangle], kind: usize) -> (Triangle, Ray) {
        let tri = sphere[rng.random_range(0..sphere.len())];
        match kind {
            // Through a vertex or an edge's midpoint of a closed mesh: exact-zero edge functions.
            0 => {
                let [p0, p1, p2] = tri.p;
                let target = [p0, p1, 0.5 * (p0 + p1), 0.5 * (p1 + p2)][rng.random_range(0..4)];
                (tri, Ray::new(Vec3::ZERO, target.normalize()))
            }
            // A hair off the plane z = 0 (exactly representable there), grazing into it: hits
            // within the error bound, decided by the f64 plane distance.
            1 => {
                let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
                let o = Vec3::new(rng.random::<f32>() * 0.5, rng.random::<f32>() * 0.5, side * 1e-9);
                let d = Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, -side * 0.3);
                (unit(), Ray::new(o, d.normalize()))
            }
            // A zero direction: no hit.
            2 => (tri, Ray { origin: Vec3::ZERO, dir: Vec3::ZERO, time: 0.0 }),
            // Equal largest components: glam's choice of the dominant axis.
            3 => {
                let d = [[1.0, 1.0, 0.0], [1.0, -1.0, 1.0], [0.0, 1.0, -1.0], [-1.0, 0.0, -1.0]];
                let d = Vec3::from(d[rng.random_range(0..4)]).normalize();
                (tri, Ray::new(-d * 0.5 + random_unit(rng) * 0.2, d))
            }
            // A random triangle and a ray aimed at a random point of it.
            _ => {
                let p0 = random_point(rng, 10.0);
                let tri = Triangle::new(p0, p0 + random_unit(rng), p0 + random_unit(rng));
                let (b1, b2) = (rng.random::<f32>(), rng.random::<f32>());
                let target = (1.0 - b1 - b2) * tri.p[0] + b1 * tri.p[1] + b2 * tri.p[2];
                let o = target + random_unit(rng) * (0.1 + 5.0 * rng.random::<f32>());
                (tri, Ray::new(o, (target - o).normalize()))
            }
        }
    }

    #[test]
    fn the_triangle_test_across_lanes_is_the_one_ray_test_bit_for_bit() {
        let (_, sphere) = uv_sphere(Vec3::ZERO, 1.0, 12, 24);
        let mut rng = Pcg32::seed_from_u64(53);
        for isa in Isa::available() {
            let (mut hit_count, mut on_edges, mut near) = (0, 0, 0);
            for batch in 0..2_000 {
                let cases: [(Triangle, Ray); WIDTH] =
                    std::array::from_fn(|k| awkward_case(&mut rng, &sphere, (batch + k) % 6));
                // The limit: none, just at the hit (which the open interval excludes), one ulp
                // beyond it, or random.
                let tmax: [f32; WIDTH] = std::array::from_fn(|k| {
                    let (tri, ray) = &cases[k];
                    let t = tri.intersect(ray, 0.0, f32::INFINITY).unwrap_or(1.0);
                    [f32::INFINITY, t, t.next_up(), rng.random::<f32>() * 4.0][rng.random_range(0..4)]
                });
                // Each lane its own triangle, then every lane the first lane's triangle.
                for splat in [false, true] {
                    let p = std::array::from_fn(|k| cases[if splat { 0 } else { k }].0.p);
                    let rays = cases.map(|(_, r)| r);
                    let got = hits_across(isa, &p, &rays, &tmax);
                    for k in 0..WIDTH {
                        let tri = Triangle { p: p[k] };
                        let want = ShearedRay::new(&rays[k])
                            .and_then(|s| tri.hit_sheared(&s, &rays[k], 0.0, tmax[k]));
                        let lane = got.filter(|(hit, ..)| hit.0[k]).map(|(_, t, b)| {
                            (t.0[k].to_bits(), [b[0].0[k], b[1].0[k], b[2].0[k]].map(f32::to_bits))
                        });
                        let want_bits = want.map(|(t, b)| (t.to_bits(), b.map(f32::to_bits)));
                        assert_eq!(
                            lane, want_bits,
                            "{isa:?}, lane {k}: {tri:?}, {:?}, tmax {}",
                            rays[k], tmax[k]
                        );
                        if let Some((t, b)) = want {
                            hit_count += 1;
                            on_edges += b.contains(&0.0) as usize;
                            near += (t < 1e-6) as usize;
                        }
                    }
                }
            }
            // The awkward kinds were met: hits on edges and vertices, hits within the error bound.
            assert!(hit_count > 5_000 && on_edges > 1_000 && near > 1_000, "{hit_count} {on_edges} {near}");
        }
    }

    #[test]
    fn spawned_rays_do_not_self_intersect() {
        let mut rng = Pcg32::seed_from_u64(41);
        let mut checked = 0;
        while checked < 2_000 {
            let p0 = random_point(&mut rng, 100.0);
            let scale = 0.01 + 10.0 * rng.random::<f32>();
            let tri =
                Triangle::new(p0, p0 + random_unit(&mut rng) * scale, p0 + random_unit(&mut rng) * scale);
            if tri.is_degenerate() {
                continue;
            }
            let (b1, b2) = (rng.random::<f32>(), rng.random::<f32>());
            let (b1, b2) = if b1 + b2 > 1.0 { (1.0 - b1, 1.0 - b2) } else { (b1, b2) };
            let target = (1.0 - b1 - b2) * tri.p[0] + b1 * tri.p[1] + b2 * tri.p[2];
            let o = target + random_unit(&mut rng) * scale * (0.1 + 20.0 * rng.random::<f32>());
            let r = Ray::new(o, (target - o).normalize());
            let Some(t) = tri.intersect(&r, 0.0, f32::INFINITY) else { continue };
            let hit = tri.surface(&r, t);
            for spawned in spawned_rays(&hit, r.dir, &mut rng) {
                assert_eq!(tri.intersect(&spawned, 0.0, f32::INFINITY), None, "self-hit {hit:?}");
            }
            checked += 1;
        }
    }
}
