//! Values across lanes: [`F32x`] (one `f32` per lane), [`Mask`] (one `bool` per lane) and
//! [`Vec3x`] (one 3-vector per lane), with the arithmetic the wavefront engine's shading needs.
//!
//! Every operation is a loop over the [`WIDTH`] lanes applying the scalar operation (the same
//! `f32` method or operator that glam and the scalar code call), so each lane's result is the
//! scalar result to the bit, and each loop is small and branch-free, so the compiler turns it
//! into one or two vector instructions under the `#[target_feature]` of the kernel that inlines
//! it ([`super::dispatch`]). Branches become [`Mask`]s and [`F32x::select`]s.

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::{Lanes, WIDTH};
use glam::Vec3;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// One `f32` per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F32x(pub Lanes);

/// One `bool` per lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mask(pub [bool; WIDTH]);

/// One 3-vector per lane, as three lanes of components.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vec3x {
    /// x components.
    pub x: F32x,
    /// y components.
    pub y: F32x,
    /// z components.
    pub z: F32x,
}

/// `f(a[k])` for every lane.
#[inline(always)]
fn map(a: &Lanes, f: impl Fn(f32) -> f32) -> F32x {
    let mut out = [0.0; WIDTH];
    for k in 0..WIDTH {
        out[k] = f(a[k]);
    }
    F32x(out)
}

/// `f(a[k], b[k])` for every lane.
#[inline(always)]
fn zip(a: &Lanes, b: &Lanes, f: impl Fn(f32, f32) -> f32) -> F32x {
    let mut out = [0.0; WIDTH];
    for k in 0..WIDTH {
        out[k] = f(a[k], b[k]);
    }
    F32x(out)
}

/// `f(a[k], b[k])` for every lane, as a mask.
#[inline(always)]
fn test(a: &Lanes, b: &Lanes, f: impl Fn(f32, f32) -> bool) -> Mask {
    let mut out = [false; WIDTH];
    for k in 0..WIDTH {
        out[k] = f(a[k], b[k]);
    }
    Mask(out)
}

impl F32x {
    /// 0 in every lane.
    pub const ZERO: F32x = F32x([0.0; WIDTH]);
    /// 1 in every lane.
    pub const ONE: F32x = F32x([1.0; WIDTH]);

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: f32) -> F32x {
        F32x([v; WIDTH])
    }

    /// `|x|`.
    #[inline(always)]
    pub fn abs(self) -> F32x {
        map(&self.0, f32::abs)
    }

    /// `√x`.
    #[inline(always)]
    pub fn sqrt(self) -> F32x {
        map(&self.0, f32::sqrt)
    }

    /// `⌊x⌋`.
    #[inline(always)]
    pub fn floor(self) -> F32x {
        map(&self.0, f32::floor)
    }

    /// [`f32::signum`].
    #[inline(always)]
    pub fn signum(self) -> F32x {
        map(&self.0, f32::signum)
    }

    /// [`f32::max`] (the number where one is NaN).
    #[inline(always)]
    pub fn max(self, o: F32x) -> F32x {
        zip(&self.0, &o.0, f32::max)
    }

    /// [`f32::clamp`].
    #[inline(always)]
    pub fn clamp(self, lo: f32, hi: f32) -> F32x {
        map(&self.0, |x| x.clamp(lo, hi))
    }

    /// `x < o`.
    #[inline(always)]
    pub fn lt(self, o: F32x) -> Mask {
        test(&self.0, &o.0, |a, b| a < b)
    }

    /// `x <= o`.
    #[inline(always)]
    pub fn le(self, o: F32x) -> Mask {
        test(&self.0, &o.0, |a, b| a <= b)
    }

    /// `x > o`.
    #[inline(always)]
    pub fn gt(self, o: F32x) -> Mask {
        test(&self.0, &o.0, |a, b| a > b)
    }

    /// `x >= o`.
    #[inline(always)]
    pub fn ge(self, o: F32x) -> Mask {
        test(&self.0, &o.0, |a, b| a >= b)
    }

    /// `x == o`.
    #[inline(always)]
    pub fn eq(self, o: F32x) -> Mask {
        test(&self.0, &o.0, |a, b| a == b)
    }

    /// `x != o`.
    #[inline(always)]
    pub fn ne(self, o: F32x) -> Mask {
        test(&self.0, &o.0, |a, b| a != b)
    }

    /// Whether `x` is neither infinite nor NaN.
    #[inline(always)]
    pub fn is_finite(self) -> Mask {
        test(&self.0, &self.0, |a, _| a.is_finite())
    }

    /// Whether `x` is ±∞.
    #[inline(always)]
    pub fn is_infinite(self) -> Mask {
        test(&self.0, &self.0, |a, _| a.is_infinite())
    }

    /// `if m { a } else { b }` per lane.
    #[inline(always)]
    pub fn select(m: Mask, a: F32x, b: F32x) -> F32x {
        let mut out = [0.0; WIDTH];
        for k in 0..WIDTH {
            out[k] = if m.0[k] { a.0[k] } else { b.0[k] };
        }
        F32x(out)
    }

    /// The parity of ⌊x⌋ + ⌊y⌋ + ⌊z⌋ of the lanes' floors `x`, `y`, `z` (each cast to `i64` as
    /// `as` does), as [`crate::texture::Texture`]'s checker takes it: whether it is even.
    #[inline(always)]
    pub fn even_sum(x: F32x, y: F32x, z: F32x) -> Mask {
        let mut out = [false; WIDTH];
        // Where every floor fits an i32, `as i32` has the same low bit as `as i64` (vector
        // conversions exist for i32 on every x86 vector set, for i64 only with AVX-512).
        let limit = 2_147_483_520.0; // the largest f32 below 2³¹
        let fits =
            (0..WIDTH).all(|k| x.0[k].abs() <= limit && y.0[k].abs() <= limit && z.0[k].abs() <= limit);
        if fits {
            for k in 0..WIDTH {
                let sum = (x.0[k] as i32).wrapping_add(y.0[k] as i32).wrapping_add(z.0[k] as i32);
                out[k] = sum & 1 == 0;
            }
        } else {
            for k in 0..WIDTH {
                let sum = (x.0[k] as i64).wrapping_add(y.0[k] as i64).wrapping_add(z.0[k] as i64);
                out[k] = sum.rem_euclid(2) == 0;
            }
        }
        Mask(out)
    }

    /// The next float in the direction of `towards`'s sign (kept where it is 0), as
    /// [`crate::geometry::spawn_origin`] rounds a point away from a surface.
    #[inline(always)]
    pub fn away(self, towards: F32x) -> F32x {
        let mut out = [0.0; WIDTH];
        for k in 0..WIDTH {
            out[k] = crate::geometry::away_from(self.0[k], towards.0[k]);
        }
        F32x(out)
    }
}

