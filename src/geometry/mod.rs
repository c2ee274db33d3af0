//! Rays, analytic shapes and triangles: intersection, surface geometry and robust ray spawning.
//!
//! Every shape answers two questions: `intersect` (the nearest parametric distance in an open
//! interval, as cheaply as possible, called inside BVH traversal) and `surface` (the full hit record
//! for the one hit that won). Hit points come with a conservative absolute error bound so that new
//! rays can leave the surface without re-hitting it (see [`spawn_origin`]).

mod affine;
mod cylinder;
mod disk;
mod polygon;
mod quad;
mod sphere;
mod triangle;

pub use affine::AffineShape;
pub(crate) use cylinder::wall_uv;
pub use cylinder::Cylinder;
pub use disk::{disk_uv, Disk};
pub use polygon::Polygon;
pub use quad::Quad;
pub(crate) use sphere::MIN_QUADRATIC_A;
pub use sphere::{sphere_uv, Sphere};
pub use triangle::{ShearedRay, Triangle, VertexAttributes};

use crate::lanes::{Real, Vector};
use glam::{Vec2, Vec3};
use std::cell::OnceCell;

/// A ray with a unit-length direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Unit direction; `-0.0` components are canonicalised to `+0.0` by [`Ray::new`].
    pub dir: Vec3,
    /// Time within the shutter interval (moving objects are intersected where they are then).
    pub time: f32,
}

impl Ray {
    /// A ray from `origin` along the unit vector `dir` (negative zeros become positive zeros).
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir: dir + Vec3::ZERO, time: 0.0 }
    }

    /// A ray leaving `origin` along `dir` at the same time as this one.
    #[inline]
    pub fn spawn(&self, origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir: dir + Vec3::ZERO, time: self.time }
    }

    /// The point at parametric distance `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Geometry of a ray–surface hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    /// Parametric distance along the ray.
    pub t: f32,
    /// The hit point, refined onto the surface where the shape allows it.
    pub p: Vec3,
    /// Unit geometric normal on the shape's *outside*: the side its interface calls outside.
    /// Ray origins are offset along it, and it decides which side of an interface a direction
    /// lies on.
    pub n: Vec3,
    /// Unit shading normal, on the same side as `n`: a mesh's interpolated vertex normal
    /// (OBJ `vn`), else exactly `n`. BSDFs are evaluated in a frame around it
    /// ([`crate::bsdf::ShadingFrame`]).
    pub shading_n: Vec3,
    /// Surface parameterisation in [0,1]² (used by textures).
    pub uv: Vec2,
    /// Conservative bound on the absolute error of every coordinate of `p`.
    pub p_error: f32,
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

/// Unit roundoff of f32 arithmetic.
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// The γ(n) error-growth bound of Higham / pbrt: n·ε / (1 − n·ε).
#[inline]
pub const fn gamma(n: i32) -> f32 {
    (n as f32 * MACHINE_EPSILON) / (1.0 - n as f32 * MACHINE_EPSILON)
}

/// Error bound for a hit point `p` computed as a shape's reference point plus an offset of
/// magnitude `local` that is exact to within `ulps` roundings, as in pbrt-v4: `γ(ulps)·local` for
/// the offset and `γ(2)·|p|` for adding the reference point. It scales with the shape's own size,
/// not with its distance from the world origin (a thin shell far from the origin stays sound).
#[inline]
pub fn point_error(p: Vec3, local: f32, ulps: i32) -> f32 {
    gamma(ulps) * local + gamma(2) * p.abs().max_element()
}

/// `v` scaled to unit length, rescaled by its largest component first so that tiny and huge
/// vectors normalise too; `None` for zero or non-finite vectors.
pub fn try_unit(v: Vec3) -> Option<Vec3> {
    let largest = v.abs().max_element();
    if largest > 0.0 && largest.is_finite() {
        (v / largest).try_normalize()
    } else {
        None
    }
}

/// Unit normal `u × v` of the parallelogram spanned by `u` and `v`, or `None` when the edges are
/// zero or (to within 1e-6 radians) parallel, at any scale.
pub fn parallelogram_normal(u: Vec3, v: Vec3) -> Option<Vec3> {
    let (a, b) = (try_unit(u)?, try_unit(v)?);
    let n = a.cross(b);
    (n.length() > 1e-6).then(|| n.normalize())
}

