//! One source for one ray and for [`WIDTH`](super::WIDTH) lanes: the numbers shading is written
//! over.
//!
//! A function written once over [`Real`] (a number) and [`Vector`] (a 3-vector of them) runs
//! for one ray with `f32` and glam's `Vec3`, and for 16 rays with [`F32x`] and [`Vec3x`]: the
//! single-source idea of Mitsuba 3 and Dr.Jit, in plain Rust generics. Branches are written as
//! [`Real::select`] over masks (`bool` for one ray, [`Mask`] across lanes), so both forms run
//! the same operations in the same order and each lane's result is the one-ray result to the
//! bit. Monomorphisation makes the `f32` form the code one would write by hand (a select of two
//! computed values compiles to a branch-free move); the lane form inlines into the vector kernels
//! ([`super::dispatch`]). `docs/architecture.md` ("One source for one ray and for lanes") says
//! which pieces are written this way and what it cost (nothing measurable: `benches/lanes.rs`).
//!
//! A number written on the left of an operator (`1.0 - x`) needs the bound on `f32` that Rust
//! does not carry from a trait to its users, so generic code writes [`Real::splat`]`(1.0) - x`
//! or `-x + 1.0` where the rounding is the same.

use super::wide::{F32x, Mask, Vec3x};
use glam::Vec3;
use std::fmt::Debug;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// A number for one ray (`f32`) or one per lane ([`F32x`]).
pub trait Real:
    Copy
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f32, Output = Self>
    + Sub<f32, Output = Self>
    + Mul<f32, Output = Self>
    + Div<f32, Output = Self>
    + PartialEq
{
    /// A truth value for one ray (`bool`) or one per lane ([`Mask`]).
    type Mask: Copy
        + Debug
        + PartialEq
        + Not<Output = Self::Mask>
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>;

    /// `v` (in every lane).
    fn splat(v: f32) -> Self;
    /// `|x|`.
    fn abs(self) -> Self;
    /// `√x`.
    fn sqrt(self) -> Self;
    /// `⌊x⌋`.
    fn floor(self) -> Self;
    /// [`f32::signum`].
    fn signum(self) -> Self;
    /// [`f32::max`] (the number where one is NaN).
    fn max(self, o: Self) -> Self;
    /// [`f32::clamp`].
    fn clamp(self, lo: f32, hi: f32) -> Self;
    /// `x < o`.
    fn lt(self, o: Self) -> Self::Mask;
    /// `x <= o`.
    fn le(self, o: Self) -> Self::Mask;
    /// `x > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// `x >= o`.
    fn ge(self, o: Self) -> Self::Mask;
    /// `x == o`.
    fn eq(self, o: Self) -> Self::Mask;
    /// `x != o`.
    fn ne(self, o: Self) -> Self::Mask;
    /// Whether `x` is neither infinite nor NaN.
    fn is_finite(self) -> Self::Mask;
    /// Whether `x` is ±∞.
    fn is_infinite(self) -> Self::Mask;
    /// `if m { a } else { b }`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// The next float in the direction of `towards`'s sign (kept where it is 0):
    /// [`crate::geometry::away_from`].
    fn away(self, towards: Self) -> Self;
    /// Whether ⌊x⌋ + ⌊y⌋ + ⌊z⌋ of the floors `x`, `y`, `z` (each cast to `i64` as `as` does) is
    /// even: the parity of a 3-D checker's cell.
    fn even_sum(x: Self, y: Self, z: Self) -> Self::Mask;
    /// The truth value `v` (in every lane).
    fn mask(v: bool) -> Self::Mask;
    /// Whether `m` holds (in any lane): what guards work that only some lanes need.
    fn any(m: Self::Mask) -> bool;
    /// `a·b − c·d` evaluated in f64 (the products exact, only the difference and the final
    /// conversion round), as an `f32`.
    fn products_difference_f64(a: Self, b: Self, c: Self, d: Self) -> Self;
    /// `f(k)` in each lane `k` where `active` (lane 0 for one ray), unchanged elsewhere: a
    /// one-ray function (a rare, cold case) run lane by lane.
    fn lanes_where(self, active: Self::Mask, f: impl FnMut(usize) -> f32) -> Self;
}