macro_rules! binary {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F32x {
            type Output = F32x;
            #[inline(always)]
            fn $method(self, o: F32x) -> F32x {
                zip(&self.0, &o.0, |a, b| a $op b)
            }
        }
        impl $trait<f32> for F32x {
            type Output = F32x;
            #[inline(always)]
            fn $method(self, o: f32) -> F32x {
                map(&self.0, |a| a $op o)
            }
        }
        impl $trait<F32x> for f32 {
            type Output = F32x;
            #[inline(always)]
            fn $method(self, o: F32x) -> F32x {
                map(&o.0, |b| self $op b)
            }
        }
    };
}

binary!(Add, add, +);
binary!(Sub, sub, -);
binary!(Mul, mul, *);
binary!(Div, div, /);

impl Neg for F32x {
    type Output = F32x;
    #[inline(always)]
    fn neg(self) -> F32x {
        map(&self.0, |a| -a)
    }
}

impl Mask {
    /// No lane set.
    pub const NONE: Mask = Mask([false; WIDTH]);
    /// Every lane set.
    pub const ALL: Mask = Mask([true; WIDTH]);

    /// How many lanes are set.
    #[inline(always)]
    pub fn count(self) -> usize {
        self.0.iter().filter(|&&b| b).count()
    }

    /// `v` in every lane.
    #[inline(always)]
    pub fn splat(v: bool) -> Mask {
        Mask([v; WIDTH])
    }

    /// Whether any lane is set.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().any(|&b| b)
    }
}

impl BitAnd for Mask {
    type Output = Mask;
    #[inline(always)]
    fn bitand(self, o: Mask) -> Mask {
        Mask(std::array::from_fn(|k| self.0[k] & o.0[k]))
    }
}

impl BitOr for Mask {
    type Output = Mask;
    #[inline(always)]
    fn bitor(self, o: Mask) -> Mask {
        Mask(std::array::from_fn(|k| self.0[k] | o.0[k]))
    }
}

impl Not for Mask {
    type Output = Mask;
    #[inline(always)]
    fn not(self) -> Mask {
        Mask(std::array::from_fn(|k| !self.0[k]))
    }
}

impl Vec3x {
    /// The zero vector in every lane.
    pub const ZERO: Vec3x = Vec3x { x: F32x::ZERO, y: F32x::ZERO, z: F32x::ZERO };
    /// (1, 1, 1) in every lane.
    pub const ONE: Vec3x = Vec3x { x: F32x::ONE, y: F32x::ONE, z: F32x::ONE };

    /// Sets lane `k` to `v`.
    #[inline(always)]
    pub fn set_lane(&mut self, k: usize, v: Vec3) {
        (self.x.0[k], self.y.0[k], self.z.0[k]) = (v.x, v.y, v.z);
    }