/// Origin for a ray leaving a surface point in direction `w`: `p` pushed along the geometric
/// normal `n` to the side `w` points to, by the point's error bound, then rounded away from it
/// ([`offset_origin`]).
#[inline(always)]
pub fn spawn_origin(hit: &SurfaceHit, w: Vec3) -> Vec3 {
    offset_origin(hit.p, hit.n, hit.p_error, w)
}

/// [`spawn_origin`] of the point `p` (geometric normal `n`, error bound `p_error`), for one ray
/// or across lanes.
#[inline(always)]
pub fn offset_origin<V: Vector>(p: V, n: V, p_error: V::Real, w: V) -> V {
    // pbrt-v4's dot(|n|, pError) for an error bound that is the same on every axis.
    let offset = n * (p_error * n.abs().element_sum() + f32::MIN_POSITIVE);
    let offset = V::select(w.dot(n).lt(V::Real::splat(0.0)), -offset, offset);
    let po = p + offset;
    V::new(po.x().away(offset.x()), po.y().away(offset.y()), po.z().away(offset.z()))
}

/// `x` moved to the next float in the direction of `offset`'s sign (kept where it is 0).
#[inline(always)]
pub(crate) fn away_from(x: f32, offset: f32) -> f32 {
    if offset > 0.0 {
        next_up(x)
    } else if offset < 0.0 {
        next_down(x)
    } else {
        x
    }
}

/// [`f32::next_up`] without a branch (the same value for every input, NaN and ±∞ included).
#[inline(always)]
pub fn next_up(x: f32) -> f32 {
    let bits = x.to_bits();
    let abs = bits & 0x7fff_ffff;
    let next = if abs == 0 {
        1
    } else if bits == abs {
        bits.wrapping_add(1)
    } else {
        bits.wrapping_sub(1)
    };
    if x.is_nan() || x == f32::INFINITY {
        x
    } else {
        f32::from_bits(next)
    }
}

/// [`f32::next_down`] without a branch (the same value for every input, NaN and ±∞ included).
#[inline(always)]
pub fn next_down(x: f32) -> f32 {
    -next_up(-x)
}

/// A geometric primitive the BVH holds: one analytic surface or one triangle. The analytic
/// shapes are boxed, so that the enum is the size of a triangle: meshes, which can have millions
/// of primitives, stay compact in memory and in the caches during traversal.
#[derive(Clone, Debug)]
pub enum Shape {
    /// Full sphere, or a sphere clipped by a plane (a bowl's hemisphere).
    Sphere(Box<Sphere>),
    /// Open cylinder wall (caps are separate disks).
    Cylinder(Box<Cylinder>),
    /// Disk or annulus.
    Disk(Box<Disk>),
    /// Parallelogram.
    Quad(Box<Quad>),
    /// Planar convex polygon.
    Polygon(Box<Polygon>),
    /// Triangle (from a mesh).
    Triangle(Triangle),
    /// A sphere, disk or cylinder under a general affine map (an ellipsoid, an elliptic disk or
    /// cylinder), intersected in its object space.
    Affine(Box<AffineShape>),
}

impl Shape {
    /// Nearest hit distance in the open interval (`tmin`, `tmax`), or `None`.
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<f32> {
        match self {
            Shape::Sphere(s) => s.intersect(ray, tmin, tmax),
            Shape::Cylinder(s) => s.intersect(ray, tmin, tmax),
            Shape::Disk(s) => s.intersect(ray, tmin, tmax),
            Shape::Quad(s) => s.intersect(ray, tmin, tmax),
            Shape::Polygon(s) => s.intersect(ray, tmin, tmax),
            Shape::Triangle(s) => s.intersect(ray, tmin, tmax),
            Shape::Affine(s) => s.intersect(ray, tmin, tmax),
        }
    }

    /// [`Shape::intersect`] with `ray`'s watertight-test constants computed once, at the first
    /// triangle, for all the triangles it meets (`sheared` starts empty for each ray).
    #[inline]
    pub fn intersect_sheared(
        &self,
        ray: &Ray,
        sheared: &OnceCell<Option<ShearedRay>>,
        tmin: f32,
        tmax: f32,
    ) -> Option<f32> {
        self.hit_sheared(ray, sheared, tmin, tmax).map(|(t, _)| t)
    }

