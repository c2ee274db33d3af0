//! The shading functions of `path` across lanes: each the scalar function it is named after,
//! operation for operation on [`F32x`] and [`Vec3x`] (branches as selects), so that every lane's
//! result is the scalar one to the bit (the tests below check each against it).

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::wide::{F32x, Mask, Vec3x};
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// [`crate::camera::Camera::generate_ray`]'s directions through the film positions (`fx`,
/// `fy`) in pixel units (the rays start at the camera's position).
#[inline(always)]
pub fn pinhole_directions(camera: &crate::camera::Camera, fx: F32x, fy: F32x) -> Vec3x {
    let (w, h) = (camera.width as f32, camera.height as f32);
    let aspect = w / h;
    let tan = camera.tan_half_fov;
    let ndc_x = (2.0 * fx / w - 1.0) * aspect * tan;
    let ndc_y = (1.0 - 2.0 * fy / h) * tan;
    let dir =
        (Vec3x::splat(camera.forward) + ndc_x * Vec3x::splat(camera.right)) + ndc_y * Vec3x::splat(camera.up);
    // Ray::new canonicalises −0 to +0.
    dir.normalize() + Vec3x::splat(Vec3::ZERO)
}

/// A local frame per lane: [`crate::bsdf::Frame`].
#[derive(Clone, Copy, Debug)]
pub struct FrameX {
    /// First tangent.
    pub s: Vec3x,
    /// Second tangent.
    pub t: Vec3x,
    /// Normal.
    pub n: Vec3x,
}

impl FrameX {
    /// [`crate::bsdf::Frame::from_normal`]: glam's `any_orthonormal_pair` (Duff et al. 2017).
    #[inline(always)]
    pub fn from_normal(n: Vec3x) -> FrameX {
        let sign = n.z.signum();
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3x::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3x::new(b, sign + n.y * n.y * a, -n.y);
        FrameX { s, t, n }
    }

