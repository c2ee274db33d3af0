//! Light sources: point lights, spot lights (Mitsuba 3's `spot`, [`SpotBeam`]), directional
//! lights (Mitsuba 3's `directional`), one-sided area quads and spheres, emissive surfaces
//! (diffuse emitters on spheres, quads, disks, cylinders and meshes, two-sided or one-sided) and
//! an environment, constant or an importance-sampled HDR map.
//!
//! Point, spot and directional lights are delta lights: no ray can hit them, only next-event
//! estimation and light paths reach them. A spot's light paths leave its position in a direction
//! uniform over its cone; a directional light's, like the environment's (below), start on a
//! disk of the scene's bounding sphere's radius facing the light, at density `1/(π R²)` per
//! unit disk area, all along the light's direction.
//!
//! The environment is infinitely far away, so a light path cannot start on it at a point: it
//! starts on a disk of the scene's bounding sphere's radius, perpendicular to a uniformly
//! sampled direction and just outside the sphere (Dutré et al.; pbrt's infinite lights and
//! SmallVCM's background light do the same), so that every ray of that direction which can meet
//! the scene starts on the disk. Its densities are `1/(4π)` per solid angle times `1/(π R²)` per
//! unit disk area.

mod emitter_mesh;
pub(crate) mod environment_map;
pub mod spot;

pub use emitter_mesh::EmitterMesh;
pub use environment_map::EnvironmentMap;
pub use spot::SpotBeam;

use crate::bsdf::lambert::cosine_hemisphere;
use crate::bsdf::Frame;
use crate::geometry::{
    disk_uv, point_error, spawn_origin, sphere_uv, texture_frame, wall_uv, Ray, SurfaceHit,
};
use crate::lanes::{Mask3, Real, Vector};
use crate::texture::Texture;
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// A light source.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity (W/sr).
        intensity: Vec3,
    },
    /// A point light shining into a cone (Mitsuba 3's `spot`): intensity `intensity` times the
    /// beam's falloff at the angle from `direction`.
    Spot {
        /// Position.
        position: Vec3,
        /// Unit direction of the beam's axis.
        direction: Vec3,
        /// Radiant intensity on the axis (W/sr).
        intensity: Vec3,
        /// The angular profile.
        beam: SpotBeam,
    },
    /// Parallel light from infinitely far away (Mitsuba 3's `directional`), e.g. the sun.
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        /// Irradiance on a surface facing the light (W/m²).
        irradiance: Vec3,
    },
    /// One-sided Lambertian parallelogram emitter; it is also a visible primitive.
    Quad {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
        /// Unit normal `u × v`: the emitting side.
        normal: Vec3,
        /// Emitted radiance (W/(m²·sr)).
        radiance: Vec3,
    },
    /// Lambertian spherical emitter; it is also a visible primitive.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// Emitted radiance (W/(m²·sr)).
        radiance: Vec3,
    },
    /// An object whose diffuse material emits: Lambertian on both sides of its surface, or
    /// only on the side its normal points to (Mitsuba's `area` emitter).
    Surface {
        /// The emitting geometry.
        shape: EmitterShape,
        /// Emitted radiance (W/(m²·sr)); with a texture, the factor on its colours.
        radiance: Vec3,
        /// How the emission varies over the surface (by its texture coordinates), if it does.
        texture: Option<Texture>,
        /// Whether only the side the surface normal points to emits (black from behind).
        one_sided: bool,
    },
    /// Radiance arriving from every direction that leaves the scene: constant, or an HDR map
    /// (importance-sampled) times a scale.
    Environment {
        /// Radiance (W/(m²·sr)) without a map; the scale of the map's texels with one.
        radiance: Vec3,
        /// The equirectangular map, if any.
        map: Option<Arc<EnvironmentMap>>,
    },
}

/// A sphere that bounds every object of a scene: where light paths from the environment start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneSphere {
    /// Centre.
    pub centre: Vec3,
    /// Radius (never zero).
    pub radius: f32,
}

impl SceneSphere {
    /// The sphere around the axis-aligned box `(lo, hi)`, enlarged a little so that points
    /// started on its tangent disks lie strictly outside every object.
    pub fn around(lo: Vec3, hi: Vec3) -> SceneSphere {
        let radius = 0.5 * (hi - lo).length();
        SceneSphere { centre: 0.5 * (lo + hi), radius: (radius * 1.001).max(1e-3) }
    }

    /// Area density of a point on the sphere's great disk, `1/(π R²)`.
    pub fn disk_pdf(&self) -> f32 {
        1.0 / (PI * self.radius * self.radius)
    }

    /// Where a light path travelling along the unit direction `dir` from infinitely far away
    /// starts: the point of the disk of radius R perpendicular to `dir`, tangent to the sphere
    /// on the side the light comes from, that `u` picks uniformly by area (density
    /// [`disk_pdf`](Self::disk_pdf)).
    pub fn entry_point(&self, dir: Vec3, u: Vec2) -> Vec3 {
        let (t, b) = dir.any_orthonormal_pair();
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let on_disk = t * (r * phi.cos()) + b * (r * phi.sin());
        self.centre + self.radius * (on_disk - dir)
    }
}

/// The geometry of an emissive object, sampled uniformly by area.
#[derive(Clone, Debug, PartialEq)]
pub enum EmitterShape {
    /// A sphere.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
        /// The texture frame of the object's sphere: uv pole and longitude tangents (turned with
        /// a rotated object), so that a sampled point's uv is the one a ray's hit there gets.
        frame: (Vec3, (Vec3, Vec3)),
    },
    /// A parallelogram `corner + a·u + b·v`.
    Quad {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
    },
    /// A disk or annulus.
    Disk {
        /// Centre.
        center: Vec3,
        /// Unit normal.
        normal: Vec3,
        /// Outer radius.
        radius: f32,
        /// Radius of the hole.
        inner_radius: f32,
        /// The in-plane texture frame of the object's disk (turned with a rotated object).
        frame: (Vec3, Vec3),
    },
    /// The wall of a cylinder (an open tube) from `base` along the unit `axis` for `height`,
    /// with its two end disks where `caps` holds their texture frames (a closed cylinder).
    Cylinder {
        /// Centre of the bottom circle.
        base: Vec3,
        /// Unit axis from the bottom circle to the top one.
        axis: Vec3,
        /// Radius.
        radius: f32,
        /// Length along the axis.
        height: f32,
        /// The cross-section frame the wall's texture angle is measured in (turned with a
        /// rotated object), so that a sampled point's uv is the one a ray's hit there gets.
        frame: (Vec3, Vec3),
        /// The in-plane texture frames of the bottom (normal −`axis`) and top (+`axis`) caps,
        /// for a cylinder with caps; `None` for the open tube.
        caps: Option<[(Vec3, Vec3); 2]>,
        /// Whether every normal is turned the other way, towards the inside (Mitsuba's
        /// `flip_normals`): the wall's to the axis, the caps' into the cylinder.
        inward: bool,
    },
    /// A triangle mesh (no texture coordinates: its emission is not textured).
    Mesh(Arc<EmitterMesh>),
    /// A sphere, disk or cylinder (`object`, in its object space) placed by a general affine
    /// map `p ↦ linear·p + translate`: an ellipsoid, elliptic disk or elliptic (or oblique)
    /// cylinder. It is sampled as `object` is, uniformly by object area, and the point mapped:
    /// its world area density is `1/(A_o·J)` with `J = det M·|M⁻ᵀ n_o|` the local area scale
    /// of the map (Nanson's formula), which varies over the surface
    /// ([`point_area`](EmitterShape::point_area)).
    Affine(Arc<AffineEmitter>),
}

/// The map of an [`EmitterShape::Affine`] and what its sampling needs of it.
#[derive(Clone, Debug, PartialEq)]
pub struct AffineEmitter {
    /// The shape in its object space (a sphere, disk or cylinder).
    pub object: EmitterShape,
    /// The linear part `M` of the map to the world (determinant > 0).
    pub linear: Mat3,
    /// The translation, applied after `M`.
    pub translate: Vec3,
    /// `M⁻¹`.
    to_object: Mat3,
    /// `M⁻ᵀ`, which carries normals to the world.
    normal_to_world: Mat3,
    /// `det M`.
    det: f32,
    /// The world area (by [`crate::geometry::AffineShape::area`]'s quadrature).
    area: f32,
}

impl AffineEmitter {
    /// `object` placed by `p ↦ linear·p + translate`, its world area `area` (computed by the
    /// caller's geometry); `None` for a map that is singular, mirrors or is not finite, or an
    /// object that is not a sphere, disk or cylinder.
    pub fn new(object: EmitterShape, linear: Mat3, translate: Vec3, area: f32) -> Option<AffineEmitter> {
        let det = linear.determinant();
        let round = matches!(
            object,
            EmitterShape::Sphere { .. } | EmitterShape::Disk { .. } | EmitterShape::Cylinder { .. }
        );
        let to_object = linear.inverse();
        (round && det > 0.0 && det.is_finite() && to_object.is_finite() && translate.is_finite()).then(|| {
            AffineEmitter {
                object,
                linear,
                translate,
                to_object,
                normal_to_world: to_object.transpose(),
                det,
                area,
            }
        })
    }

    /// The world point and unit normal of the object-space point `p` (normal `n`).
    fn to_world(&self, (p, n): (Vec3, Vec3)) -> (Vec3, Vec3) {
        let world_n = (self.normal_to_world * n).normalize_or(n);
        (self.linear * p + self.translate, world_n)
    }
}

/// The point of the annulus around `center` between `inner_radius` and `radius` in the plane
/// spanned by the orthonormal `(t, b)` that `u` picks uniformly by area.
fn annulus_point(center: Vec3, (t, b): (Vec3, Vec3), radius: f32, inner_radius: f32, u: Vec2) -> Vec3 {
    let r = (inner_radius * inner_radius + u.x * (radius * radius - inner_radius * inner_radius)).sqrt();
    let phi = 2.0 * PI * u.y;
    center + r * (phi.cos() * t + phi.sin() * b)
}

