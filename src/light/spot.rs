//! The beam of a spot light, as Mitsuba 3's `spot` emitter defines it (`src/emitters/spot.cpp`):
//! the full intensity within `beam_width` of the axis, then a falloff linear in the angle θ
//! from the axis, `(cutoff − θ) / (cutoff − beam_width)`, down to 0 at `cutoff_angle`, and
//! nothing beyond. Light paths leave the spot in a direction uniform over the cone of the
//! cutoff (Mitsuba's `square_to_uniform_cone`), density `1 / (2π (1 − cos cutoff))` per solid
//! angle, weighted by the falloff.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The angular profile of a spot light's beam, about its local +Z axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotBeam {
    /// Half-angle of the cone beyond which the light is black (radians, in (0, π]).
    cutoff: f32,
    /// Half-angle of the core of full intensity (radians, in [0, `cutoff`]).
    beam_width: f32,
    /// The two angles in degrees, as given (written back by the exporter and `vitrum info`).
    degrees: (f32, f32),
    cos_cutoff: f32,
    cos_beam_width: f32,
    /// `1 − cos cutoff`, computed without cancellation for narrow cones.
    one_minus_cos_cutoff: f32,
}

impl SpotBeam {
    /// The default cutoff angle, Mitsuba's (degrees).
    pub const DEFAULT_CUTOFF_DEGREES: f32 = 20.0;

    /// The beam with half-angles `cutoff` and `beam_width` in degrees; `None` unless
    /// 0 < `cutoff` ≤ 180 and 0 ≤ `beam_width` ≤ `cutoff` (the scene compiler reports which).
    pub fn from_degrees(cutoff: f32, beam_width: f32) -> Option<SpotBeam> {
        if !(cutoff > 0.0 && cutoff <= 180.0 && beam_width >= 0.0 && beam_width <= cutoff) {
            return None;
        }
        let degrees = (cutoff, beam_width);
        let (cutoff, beam_width) = (cutoff.to_radians(), beam_width.to_radians());
        let half = (0.5 * cutoff).sin();
        Some(SpotBeam {
            degrees,
            cutoff,
            beam_width,
            cos_cutoff: cutoff.cos(),
            cos_beam_width: beam_width.cos(),
            one_minus_cos_cutoff: 2.0 * half * half,
        })
    }

    /// Mitsuba's default beam width for a cutoff angle: three quarters of it (degrees).
    pub fn default_beam_width(cutoff_degrees: f32) -> f32 {
        cutoff_degrees * 0.75
    }

    /// The cutoff angle in degrees.
    pub fn cutoff_degrees(&self) -> f32 {
        self.degrees.0
    }

    /// The beam width in degrees.
    pub fn beam_width_degrees(&self) -> f32 {
        self.degrees.1
    }

    /// The fraction of the peak intensity emitted at angle θ from the axis, given `cos θ`:
    /// 1 where `cos θ ≥ cos beam_width`, `(cutoff − θ) / (cutoff − beam_width)` in the
    /// transition, 0 where `cos θ ≤ cos cutoff` (Mitsuba's `falloff_curve`).
    pub fn falloff(&self, cos_theta: f32) -> f32 {
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam_width || self.cutoff <= self.beam_width {
            1.0
        } else {
            let theta = cos_theta.clamp(-1.0, 1.0).acos();
            ((self.cutoff - theta) / (self.cutoff - self.beam_width)).clamp(0.0, 1.0)
        }
    }