    /// [`Shape::intersect_sheared`] with a triangle's barycentrics (for
    /// [`Shape::surface_with`], which then need not find them again).
    #[inline]
    pub fn hit_sheared(
        &self,
        ray: &Ray,
        sheared: &OnceCell<Option<ShearedRay>>,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, Option<[f32; 3]>)> {
        match self {
            Shape::Triangle(s) => s
                .hit_sheared(sheared.get_or_init(|| ShearedRay::new(ray)).as_ref()?, ray, tmin, tmax)
                .map(|(t, bary)| (t, Some(bary))),
            other => other.intersect(ray, tmin, tmax).map(|t| (t, None)),
        }
    }

    /// [`Shape::surface`], with the barycentrics [`Shape::hit_sheared`] found for a triangle, and
    /// the angular texture coordinates of spheres, cylinders and disks only where `with_uv` (else
    /// zero; they cost an `atan2` per hit, which a scene whose textures read no uv never needs).
    #[inline]
    pub fn surface_with(&self, ray: &Ray, t: f32, bary: Option<[f32; 3]>, with_uv: bool) -> SurfaceHit {
        match (self, bary) {
            (Shape::Triangle(s), Some(bary)) => s.surface_at(ray, t, bary),
            (Shape::Sphere(s), _) => s.surface_uv(ray, t, with_uv),
            (Shape::Cylinder(s), _) => s.surface_uv(ray, t, with_uv),
            (Shape::Disk(s), _) => s.surface_uv(ray, t, with_uv),
            (Shape::Affine(s), _) => s.surface_uv(ray, t, with_uv),
            _ => self.surface(ray, t),
        }
    }

    /// Full hit record for a hit at distance `t` previously returned by [`Shape::intersect`].
    #[inline]
    pub fn surface(&self, ray: &Ray, t: f32) -> SurfaceHit {
        match self {
            Shape::Sphere(s) => s.surface(ray, t),
            Shape::Cylinder(s) => s.surface(ray, t),
            Shape::Disk(s) => s.surface(ray, t),
            Shape::Quad(s) => s.surface(ray, t),
            Shape::Polygon(s) => s.surface(ray, t),
            Shape::Triangle(s) => s.surface(ray, t),
            Shape::Affine(s) => s.surface(ray, t),
        }
    }

    /// Conservative world-space bounds.
    pub fn bounds(&self) -> Bounds {
        match self {
            Shape::Sphere(s) => s.bounds(),
            Shape::Cylinder(s) => s.bounds(),
            Shape::Disk(s) => s.bounds(),
            Shape::Quad(s) => s.bounds(),
            Shape::Polygon(s) => s.bounds(),
            Shape::Triangle(s) => s.bounds(),
            Shape::Affine(s) => s.bounds(),
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        match self {
            Shape::Sphere(s) => s.area(),
            Shape::Cylinder(s) => s.area(),
            Shape::Disk(s) => s.area(),
            Shape::Quad(s) => s.area(),
            Shape::Polygon(s) => s.area(),
            Shape::Triangle(s) => s.area(),
            Shape::Affine(s) => s.area(),
        }
    }

    /// Turns the texture frame of a sphere, disk or cylinder that is `unplaced` placed by a
    /// similarity with `rotation` to `unplaced`'s frame turned by it, so that the image turns
    /// with the shape (its intersections do not change); other shapes, or shapes of different
    /// kinds, are left as they are (quads, polygons and meshes carry their uv with them).
    pub fn turn_texture_frame(&mut self, unplaced: &Shape, rotation: glam::Mat3) {
        match (self, unplaced) {
            (Shape::Sphere(s), Shape::Sphere(u)) => s.turn_texture_frame(u, rotation),
            (Shape::Disk(s), Shape::Disk(u)) => s.turn_texture_frame(u, rotation),
            (Shape::Cylinder(s), Shape::Cylinder(u)) => s.turn_texture_frame(u, rotation),
            _ => {}
        }
    }

    /// Short name of the shape kind.
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Sphere(_) => "sphere",
            Shape::Cylinder(_) => "cylinder",
            Shape::Disk(_) => "disk",
            Shape::Quad(_) => "quad",
            Shape::Polygon(_) => "polygon",
            Shape::Triangle(_) => "triangle",
            Shape::Affine(s) => s.kind(),
        }
    }
}