    /// [`crate::bsdf::Frame::to_local`].
    #[inline(always)]
    pub fn to_local(&self, v: Vec3x) -> Vec3x {
        Vec3x::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// [`crate::bsdf::Frame::to_world`].
    #[inline(always)]
    pub fn to_world(&self, v: Vec3x) -> Vec3x {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// [`crate::light::area_to_solid_angle`].
#[inline(always)]
pub fn area_to_solid_angle(area_pdf: F32x, p: Vec3x, y: Vec3x, n_y: Vec3x) -> F32x {
    let d = y - p;
    let cos = d.normalize_or_zero().dot(n_y).abs();
    let pdf = area_pdf * d.length_squared() / cos;
    F32x::select(cos.eq(F32x::splat(0.0)), F32x::splat(0.0), pdf)
}

/// The power heuristic of `path` (β = 2): `a²/(a² + b²)`, 1 where `a²` is infinite, 0 where both
/// are 0.
#[inline(always)]
pub fn power_heuristic(a: F32x, b: F32x) -> F32x {
    let (a2, b2) = (a * a, b * b);
    let zero = F32x::splat(0.0);
    let w = F32x::select((a2 + b2).eq(zero), zero, a2 / (a2 + b2));
    F32x::select(a2.is_infinite(), F32x::splat(1.0), w)
}

/// [`crate::optics::fresnel_dielectric`].
#[inline(always)]
pub fn fresnel_dielectric(cos_i: F32x, eta: F32x) -> F32x {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i).max(F32x::splat(0.0)) / (eta * eta);
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r = 0.5 * (r_parl * r_parl + r_perp * r_perp);
    F32x::select(sin2_t.ge(F32x::splat(1.0)), F32x::splat(1.0), r)
}

/// [`crate::optics::refraction`].
#[inline(always)]
pub fn refraction(wi: Vec3x, n: Vec3x, eta: F32x) -> (Mask, Vec3x) {
    let cos_i = wi.dot(n).clamp(-1.0, 1.0);
    let sin2_i = (1.0 - cos_i * cos_i).max(F32x::splat(0.0));
    let sin2_t = sin2_i / (eta * eta);
    let cos_t = (1.0 - sin2_t).sqrt();
    (!sin2_t.ge(F32x::splat(1.0)), ((-wi) / eta + (cos_i / eta - cos_t) * n).normalize())
}

/// A BSDF sample per lane (the fields of [`crate::bsdf::BsdfSample`] that `path` reads; `f` is
/// one value for every channel of a glass sample, a colour for a diffuse one).
#[derive(Clone, Copy, Debug)]
pub struct SampleX {
    /// Direction in the local frame.
    pub wi: Vec3x,
    /// The BSDF value.
    pub f: Vec3x,
    /// Density (or a delta lobe's probability).
    pub pdf: F32x,
    /// Whether `wi` crossed the surface.
    pub transmits: Mask,
    /// Relative index crossed (1 for reflection).
    pub eta: F32x,
}

/// [`crate::bsdf::RoughDielectric::specular_sample`] in radiance transport, for relative indices
/// `eta`: whether there is a sample, and the sample.
#[inline(always)]
pub fn specular_sample(eta: F32x, wo: Vec3x, uc: F32x) -> (Mask, SampleX) {
    let zero = F32x::splat(0.0);
    let above = wo.z.gt(zero);
    let etap = F32x::select(above, eta, 1.0 / eta);
    let r = fresnel_dielectric(wo.z.abs(), etap);
    let reflects = uc.lt(r);
    let mirrored = Vec3x::new(-wo.x, -wo.y, wo.z);
    let normal = Vec3x::splat(Vec3::Z) * wo.z.signum();
    let (refracts, refracted) = refraction(wo, normal, etap);
    let t = 1.0 - r;
    let scale = 1.0 / (etap * etap);
    let f = F32x::select(reflects, r / mirrored.z.abs(), t * scale / refracted.z.abs());
    let sample = SampleX {
        wi: Vec3x::select(reflects, mirrored, refracted),
        f: Vec3x::new(f, f, f),
        pdf: F32x::select(reflects, r, t),
        transmits: !reflects,
        eta: F32x::select(reflects, F32x::splat(1.0), etap),
    };
    (wo.z.ne(zero) & (reflects | refracts), sample)
}

/// [`crate::camera::concentric_polar`]: whether `u` maps to the disk's centre, the signed
/// radius and the angle.
#[inline(always)]
pub fn concentric_polar(ux: F32x, uy: F32x) -> (Mask, F32x, F32x) {
    let (ox, oy) = (2.0 * ux - 1.0, 2.0 * uy - 1.0);
    let wide = ox.abs().gt(oy.abs());
    let r = F32x::select(wide, ox, oy);
    let theta = F32x::select(wide, FRAC_PI_4 * (oy / ox), FRAC_PI_2 - FRAC_PI_4 * (ox / oy));
    let zero = F32x::splat(0.0);
    (ox.eq(zero) & oy.eq(zero), r, theta)
}

/// [`crate::bsdf::Lambert::eval`] times nothing: `albedo/π` where `wo` and `wi` lie on the same
/// side, else 0.
#[inline(always)]
pub fn lambert_eval(albedo: Vec3x, wo: Vec3x, wi: Vec3x) -> Vec3x {
    let same = (wo.z * wi.z).gt(F32x::splat(0.0));
    Vec3x::select(same, albedo * FRAC_1_PI, Vec3x::splat(Vec3::ZERO))
}

/// [`crate::bsdf::Lambert::pdf`].
#[inline(always)]
pub fn lambert_pdf(wo: Vec3x, wi: Vec3x) -> F32x {
    let same = (wo.z * wi.z).gt(F32x::splat(0.0));
    F32x::select(same, wi.z.abs() * FRAC_1_PI, F32x::splat(0.0))
}

/// [`crate::bsdf::Lambert::disk_sample`] from the disk points (`dx`, `dy`): whether there is a
/// sample, and the sample.
#[inline(always)]
pub fn lambert_sample(albedo: Vec3x, wo: Vec3x, dx: F32x, dy: F32x) -> (Mask, SampleX) {
    let zero = F32x::splat(0.0);
    let z = (1.0 - (dx * dx + dy * dy)).max(zero).sqrt();
    let wi = Vec3x::new(dx, dy, F32x::select(wo.z.lt(zero), -z, z));
    let sample = SampleX {
        wi,
        f: albedo * FRAC_1_PI,
        pdf: wi.z.abs() / PI,
        transmits: Mask::splat(false),
        eta: F32x::splat(1.0),
    };
    (!(wi.z.eq(zero) | wo.z.eq(zero)), sample)
}

/// [`crate::geometry::spawn_origin`] of the hit point `p` (geometric normal `n`, error bound
/// `p_error`) for a ray along `w`.
#[inline(always)]
pub fn spawn_origin(p: Vec3x, n: Vec3x, p_error: F32x, w: Vec3x) -> Vec3x {
    let offset = n * (p_error * n.abs().element_sum() + f32::MIN_POSITIVE);
    let offset = Vec3x::select(w.dot(n).lt(F32x::splat(0.0)), -offset, offset);
    let po = p + offset;
    Vec3x::new(po.x.away(offset.x), po.y.away(offset.y), po.z.away(offset.z))
}

/// A shadow ray per lane: [`crate::lighting::ShadowRay::toward`].
#[derive(Clone, Copy, Debug)]
pub struct ShadowX {
    /// Origin.
    pub origin: Vec3x,
    /// Direction.
    pub dir: Vec3x,
    /// Hits below this distance can block it.
    pub tmax: F32x,
    /// Distance from the origin to the target.
    pub remaining: F32x,
}

/// [`crate::lighting::ShadowRay::toward`] from the hit (`p`, `n`, `p_error`) to `target`.
#[inline(always)]
pub fn shadow_toward(p: Vec3x, n: Vec3x, p_error: F32x, target: Vec3x) -> ShadowX {
    let dir = (target - p).normalize();
    let origin = spawn_origin(p, n, p_error, dir);
    let remaining = (target - origin).dot(dir);
    // Ray::new canonicalises −0 to +0.
    ShadowX { origin, dir: dir + Vec3x::splat(Vec3::ZERO), tmax: remaining * (1.0 - 1e-5), remaining }
}

/// [`crate::texture::Texture::eval`] of a checker of cell size `size` at `p`: `color1` on even
/// cells, `color2` on odd ones.
#[inline(always)]
pub fn checker(p: Vec3x, size: F32x, color1: Vec3x, color2: Vec3x) -> Vec3x {
    let bias = F32x::splat(1e-4);
    let cell = Vec3x::new(p.x / size + bias, p.y / size + bias, p.z / size + bias).floor();
    Vec3x::select(F32x::even_sum(cell.x, cell.y, cell.z), color1, color2)
}

#[cfg(test)]
mod tests {
    use super::super::{dispatch, Isa, WIDTH};
    use super::*;
    use crate::bsdf::{Frame, Lambert, RoughDielectric, TransportMode, TrowbridgeReitz};
    use crate::geometry::SurfaceHit;
    use crate::lighting::ShadowRay;
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

    /// Every lane function against its scalar function on 16 × 500 inputs, per instruction set.
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
            let frame = FrameX::from_normal(a);
            let local = frame.to_local(b);
            let world = frame.to_world(b);
            let solid = area_to_solid_angle(s, raw, b, a);
            let heuristic = power_heuristic(s, raw.x);
            let fresnel = fresnel_dielectric(b.z, s * 2.0);
            let (refracts, refracted) = refraction(b, a, s + 0.5);
            let (glass_ok, glass) = specular_sample(s * 2.0 + 0.5, b, u);
            let (centre, radius, theta) =
                concentric_polar(u, F32x(std::array::from_fn(|k| input[k][5] * 0.5 + 0.5)));
            let eval = lambert_eval(raw, a, b);
            let pdf = lambert_pdf(a, b);
            let (lambert_ok, lambert) = lambert_sample(raw, a, b.x * 0.7, b.y * 0.7);
            let shadow = shadow_toward(raw, a, s * 1e-3, raw + b);
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
            let pinhole = pinhole_directions(&camera, fx, fy);
            for k in 0..WIDTH {
                let (va, vb, vraw) = (a.lane(k), b.lane(k), raw.lane(k));
                let f = Frame::from_normal(va);
                assert!(same(frame.s.lane(k), f.s) && same(frame.t.lane(k), f.t), "frame of {va}");
                assert!(same(local.lane(k), f.to_local(vb)) && same(world.lane(k), f.to_world(vb)));
                let want = crate::light::area_to_solid_angle(s.0[k], vraw, vb, va);
                assert_eq!(solid.0[k].to_bits(), want.to_bits());
                let want = crate::integrators::power_heuristic(s.0[k], vraw.x);
                assert_eq!(heuristic.0[k].to_bits(), want.to_bits());
                let want = crate::optics::fresnel_dielectric(vb.z, s.0[k] * 2.0);
                assert_eq!(fresnel.0[k].to_bits(), want.to_bits());
                let (ok, dir) = crate::optics::refraction(vb, va, s.0[k] + 0.5);
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
                    assert_eq!(glass.transmits.0[k], g.is_transmission);
                }
                let (c, r, t) = crate::camera::concentric_polar(Vec2::new(u.0[k], input[k][5] * 0.5 + 0.5));
                assert_eq!(centre.0[k], c);
                assert!(c || (radius.0[k].to_bits(), theta.0[k].to_bits()) == (r.to_bits(), t.to_bits()));
                let l = Lambert::two_sided(vraw);
                assert!(same(eval.lane(k), l.eval(va, vb)));
                assert_eq!(pdf.0[k].to_bits(), l.pdf(va, vb).to_bits());
                let (ok, d) = l.disk_sample(va, Vec2::new(vb.x * 0.7, vb.y * 0.7));
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
    fn every_lane_function_is_its_scalar_function_bit_for_bit() {
        for isa in Isa::available() {
            check(isa, ());
        }
    }
}