    /// A direction (local frame, axis +Z) uniformly distributed over the cone of the cutoff.
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let cos_theta = 1.0 - u.x * self.one_minus_cos_cutoff;
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
    }

    /// The solid-angle density of [`sample`](Self::sample) inside the cone,
    /// `1 / (2π (1 − cos cutoff))`.
    pub fn pdf(&self) -> f32 {
        1.0 / (2.0 * PI * self.one_minus_cos_cutoff)
    }

    /// The falloff integrated over the sphere of directions (steradians): the power of a spot of
    /// peak intensity `I` is `I` times this. Inside the beam `2π (1 − cos b)`; the transition
    /// adds `2π ∫_b^c (c − θ)/(c − b) sin θ dθ`; together `2π (1 − cos m · sin h / h)` with
    /// `m = (c + b)/2`, `h = (c − b)/2` (`2π (1 − cos c)` for a hard edge, h = 0).
    pub fn solid_angle(&self) -> f32 {
        let (c, b) = (f64::from(self.cutoff), f64::from(self.beam_width));
        let (m, h) = (0.5 * (c + b), 0.5 * (c - b));
        let sinc = if h > 0.0 { h.sin() / h } else { 1.0 };
        (2.0 * std::f64::consts::PI * (1.0 - m.cos() * sinc)) as f32
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::bsdf::chi2::{self, ChiSquare};

    /// Number of chi-square cases run here (counted in the Šidák correction).
    pub(crate) const CHI2_CASES: usize = 2;

    #[test]
    fn falloff_follows_mitsubas_linear_ramp() {
        let beam = SpotBeam::from_degrees(30.0, 20.0).unwrap();
        let at = |deg: f32| beam.falloff(deg.to_radians().cos());
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(19.9), 1.0);
        for deg in [21.0f32, 25.0, 29.0] {
            let expected = (30.0 - deg) / 10.0;
            assert!((at(deg) - expected).abs() < 1e-4, "{deg}°: {} vs {expected}", at(deg));
        }
        assert_eq!(at(30.5), 0.0);
        assert_eq!(at(120.0), 0.0);
        // A hard edge.
        let hard = SpotBeam::from_degrees(10.0, 10.0).unwrap();
        assert_eq!(hard.falloff(9.9f32.to_radians().cos()), 1.0);
        assert_eq!(hard.falloff(10.1f32.to_radians().cos()), 0.0);
    }

    #[test]
    fn bad_angles_are_refused() {
        assert!(SpotBeam::from_degrees(-5.0, 0.0).is_none());
        assert!(SpotBeam::from_degrees(0.0, 0.0).is_none());
        assert!(SpotBeam::from_degrees(190.0, 10.0).is_none());
        assert!(SpotBeam::from_degrees(20.0, 25.0).is_none());
        assert!(SpotBeam::from_degrees(20.0, -1.0).is_none());
        assert!(SpotBeam::from_degrees(f32::NAN, 1.0).is_none());
        assert!(SpotBeam::from_degrees(180.0, 90.0).is_some());
    }

    #[test]
    fn solid_angle_is_the_integral_of_the_falloff() {
        // Midpoint quadrature of 2π ∫ f(θ) sin θ dθ over [0, π] in f64.
        for (c, b) in [(20.0f32, 15.0f32), (45.0, 0.0), (90.0, 89.0), (10.0, 10.0), (180.0, 120.0)] {
            let beam = SpotBeam::from_degrees(c, b).unwrap();
            let n = 200_000;
            let mut sum = 0.0f64;
            for k in 0..n {
                let theta = std::f64::consts::PI * (k as f64 + 0.5) / n as f64;
                sum += f64::from(beam.falloff(theta.cos() as f32)) * theta.sin();
            }
            let quadrature = 2.0 * std::f64::consts::PI * sum * std::f64::consts::PI / n as f64;
            let exact = f64::from(beam.solid_angle());
            assert!(
                (quadrature - exact).abs() < 1e-4 * exact.max(1e-3),
                "({c}, {b}): {quadrature} vs {exact}"
            );
        }
    }

    #[test]
    fn chi2_cone_sampling_matches_pdf() {
        let mut results = Vec::new();
        for (k, cutoff) in [25.0f32, 120.0].into_iter().enumerate() {
            let beam = SpotBeam::from_degrees(cutoff, 0.5 * cutoff).unwrap();
            let cos_cutoff = cutoff.to_radians().cos();
            let outcome = ChiSquare::default()
                .seed(900 + k as u64)
                .run(|_, u| Some(beam.sample(u)), |w| if w.z > cos_cutoff { beam.pdf() } else { 0.0 });
            results.push((format!("spot cone, cutoff {cutoff}°"), outcome));
        }
        assert_eq!(results.len(), CHI2_CASES);
        chi2::assert_all_pass(&results);
    }
}
