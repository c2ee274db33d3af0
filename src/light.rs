//! Light sources: isotropic point lights and one-sided area quads.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

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
    /// Lambertian spherical emitter; it is also a visible primitive.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f32,
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
    /// Total emitted power (W), as `vitrum info` reports it.
    pub fn power(&self) -> Vec3 {
        match self {
            Light::Point { intensity, .. } => 4.0 * std::f32::consts::PI * *intensity,
            Light::Quad { u, v, radiance, .. } => PI * u.cross(*v).length() * *radiance,
            Light::Sphere { radius, radiance, .. } => 4.0 * PI * PI * radius * radius * *radiance,
        }
    }

    /// Whether the light has an area (and so casts soft shadows).
    pub fn is_area(&self) -> bool {
        !matches!(self, Light::Point { .. })
    }

    /// Radiance leaving the emitter's surface at a point with outward normal `n` towards `wo`.
    pub fn emitted(&self, n: Vec3, wo: Vec3) -> Vec3 {
        match self {
            Light::Point { .. } => Vec3::ZERO,
            Light::Quad { radiance, .. } | Light::Sphere { radiance, .. } => {
                if n.dot(wo) > 0.0 {
                    *radiance
                } else {
                    Vec3::ZERO
                }
            }
        }
    }

    /// A random point on the light for shading point `p`, seen as a point source: its position
    /// and the intensity towards `p` divided by the sampling density, so that `I·cos θ_p / d²`
    /// is an unbiased estimate of the irradiance at `p` (area sampling, pdf = 1/area; spheres
    /// sample the hemisphere facing `p`). Point lights return themselves.
    pub fn sample_point(&self, p: Vec3, u: Vec2) -> PointIllumination {
        match self {
            Light::Point { .. } => self.as_point_from(p),
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

    /// The light as the deterministic methods (raycast, whitted) see it from point `p`: a point
    /// light as itself; an area quad as a point at its centre with the intensity of a Lambertian
    /// emitter in that direction, `L·A·cos θ`; a sphere as a point at its centre with intensity
    /// `L·πr²` (exact in the far field, no penumbra).
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
            Light::Sphere { center, radius, radiance } => {
                PointIllumination { position: *center, intensity: *radiance * PI * radius * radius }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