/// A 3-vector for one ray (glam's `Vec3`) or one per lane ([`Vec3x`]), with glam's arithmetic
/// (the same operations in the same order).
pub trait Vector:
    Copy
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Mul<<Self as Vector>::Real, Output = Self>
    + Mul<f32, Output = Self>
    + Div<<Self as Vector>::Real, Output = Self>
    + Neg<Output = Self>
{
    /// Its components' number type.
    type Real: Real;
    /// The dominant axis (one per lane), as [`Vector::max_axis`] gives it and
    /// [`Vector::permute`] takes it.
    type Axis: Copy + Debug;

    /// The vector `(x, y, z)`.
    fn new(x: Self::Real, y: Self::Real, z: Self::Real) -> Self;
    /// `v` (in every lane).
    fn splat(v: Vec3) -> Self;
    /// The x component.
    fn x(self) -> Self::Real;
    /// The y component.
    fn y(self) -> Self::Real;
    /// The z component.
    fn z(self) -> Self::Real;
    /// glam's `dot`: `(x·x' + y·y') + z·z'`.
    fn dot(self, o: Self) -> Self::Real;
    /// glam's `length`.
    fn length(self) -> Self::Real;
    /// glam's `length_squared`.
    fn length_squared(self) -> Self::Real;
    /// glam's `normalize`: `v · (1/|v|)`.
    fn normalize(self) -> Self;
    /// glam's `normalize_or_zero`.
    fn normalize_or_zero(self) -> Self;
    /// glam's `abs`.
    fn abs(self) -> Self;
    /// glam's `element_sum`: `(x + y) + z`.
    fn element_sum(self) -> Self::Real;
    /// glam's `floor`.
    fn floor(self) -> Self;
    /// `if m { a } else { b }`.
    fn select(m: Mask3<Self>, a: Self, b: Self) -> Self;
    /// Whether every component is 0 (glam's `== Vec3::ZERO`).
    fn is_zero(self) -> Mask3<Self>;
    /// glam's `max_element`.
    fn max_element(self) -> Self::Real;
    /// glam's `exp`, by libm component by component where `active` (unchanged elsewhere).
    fn exp_where(self, active: Mask3<Self>) -> Self;
    /// Lane `k` (the vector itself for one ray).
    fn lane(self, k: usize) -> Vec3;
    /// glam's `max_position`, the axis `kz`.
    fn max_axis(self) -> Self::Axis;
    /// The components `(v[kx], v[ky], v[kz])` with `kx = (kz + 1) mod 3` and `ky = (kx + 1) mod 3`
    /// for the axis `kz`: the dominant axis last, the other two in cyclic order.
    fn permute(self, kz: Self::Axis) -> Self;
}

/// The truth values of a [`Vector`]'s numbers.
pub type Mask3<V> = <<V as Vector>::Real as Real>::Mask;

impl Real for f32 {
    type Mask = bool;