/// Which part of a cylinder emitter ([`EmitterShape::Cylinder`]) `u.x` picks, by area: the wall
/// (`None`) or a cap (`Some(0)` bottom, `Some(1)` top), with `u.x` stretched back to [0, 1) within
/// the part. Without caps, always the wall and `u` itself.
fn cylinder_part(radius: f32, height: f32, caps: bool, u: Vec2) -> (Option<usize>, Vec2) {
    if !caps {
        return (None, u);
    }
    let (wall, cap) = (2.0 * PI * radius * height, PI * radius * radius);
    let s = u.x * (wall + 2.0 * cap);
    let (part, x) = if s < wall {
        (None, s / wall)
    } else if s < wall + cap {
        (Some(0), (s - wall) / cap)
    } else {
        (Some(1), (s - wall - cap) / cap)
    };
    (part, Vec2::new(x.clamp(0.0, 1.0 - f32::EPSILON / 2.0), u.y))
}

impl EmitterShape {
    /// A sphere with the texture frame of an unrotated one (pole +Y).
    pub fn sphere(center: Vec3, radius: f32) -> EmitterShape {
        EmitterShape::Sphere { center, radius, frame: (Vec3::Y, texture_frame(Vec3::Y)) }
    }

    /// A disk or annulus facing the unit `normal`, with the texture frame of an unrotated one.
    pub fn disk(center: Vec3, normal: Vec3, radius: f32, inner_radius: f32) -> EmitterShape {
        EmitterShape::Disk { center, normal, radius, inner_radius, frame: texture_frame(normal) }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        match *self {
            EmitterShape::Sphere { radius, .. } => 4.0 * PI * radius * radius,
            EmitterShape::Quad { u, v, .. } => u.cross(v).length(),
            EmitterShape::Disk { radius, inner_radius, .. } => {
                PI * (radius * radius - inner_radius * inner_radius)
            }
            EmitterShape::Cylinder { radius, height, caps, .. } => {
                2.0 * PI * radius * height + if caps.is_some() { 2.0 * PI * radius * radius } else { 0.0 }
            }
            EmitterShape::Mesh(ref mesh) => mesh.area(),
            EmitterShape::Affine(ref a) => a.area,
        }
    }

    /// The reciprocal of the area density with which [`sample`](Self::sample) picks the point
    /// of unit normal `n` on the surface: the area itself for every shape but an affine one,
    /// whose density varies, `A_o·det M / |Mᵀ n|` (the object's area times the map's local area
    /// scale there: `|Mᵀ n| = 1/|M⁻ᵀ n_o|` for the object normal `n_o` mapped to `n`).
    pub fn point_area(&self, n: Vec3) -> f32 {
        match *self {
            EmitterShape::Affine(ref a) => a.object.area() * a.det / (a.linear.transpose() * n).length(),
            _ => self.area(),
        }
    }

    /// A length bounding the shape's size about its points (for the roundoff bound of a
    /// sampled point).
    fn extent(&self) -> f32 {
        match *self {
            EmitterShape::Sphere { radius, .. } | EmitterShape::Disk { radius, .. } => radius,
            EmitterShape::Quad { u, v, .. } => (u.abs() + v.abs()).max_element(),
            EmitterShape::Cylinder { radius, height, .. } => radius + height,
            EmitterShape::Mesh(ref mesh) => mesh.extent(),
            // The object's points' size, stretched at most by the Frobenius norm of M.
            EmitterShape::Affine(ref a) => {
                let m = a.linear;
                let frobenius =
                    (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared())
                        .sqrt();
                frobenius * (a.object.extent() + a.object.centre().abs().max_element())
            }
        }
    }

    /// A point uniformly distributed over the surface, with its unit normal.
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3) {
        match *self {
            EmitterShape::Sphere { center, radius, .. } => {
                let n = uniform_sphere(u);
                (center + radius * n, n)
            }
            EmitterShape::Quad { corner, u: eu, v: ev } => {
                (corner + u.x * eu + u.y * ev, eu.cross(ev).normalize())
            }
            EmitterShape::Disk { center, normal, radius, inner_radius, .. } => {
                (annulus_point(center, normal.any_orthonormal_pair(), radius, inner_radius, u), normal)
            }
            EmitterShape::Cylinder { base, axis, radius, height, frame: (t, b), caps, inward } => {
                let (p, outward) = match cylinder_part(radius, height, caps.is_some(), u) {
                    (None, u) => {
                        // The wall's angle from the texture frame, its height linear in u.x.
                        let phi = 2.0 * PI * u.y;
                        let n = phi.cos() * t + phi.sin() * b;
                        (base + (u.x * height) * axis + radius * n, n)
                    }
                    (Some(k), u) => {
                        let frames = caps.expect("a cap only with caps");
                        let (center, n) = if k == 0 { (base, -axis) } else { (base + height * axis, axis) };
                        (annulus_point(center, frames[k], radius, 0.0, u), n)
                    }
                };
                (p, if inward { -outward } else { outward })
            }
            EmitterShape::Mesh(ref mesh) => mesh.sample(u),
            EmitterShape::Affine(ref a) => a.to_world(a.object.sample(u)),
        }
    }

    /// The texture coordinates of the point `p` (normal `n`) that [`sample`](Self::sample) made
    /// from `u`, as the object's shape gives them to a ray's hit (see `scenes/README.md`).
    pub fn uv_at(&self, u: Vec2, p: Vec3, n: Vec3) -> Vec2 {
        match *self {
            EmitterShape::Quad { .. } => u,
            EmitterShape::Mesh(_) => Vec2::ZERO,
            // The object-space point's: the texture frame moves with the shape, as a ray's hit.
            EmitterShape::Affine(ref a) => {
                let (p, n) = a.object.sample(u);
                a.object.uv_at(u, p, n)
            }
            EmitterShape::Sphere { frame: (pole, tangents), .. } => sphere_uv(pole, tangents, n),
            EmitterShape::Disk { center, radius, inner_radius, frame, .. } => {
                disk_uv(frame, p - center, radius, inner_radius)
            }
            EmitterShape::Cylinder { base, axis, radius, height, frame, caps, inward } => {
                match cylinder_part(radius, height, caps.is_some(), u) {
                    // As the wall's hits: the angle of the outward normal in its frame, the
                    // height along the axis.
                    (None, _) => {
                        let outward = if inward { -n } else { n };
                        wall_uv(frame, outward, (p - base).dot(axis), height)
                    }
                    (Some(k), _) => {
                        let center = if k == 0 { base } else { base + height * axis };
                        disk_uv(caps.expect("a cap only with caps")[k], p - center, radius, 0.0)
                    }
                }
            }
        }
    }

    /// A representative point (for the deterministic methods, which see an emitter as a point).
    pub fn centre(&self) -> Vec3 {
        match *self {
            EmitterShape::Sphere { center, .. } | EmitterShape::Disk { center, .. } => center,
            EmitterShape::Quad { corner, u, v } => corner + 0.5 * (u + v),
            EmitterShape::Cylinder { base, axis, height, .. } => base + 0.5 * height * axis,
            EmitterShape::Mesh(ref mesh) => mesh.centre(),
            EmitterShape::Affine(ref a) => a.linear * a.object.centre() + a.translate,
        }
    }

    /// Whether `p` lies strictly inside the emitting sphere or cylinder (or their affine image),
    /// well away from its surface (see [`Light::encloses`]).
    pub fn encloses(&self, p: Vec3) -> bool {
        match *self {
            EmitterShape::Sphere { center, radius, .. } => encloses_sphere(center, radius, p),
            EmitterShape::Cylinder { base, axis, radius, height, .. } => {
                // Well inside, as for the sphere: between the end planes and within the wall.
                let z = (p - base).dot(axis);
                let radial = (p - base - z * axis).length();
                let margin = 1e-3 * height;
                radial < radius * (1.0 - 1e-3) && z > margin && z < height - margin
            }
            EmitterShape::Affine(ref a) => a.object.encloses(a.to_object * (p - a.translate)),
            _ => false,
        }
    }

    /// The radiant intensity towards the unit direction `to_p` of the shape emitting `radiance`
    /// (Lambertian, on one side or both): `radiance` times its projected area (see
    /// [`Light::as_point_from`]). An affine image's is exact from its object's: an element of
    /// vector area `n_o dA_o` becomes `det M·M⁻ᵀ n_o dA_o`, whose projection on `to_p` is
    /// `det M·|M⁻¹ to_p|` times the object's projection on the unit `M⁻¹ to_p`.
    fn outline_intensity(&self, radiance: Vec3, to_p: Vec3, one_sided: bool) -> Vec3 {
        match self {
            // a sphere shows the same projected area πr² from everywhere
            EmitterShape::Sphere { .. } => radiance * self.area() * 0.25,
            EmitterShape::Mesh(mesh) => radiance * mesh.projected_area(to_p, one_sided),
            // The wall's outline 2rh·sin θ from the axis, and one cap's πr²·|cos θ|; an
            // open tube emitting inwards on one side shows its inside through one mouth,
            // πr²·|cos θ|, a closed one nothing.
            EmitterShape::Cylinder { axis, radius, height, caps, inward, .. } => {
                let cos = to_p.dot(*axis).abs();
                let mouth = PI * radius * radius * cos;
                if *inward && one_sided {
                    radiance * if caps.is_some() { 0.0 } else { mouth }
                } else {
                    let wall = 2.0 * radius * height * (1.0 - cos * cos).max(0.0).sqrt();
                    radiance * (wall + if caps.is_some() { mouth } else { 0.0 })
                }
            }
            EmitterShape::Affine(a) => {
                let w = a.to_object * to_p;
                a.object.outline_intensity(radiance, w.normalize_or_zero(), one_sided) * (a.det * w.length())
            }
            // A flat emitter: its area times the cosine, one-sided on its front only.
            EmitterShape::Quad { .. } | EmitterShape::Disk { .. } => {
                let n = self.sample(Vec2::splat(0.5)).1;
                let cos = to_p.dot(n);
                radiance * self.area() * if one_sided { cos.max(0.0) } else { cos.abs() }
            }
        }
    }
}

/// Whether `p` is well inside the sphere: a point sampled on the surface (roundoff included)
/// is not enclosed.
fn encloses_sphere(center: Vec3, radius: f32, p: Vec3) -> bool {
    (p - center).length() < radius * (1.0 - 1e-3)
}

/// The solid-angle density seen from `p` of the point `y` (normal `n_y`) drawn with the area
/// density `area_pdf`: `area_pdf·d² / |cos θ_y|`, 0 where the direction grazes the surface.
/// For one point or across lanes.
#[inline(always)]
pub fn area_to_solid_angle<V: Vector>(area_pdf: V::Real, p: V, y: V, n_y: V) -> V::Real {
    let d = y - p;
    let cos = d.normalize_or_zero().dot(n_y).abs();
    let pdf = area_pdf * d.length_squared() / cos;
    let zero = V::Real::splat(0.0);
    V::Real::select(cos.eq(zero), zero, pdf)
}

