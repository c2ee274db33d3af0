//! Light sources: isotropic point lights and one-sided area quads.

use glam::Vec3;

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
}

/// What one light contributes at a shading point, seen as a point source.
#[derive(Clone, Copy, Debug)]
pub struct PointIllumination {
    /// Where the light arrives from.
    pub position: Vec3,
    /// Radiant intensity towards the shading point (W/sr).
    pub intensity: Vec3,
}

impl Light {
    /// Total emitted power (W), used for statistics and light selection.
    pub fn power(&self) -> Vec3 {
        match self {
            Light::Point { intensity, .. } => 4.0 * std::f32::consts::PI * *intensity,
            Light::Quad { u, v, radiance, .. } => std::f32::consts::PI * u.cross(*v).length() * *radiance,
        }
    }

    /// The light as the deterministic methods (raycast, whitted) see it from point `p`: a point
    /// light as itself; an area quad as a point at its centre with the intensity of a Lambertian
    /// emitter in that direction, `L·A·cos θ` (exact in the far field, no penumbra).
    pub fn as_point_from(&self, p: Vec3) -> PointIllumination {
        match self {
            Light::Point { position, intensity } => {
                PointIllumination { position: *position, intensity: *intensity }
            }
            Light::Quad { corner, u, v, normal, radiance } => {
                let centre = *corner + 0.5 * (*u + *v);
                let area = u.cross(*v).length();
                let to_p = (p - centre).normalize_or_zero();
                let cos = to_p.dot(*normal).max(0.0);
                PointIllumination { position: centre, intensity: *radiance * area * cos }
            }
        }
    }
}