    #[inline(always)]
    fn splat(v: f32) -> f32 {
        v
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn floor(self) -> f32 {
        f32::floor(self)
    }
    #[inline(always)]
    fn signum(self) -> f32 {
        f32::signum(self)
    }
    #[inline(always)]
    fn max(self, o: f32) -> f32 {
        f32::max(self, o)
    }
    #[inline(always)]
    fn clamp(self, lo: f32, hi: f32) -> f32 {
        f32::clamp(self, lo, hi)
    }
    #[inline(always)]
    fn lt(self, o: f32) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f32) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: f32) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: f32) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: f32) -> bool {
        self == o
    }
    #[inline(always)]
    fn ne(self, o: f32) -> bool {
        self != o
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn is_infinite(self) -> bool {
        f32::is_infinite(self)
    }
    #[inline(always)]
    fn select(m: bool, a: f32, b: f32) -> f32 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn away(self, towards: f32) -> f32 {
        crate::geometry::away_from(self, towards)
    }
    #[inline(always)]
    fn even_sum(x: f32, y: f32, z: f32) -> bool {
        (x as i64).wrapping_add(y as i64).wrapping_add(z as i64).rem_euclid(2) == 0
    }
    #[inline(always)]
    fn mask(v: bool) -> bool {
        v
    }
    #[inline(always)]
    fn any(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn products_difference_f64(a: f32, b: f32, c: f32, d: f32) -> f32 {
        (f64::from(a) * f64::from(b) - f64::from(c) * f64::from(d)) as f32
    }
    #[inline(always)]
    fn lanes_where(self, active: bool, mut f: impl FnMut(usize) -> f32) -> f32 {
        if active {
            f(0)
        } else {
            self
        }
    }
}

impl Real for F32x {
    type Mask = Mask;

    #[inline(always)]
    fn splat(v: f32) -> F32x {
        F32x::splat(v)
    }
    #[inline(always)]
    fn abs(self) -> F32x {
        F32x::abs(self)
    }
    #[inline(always)]
    fn sqrt(self) -> F32x {
        F32x::sqrt(self)
    }
    #[inline(always)]
    fn floor(self) -> F32x {
        F32x::floor(self)
    }
    #[inline(always)]
    fn signum(self) -> F32x {
        F32x::signum(self)
    }
    #[inline(always)]
    fn max(self, o: F32x) -> F32x {
        F32x::max(self, o)
    }
    #[inline(always)]
    fn clamp(self, lo: f32, hi: f32) -> F32x {
        F32x::clamp(self, lo, hi)
    }
    #[inline(always)]
    fn lt(self, o: F32x) -> Mask {
        F32x::lt(self, o)
    }
    #[inline(always)]
    fn le(self, o: F32x) -> Mask {
        F32x::le(self, o)
    }
    #[inline(always)]
    fn gt(self, o: F32x) -> Mask {
        F32x::gt(self, o)
    }
    #[inline(always)]
    fn ge(self, o: F32x) -> Mask {
        F32x::ge(self, o)
    }
    #[inline(always)]
    fn eq(self, o: F32x) -> Mask {
        F32x::eq(self, o)
    }
    #[inline(always)]
    fn ne(self, o: F32x) -> Mask {
        F32x::ne(self, o)
    }
    #[inline(always)]
    fn is_finite(self) -> Mask {
        F32x::is_finite(self)
    }
    #[inline(always)]
    fn is_infinite(self) -> Mask {
        F32x::is_infinite(self)
    }
    #[inline(always)]
    fn select(m: Mask, a: F32x, b: F32x) -> F32x {
        F32x::select(m, a, b)
    }
    #[inline(always)]
    fn away(self, towards: F32x) -> F32x {
        F32x::away(self, towards)
    }
    #[inline(always)]
    fn even_sum(x: F32x, y: F32x, z: F32x) -> Mask {
        F32x::even_sum(x, y, z)
    }
    #[inline(always)]
    fn mask(v: bool) -> Mask {
        Mask::splat(v)
    }
    #[inline(always)]
    fn any(m: Mask) -> bool {
        m.any()
    }
    #[inline(always)]
    fn products_difference_f64(a: F32x, b: F32x, c: F32x, d: F32x) -> F32x {
        let mut out = F32x::ZERO;
        for k in 0..super::WIDTH {
            out.0[k] = f32::products_difference_f64(a.0[k], b.0[k], c.0[k], d.0[k]);
        }
        out
    }
    #[inline(always)]
    fn lanes_where(self, active: Mask, mut f: impl FnMut(usize) -> f32) -> F32x {
        let mut out = self;
        for k in 0..super::WIDTH {
            if active.0[k] {
                out.0[k] = f(k);
            }
        }
        out
    }
}

impl Vector for Vec3 {
    type Real = f32;

    #[inline(always)]
    fn new(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }
    #[inline(always)]
    fn splat(v: Vec3) -> Vec3 {
        v
    }
    #[inline(always)]
    fn x(self) -> f32 {
        self.x
    }
    #[inline(always)]
    fn y(self) -> f32 {
        self.y
    }
    #[inline(always)]
    fn z(self) -> f32 {
        self.z
    }
    #[inline(always)]
    fn dot(self, o: Vec3) -> f32 {
        Vec3::dot(self, o)
    }
    #[inline(always)]
    fn length(self) -> f32 {
        Vec3::length(self)
    }
    #[inline(always)]
    fn length_squared(self) -> f32 {
        Vec3::length_squared(self)
    }
    #[inline(always)]
    fn normalize(self) -> Vec3 {
        Vec3::normalize(self)
    }
    #[inline(always)]
    fn normalize_or_zero(self) -> Vec3 {
        Vec3::normalize_or_zero(self)
    }
    #[inline(always)]
    fn abs(self) -> Vec3 {
        Vec3::abs(self)
    }
    #[inline(always)]
    fn element_sum(self) -> f32 {
        Vec3::element_sum(self)
    }
    #[inline(always)]
    fn floor(self) -> Vec3 {
        Vec3::floor(self)
    }
    #[inline(always)]
    fn select(m: bool, a: Vec3, b: Vec3) -> Vec3 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn is_zero(self) -> bool {
        self == Vec3::ZERO
    }
    #[inline(always)]
    fn max_element(self) -> f32 {
        Vec3::max_element(self)
    }
    #[inline(always)]
    fn exp_where(self, active: bool) -> Vec3 {
        if active {
            self.exp()
        } else {
            self
        }
    }
    #[inline(always)]
    fn lane(self, _: usize) -> Vec3 {
        self
    }
    /// The source axes `[kx, ky, kz]` of the permuted components (worked out once).
    type Axis = [usize; 3];
    #[inline(always)]
    fn max_axis(self) -> [usize; 3] {
        let kz = self.max_position();
        let kx = (kz + 1) % 3;
        [kx, (kx + 1) % 3, kz]
    }
    #[inline(always)]
    fn permute(self, [kx, ky, kz]: [usize; 3]) -> Vec3 {
        let v = self.to_array();
        Vec3::new(v[kx], v[ky], v[kz])
    }
}

impl Vector for Vec3x {
    type Real = F32x;

    #[inline(always)]
    fn new(x: F32x, y: F32x, z: F32x) -> Vec3x {
        Vec3x::new(x, y, z)
    }
    #[inline(always)]
    fn splat(v: Vec3) -> Vec3x {
        Vec3x::splat(v)
    }
    #[inline(always)]
    fn x(self) -> F32x {
        self.x
    }
    #[inline(always)]
    fn y(self) -> F32x {
        self.y
    }
    #[inline(always)]
    fn z(self) -> F32x {
        self.z
    }
    #[inline(always)]
    fn dot(self, o: Vec3x) -> F32x {
        Vec3x::dot(self, o)
    }
    #[inline(always)]
    fn length(self) -> F32x {
        Vec3x::length(self)
    }
    #[inline(always)]
    fn length_squared(self) -> F32x {
        Vec3x::length_squared(self)
    }
    #[inline(always)]
    fn normalize(self) -> Vec3x {
        Vec3x::normalize(self)
    }
    #[inline(always)]
    fn normalize_or_zero(self) -> Vec3x {
        Vec3x::normalize_or_zero(self)
    }
    #[inline(always)]
    fn abs(self) -> Vec3x {
        Vec3x::abs(self)
    }
    #[inline(always)]
    fn element_sum(self) -> F32x {
        Vec3x::element_sum(self)
    }
    #[inline(always)]
    fn floor(self) -> Vec3x {
        Vec3x::floor(self)
    }
    #[inline(always)]
    fn select(m: Mask, a: Vec3x, b: Vec3x) -> Vec3x {
        Vec3x::select(m, a, b)
    }
    #[inline(always)]
    fn is_zero(self) -> Mask {
        Vec3x::is_zero(self)
    }
    #[inline(always)]
    fn max_element(self) -> F32x {
        Vec3x::max_element(self)
    }
    #[inline(always)]
    fn exp_where(self, active: Mask) -> Vec3x {
        let mut v = self;
        for k in 0..super::WIDTH {
            if active.0[k] {
                v.set_lane(k, self.lane(k).exp());
            }
        }
        v
    }
    #[inline(always)]
    fn lane(self, k: usize) -> Vec3 {
        Vec3x::lane(&self, k)
    }
    /// Whether the axis is x, and whether it is y (z where neither).
    type Axis = [Mask; 2];
    #[inline(always)]
    fn max_axis(self) -> [Mask; 2] {
        // glam's comparisons: y wins over x only when larger, z over the larger of the two only
        // when larger.
        let y = self.y.gt(self.x);
        let z = self.z.gt(F32x::select(y, self.y, self.x));
        [!z & !y, !z & y]
    }
    #[inline(always)]
    fn permute(self, [kx, ky]: [Mask; 2]) -> Vec3x {
        let (x, y, z) = (self.x, self.y, self.z);
        // kz = x: (y, z, x); kz = y: (z, x, y); kz = z: (x, y, z).
        let pick = |if_x: F32x, if_y: F32x, if_z: F32x| F32x::select(kx, if_x, F32x::select(ky, if_y, if_z));
        Vec3x::new(pick(y, z, x), pick(z, x, y), pick(x, y, z))
    }
}

#[cfg(test)]
// Lane loops index several arrays by the lane.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::super::{dispatch, Isa, WIDTH};
    use super::*;
    use crate::bsdf::rough_dielectric::smooth_dielectric_sample;
    use crate::bsdf::{Frame, Lambert, RoughDielectric, TransportMode, TrowbridgeReitz};
    use crate::camera::{concentric_disk_point, concentric_polar};
    use crate::geometry::SurfaceHit;
    use crate::light::area_to_solid_angle;
    use crate::lighting::{ShadowRay, ShadowSegment};
    use crate::optics::{fresnel_dielectric, refraction};
    use crate::texture::checker;
    use glam::Vec2;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    /// Random inputs with the awkward ones mixed in: zeros of both signs, axis directions,
    /// grazing angles, NaN-free.
    fn values(rng: &mut Pcg32, k: usize) -> [f32; 6] {
        let mut v: [f32; 6] = std::array::from_fn(|_| rng.random::<f32>() * 2.0 - 1.0);
        match k % 9 {
            0 => v[0] = 0.0,
            1 => v[2] = -0.0,
            2 => v[1] = 1e-8,
            3 => v = [0.0, 0.0, 1.0, 0.0, 0.0, -1.0],
            4 => v[3] = 0.5,
            _ => {}
        }
        v
    }

    fn unit(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z).try_normalize().unwrap_or(Vec3::Z)
    }

    fn lanes(rng: &mut Pcg32, batch: usize) -> [[f32; 6]; WIDTH] {
        std::array::from_fn(|k| values(rng, batch * WIDTH + k))
    }

    fn vec(inputs: &[[f32; 6]; WIDTH], at: usize, f: impl Fn(Vec3) -> Vec3) -> Vec3x {
        let v: [Vec3; WIDTH] =
            std::array::from_fn(|k| f(Vec3::new(inputs[k][at], inputs[k][at + 1], inputs[k][at + 2])));
        Vec3x::new(F32x(v.map(|v| v.x)), F32x(v.map(|v| v.y)), F32x(v.map(|v| v.z)))
    }

    fn same(a: Vec3, b: Vec3) -> bool {
        a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)
    }

    /// Every function written over [`Real`] and [`Vector`], across lanes against one ray at a
    /// time, on 16 × 500 inputs, per instruction set: the lane arithmetic of `wide.rs` is the
    /// one-ray arithmetic of `f32` and glam, operation for operation.
    #[inline(always)]
    fn check_all() {
        let mut rng = Pcg32::seed_from_u64(3);
        for batch in 0..500 {
            let input = lanes(&mut rng, batch);
            let a = vec(&input, 0, |v| unit(v.x, v.y, v.z));
            let b = vec(&input, 3, |v| unit(v.x, v.y, v.z));
            let raw = vec(&input, 3, |v| v * 3.0);
            let s = F32x(std::array::from_fn(|k| input[k][3].abs()));
            let u = F32x(std::array::from_fn(|k| input[k][4] * 0.5 + 0.5));
            let frame = Frame::from_normal(a);
            let local = frame.to_local(b);
            let world = frame.to_world(b);
            let solid = area_to_solid_angle(s, raw, b, a);
            let heuristic = crate::integrators::power_heuristic(s, raw.x);
            let fresnel = fresnel_dielectric(b.z, s * 2.0);
            let (refracts, refracted) = refraction(b, a, s + 0.5);
            let (glass_ok, glass) = smooth_dielectric_sample(s * 2.0 + 0.5, b, u, TransportMode::Radiance);
            let v = F32x(std::array::from_fn(|k| input[k][5] * 0.5 + 0.5));
            let (centre, wide, radius, angle) = concentric_polar(u, v);
            let disk = concentric_disk_point(u, v);
            // One-sided in every other lane.
            let one_sided = Mask(std::array::from_fn(|k| k % 2 == 1));
            let diffuse = Lambert { albedo: raw, one_sided };
            let eval = diffuse.eval(a, b);
            let pdf = diffuse.pdf(a, b);
            let (lambert_ok, lambert) = diffuse.disk_sample(a, b.x * 0.7, b.y * 0.7);
            let shadow = ShadowSegment::toward(raw, a, s * 1e-3, raw + b);
            let albedo = checker(raw, s + 0.1, a, b);
            let camera = crate::camera::Camera::new(
                Vec3::new(0.1, 1.0, 3.8),
                Vec3::new(0.0, 0.9, 0.0),
                Vec3::Y,
                39.0,
                40,
                30,
            )
            .unwrap();
            let (fx, fy) = (u * 40.0, F32x(std::array::from_fn(|k| input[k][5].abs() * 30.0)));
            let pinhole = camera.pinhole_direction::<Vec3x>(fx, fy) + Vec3x::ZERO;
            let thin_lens = camera.clone().with_lens(0.2, 3.0).with_near_clip(0.5);
            let lens_v = F32x(std::array::from_fn(|k| input[k][5] * 0.5 + 0.5));
            let (lens_origin, lens_dir) = thin_lens.ray_through::<Vec3x>(fx, fy, u, lens_v);
            for k in 0..WIDTH {
                let (va, vb, vraw) = (a.lane(k), b.lane(k), raw.lane(k));
                let f = Frame::from_normal(va);
                assert!(same(frame.s.lane(k), f.s) && same(frame.t.lane(k), f.t), "frame of {va}");
                assert!(same(local.lane(k), f.to_local(vb)) && same(world.lane(k), f.to_world(vb)));
                let want = area_to_solid_angle(s.0[k], vraw, vb, va);
                assert_eq!(solid.0[k].to_bits(), want.to_bits());
                let want = crate::integrators::power_heuristic(s.0[k], vraw.x);
                assert_eq!(heuristic.0[k].to_bits(), want.to_bits());
                let want = fresnel_dielectric(vb.z, s.0[k] * 2.0);
                assert_eq!(fresnel.0[k].to_bits(), want.to_bits());
                let (ok, dir) = refraction(vb, va, s.0[k] + 0.5);
                assert_eq!(refracts.0[k], ok);
                assert!(!ok || same(refracted.lane(k), dir));
                let model = RoughDielectric::new(s.0[k] * 2.0 + 0.5, TrowbridgeReitz::from_roughness(0.0));
                let (ok, g) = model.specular_sample(vb, u.0[k], TransportMode::Radiance);
                assert_eq!(glass_ok.0[k], ok);
                if ok {
                    assert!(same(glass.wi.lane(k), g.wi) && same(glass.f.lane(k), g.f));
                    assert_eq!(
                        (glass.pdf.0[k].to_bits(), glass.eta.0[k].to_bits()),
                        (g.pdf.to_bits(), g.eta.to_bits())
                    );
                    assert_eq!(glass.is_transmission.0[k], g.is_transmission);
                }
                let (c, w, r, t) = concentric_polar(u.0[k], v.0[k]);
                assert_eq!((centre.0[k], wide.0[k]), (c, w));
                assert!(c || (radius.0[k].to_bits(), angle.0[k].to_bits()) == (r.to_bits(), t.to_bits()));
                let (x, y) = concentric_disk_point(u.0[k], v.0[k]);
                assert_eq!((disk.0 .0[k].to_bits(), disk.1 .0[k].to_bits()), (x.to_bits(), y.to_bits()));
                let l = Lambert { albedo: vraw, one_sided: k % 2 == 1 };
                assert!(same(eval.lane(k), l.eval(va, vb)));
                assert_eq!(pdf.0[k].to_bits(), l.pdf(va, vb).to_bits());
                let (ok, d) = l.disk_sample(va, vb.x * 0.7, vb.y * 0.7);
                assert_eq!(lambert_ok.0[k], ok);
                assert!(same(lambert.wi.lane(k), d.wi) && same(lambert.f.lane(k), d.f));
                assert_eq!(lambert.pdf.0[k].to_bits(), d.pdf.to_bits());
                let hit = SurfaceHit {
                    t: 1.0,
                    p: vraw,
                    n: va,
                    shading_n: va,
                    uv: Vec2::ZERO,
                    p_error: s.0[k] * 1e-3,
                };
                let want = ShadowRay::toward(&hit, vraw + vb, None, 0.0);
                assert!(
                    same(shadow.origin.lane(k), want.ray.origin) && same(shadow.dir.lane(k), want.ray.dir)
                );
                assert_eq!(shadow.tmax.0[k].to_bits(), want.tmax.to_bits());
                let ray = camera.generate_ray(Vec2::new(fx.0[k], fy.0[k]));
                assert!(same(pinhole.lane(k), ray.dir), "camera ray through ({}, {})", fx.0[k], fy.0[k]);
                let film = Vec2::new(fx.0[k], fy.0[k]);
                let ray = thin_lens.generate_ray_lens(film, Vec2::new(u.0[k], lens_v.0[k]), 0.0);
                assert!(
                    same(lens_origin.lane(k), ray.origin) && same(lens_dir.lane(k), ray.dir),
                    "thin lens"
                );
                let texture = crate::texture::Texture::Checker { color1: va, color2: vb, size: s.0[k] + 0.1 };
                assert!(same(albedo.lane(k), texture.eval(vraw, Vec2::ZERO)));
            }
        }
    }

    dispatch! {
        fn check(unused: ()) -> () => check_all_with
    }

    #[inline(always)]
    fn check_all_with(_: ()) {
        check_all()
    }

    #[test]
    fn every_function_written_once_gives_each_lane_the_one_ray_result_bit_for_bit() {
        for isa in Isa::available() {
            check(isa, ());
        }
    }
}