/// Next-event estimation's sample of a light from the point `p`, for one point or per lane:
/// where there is one, the unit direction towards the light, its distance, the radiance
/// arriving and the solid-angle density.
#[derive(Clone, Copy, Debug)]
pub struct LightSampleOf<V: Vector> {
    /// Where the light has a sample.
    pub sampled: Mask3<V>,
    /// Unit direction from `p` towards the light.
    pub wi: V,
    /// Distance to the light's point.
    pub distance: V::Real,
    /// Radiance arriving at `p` (intensity over distance² for a point light).
    pub radiance: V,
    /// Solid-angle density (1 for a point light).
    pub pdf: V::Real,
}

impl<V: Vector> LightSampleOf<V> {
    /// No sample (in any lane).
    #[inline(always)]
    pub fn none() -> LightSampleOf<V> {
        let (zero, v) = (V::Real::splat(0.0), V::splat(Vec3::ZERO));
        LightSampleOf { sampled: V::Real::mask(false), wi: v, distance: zero, radiance: v, pdf: zero }
    }

    /// `if m { a } else { b }`, field by field (per lane).
    #[inline(always)]
    pub fn select(m: Mask3<V>, a: &LightSampleOf<V>, b: &LightSampleOf<V>) -> LightSampleOf<V> {
        LightSampleOf {
            sampled: (m & a.sampled) | (!m & b.sampled),
            wi: V::select(m, a.wi, b.wi),
            distance: V::Real::select(m, a.distance, b.distance),
            radiance: V::select(m, a.radiance, b.radiance),
            pdf: V::Real::select(m, a.pdf, b.pdf),
        }
    }
}

/// The sample of a point light at `position` of intensity `intensity` from `p`.
#[inline(always)]
pub fn point_light_sample<V: Vector>(p: V, position: V, intensity: V) -> LightSampleOf<V> {
    let d = position - p;
    let distance = d.length();
    LightSampleOf {
        sampled: distance.gt(V::Real::splat(0.0)),
        wi: d / distance,
        distance,
        radiance: intensity / (distance * distance),
        pdf: V::Real::splat(1.0),
    }
}

/// The point of a quad (corner `corner`, edges `eu`, `ev`) at the uniform numbers (`ux`, `uy`).
#[inline(always)]
pub fn quad_point<V: Vector>(corner: V, eu: V, ev: V, ux: V::Real, uy: V::Real) -> V {
    corner + eu * ux + ev * uy
}

/// What an area light that emits `radiance` from its front (normal `n`) sends towards `wo`:
/// `radiance` where `wo` leaves the front, else nothing. For one point or one per lane.
#[inline(always)]
pub fn front_emitted<V: Vector>(n: V, wo: V, radiance: V) -> V {
    V::select(n.dot(wo).gt(V::Real::splat(0.0)), radiance, V::splat(Vec3::ZERO))
}

/// The sample of the point `y` (normal `n`) of an area light that emits `radiance` from its
/// front, sampled with area density `area_pdf`, from `p`: none where `y` is `p`, is seen from
/// behind, or has no finite positive density.
#[inline(always)]
pub fn front_area_sample<V: Vector>(p: V, y: V, n: V, radiance: V, area_pdf: V::Real) -> LightSampleOf<V> {
    let zero = V::Real::splat(0.0);
    let d = y - p;
    let distance = d.length();
    let wi = d / distance;
    let radiance = V::select(n.dot(-wi).gt(zero), radiance, V::splat(Vec3::ZERO));
    let pdf = area_to_solid_angle(area_pdf, p, y, n);
    let sampled = distance.gt(zero) & !radiance.is_zero() & pdf.gt(zero) & pdf.is_finite();
    LightSampleOf { sampled, wi, distance, radiance, pdf }
}

/// A uniformly distributed unit vector.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A sampled direction towards a light, for next-event estimation.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// The sampled point on the light (far along `wi` for the environment).
    pub position: Vec3,
    /// Unit direction from the shading point to the light.
    pub wi: Vec3,
    /// Distance to `position` (infinite for the environment).
    pub distance: f32,
    /// Radiance arriving along `wi` (for a point light: intensity / distance²).
    pub radiance: Vec3,
    /// Solid-angle density of the sample (1 for a point light).
    pub pdf: f32,
    /// Whether the light is a delta (point) light that only next-event estimation can reach.
    pub delta: bool,
    /// The light's unit normal at `position` (−`wi` for a point light and the environment).
    pub normal: Vec3,
}

/// How a light path leaves its light ([`Light::emit`]), with the densities multiple importance
/// sampling between light and camera paths needs.
#[derive(Clone, Copy, Debug)]
pub struct Emission {
    /// The first ray.
    pub ray: Ray,
    /// Path weight of the emitted ray, `L_e·|cos| / (p_light·p_area·p_dir)` or `I / (p_light·p_dir)`.
    pub beta: Vec3,
    /// For area lights: the emission point, and `1 / (p_light·p_area)` for its direct splat.
    pub origin: Option<(SurfaceHit, f32)>,
    /// Density of the emitted ray, `p_light · p_area · p_dir` (area × solid angle; for a point
    /// light `p_light · p_dir`).
    pub pdf_emit: f32,
    /// `p_light` times the area density with which next-event estimation picks the emission
    /// point (for a point light, `p_light`: the delta is left out on both sides).
    pub pdf_direct: f32,
    /// |cos| between the emitted ray and the emitter's normal (1 for a point light).
    pub cos_light: f32,
    /// Whether the light is a point (delta) light, which no ray can hit.
    pub delta: bool,
    /// Whether the light is infinitely far away (the environment): its first segment has no
    /// length, so the densities of the other strategies do not convert by its squared distance.
    pub infinite: bool,
}

/// What one light contributes at a shading point, seen as a point source.
#[derive(Clone, Copy, Debug)]
pub struct PointIllumination {
    /// Where the light arrives from.
    pub position: Vec3,
    /// Radiant intensity towards the shading point (W/sr).
    pub intensity: Vec3,
}

/// How strong a light is, as `vitrum info` reports it ([`Light::strength`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Strength {
    /// The total emitted power (W) of a light at a finite distance.
    Power(Vec3),
    /// The radiance (W/(m²·sr)) of the environment averaged over all directions: an infinitely
    /// distant light has no finite power.
    MeanRadiance(Vec3),
    /// The irradiance (W/m²) of a directional light on a surface facing it: an infinitely
    /// distant light has no finite power.
    Irradiance(Vec3),
}

impl Strength {
    /// The number, whatever its unit.
    pub fn value(self) -> Vec3 {
        match self {
            Strength::Power(v) | Strength::MeanRadiance(v) | Strength::Irradiance(v) => v,
        }
    }
}

impl Light {
    /// How strong the light is, as `vitrum info` reports it: the total emitted power of a light
    /// at a finite distance (a textured emitter with its texture's mean colour, exact where the
    /// texture coordinates are uniform over the area), the mean radiance of the environment.
    pub fn strength(&self) -> Strength {
        match self {
            Light::Point { intensity, .. } => Strength::Power(4.0 * std::f32::consts::PI * *intensity),
            Light::Spot { intensity, beam, .. } => Strength::Power(beam.solid_angle() * *intensity),
            Light::Directional { irradiance, .. } => Strength::Irradiance(*irradiance),
            Light::Quad { u, v, radiance, .. } => Strength::Power(PI * u.cross(*v).length() * *radiance),
            Light::Sphere { radius, radiance, .. } => {
                Strength::Power(4.0 * PI * PI * radius * radius * *radiance)
            }
            Light::Surface { shape, radiance, texture, one_sided } => Strength::Power(
                if *one_sided { PI } else { 2.0 * PI }
                    * shape.area()
                    * *radiance
                    * texture.as_ref().map_or(Vec3::ONE, Texture::mean),
            ),
            Light::Environment { radiance, map } => {
                Strength::MeanRadiance(*radiance * map.as_ref().map_or(Vec3::ONE, |m| m.mean()))
            }
        }
    }

    /// A direction towards the light from `p` for next-event estimation, with its solid-angle
    /// density; `None` when the sample carries no light.
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        if let Light::Point { position, intensity } = self {
            let s = point_light_sample(p, *position, *intensity);
            return s.sampled.then_some(LightSample {
                position: *position,
                wi: s.wi,
                distance: s.distance,
                radiance: s.radiance,
                pdf: 1.0,
                delta: true,
                normal: -s.wi,
            });
        }
        if let Light::Quad { corner, u: eu, v: ev, normal, radiance } = self {
            let y = quad_point(*corner, *eu, *ev, u.x, u.y);
            let s = front_area_sample(p, y, *normal, *radiance, 1.0 / eu.cross(*ev).length());
            return s.sampled.then_some(LightSample {
                position: y,
                wi: s.wi,
                distance: s.distance,
                radiance: s.radiance,
                pdf: s.pdf,
                delta: false,
                normal: *normal,
            });
        }
        if let Light::Spot { position, direction, intensity, beam } = self {
            let d = *position - p;
            let distance = d.length();
            let wi = d / distance;
            let falloff = beam.falloff(-wi.dot(*direction));
            return (distance > 0.0 && falloff > 0.0).then(|| LightSample {
                position: *position,
                wi,
                distance,
                radiance: *intensity * (falloff / (distance * distance)),
                pdf: 1.0,
                delta: true,
                normal: -wi,
            });
        }
        if let Light::Directional { direction, irradiance } = self {
            return Some(LightSample {
                position: p - *direction,
                wi: -*direction,
                distance: f32::INFINITY,
                radiance: *irradiance,
                pdf: 1.0,
                delta: true,
                normal: *direction,
            });
        }
        if let Light::Environment { .. } = self {
            let (wi, pdf) = self.sample_environment(u)?;
            return Some(LightSample {
                position: p + wi,
                wi,
                distance: f32::INFINITY,
                radiance: self.environment_radiance(wi),
                pdf,
                delta: false,
                normal: -wi,
            });
        }
        let (y, n, uv) = match self {
            Light::Sphere { center, radius, .. } => {
                let s = self.sample_point(p, u);
                (s.position, (s.position - *center) / *radius, Vec2::ZERO)
            }
            Light::Surface { shape, texture, .. } => {
                let (y, n) = shape.sample(u);
                (y, n, if texture.is_some() { shape.uv_at(u, y, n) } else { Vec2::ZERO })
            }
            Light::Point { .. }
            | Light::Quad { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Environment { .. } => unreachable!("handled above"),
        };
        let d = y - p;
        let distance = d.length();
        if distance <= 0.0 {
            return None;
        }
        let wi = d / distance;
        let radiance = self.emitted(&emitter_point(y, n, uv, 0.0), -wi);
        let pdf = self.pdf_li(p, y, n);
        (radiance != Vec3::ZERO && pdf > 0.0 && pdf.is_finite()).then_some(LightSample {
            position: y,
            wi,
            distance,
            radiance,
            pdf,
            delta: false,
            normal: n,
        })
    }

