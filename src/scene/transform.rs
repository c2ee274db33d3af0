//! Object transforms: `transform = { scale, rotate = { axis, angle }, translate }`, applied in
//! the order scale, rotate, translate.
//!
//! The shapes are analytic, so a transform is applied once, at compile time, to the numbers that
//! define them (points transformed, directions rotated, lengths scaled) and to every vertex and
//! normal of a mesh; nothing is transformed while rendering.

use glam::{DMat3, DVec3, Mat3, Vec3};

use crate::geometry::try_unit;

/// A compiled transform `p ↦ R·(S·p) + t`: a positive scale per axis, a rotation and a translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Scale per axis (all > 0), applied first.
    pub scale: Vec3,
    /// Rotation matrix, applied second; `None` for no rotation (so that a transform without one
    /// does exactly the arithmetic of a scale and a translation).
    pub rotation: Option<Mat3>,
    /// Translation, applied last.
    pub translate: Vec3,
}

impl Transform {
    /// The transform that changes nothing.
    pub const IDENTITY: Transform = Transform { scale: Vec3::ONE, rotation: None, translate: Vec3::ZERO };

    /// The point `p` transformed: scaled, rotated, translated.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.vector(p) + self.translate
    }

    /// The vector `v` (an edge, a difference of points) scaled and rotated.
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.rotate(v * self.scale)
    }

    /// `v` rotated only.
    #[inline]
    pub fn rotate(&self, v: Vec3) -> Vec3 {
        match self.rotation {
            Some(m) => m * v,
            None => v,
        }
    }

    /// The unit normal `n` of a surface carried along: the inverse transpose of the linear part,
    /// `R·(S⁻¹·n)`, normalised (a positive scale never flips a normal); `None` for a zero `n`.
    #[inline]
    pub fn normal(&self, n: Vec3) -> Option<Vec3> {
        try_unit(self.rotate(n / self.scale))
    }

    /// The scale when it is the same on every axis.
    pub fn uniform_scale(&self) -> Option<f32> {
        let s = self.scale;
        (s.x == s.y && s.y == s.z).then_some(s.x)
    }
}

/// The rotation by `degrees` about the unit `axis` (right-handed: counter-clockwise seen from
/// the tip of the axis), by Rodrigues' formula in double precision. Sine and cosine of whole
/// multiples of 90° are exact, so quarter turns about a coordinate axis map coordinates to
/// coordinates without roundoff.
pub fn rotation(axis: Vec3, degrees: f32) -> Mat3 {
    let k = axis.as_dvec3().normalize();
    let (s, c) = sin_cos_degrees(f64::from(degrees));
    let cross =
        DMat3::from_cols(DVec3::new(0.0, k.z, -k.y), DVec3::new(-k.z, 0.0, k.x), DVec3::new(k.y, -k.x, 0.0));
    let outer = DMat3::from_cols(k * k.x, k * k.y, k * k.z);
    let m = DMat3::IDENTITY * c + cross * s + outer * (1.0 - c);
    m.as_mat3()
}

/// Sine and cosine of an angle in degrees, exact at whole multiples of 90°.
fn sin_cos_degrees(degrees: f64) -> (f64, f64) {
    let turn = degrees.rem_euclid(360.0);
    if turn % 90.0 == 0.0 {
        return match (turn / 90.0) as u32 {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        };
    }
    turn.to_radians().sin_cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quarter_turns_are_exact_and_rotations_right_handed() {
        let r = rotation(Vec3::Y, 90.0);
        assert_eq!(r * Vec3::new(1.0, 2.0, 3.0), Vec3::new(3.0, 2.0, -1.0));
        assert_eq!(rotation(Vec3::Z, -270.0) * Vec3::X, Vec3::Y);
        assert_eq!(rotation(Vec3::X, 180.0) * Vec3::Y, -Vec3::Y);
        // A general rotation is orthonormal and keeps its axis.
        let axis = Vec3::new(1.0, 2.0, 3.0).normalize();
        let m = rotation(axis, 37.0);
        assert!((m * axis).abs_diff_eq(axis, 1e-6));
        assert!((m.transpose() * m).abs_diff_eq(Mat3::IDENTITY, 1e-6));
        assert!((m.determinant() - 1.0).abs() < 1e-6);
        let v = Vec3::new(-axis.y, axis.x, 0.0).normalize();
        assert!(((m * v).dot(v) - 37f32.to_radians().cos()).abs() < 1e-6);
    }

    #[test]
    fn order_is_scale_rotate_translate_and_normals_follow() {
        let t = Transform {
            scale: Vec3::new(2.0, 1.0, 1.0),
            rotation: Some(rotation(Vec3::Z, 90.0)),
            translate: Vec3::new(0.0, 0.0, 5.0),
        };
        assert_eq!(t.point(Vec3::X), Vec3::new(0.0, 2.0, 5.0));
        assert_eq!(t.vector(Vec3::X), Vec3::new(0.0, 2.0, 0.0));
        // The plane x + y = 1 becomes, after x ↦ 2x, the plane x/2 + y = 1 (normal (1, 2)/√5),
        // then rotated by 90° about z: normal (−2, 1)/√5.
        let n = t.normal(Vec3::new(1.0, 1.0, 0.0).normalize()).unwrap();
        assert!(n.abs_diff_eq(Vec3::new(-2.0, 1.0, 0.0) / 5f32.sqrt(), 1e-6), "{n}");
        assert_eq!(Transform::IDENTITY.point(Vec3::new(1.5, -2.0, 0.25)), Vec3::new(1.5, -2.0, 0.25));
        assert_eq!(t.uniform_scale(), None);
        assert_eq!(Transform { scale: Vec3::splat(3.0), ..t }.uniform_scale(), Some(3.0));
    }
}