/// Roundoff scale (in units of γ) of the seam slack, see [`seam_slack`].
pub(crate) const SEAM_ULPS: i32 = 8;

/// Absolute slack by which bounded-range checks (cylinder height, disk radii, clipped-sphere
/// height, quad and polygon edges) accept points beyond their exact edge, so that analytic
/// pieces meeting at a seam overlap instead of leaving a crack.
///
/// Two roundoffs decide on which side of a seam a computed hit falls: the one of the hit
/// coordinate itself, computed from `origin_offset` (ray origin minus the shape's `reference`
/// point) and a `t` of similar magnitude, and the one in how the scene built the neighbouring
/// piece (a cap centre `base + axis·height` is rounded at the magnitude of its world
/// coordinates). Both are a few ulps of `size + |reference| + |origin_offset|`; the slack is
/// `γ(SEAM_ULPS)` of that, i.e. about 5e-7 of the shape's size for a ray starting next to a
/// shape near the world origin. (Measured: 4 ulps is the smallest scale without cracks in
/// millions of seam rays, 3 is not enough; 8 doubles that margin.)
#[inline]
pub(crate) fn seam_slack(size: f32, reference: Vec3, origin_offset: Vec3) -> f32 {
    gamma(SEAM_ULPS) * (size + reference.abs().max_element() + origin_offset.abs().max_element())
}

/// The smallest box holding all `points` (empty slice gives an inverted, empty box).
pub(crate) fn bounds_of(points: &[Vec3]) -> Bounds {
    points.iter().fold(Bounds { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY }, |b, &p| Bounds {
        min: b.min.min(p),
        max: b.max.max(p),
    })
}

/// `v` scaled to unit length, or `fallback` when it is zero or not finite. Rescales by the
/// largest component first, so tiny and huge vectors do not underflow or overflow when squared.
#[inline]
pub(crate) fn unit_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let largest = v.abs().max_element();
    if largest > 0.0 && largest.is_finite() {
        (v / largest).normalize_or(fallback)
    } else {
        fallback
    }
}

/// The frame `(t1, t2)` in which the angular texture coordinate of a sphere, cylinder or disk
/// around the unit `axis` is measured: from `t1` (angle 0) towards `t2`, right-handed about the
/// axis (`t1 × t2 = axis`). It is the orthonormal basis of Duff et al. (2017), "Building an
/// orthonormal basis, revisited": with `s = sign(z)`, `a = −1/(s + z)`, `b = x·y·a`,
/// `t1 = (1 + s·x²·a, s·b, −s·x)` and `t2 = (b, s + y²·a, −y)`. For +Y it is (+X, −Z), for −Y
/// (+X, +Z), for +Z (+X, +Y).
#[inline]
pub fn texture_frame(axis: Vec3) -> (Vec3, Vec3) {
    axis.any_orthonormal_pair()
}