    /// Solid-angle density with which [`Light::sample_li`] from `p` picks the point `y` (normal
    /// `n_y`) of this area light; for the environment, the density of the direction from `p`
    /// to `y`.
    pub fn pdf_li(&self, p: Vec3, y: Vec3, n_y: Vec3) -> f32 {
        let area_pdf = match self {
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } => return 0.0,
            Light::Environment { .. } => return self.environment_pdf((y - p).normalize_or(Vec3::Y)),
            Light::Quad { u, v, .. } => 1.0 / u.cross(*v).length(),
            Light::Sphere { center, radius, .. } => {
                // hemisphere facing p
                if (y - *center).dot(p - *center) <= 0.0 {
                    return 0.0;
                }
                1.0 / (2.0 * PI * radius * radius)
            }
            Light::Surface { shape, .. } => 1.0 / shape.point_area(n_y),
        };
        area_to_solid_angle(area_pdf, p, y, n_y)
    }

    /// Sample how a path leaves the light (picked with probability `p_light`): `side` picks the
    /// side of a two-sided emitter, `u_point` the point, `u_dir` the direction. A point light
    /// emits uniformly over the sphere, a spot uniformly over its cone (weighted by its falloff);
    /// a directional light along its direction from a uniform point of the disk of `sphere`
    /// facing it; an area light from a point uniform over its area in a
    /// cosine-distributed direction about the normal; the environment in a uniform direction
    /// from a uniform point of the disk of `sphere` facing it (see the module documentation).
    pub fn emit(
        &self,
        p_light: f32,
        side: f32,
        u_point: Vec2,
        u_dir: Vec2,
        sphere: &SceneSphere,
    ) -> Option<Emission> {
        match *self {
            Light::Point { position, intensity } => {
                // β = I / (p_light · 1/(4π))
                let dir = uniform_sphere(u_dir);
                Some(Emission {
                    ray: Ray::new(position, dir),
                    beta: intensity * (4.0 * PI / p_light),
                    origin: None,
                    pdf_emit: p_light / (4.0 * PI),
                    pdf_direct: p_light,
                    cos_light: 1.0,
                    delta: true,
                    infinite: false,
                })
            }
            Light::Spot { position, direction, intensity, beam } => {
                // β = I·falloff / (p_light · p_cone)
                let local = beam.sample(u_dir);
                let falloff = beam.falloff(local.z);
                if falloff <= 0.0 {
                    return None;
                }
                let dir = Frame::from_normal(direction).to_world(local);
                let pdf = beam.pdf();
                Some(Emission {
                    ray: Ray::new(position, dir),
                    beta: intensity * (falloff / (p_light * pdf)),
                    origin: None,
                    pdf_emit: p_light * pdf,
                    pdf_direct: p_light,
                    cos_light: 1.0,
                    delta: true,
                    infinite: false,
                })
            }
            Light::Directional { direction, irradiance } => {
                // β = E / (p_light · 1/(π R²))
                let disk_pdf = sphere.disk_pdf();
                Some(Emission {
                    ray: Ray::new(sphere.entry_point(direction, u_point), direction),
                    beta: irradiance / (p_light * disk_pdf),
                    origin: None,
                    pdf_emit: p_light * disk_pdf,
                    pdf_direct: p_light,
                    cos_light: 1.0,
                    delta: true,
                    infinite: true,
                })
            }
            Light::Environment { .. } => {
                let (towards, _) = self.sample_environment(u_dir)?;
                let dir = -towards;
                let origin = sphere.entry_point(dir, u_point);
                let (pdf_emit, pdf_direct) = self.environment_pdfs(sphere, towards);
                Some(Emission {
                    ray: Ray::new(origin, dir),
                    beta: self.environment_radiance(towards) / (p_light * pdf_emit),
                    origin: None,
                    pdf_emit: p_light * pdf_emit,
                    pdf_direct: p_light * pdf_direct,
                    cos_light: 1.0,
                    delta: false,
                    infinite: true,
                })
            }
            Light::Quad { radiance, .. } => {
                let (hit, area) = self.area_point(u_point)?;
                area_emission(hit, area, 1.0 / area, radiance, None, u_dir, p_light)
            }
            Light::Sphere { radius, radiance, .. } => {
                let (hit, area) = self.area_point(u_point)?;
                // Next-event estimation samples the hemisphere facing the shading point, which
                // every emitted ray's next vertex is in.
                let direct = 1.0 / (2.0 * PI * radius * radius);
                area_emission(hit, area, direct, radiance, None, u_dir, p_light)
            }
            Light::Surface { one_sided, .. } => {
                let (hit, area) = self.area_point(u_point)?;
                let radiance = self.emitted(&hit, hit.n);
                let side = (!one_sided).then_some(side);
                area_emission(hit, area, 1.0 / area, radiance, side, u_dir, p_light)
            }
        }
    }

    /// A point of an area light uniformly distributed over its whole surface (both hemispheres
    /// of a sphere), as an emitter hit (its outward normal, texture coordinates and error
    /// bound), with the light's area: the reciprocal of the point's area density. `None` for
    /// delta lights and the environment. Light paths start there ([`Light::emit`]), and manifold
    /// next-event estimation connects through glass from there ([`crate::manifold`]).
    pub fn area_point(&self, u_point: Vec2) -> Option<(SurfaceHit, f32)> {
        match *self {
            Light::Quad { corner, u, v, normal, .. } => {
                let p = corner + u_point.x * u + u_point.y * v;
                let error = point_error(p, (u.abs() + v.abs()).max_element(), 8);
                Some((emitter_point(p, normal, Vec2::ZERO, error), u.cross(v).length()))
            }
            Light::Sphere { center, radius, .. } => {
                let n = uniform_sphere(u_point);
                let p = center + radius * n;
                let hit = emitter_point(p, n, Vec2::ZERO, point_error(p, radius, 8));
                Some((hit, 4.0 * PI * radius * radius))
            }
            Light::Surface { ref shape, ref texture, .. } => {
                let (p, n) = shape.sample(u_point);
                let uv = if texture.is_some() { shape.uv_at(u_point, p, n) } else { Vec2::ZERO };
                Some((emitter_point(p, n, uv, point_error(p, shape.extent(), 8)), shape.point_area(n)))
            }
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Environment { .. } => None,
        }
    }

    /// The radiant intensity (W/sr) of a point or spot light towards the unit direction `dir`;
    /// zero for every other light.
    pub fn intensity_towards(&self, dir: Vec3) -> Vec3 {
        match self {
            Light::Point { intensity, .. } => *intensity,
            Light::Spot { direction, intensity, beam, .. } => *intensity * beam.falloff(dir.dot(*direction)),
            _ => Vec3::ZERO,
        }
    }

    /// The densities of the other strategies for light leaving the point `y` (normal `n`) of this
    /// area light towards `wo`, reached by a ray from `from`: `(pdf_emit, pdf_direct)` as in
    /// [`Emission`], without the light's selection probability. (0, 0) for a delta light and the
    /// environment.
    pub fn emission_pdfs(&self, from: Vec3, y: Vec3, n: Vec3, wo: Vec3) -> (f32, f32) {
        let cos = n.dot(wo).abs();
        let (area, sides) = match self {
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Environment { .. } => return (0.0, 0.0),
            Light::Quad { u, v, .. } => (u.cross(*v).length(), 1.0),
            Light::Sphere { radius, .. } => (4.0 * PI * radius * radius, 1.0),
            Light::Surface { shape, one_sided, .. } => {
                (shape.point_area(n), if *one_sided { 1.0 } else { 2.0 })
            }
        };
        let d = y - from;
        let direct = self.pdf_li(from, y, n) * cos / d.length_squared();
        (cos / (PI * area * sides), direct)
    }

    /// The densities of the other strategies for a next-event sample of this delta light at
    /// `distance` from the shading point (its direction within the light's emission):
    /// `(direct, emit)` without the light's selection probability, in the measures of SmallVCM's
    /// `Illuminate` — `direct` the density of next-event estimation turned per solid angle (a
    /// delta of unit area density at a finite distance: `distance²`; a direction: 1), `emit` the
    /// density of the emitted ray (`1/(4π)` for a point light, the cone's for a spot, `1/(π R²)`
    /// of `sphere`'s disk for a directional light). `None` for lights that are not delta lights.
    pub fn delta_pdfs(&self, sphere: &SceneSphere, distance: f32) -> Option<(f32, f32)> {
        match self {
            Light::Point { .. } => Some((distance * distance, 1.0 / (4.0 * PI))),
            Light::Spot { beam, .. } => Some((distance * distance, beam.pdf())),
            Light::Directional { .. } => Some((1.0, sphere.disk_pdf())),
            _ => None,
        }
    }

    /// The densities of the other strategies for light arriving from this environment from the
    /// unit direction `towards` (pointing away from the scene): `(pdf_emit, pdf_direct)` as in
    /// [`Emission`] without the light's selection probability, the solid-angle density of the
    /// direction times `1/(π R²)`, and that density itself (next-event estimation); for a
    /// constant environment `1/(4π) · 1/(π R²)` and `1/(4π)`.
    pub fn environment_pdfs(&self, sphere: &SceneSphere, towards: Vec3) -> (f32, f32) {
        let direct = self.environment_pdf(towards);
        (direct * sphere.disk_pdf(), direct)
    }

    /// The radiance arriving from the unit direction `towards` (pointing away from the scene)
    /// when this is the environment; zero for every other light.
    #[inline]
    pub fn environment_radiance(&self, towards: Vec3) -> Vec3 {
        match self {
            Light::Environment { radiance, map: None } => *radiance,
            Light::Environment { radiance, map: Some(map) } => *radiance * map.radiance(towards),
            _ => Vec3::ZERO,
        }
    }

    /// The solid-angle density with which the environment's direction sampling returns
    /// `towards`: `1/(4π)` without a map, the map's density with one (0 for other lights).
    #[inline]
    pub fn environment_pdf(&self, towards: Vec3) -> f32 {
        match self {
            Light::Environment { map: None, .. } => 1.0 / (4.0 * PI),
            Light::Environment { map: Some(map), .. } => map.pdf(towards),
            _ => 0.0,
        }
    }

    /// A direction towards the environment with its solid-angle density: uniform over the sphere
    /// without a map, by the map's distribution with one.
    fn sample_environment(&self, u: Vec2) -> Option<(Vec3, f32)> {
        match self {
            Light::Environment { map: Some(map), .. } => map.sample(u),
            _ => Some((uniform_sphere(u), 1.0 / (4.0 * PI))),
        }
    }

    /// Whether the light has an area (and so casts soft shadows).
    pub fn is_area(&self) -> bool {
        !self.is_delta()
    }

    /// Whether the light is a delta light (point, spot, directional): no ray can hit it.
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. })
    }

    /// Radiance leaving the emitter's surface at the point `at` (its outward normal, and its
    /// texture coordinates for a textured emitter) towards `wo`.
    pub fn emitted(&self, at: &SurfaceHit, wo: Vec3) -> Vec3 {
        match self {
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Environment { .. } => Vec3::ZERO,
            Light::Surface { one_sided: true, .. } if at.n.dot(wo) <= 0.0 => Vec3::ZERO,
            Light::Surface { radiance, texture: None, .. } => *radiance,
            Light::Surface { radiance, texture: Some(t), .. } => *radiance * t.eval(at.p, at.uv),
            Light::Quad { radiance, .. } | Light::Sphere { radiance, .. } => {
                front_emitted(at.n, wo, *radiance)
            }
        }
    }

    /// A random point on the light for shading point `p`, seen as a point source: its position
    /// and the intensity towards `p` divided by the sampling density, so that `I·cos θ_p / d²`
    /// is an unbiased estimate of the irradiance at `p` (area sampling, pdf = 1/area; spheres
    /// sample the hemisphere facing `p`). Delta lights return themselves.
    pub fn sample_point(&self, p: Vec3, u: Vec2) -> PointIllumination {
        match self {
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Directional { .. }
            | Light::Environment { .. } => self.as_point_from(p),
            Light::Surface { shape, texture, one_sided, .. } => {
                let (y, n) = shape.sample(u);
                let cos = (p - y).normalize_or_zero().dot(n);
                let cos = if *one_sided { cos.max(0.0) } else { cos.abs() };
                let uv = if texture.is_some() { shape.uv_at(u, y, n) } else { Vec2::ZERO };
                let radiance = self.emitted(&emitter_point(y, n, uv, 0.0), n);
                PointIllumination { position: y, intensity: radiance * shape.point_area(n) * cos }
            }
            Light::Quad { corner, u: eu, v: ev, normal, radiance } => {
                let y = *corner + u.x * *eu + u.y * *ev;
                let area = eu.cross(*ev).length();
                let cos = (p - y).normalize_or_zero().dot(*normal).max(0.0);
                PointIllumination { position: y, intensity: *radiance * area * cos }
            }
            Light::Sphere { center, radius, radiance } => {
                let axis = (p - *center).normalize_or(Vec3::Y);
                let (t, b) = axis.any_orthonormal_pair();
                // uniform on the hemisphere around `axis`
                let z = u.x;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * PI * u.y;
                let n = t * (r * phi.cos()) + b * (r * phi.sin()) + axis * z;
                let y = *center + *radius * n;
                let cos = (p - y).normalize_or_zero().dot(n).max(0.0);
                PointIllumination { position: y, intensity: *radiance * (2.0 * PI * radius * radius) * cos }
            }
        }
    }

    /// The light's kind in words: `point`, `spot`, `directional`, `quad`, `sphere`, `emissive
    /// object` or `environment`.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Light::Point { .. } => "point",
            Light::Spot { .. } => "spot",
            Light::Directional { .. } => "directional",
            Light::Quad { .. } => "quad",
            Light::Sphere { .. } => "sphere",
            Light::Surface { .. } => "emissive object",
            Light::Environment { .. } => "environment",
        }
    }

    /// Whether `p` lies strictly inside the light's emitting sphere or cylinder (their centres,
    /// where [`Light::as_point_from`] puts their point stand-ins): a shadow ray towards such a
    /// point reaches the light where it meets its surface.
    pub fn encloses(&self, p: Vec3) -> bool {
        match self {
            Light::Sphere { center, radius, .. } => encloses_sphere(*center, *radius, p),
            Light::Surface { shape, .. } => shape.encloses(p),
            _ => false,
        }
    }

    /// The light as the deterministic methods (raycast, whitted) see it from point `p`: a point
    /// light as itself; a spot as a point light of its intensity towards `p`; a directional light
    /// as a point far beyond the scene against its direction, at distance `D = 10⁶·(1 + |p|∞)`
    /// with intensity `E·D²` (so `I/D² = E`); an area quad as a point at its centre with the intensity of a Lambertian
    /// emitter in that direction, `L·A·cos θ`; a sphere as a point at its centre with intensity
    /// `L·πr²` (exact in the far field, no penumbra); a cylinder as a point on its axis halfway
    /// with the intensity of its outline, `L·(2rh·sin θ + πr²·|cos θ|)` (the cap term with caps);
    /// an emitting disk, quad or mesh as a point with its projected area, that of its front
    /// alone when it emits on one side.
    pub fn as_point_from(&self, p: Vec3) -> PointIllumination {
        match self {
            Light::Point { position, .. } | Light::Spot { position, .. } => PointIllumination {
                position: *position,
                intensity: self.intensity_towards((p - *position).normalize_or_zero()),
            },
            Light::Directional { direction, irradiance } => {
                let distance = DIRECTIONAL_STAND_IN * (1.0 + p.abs().max_element());
                PointIllumination {
                    position: p - *direction * distance,
                    intensity: *irradiance * (distance * distance),
                }
            }
            Light::Quad { corner, u, v, normal, radiance } => {
                let centre = *corner + 0.5 * (*u + *v);
                let area = u.cross(*v).length();
                let to_p = (p - centre).normalize_or_zero();
                let cos = to_p.dot(*normal).max(0.0);
                PointIllumination { position: centre, intensity: *radiance * area * cos }
            }
            Light::Sphere { center, radius, radiance } => {
                PointIllumination { position: *center, intensity: *radiance * PI * radius * radius }
            }
            Light::Surface { shape, texture, one_sided, .. } => {
                let centre = shape.centre();
                let (y, n) = shape.sample(Vec2::splat(0.5));
                let uv = if texture.is_some() { shape.uv_at(Vec2::splat(0.5), y, n) } else { Vec2::ZERO };
                let radiance = self.emitted(&emitter_point(centre, n, uv, 0.0), n);
                let to_p = (p - centre).normalize_or_zero();
                PointIllumination {
                    position: centre,
                    intensity: shape.outline_intensity(radiance, to_p, *one_sided),
                }
            }
            // The deterministic methods see the environment only where rays leave the scene.
            Light::Environment { .. } => PointIllumination { position: p + Vec3::Y, intensity: Vec3::ZERO },
        }
    }
}