    /// The vector `v` in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Vec3x {
        Vec3x { x: F32x::splat(v.x), y: F32x::splat(v.y), z: F32x::splat(v.z) }
    }

    /// The lanes of three component arrays.
    #[inline(always)]
    pub fn from_lanes(v: &[Lanes; 3]) -> Vec3x {
        Vec3x { x: F32x(v[0]), y: F32x(v[1]), z: F32x(v[2]) }
    }

    /// The three component arrays.
    #[inline(always)]
    pub fn to_lanes(self) -> [Lanes; 3] {
        [self.x.0, self.y.0, self.z.0]
    }

    /// Lane `k`.
    #[inline(always)]
    pub fn lane(&self, k: usize) -> Vec3 {
        Vec3::new(self.x.0[k], self.y.0[k], self.z.0[k])
    }

    /// The vectors `(x, y, z)`.
    #[inline(always)]
    pub fn new(x: F32x, y: F32x, z: F32x) -> Vec3x {
        Vec3x { x, y, z }
    }

    /// glam's `Vec3::dot`: `(x·x' + y·y') + z·z'`.
    #[inline(always)]
    pub fn dot(self, o: Vec3x) -> F32x {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// glam's `Vec3::length`.
    #[inline(always)]
    pub fn length(self) -> F32x {
        self.dot(self).sqrt()
    }

    /// glam's `Vec3::length_squared`.
    #[inline(always)]
    pub fn length_squared(self) -> F32x {
        self.dot(self)
    }

    /// glam's `Vec3::normalize`: `v · (1/|v|)`.
    #[inline(always)]
    pub fn normalize(self) -> Vec3x {
        self * (1.0 / self.length())
    }

    /// glam's `Vec3::normalize_or_zero`.
    #[inline(always)]
    pub fn normalize_or_zero(self) -> Vec3x {
        let rcp = 1.0 / self.length();
        let keep = rcp.is_finite() & rcp.gt(F32x::splat(0.0));
        Vec3x::select(keep, self * rcp, Vec3x::splat(Vec3::ZERO))
    }

    /// glam's `Vec3::abs`.
    #[inline(always)]
    pub fn abs(self) -> Vec3x {
        Vec3x { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }

    /// glam's `Vec3::element_sum`: `(x + y) + z`.
    #[inline(always)]
    pub fn element_sum(self) -> F32x {
        self.x + self.y + self.z
    }

    /// glam's `Vec3::max_element`: `max(x, max(y, z))` with `if a > b { a } else { b }`.
    #[inline(always)]
    pub fn max_element(self) -> F32x {
        let yz = F32x::select(self.y.gt(self.z), self.y, self.z);
        F32x::select(self.x.gt(yz), self.x, yz)
    }

    /// glam's `Vec3::floor`.
    #[inline(always)]
    pub fn floor(self) -> Vec3x {
        Vec3x { x: self.x.floor(), y: self.y.floor(), z: self.z.floor() }
    }

    /// Whether every component is 0 (glam's `== Vec3::ZERO`).
    #[inline(always)]
    pub fn is_zero(self) -> Mask {
        let zero = F32x::splat(0.0);
        self.x.eq(zero) & self.y.eq(zero) & self.z.eq(zero)
    }

    /// `if m { a } else { b }` per lane.
    #[inline(always)]
    pub fn select(m: Mask, a: Vec3x, b: Vec3x) -> Vec3x {
        Vec3x { x: F32x::select(m, a.x, b.x), y: F32x::select(m, a.y, b.y), z: F32x::select(m, a.z, b.z) }
    }
}

impl Add for Vec3x {
    type Output = Vec3x;
    #[inline(always)]
    fn add(self, o: Vec3x) -> Vec3x {
        Vec3x { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl Sub for Vec3x {
    type Output = Vec3x;
    #[inline(always)]
    fn sub(self, o: Vec3x) -> Vec3x {
        Vec3x { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl Mul for Vec3x {
    type Output = Vec3x;
    #[inline(always)]
    fn mul(self, o: Vec3x) -> Vec3x {
        Vec3x { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
}

impl Mul<F32x> for Vec3x {
    type Output = Vec3x;
    #[inline(always)]
    fn mul(self, s: F32x) -> Vec3x {
        Vec3x { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

impl Mul<Vec3x> for F32x {
    type Output = Vec3x;
    #[inline(always)]
    fn mul(self, v: Vec3x) -> Vec3x {
        Vec3x { x: self * v.x, y: self * v.y, z: self * v.z }
    }
}

impl Mul<f32> for Vec3x {
    type Output = Vec3x;
    #[inline(always)]
    fn mul(self, s: f32) -> Vec3x {
        Vec3x { x: self.x * s, y: self.y * s, z: self.z * s }
    }
}

impl Div<F32x> for Vec3x {
    type Output = Vec3x;
    #[inline(always)]
    fn div(self, s: F32x) -> Vec3x {
        Vec3x { x: self.x / s, y: self.y / s, z: self.z / s }
    }
}

impl Neg for Vec3x {
    type Output = Vec3x;
    #[inline(always)]
    fn neg(self) -> Vec3x {
        Vec3x { x: -self.x, y: -self.y, z: -self.z }
    }
}
