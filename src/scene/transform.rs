//! Object transforms: `transform = { scale, rotate = { axis, angle }, translate }`, applied in
//! the order scale, rotate, translate, or `transform = { matrix = [16 numbers, row-major] }`.
//!
//! A similarity (one scale factor, a rotation, a translation) is applied once, at compile time,
//! to the numbers that define an analytic shape (points transformed, directions rotated, lengths
//! scaled; the texture frame turned with it). Quads, polygons and meshes take any transform on
//! their points and normals the same way. A sphere, disk or cylinder (or a body built of them)
//! under a general affine map (a per-axis scale, a matrix) keeps its own numbers and is
//! intersected in its object space ([`crate::geometry::AffineShape`]).

use glam::{DMat3, DVec3, Mat3, Vec3};

use crate::geometry::try_unit;

/// A compiled transform `p ↦ R·(S·p) + t` (a positive scale per axis, a rotation and a
/// translation) or `p ↦ M·p + t` (a general invertible matrix, from `matrix`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Scale per axis (all > 0), applied first (1 with a `matrix`).
    pub scale: Vec3,
    /// Rotation matrix, applied second; `None` for no rotation (so that a transform without one
    /// does exactly the arithmetic of a scale and a translation).
    pub rotation: Option<Mat3>,
    /// The general linear part written as `matrix` (positive determinant), in place of `scale`
    /// and `rotation`.
    pub matrix: Option<Mat3>,
    /// Translation, applied last.
    pub translate: Vec3,
}

impl Transform {
    /// The transform that changes nothing.
    pub const IDENTITY: Transform =
        Transform { scale: Vec3::ONE, rotation: None, matrix: None, translate: Vec3::ZERO };

    /// The transform `p ↦ matrix·p + translate`.
    pub fn affine(matrix: Mat3, translate: Vec3) -> Transform {
        Transform { matrix: Some(matrix), ..Transform { translate, ..Transform::IDENTITY } }
    }

    /// The point `p` transformed: scaled, rotated, translated.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.vector(p) + self.translate
    }

    /// The vector `v` (an edge, a difference of points) scaled and rotated.
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        match self.matrix {
            Some(m) => m * v,
            None => self.rotate(v * self.scale),
        }
    }

    /// `v` rotated only (a similarity's directions; a `matrix` is not a rotation, see
    /// [`Transform::similarity`]).
    #[inline]
    pub fn rotate(&self, v: Vec3) -> Vec3 {
        match self.rotation {
            Some(m) => m * v,
            None => v,
        }
    }

    /// The unit normal `n` of a surface carried along: the inverse transpose of the linear part,
    /// `R·(S⁻¹·n)` or `M⁻ᵀ·n`, normalised (a positive scale or determinant never flips a
    /// normal); `None` for a zero `n`.
    #[inline]
    pub fn normal(&self, n: Vec3) -> Option<Vec3> {
        match self.matrix {
            Some(m) => try_unit(m.inverse().transpose() * n),
            None => try_unit(self.rotate(n / self.scale)),
        }
    }

    /// The linear part as one matrix: `R·S` or `M`.
    pub fn linear(&self) -> Mat3 {
        match self.matrix {
            Some(m) => m,
            None => self.rotation.unwrap_or(Mat3::IDENTITY) * Mat3::from_diagonal(self.scale),
        }
    }

    /// The scale when the transform is a similarity written as `scale`, `rotate` and
    /// `translate` with the same factor on every axis (a `matrix` never is one: it takes the
    /// general path even when it happens to be a rotation).
    pub fn uniform_scale(&self) -> Option<f32> {
        let s = self.scale;
        (self.matrix.is_none() && s.x == s.y && s.y == s.z).then_some(s.x)
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
            matrix: None,
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
        // The same map as a matrix: points and normals agree, but it is not a similarity.
        let m = Transform::affine(t.linear(), t.translate);
        assert_eq!(m.point(Vec3::X), Vec3::new(0.0, 2.0, 5.0));
        assert!(m.normal(Vec3::new(1.0, 1.0, 0.0).normalize()).unwrap().abs_diff_eq(n, 1e-6));
        assert_eq!(m.uniform_scale(), None);
        assert_eq!(Transform::affine(Mat3::IDENTITY, Vec3::ZERO).uniform_scale(), None);
    }
}