/// The distance, per unit of a shading point's largest coordinate (plus one), at which the
/// deterministic methods place a directional light's point stand-in ([`Light::as_point_from`]):
/// beyond any object of a sensible scene.
const DIRECTIONAL_STAND_IN: f32 = 1e6;

/// A point on an emitter with texture coordinates `uv` as a surface hit (for spawning rays from
/// it and reading its emission).
fn emitter_point(p: Vec3, n: Vec3, uv: Vec2, p_error: f32) -> SurfaceHit {
    SurfaceHit { t: 0.0, p, n, shading_n: n, uv, p_error }
}

/// Emission from a Lambertian emitter of area `area` at `hit`: a cosine-distributed direction
/// about the normal, or for a two-sided emitter (`side` given) about the normal's side `side`
/// picks with probability ½ each. β = L·|cos| / (p_light · (1/area) · (|cos|/π) · p_side).
/// `direct` is the area density with which next-event estimation picks `hit`.
fn area_emission(
    hit: SurfaceHit,
    area: f32,
    direct: f32,
    radiance: Vec3,
    side: Option<f32>,
    u_dir: Vec2,
    p_light: f32,
) -> Option<Emission> {
    let local = cosine_hemisphere(u_dir);
    if local.z <= 0.0 || area <= 0.0 {
        return None;
    }
    let (facing, sides) = match side {
        Some(s) if s >= 0.5 => (-hit.n, 2.0),
        Some(_) => (hit.n, 2.0),
        None => (hit.n, 1.0),
    };
    let dir = Frame::from_normal(facing).to_world(local);
    Some(Emission {
        ray: Ray::new(spawn_origin(&hit, dir), dir),
        beta: radiance * (PI * area * sides / p_light),
        origin: Some((hit, area / p_light)),
        pdf_emit: p_light * local.z / (PI * area * sides),
        pdf_direct: p_light * direct,
        cos_light: local.z,
        delta: false,
        infinite: false,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2::{self, ChiSquare};

    /// Number of chi-square cases run here (counted in the Šidák correction).
    pub(crate) const CHI2_CASES: usize = 10;

    #[test]
    fn only_the_inside_of_a_sphere_is_enclosed() {
        let center = Vec3::new(0.5, 1.0, -2.0);
        let sphere = Light::Sphere { center, radius: 0.05, radiance: Vec3::ONE };
        let ball = Light::Surface {
            shape: EmitterShape::sphere(center, 0.05),
            radiance: Vec3::ONE,
            texture: None,
            one_sided: false,
        };
        for light in [&sphere, &ball] {
            assert!(light.encloses(center));
            assert!(light.encloses(center + Vec3::new(0.0, 0.049, 0.0)));
            // Sampled surface points, roundoff included, are outside.
            for k in 0..100 {
                let (p, _) = EmitterShape::sphere(center, 0.05)
                    .sample(Vec2::new(k as f32 / 100.0, (k as f32 * 0.618).fract()));
                assert!(!light.encloses(p), "{p}");
            }
            assert!(!light.encloses(center + Vec3::X));
        }
        let quad =
            Light::Quad { corner: Vec3::ZERO, u: Vec3::X, v: Vec3::Z, normal: -Vec3::Y, radiance: Vec3::ONE };
        assert!(!quad.encloses(Vec3::new(0.5, 0.0, 0.5)));
        // A cylinder encloses its axis between its ends (its stand-in is halfway along it), not
        // its sampled surface points nor what lies beyond its ends or its wall.
        let shape = cylinder_emitter(center, Vec3::new(0.2, 1.0, 0.0), 0.3, 1.0, false);
        let tube =
            Light::Surface { shape: shape.clone(), radiance: Vec3::ONE, texture: None, one_sided: true };
        assert!(tube.encloses(shape.centre()));
        for k in 0..100 {
            let (p, _) = shape.sample(Vec2::new(k as f32 / 100.0, (k as f32 * 0.618).fract()));
            assert!(!tube.encloses(p), "{p}");
        }
        let axis = Vec3::new(0.2, 1.0, 0.0).normalize();
        assert!(!tube.encloses(center - 0.1 * axis) && !tube.encloses(center + 1.1 * axis));
        assert!(!tube.encloses(shape.centre() + 0.4 * Vec3::Z));
    }

    /// Distances along `p + t·w` (t > 0) at which the ray meets the sphere.
    fn sphere_hits(p: Vec3, w: Vec3, center: Vec3, radius: f32) -> Vec<f32> {
        let oc = p - center;
        let b = oc.dot(w);
        let disc = b * b - (oc.length_squared() - radius * radius);
        if disc <= 0.0 {
            return Vec::new();
        }
        let q = disc.sqrt();
        [-b - q, -b + q].into_iter().filter(|&t| t > 0.0).collect()
    }

    /// Distance along `p + t·w` to the plane through `origin` with normal `n`, if ahead.
    fn plane_hit(p: Vec3, w: Vec3, origin: Vec3, n: Vec3) -> Option<f32> {
        let t = (origin - p).dot(n) / w.dot(n);
        (t > 0.0 && t.is_finite()).then_some(t)
    }

    /// The parallelogram `corner + a·u + b·v` met by `p + t·w`, as the point and its distance.
    fn parallelogram_hit(p: Vec3, w: Vec3, corner: Vec3, u: Vec3, v: Vec3) -> Option<Vec3> {
        let n = u.cross(v).normalize();
        let y = p + w * plane_hit(p, w, corner, n)?;
        // Coordinates of y in the (u, v) basis.
        let d = y - corner;
        let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
        let det = uu * vv - uv * uv;
        let a = (d.dot(u) * vv - d.dot(v) * uv) / det;
        let b = (d.dot(v) * uu - d.dot(u) * uv) / det;
        ((0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)).then_some(y)
    }

    /// The solid-angle density with which `sample_li` from `p` returns the direction `w`: the sum
    /// of `pdf_li` over every point of the light along `w` that `sample_li` can return (one that
    /// emits towards `p`), found by intersecting the ray with the light's shape independently.
    fn direction_pdf(light: &Light, p: Vec3, w: Vec3) -> f32 {
        let points: Vec<(Vec3, Vec3)> = match *light {
            Light::Environment { .. } => return light.environment_pdf(w),
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } => return 0.0,
            Light::Quad { corner, u, v, normal, .. } => {
                parallelogram_hit(p, w, corner, u, v).map(|y| (y, normal)).into_iter().collect()
            }
            Light::Sphere { center, radius, .. }
            | Light::Surface { shape: EmitterShape::Sphere { center, radius, .. }, .. } => {
                sphere_hits(p, w, center, radius)
                    .into_iter()
                    .map(|t| {
                        let y = p + w * t;
                        (y, (y - center) / radius)
                    })
                    .collect()
            }
            Light::Surface { shape: EmitterShape::Quad { corner, u, v }, .. } => {
                parallelogram_hit(p, w, corner, u, v)
                    .map(|y| (y, u.cross(v).normalize()))
                    .into_iter()
                    .collect()
            }
            Light::Surface {
                shape: EmitterShape::Disk { center, normal, radius, inner_radius, .. }, ..
            } => plane_hit(p, w, center, normal)
                .map(|t| p + w * t)
                .filter(|y| (inner_radius..=radius).contains(&(*y - center).length()))
                .map(|y| (y, normal))
                .into_iter()
                .collect(),
            Light::Surface {
                shape: EmitterShape::Cylinder { base, axis, radius, height, caps, .. }, ..
            } => {
                // Every crossing of the wall and of the caps, by the geometry's own intersection.
                let ray = Ray::new(p, w);
                let wall = crate::geometry::Cylinder::new(base, axis, radius, height);
                let mut points = Vec::new();
                let mut t = 0.0;
                while let Some(hit) = wall.intersect(&ray, t, f32::INFINITY) {
                    points.push((p + w * hit, wall.surface(&ray, hit).n));
                    t = hit;
                }
                if caps.is_some() {
                    for (center, n) in [(base, -axis), (base + height * axis, axis)] {
                        let cap = crate::geometry::Disk::new(center, n, radius, 0.0);
                        if let Some(hit) = cap.intersect(&ray, 0.0, f32::INFINITY) {
                            points.push((p + w * hit, n));
                        }
                    }
                }
                points
            }
            Light::Surface { shape: EmitterShape::Affine(_), .. } => unreachable!("no affine light here"),
            Light::Surface { shape: EmitterShape::Mesh(ref mesh), .. } => mesh
                .corners()
                .iter()
                .filter_map(|&[a, b, c]| {
                    let t = crate::geometry::Triangle::new(a, b, c);
                    let hit = t.intersect(&Ray::new(p, w), 0.0, f32::INFINITY)?;
                    Some((p + w * hit, t.normal()))
                })
                .collect(),
        };
        points
            .into_iter()
            .filter(|&(y, n)| {
                light.emitted(&emitter_point(y, n, Vec2::ZERO, 0.0), (p - y).normalize()) != Vec3::ZERO
            })
            .map(|(y, n)| light.pdf_li(p, y, n))
            .sum()
    }

    /// A cylinder emitter from `base` along `axis` (normalised), with caps if `caps`, with the
    /// texture frames the geometry's own wall and disks get.
    fn cylinder_emitter(base: Vec3, axis: Vec3, radius: f32, height: f32, caps: bool) -> EmitterShape {
        use crate::geometry::{Cylinder, Disk};
        let wall = Cylinder::new(base, axis, radius, height);
        let axis = wall.axis();
        let frames = [
            Disk::new(base, -axis, radius, 0.0).texture_frame(),
            Disk::new(base + height * axis, axis, radius, 0.0).texture_frame(),
        ];
        EmitterShape::Cylinder {
            base,
            axis,
            radius,
            height,
            frame: wall.texture_frame(),
            caps: caps.then_some(frames),
            inward: false,
        }
    }

    #[test]
    fn sampled_cylinder_points_are_uniform_by_area_and_carry_the_uv_a_ray_hit_there_gets() {
        use crate::geometry::{Cylinder, Disk, Shape};
        use rand::{RngExt, SeedableRng};
        let (base, axis, radius, height) = (Vec3::new(0.2, -0.3, 0.5), Vec3::new(0.3, 1.0, -0.4), 0.7, 1.9);
        let emitter = cylinder_emitter(base, axis, radius, height, true);
        let axis = axis.normalize();
        // The wall and the caps as a closed cylinder's primitives.
        let shapes = [
            Shape::Cylinder(Box::new(Cylinder::new(base, axis, radius, height))),
            Shape::Disk(Box::new(Disk::new(base, -axis, radius, 0.0))),
            Shape::Disk(Box::new(Disk::new(base + height * axis, axis, radius, 0.0))),
        ];
        let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
        let count = 20_000;
        let mut on_caps = 0;
        for _ in 0..count {
            let u = Vec2::new(rng.random(), rng.random());
            let (p, n) = emitter.sample(u);
            // On the surface, with the outward normal.
            let z = (p - base).dot(axis);
            let radial = p - base - z * axis;
            if n.dot(axis).abs() > 0.5 {
                on_caps += 1;
                assert!(z.abs() < 1e-5 || (z - height).abs() < 1e-5, "{p}");
                assert!(radial.length() <= radius * (1.0 + 1e-6));
                assert!((n - axis * (z - 0.5 * height).signum()).length() < 1e-6);
            } else {
                assert!((radial.length() - radius).abs() < 1e-5 && (-1e-5..=height + 1e-5).contains(&z));
                assert!((n - radial / radius).length() < 1e-5);
            }
            // A ray from outside along the normal meets the point first, with the same uv.
            let origin = p + n * 3.0;
            let ray = Ray::new(origin, (p - origin).normalize());
            let (t, shape) = shapes
                .iter()
                .filter_map(|s| s.intersect(&ray, 0.0, f32::INFINITY).map(|t| (t, s)))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .expect("the ray hits the sampled point");
            assert!((t - 3.0).abs() < 1e-4, "{t}");
            let hit = shape.surface(&ray, t);
            let uv = emitter.uv_at(u, p, n);
            let d = (hit.uv - uv).abs();
            let d = Vec2::new(d.x.min(1.0 - d.x), d.y);
            assert!(d.max_element() < 2e-4, "hit {} vs sampled {uv} at {p}", hit.uv);
        }
        // The caps' share of the area, 2πr² / (2πr² + 2πrh) = r / (r + h), within 4 standard
        // errors of the binomial count.
        let share = radius / (radius + height);
        let error = (share * (1.0 - share) / count as f32).sqrt();
        let measured = on_caps as f32 / count as f32;
        assert!((measured - share).abs() < 4.0 * error, "{measured} vs {share} ± {error}");
        assert!((emitter.area() - 2.0 * PI * radius * (radius + height)).abs() < 1e-4);
    }

    #[test]
    fn an_open_tube_gives_the_irradiance_of_its_closed_form() {
        // At the centre of a tube's bottom opening, facing along the axis, the inner wall of a
        // tube of radiance L fills the directions beyond θ₀ = atan(r/h) from the axis:
        // E = π L (1 − sin²θ₀) = π L h²/(r²+h²). Next-event estimation (two-sided) and its
        // point stand-in agree; one-sided (outward), the inner wall is dark.
        let (r, h) = (0.5f32, 1.2f32);
        let shape = cylinder_emitter(Vec3::ZERO, Vec3::Y, r, h, false);
        let expected = PI * h * h / (r * r + h * h);
        let p = Vec3::new(0.0, 1e-4, 0.0);
        let two =
            Light::Surface { shape: shape.clone(), radiance: Vec3::ONE, texture: None, one_sided: false };
        let e = irradiance(&two, p, Vec3::Y, 400);
        assert!((e - expected).abs() / expected < 2e-3, "{e} vs {expected}");
        let mut direct = 0.0;
        for i in 0..400 {
            for j in 0..400 {
                let u = Vec2::new((i as f32 + 0.5) / 400.0, (j as f32 + 0.5) / 400.0);
                if let Some(s) = two.sample_li(p, u) {
                    direct += s.radiance.x * s.wi.y.max(0.0) / s.pdf;
                }
            }
        }
        direct /= 160_000.0;
        assert!((direct - expected).abs() / expected < 2e-3, "{direct} vs {expected}");
        let one = Light::Surface { shape, radiance: Vec3::ONE, texture: None, one_sided: true };
        assert_eq!(irradiance(&one, p, Vec3::Y, 50), 0.0);
        assert!((0..100).all(|k| one.sample_li(p, Vec2::new(k as f32 / 100.0, 0.37)).is_none()));
        // Its power: π·A·L one-sided, twice that two-sided.
        let area = 2.0 * PI * r * h;
        assert!((one.strength().value().x - PI * area).abs() < 1e-4);
        assert!((two.strength().value().x - 2.0 * PI * area).abs() < 1e-4);
    }

    #[test]
    fn a_one_sided_emitter_emits_only_along_its_normal_with_the_densities_it_reports() {
        // Emitted rays leave on the normal's side whatever `side` asks, with the density that
        // `emission_pdfs` gives the same ray reached from its next vertex (one side: cos/(π A)).
        let shape = cylinder_emitter(Vec3::new(0.1, 0.0, 0.2), Vec3::new(0.0, 1.0, 0.3), 0.4, 0.9, true);
        let light = Light::Surface { shape, radiance: Vec3::splat(2.0), texture: None, one_sided: true };
        let sphere = SceneSphere::around(Vec3::splat(-3.0), Vec3::splat(3.0));
        for k in 0..200 {
            let u_point = Vec2::new((k as f32 * 0.618).fract(), (k as f32 * 0.377).fract());
            let u_dir = Vec2::new((k as f32 * 0.291).fract(), (k as f32 * 0.733).fract());
            let e = light.emit(0.5, (k % 2) as f32, u_point, u_dir, &sphere).unwrap();
            let (hit, _) = e.origin.unwrap();
            assert!(e.ray.dir.dot(hit.n) > 0.0);
            let from = hit.p + e.ray.dir * 2.0;
            let (emit, direct) = light.emission_pdfs(from, hit.p, hit.n, e.ray.dir);
            assert!((0.5 * emit - e.pdf_emit).abs() <= 1e-5 * e.pdf_emit, "{emit} vs {}", e.pdf_emit);
            // Next-event estimation from the next vertex picks the point with area density 1/A.
            let area = light_area(&light);
            assert!((direct * area - 1.0).abs() < 1e-3, "{direct} vs {}", 1.0 / area);
            assert!((0.5 * direct - e.pdf_direct).abs() <= 1e-3 * e.pdf_direct);
            assert!((e.beta.x - 2.0 * PI * light_area(&light) / 0.5).abs() < 1e-3 * e.beta.x);
            // Emission towards the back is zero.
            assert_eq!(light.emitted(&hit, -e.ray.dir), Vec3::ZERO);
            assert_eq!(light.emitted(&hit, e.ray.dir), Vec3::splat(2.0));
        }
    }

    /// The area of a surface light.
    fn light_area(light: &Light) -> f32 {
        match light {
            Light::Surface { shape, .. } => shape.area(),
            _ => unreachable!("a surface light"),
        }
    }

    #[test]
    fn sampled_emitter_points_carry_the_uv_a_ray_hit_there_gets() {
        use crate::geometry::{Disk, Quad, Shape, Sphere};
        use rand::{RngExt, SeedableRng};
        let (center, normal) = (Vec3::new(0.2, -0.3, 0.5), Vec3::new(0.3, 1.0, -0.4).normalize());
        let (corner, eu, ev) =
            (Vec3::new(-1.0, 0.5, 0.0), Vec3::new(2.0, 0.0, 0.3), Vec3::new(0.0, 1.5, 0.0));
        let cases: [(EmitterShape, Shape); 3] = [
            (EmitterShape::sphere(center, 0.7), Shape::Sphere(Box::new(Sphere::new(center, 0.7)))),
            (
                EmitterShape::disk(center, normal, 0.9, 0.2),
                Shape::Disk(Box::new(Disk::new(center, normal, 0.9, 0.2))),
            ),
            (EmitterShape::Quad { corner, u: eu, v: ev }, Shape::Quad(Box::new(Quad::new(corner, eu, ev)))),
        ];
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        for (emitter, shape) in &cases {
            for _ in 0..500 {
                let u = Vec2::new(rng.random(), rng.random());
                let (p, n) = emitter.sample(u);
                // A ray towards the point from outside, along the normal's side.
                let origin = p + n * 3.0;
                let ray = Ray::new(origin, (p - origin).normalize());
                let t = shape.intersect(&ray, 0.0, f32::INFINITY).expect("the ray hits the sampled point");
                let hit = shape.surface(&ray, t);
                let uv = emitter.uv_at(u, p, n);
                // Away from the angular seam, the two agree to roundoff.
                let d = (hit.uv - uv).abs();
                let d = Vec2::new(d.x.min(1.0 - d.x), d.y);
                assert!(d.max_element() < 2e-4, "{emitter:?}: hit {} vs sampled {uv}", hit.uv);
            }
        }
    }

    #[test]
    fn chi2_light_sampling_matches_pdf() {
        let p = Vec3::new(0.1, 0.0, -0.2);
        let lights = [
            Light::Quad {
                corner: Vec3::new(-1.0, 0.5, -1.0),
                u: Vec3::new(2.0, 0.0, 0.0),
                v: Vec3::new(0.0, 0.3, 2.0),
                // u × v faces down, towards p.
                normal: Vec3::new(2.0, 0.0, 0.0).cross(Vec3::new(0.0, 0.3, 2.0)).normalize(),
                radiance: Vec3::ONE,
            },
            Light::Sphere { center: Vec3::new(0.3, 1.4, 0.2), radius: 1.0, radiance: Vec3::ONE },
            // An emissive ball sampled uniformly by area, seen from inside (a closed emitter). From
            // outside, its density d²/cos has an integrable singularity at the silhouette on both
            // the near and the far side, where the cell quadrature reaches only 0.99984 of the
            // exact mass 1 and so cannot judge the samples.
            Light::Surface {
                shape: EmitterShape::sphere(Vec3::new(0.3, 0.4, 0.2), 1.0),
                radiance: Vec3::ONE,
                texture: None,
                one_sided: false,
            },
            Light::Surface {
                shape: EmitterShape::Quad {
                    corner: Vec3::new(-1.0, -0.6, -1.0),
                    u: Vec3::new(0.0, 0.2, 2.0),
                    v: Vec3::new(2.0, 0.0, 0.0),
                },
                radiance: Vec3::ONE,
                texture: None,
                // u × v faces up, towards p: emitting on that side only, as Mitsuba's area light.
                one_sided: true,
            },
            Light::Surface {
                shape: EmitterShape::disk(
                    Vec3::new(0.0, 0.4, 0.0),
                    Vec3::new(0.3, 1.0, 0.1).normalize(),
                    1.0,
                    0.3,
                ),
                radiance: Vec3::ONE,
                texture: None,
                one_sided: false,
            },
            Light::Surface {
                shape: EmitterShape::disk(Vec3::new(0.5, 0.1, 0.0), Vec3::X, 2.0, 0.0),
                radiance: Vec3::ONE,
                texture: None,
                one_sided: false,
            },
            // A mesh of three triangles of different sizes and tilts above p, one seen edge-on
            // from behind: each is picked by its share of the area.
            Light::Surface {
                shape: EmitterShape::Mesh(Arc::new(
                    EmitterMesh::new(&[
                        crate::geometry::Triangle::new(
                            Vec3::new(-1.0, 0.6, -1.0),
                            Vec3::new(1.0, 0.8, -1.0),
                            Vec3::new(-1.0, 0.7, 1.0),
                        ),
                        crate::geometry::Triangle::new(
                            Vec3::new(1.0, 0.8, -1.0),
                            Vec3::new(1.2, 1.5, 1.0),
                            Vec3::new(-1.0, 0.7, 1.0),
                        ),
                        crate::geometry::Triangle::new(
                            Vec3::new(0.5, -0.5, 0.5),
                            Vec3::new(0.9, -0.4, 0.5),
                            Vec3::new(0.5, -0.5, 0.9),
                        ),
                    ])
                    .unwrap(),
                )),
                radiance: Vec3::ONE,
                texture: None,
                one_sided: false,
            },
            // A closed cylinder and an open tube, seen from inside (from outside, the silhouette's
            // singular density defeats the quadrature, as for the ball above): the tube's wall
            // and, by their share of the area, its caps.
            Light::Surface {
                shape: cylinder_emitter(Vec3::new(0.3, -0.8, -0.1), Vec3::new(0.2, 1.0, 0.1), 1.0, 1.6, true),
                radiance: Vec3::ONE,
                texture: None,
                one_sided: false,
            },
            Light::Surface {
                shape: cylinder_emitter(
                    Vec3::new(0.5, -0.2, 0.0),
                    Vec3::new(-1.0, 0.2, 0.0),
                    0.6,
                    1.2,
                    false,
                ),
                radiance: Vec3::ONE,
                texture: None,
                one_sided: false,
            },
            Light::Environment { radiance: Vec3::ONE, map: None },
        ];
        let mut results = Vec::new();
        for (k, light) in lights.iter().enumerate() {
            let outcome = ChiSquare::default()
                .seed(500 + k as u64)
                .run(|_, u| light.sample_li(p, u).map(|s| s.wi), |w| direction_pdf(light, p, w));
            results.push((format!("light {k}: {light:?}"), outcome));
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }

    /// Irradiance at `p` (normal `n`) estimated from `k`×`k` stratified light samples.
    fn irradiance(light: &Light, p: Vec3, n: Vec3, k: u32) -> f32 {
        let mut e = 0.0;
        for i in 0..k {
            for j in 0..k {
                let u = Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                let s = light.sample_point(p, u);
                let d = s.position - p;
                e += s.intensity.x * n.dot(d.normalize()).max(0.0) / d.length_squared();
            }
        }
        e / (k * k) as f32
    }

    #[test]
    fn sphere_light_irradiance_matches_the_closed_form() {
        // A Lambertian sphere of radiance L seen from distance d along the normal: E = π L (r/d)².
        let light = Light::Sphere { center: Vec3::new(0.0, 3.0, 0.0), radius: 0.5, radiance: Vec3::ONE };
        let e = irradiance(&light, Vec3::ZERO, Vec3::Y, 400);
        let expected = PI * (0.5f32 / 3.0).powi(2);
        assert!((e - expected).abs() / expected < 2e-3, "{e} vs {expected}");
    }

    #[test]
    fn quad_light_irradiance_matches_the_closed_form() {
        // A unit-radiance square of side 2a centred above p at height h, facing p:
        // E = 4 · (a / √(a²+h²)) · atan(a / √(a²+h²)) (form factor of a square, ×π·L).
        let (a, h) = (0.5f32, 1.0f32);
        let light = Light::Quad {
            corner: Vec3::new(-a, h, -a),
            u: Vec3::new(2.0 * a, 0.0, 0.0),
            v: Vec3::new(0.0, 0.0, 2.0 * a),
            normal: -Vec3::Y,
            radiance: Vec3::ONE,
        };
        let e = irradiance(&light, Vec3::ZERO, Vec3::Y, 400);
        let s = (a * a + h * h).sqrt();
        let expected = 4.0 * (a / s) * (a / s).atan();
        assert!((e - expected).abs() / expected < 2e-3, "{e} vs {expected}");
    }

    #[test]
    fn environment_emission_gives_the_irradiance_of_the_sky() {
        // Light paths from a constant environment L, started on the bounding disk, cross a small
        // disk of radius ρ inside the scene (normal n) from its upper side with the expected flux
        // E·πρ², E = π L: the mean of β over the rays that cross it, divided by πρ², is π L.
        // Every ray starts outside the bounding sphere.
        use rand::{RngExt, SeedableRng};
        let sphere = SceneSphere::around(Vec3::new(-1.0, 0.0, -2.0), Vec3::new(2.0, 1.0, 1.0));
        let env = Light::Environment { radiance: Vec3::splat(0.7), map: None };
        let (centre, n, rho) = (Vec3::new(0.3, 0.6, -0.4), Vec3::new(0.3, 1.0, -0.2).normalize(), 0.4);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let count = 400_000;
        let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
        for _ in 0..count {
            let u = |rng: &mut rand_pcg::Pcg64| Vec2::new(rng.random(), rng.random());
            let (u_point, u_dir) = (u(&mut rng), u(&mut rng));
            let e = env.emit(0.5, 0.0, u_point, u_dir, &sphere).unwrap();
            assert!((e.ray.origin - sphere.centre).length() >= sphere.radius * 0.9999);
            assert!(e.infinite && !e.delta && e.origin.is_none());
            let mut x = 0.0;
            if e.ray.dir.dot(n) < 0.0 {
                let t = (centre - e.ray.origin).dot(n) / e.ray.dir.dot(n);
                if (e.ray.origin + t * e.ray.dir - centre).length() <= rho {
                    x = e.beta.x as f64;
                }
            }
            sum += x;
            sum_sq += x * x;
        }
        let mean = sum / count as f64;
        let error = ((sum_sq / count as f64 - mean * mean) / count as f64).sqrt();
        let area = std::f64::consts::PI * rho as f64 * rho as f64;
        // β carries 1/p_light (here ½, as if one of two lights): each path stands for two.
        let (estimate, expected) = (mean / area, std::f64::consts::PI * 0.7 / 0.5);
        assert!(
            (estimate - expected).abs() < 4.0 * error / area,
            "irradiance {estimate} vs {expected} (standard error {})",
            error / area
        );
        // The densities the other strategies use are the emitted ray's.
        let (emit, direct) = env.environment_pdfs(&sphere, Vec3::Y);
        let e = env.emit(0.5, 0.0, Vec2::splat(0.3), Vec2::splat(0.6), &sphere).unwrap();
        assert!((e.pdf_emit - 0.5 * emit).abs() < 1e-9 && (e.pdf_direct - 0.5 * direct).abs() < 1e-9);
    }

    /// The irradiance that light paths of `light` (picked with probability ½) bring to the small
    /// disk of radius `rho` at `centre` facing `n`, from its upper side: the mean of β over the
    /// rays that cross it (β counts each path twice, p_light = ½) halved and divided by the
    /// disk's area; with its standard error. Checks on the way that every emission is a delta
    /// light's with the densities `delta_pdfs` gives.
    fn emitted_irradiance(
        light: &Light,
        sphere: &SceneSphere,
        centre: Vec3,
        n: Vec3,
        rho: f32,
    ) -> (f64, f64) {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let count = 400_000;
        let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
        for _ in 0..count {
            let u = |rng: &mut rand_pcg::Pcg64| Vec2::new(rng.random(), rng.random());
            let (u_point, u_dir) = (u(&mut rng), u(&mut rng));
            let mut x = 0.0;
            if let Some(e) = light.emit(0.5, 0.0, u_point, u_dir, sphere) {
                assert!(e.delta && e.origin.is_none());
                let (_, emit) = light.delta_pdfs(sphere, 1.0).unwrap();
                assert!((e.pdf_emit - 0.5 * emit).abs() <= 1e-6 * emit && e.pdf_direct == 0.5);
                if e.ray.dir.dot(n) < 0.0 {
                    let t = (centre - e.ray.origin).dot(n) / e.ray.dir.dot(n);
                    if t > 0.0 && (e.ray.origin + t * e.ray.dir - centre).length() <= rho {
                        x = e.beta.x as f64;
                    }
                }
            }
            sum += x;
            sum_sq += x * x;
        }
        let mean = sum / count as f64;
        let error = ((sum_sq / count as f64 - mean * mean) / count as f64).sqrt();
        // β carries 1/p_light (½): each path stands for two.
        let area = std::f64::consts::PI * rho as f64 * rho as f64;
        (mean * 0.5 / area, error * 0.5 / area)
    }

    #[test]
    fn spot_light_paths_bring_the_irradiance_next_event_estimation_sees() {
        // At a point in the beam, in the transition and beyond the cutoff: light paths bring
        // I·f(θ)·cos/d² to a small disk (within 4 standard errors plus the disk's own variation
        // over its radius, second order), as the next-event sample there says.
        let beam = SpotBeam::from_degrees(30.0, 20.0).unwrap();
        let spot = Light::Spot {
            position: Vec3::new(0.0, 2.0, 0.0),
            direction: Vec3::new(0.0, -1.0, 0.0),
            intensity: Vec3::splat(3.0),
            beam,
        };
        let sphere = SceneSphere::around(Vec3::splat(-3.0), Vec3::splat(3.0));
        for degrees in [10.0f32, 25.0, 35.0] {
            let centre = Vec3::new(2.0 * degrees.to_radians().tan(), 0.0, 0.0);
            let expected = spot.sample_li(centre, Vec2::ZERO).map_or(0.0, |s| s.radiance.x * s.wi.y) as f64;
            if degrees > 30.0 {
                assert_eq!(expected, 0.0);
            }
            let (estimate, error) = emitted_irradiance(&spot, &sphere, centre, Vec3::Y, 0.05);
            assert!(
                (estimate - expected).abs() <= 4.0 * error + 2e-3 * expected,
                "{degrees}°: light paths {estimate} ± {error} vs next-event estimation {expected}"
            );
        }
        // The next-event sample is the delta light's.
        let s = spot.sample_li(Vec3::ZERO, Vec2::splat(0.3)).unwrap();
        assert!(s.delta && s.pdf == 1.0 && (s.distance - 2.0).abs() < 1e-6);
        assert!((s.radiance.x - 3.0 / 4.0).abs() < 1e-6);
    }

    #[test]
    fn directional_light_paths_bring_its_irradiance_times_the_cosine() {
        // Light paths start on the bounding disk facing the light and carry E·π R² / p_light:
        // a small disk inside the sphere tilted by α from the light receives E·cos α.
        let direction = Vec3::new(0.3, -1.0, 0.2).normalize();
        let light = Light::Directional { direction, irradiance: Vec3::splat(0.8) };
        let sphere = SceneSphere::around(Vec3::new(-1.0, 0.0, -2.0), Vec3::new(2.0, 1.0, 1.0));
        let n = Vec3::new(0.2, 1.0, -0.4).normalize();
        let (estimate, error) = emitted_irradiance(&light, &sphere, Vec3::new(0.3, 0.6, -0.4), n, 0.4);
        let expected = 0.8 * f64::from(n.dot(-direction));
        assert!(
            (estimate - expected).abs() <= 4.0 * error,
            "light paths {estimate} ± {error} vs E·cos α = {expected}"
        );
        for k in 0..100 {
            let u = Vec2::new(k as f32 / 100.0, (k as f32 * 0.618).fract());
            let e = light.emit(1.0, 0.0, u, u, &sphere).unwrap();
            assert!(e.infinite && e.ray.dir == direction);
            assert!((e.ray.origin - sphere.centre).length() >= sphere.radius * 0.9999);
        }
        let s = light.sample_li(Vec3::ONE, Vec2::splat(0.5)).unwrap();
        assert!(
            s.delta && s.distance == f32::INFINITY && s.wi == -direction && s.radiance == Vec3::splat(0.8)
        );
        assert!(light.is_delta() && !light.is_area());
        assert_eq!(light.strength(), Strength::Irradiance(Vec3::splat(0.8)));
    }

    #[test]
    fn the_deterministic_methods_see_delta_lights_with_their_irradiance() {
        // I/d² times the cosine at a shading point, as next-event estimation sees it.
        let p = Vec3::new(0.3, 0.0, -0.2);
        let lights = [
            Light::Spot {
                position: Vec3::new(0.0, 2.0, 0.0),
                direction: Vec3::new(0.1, -1.0, 0.0).normalize(),
                intensity: Vec3::splat(3.0),
                beam: SpotBeam::from_degrees(20.0, 5.0).unwrap(),
            },
            Light::Directional {
                direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
                irradiance: Vec3::splat(0.8),
            },
        ];
        for light in &lights {
            let s = light.sample_li(p, Vec2::ZERO).unwrap();
            let point = light.as_point_from(p);
            let d = point.position - p;
            let stand_in = point.intensity.x / d.length_squared();
            assert!(
                (stand_in - s.radiance.x).abs() <= 1e-5 * s.radiance.x,
                "{light:?}: {stand_in} vs {}",
                s.radiance.x
            );
            assert!((d.normalize() - s.wi).length() < 1e-5);
        }
    }
}