/// The texture frame about the unit `axis` whose angle 0 lies along `seam` (projected onto the
/// plane normal to the axis): (t₁, axis × t₁), right-handed about the axis as [`texture_frame`]'s;
/// `None` when `seam` is (nearly) along the axis or not finite. A seam that is already a unit
/// vector across the axis (to single precision) is t₁ as given, so that an exporter writing
/// t₁ gives a file that reads back to the same frame.
pub fn seam_frame(axis: Vec3, seam: Vec3) -> Option<(Vec3, Vec3)> {
    if (seam.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON && seam.dot(axis).abs() <= 1e-6 {
        return Some((seam, axis.cross(seam)));
    }
    let across = seam - seam.dot(axis) * axis;
    (across.length() > 1e-6 * seam.length())
        .then(|| across.try_normalize())
        .flatten()
        .map(|t1| (t1, axis.cross(t1)))
}

/// Angle of `v` around a unit axis, measured in the plane of the orthonormal `frame` from
/// `frame.0` towards `frame.1`, as a texture coordinate in [0, 1].
#[inline]
pub(crate) fn azimuth(frame: (Vec3, Vec3), v: Vec3) -> f32 {
    use std::f32::consts::TAU;
    let phi = v.dot(frame.1).atan2(v.dot(frame.0));
    (if phi < 0.0 { phi + TAU } else { phi } / TAU).clamp(0.0, 1.0)
}

/// Hit of `ray` with the plane through `reference` with unit normal `n`, if its distance lies in
/// the open interval (`tmin`, `tmax`): returns `t`, the origin relative to `reference` and the
/// hit point relative to `reference` (all planar shapes work relative to their reference point
/// so that roundoff scales with the shape, not with the world coordinates).
#[inline]
pub(crate) fn plane_hit(
    n: Vec3,
    reference: Vec3,
    ray: &Ray,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, Vec3, Vec3)> {
    let denom = n.dot(ray.dir);
    if denom == 0.0 {
        return None;
    }
    let f = ray.origin - reference;
    let t = -n.dot(f) / denom;
    if !(t > tmin && t < tmax) {
        return None;
    }
    Some((t, f, f + t * ray.dir))
}

/// The point at `t` along `ray`, relative to `reference` and projected onto the plane through
/// `reference` with unit normal `n`.
#[inline]
pub(crate) fn plane_point(n: Vec3, reference: Vec3, ray: &Ray, t: f32) -> Vec3 {
    let q = (ray.origin - reference) + t * ray.dir;
    q - q.dot(n) * n
}

/// Hit record of a planar shape from the projected in-plane offset `q` of [`plane_point`].
#[inline]
pub(crate) fn planar_surface(n: Vec3, reference: Vec3, q: Vec3, t: f32, uv: Vec2) -> SurfaceHit {
    let p = reference + q;
    SurfaceHit {
        t,
        p,
        n,
        shading_n: n,
        uv,
        // After the projection the residual off-plane component of q is the roundoff of
        // `q − (q·n)n`: γ(3)·|q|₂ from the dot product plus two roundings, γ(5)·|q|₂; one more
        // for |q|₂ against the largest component: γ(6). Adding the reference: γ(2)·|p|.
        p_error: point_error(p, q.length(), 6),
    }
}

/// Helpers shared by the shape unit tests.
#[cfg(test)]
pub(crate) mod test_support {
    use super::{spawn_origin, Ray, SurfaceHit};
    use glam::Vec3;
    use rand::RngExt;
    use rand_pcg::Pcg32;

    /// Ray from `o` along `d` (normalised).
    pub fn ray(o: [f32; 3], d: [f32; 3]) -> Ray {
        Ray::new(Vec3::from(o), Vec3::from(d).normalize())
    }

    /// Uniformly distributed unit vector.
    pub fn random_unit(rng: &mut Pcg32) -> Vec3 {
        let z = 2.0 * rng.random::<f32>() - 1.0;
        let phi = std::f32::consts::TAU * rng.random::<f32>();
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// Uniformly distributed point in the cube [−half, half]³.
    pub fn random_point(rng: &mut Pcg32, half: f32) -> Vec3 {
        (Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - 1.0) * half
    }

    /// The rays leaving `hit` for a ray arriving along `incoming`: its mirror reflection and a
    /// random direction on the other side of the surface, both spawned with [`spawn_origin`].
    pub fn spawned_rays(hit: &SurfaceHit, incoming: Vec3, rng: &mut Pcg32) -> [Ray; 2] {
        let reflected = incoming - 2.0 * incoming.dot(hit.n) * hit.n;
        let mut other = random_unit(rng);
        if (other.dot(hit.n) > 0.0) == (reflected.dot(hit.n) > 0.0) {
            other = -other;
        }
        [reflected, other].map(|w| Ray::new(spawn_origin(hit, w), w))
    }
}

#[cfg(test)]
mod next_float_tests {
    use super::{next_down, next_up};

    #[test]
    fn next_up_and_down_are_the_standard_ones_for_every_kind_of_float() {
        let mut values = vec![
            0.0f32,
            -0.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::from_bits(0x8000_0001),
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            1.0,
            -1.0,
        ];
        values.extend((0..u32::MAX).step_by(65_537).map(f32::from_bits));
        for x in values {
            assert_eq!(next_up(x).to_bits(), x.next_up().to_bits(), "{x:e} ({:#x})", x.to_bits());
            assert_eq!(next_down(x).to_bits(), x.next_down().to_bits(), "{x:e} ({:#x})", x.to_bits());
        }
    }
}
