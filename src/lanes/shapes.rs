//! Quads, spheres, cylinders and disks against [`WIDTH`] rays: their `intersect` lane by lane,
//! operation for operation (see the module above). A lane that misses holds +∞.

use super::{dispatch, Lanes, RayLanes, WIDTH};
use crate::geometry::MIN_QUADRATIC_A;
use crate::geometry::{gamma, Cylinder, Disk, Quad, Sphere, SEAM_ULPS};

/// `a·b` of two 3-vectors as glam's `Vec3::dot` sums it: `(x·x' + y·y') + z·z'`.
#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The largest of three magnitudes, as glam's `Vec3::abs().max_element()`.
#[inline(always)]
fn max_abs(v: [f32; 3]) -> f32 {
    v[0].abs().max(v[1].abs().max(v[2].abs()))
}

/// Lane `k` of `rays`: origin and direction.
#[inline(always)]
fn lane(rays: &RayLanes, k: usize) -> ([f32; 3], [f32; 3]) {
    (
        [rays.origin[0][k], rays.origin[1][k], rays.origin[2][k]],
        [rays.dir[0][k], rays.dir[1][k], rays.dir[2][k]],
    )
}

/// `o − c`, component by component.
#[inline(always)]
fn offset(o: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    [o[0] - c[0], o[1] - c[1], o[2] - c[2]]
}

/// `f + t·d`, as glam's `f + t * d`.
#[inline(always)]
fn along(f: [f32; 3], t: f32, d: [f32; 3]) -> [f32; 3] {
    [f[0] + t * d[0], f[1] + t * d[1], f[2] + t * d[2]]
}

/// `plane_hit` of the scalar tests without its early returns: for the plane through `reference`
/// with unit normal `n`, whether the ray meets it in (`tmin`, `tmax`), the distance, the origin's
/// offset `f` from `reference` and the hit's `q = f + t·d`.
#[inline(always)]
fn plane_hit(
    n: [f32; 3],
    reference: [f32; 3],
    o: [f32; 3],
    d: [f32; 3],
    tmin: f32,
    tmax: f32,
) -> (bool, f32, [f32; 3], [f32; 3]) {
    let denom = dot(n, d);
    let f = offset(o, reference);
    let t = -dot(n, f) / denom;
    ((denom != 0.0) & (t > tmin) & (t < tmax), t, f, along(f, t, d))
}

/// The scalar tests' choice between two ordered roots: none where the ray meets no surface
/// (`roots` false) or the interval (`tmin`, `tmax`) lies outside [t0, t1], else the first root
/// inside the interval whose point the shape keeps (`keep0`, `keep1`); +∞ for none.
#[inline(always)]
fn first_root(roots: bool, (t0, t1): (f32, f32), (keep0, keep1): (bool, bool), tmin: f32, tmax: f32) -> f32 {
    let usable0 = (t0 > tmin) & (t0 < tmax) & keep0;
    let usable1 = (t1 > tmin) & (t1 < tmax) & keep1;
    let overlap = !((t0 >= tmax) | (t1 <= tmin));
    let t = if usable0 {
        t0
    } else if usable1 {
        t1
    } else {
        f32::INFINITY
    };
    if roots & overlap {
        t
    } else {
        f32::INFINITY
    }
}

/// The quad kernel: [`Quad::intersect`] per lane within (`tmin`, `tmax[k]`).
#[inline(always)]
pub(super) fn quad_kernel(quad: &Quad, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes {
    let n = quad.normal.to_array();
    let corner = quad.corner.to_array();
    let (du, dv) = (quad.dual.0.to_array(), quad.dual.1.to_array());
    let corner_size = quad.size + max_abs(corner);
    let mut out = [f32::INFINITY; WIDTH];
    for k in 0..WIDTH {
        let (o, d) = lane(rays, k);
        let (plane, t, f, q) = plane_hit(n, corner, o, d, tmin, tmax[k]);
        let (a, b) = (dot(q, du), dot(q, dv));
        // seam_slack: γ·(size + |corner|max + |f|max), in that order, times the inverse widths.
        let slack = gamma(SEAM_ULPS) * (corner_size + max_abs(f));
        let (sa, sb) = (slack * quad.inv_width.x, slack * quad.inv_width.y);
        // `&`, not `&&`: no branches, so that the loop vectorises.
        let inside = (a >= -sa) & (b >= -sb) & (a <= 1.0 + sa) & (b <= 1.0 + sb);
        out[k] = if plane & inside { t } else { f32::INFINITY };
    }
    out
}

/// `radial_roots` of the scalar tests, branch-free: whether the ray meets the sphere of radius
/// `r` about the origin (`f` the origin's offset, `d` the direction), and the two roots in order.
#[inline(always)]
fn radial_roots(f: [f32; 3], d: [f32; 3], r: f32) -> (bool, f32, f32) {
    let a = dot(d, d);
    let b = 2.0 * dot(f, d);
    let c = dot(f, f) - r * r;
    let s = b / (2.0 * a);
    let m = [f[0] - s * d[0], f[1] - s * d[1], f[2] - s * d[2]]; // glam's `f - s * d`
    let closest = dot(m, m).sqrt();
    let discrim = 4.0 * a * (r + closest) * (r - closest);
    let roots = !((a < MIN_QUADRATIC_A) | a.is_nan() | (discrim < 0.0) | discrim.is_nan());
    let root = discrim.sqrt();
    let q = if b < 0.0 { -0.5 * (b - root) } else { -0.5 * (b + root) };
    let (n0, n1) = (q / a, c / q);
    let ordered = n0 <= n1;
    let t0 = if q == 0.0 {
        0.0
    } else if ordered {
        n0
    } else {
        n1
    };
    let t1 = if q == 0.0 {
        0.0
    } else if ordered {
        n1
    } else {
        n0
    };
    (roots, t0, t1)
}

/// The cylinder kernel: [`Cylinder::intersect`] per lane (radial roots in the cross-section,
/// then the height).
#[inline(always)]
pub(super) fn cylinder_kernel(cylinder: &Cylinder, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes {
    let base = cylinder.base.to_array();
    let (u, v, w) = (cylinder.u.to_array(), cylinder.v.to_array(), cylinder.w.to_array());
    let local = |x: [f32; 3]| [dot(x, u), dot(x, v), dot(x, w)];
    let size = cylinder.radius + cylinder.height + max_abs(base);
    let mut out = [f32::INFINITY; WIDTH];
    for k in 0..WIDTH {
        let (o, d) = lane(rays, k);
        let f = local(offset(o, base));
        let d = local(d);
        let (roots, t0, t1) = radial_roots([f[0], f[1], 0.0], [d[0], d[1], 0.0], cylinder.radius);
        let slack = gamma(SEAM_ULPS) * (size + max_abs(f));
        let (z0, z1) = (f[2] + t0 * d[2], f[2] + t1 * d[2]);
        let top = cylinder.height + slack;
        let keep = ((z0 >= -slack) & (z0 <= top), (z1 >= -slack) & (z1 <= top));
        out[k] = first_root(roots, (t0, t1), keep, tmin, tmax[k]);
    }
    out
}

/// The disk kernel: [`Disk::intersect`] per lane (the plane, then the annulus).
#[inline(always)]
pub(super) fn disk_kernel(disk: &Disk, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes {
    let n = disk.normal.to_array();
    let center = disk.center.to_array();
    let size = disk.radius + max_abs(center);
    let mut out = [f32::INFINITY; WIDTH];
    for k in 0..WIDTH {
        let (o, d) = lane(rays, k);
        let (plane, t, f, q) = plane_hit(n, center, o, d, tmin, tmax[k]);
        let dist2 = dot(q, q);
        let slack = gamma(SEAM_ULPS) * (size + max_abs(f));
        let (outer, inner) = (disk.radius + slack, (disk.inner_radius - slack).max(0.0));
        let inside = (dist2 <= outer * outer) & (dist2 >= inner * inner);
        out[k] = if plane & inside { t } else { f32::INFINITY };
    }
    out
}

/// The sphere kernel: [`Sphere::intersect`] per lane (radial roots, then the clipping zone).
#[inline(always)]
pub(super) fn sphere_kernel(sphere: &Sphere, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes {
    let center = sphere.center.to_array();
    let axis = sphere.axis.to_array();
    let r = sphere.radius;
    let center_size = r + max_abs(center);
    let mut out = [f32::INFINITY; WIDTH];
    for k in 0..WIDTH {
        let (o, d) = lane(rays, k);
        let f = offset(o, center);
        let (roots, t0, t1) = radial_roots(f, d, r);
        // The zone's heights, widened by the seam slack where the sphere is clipped.
        let slack = if sphere.clipped { gamma(SEAM_ULPS) * (center_size + max_abs(f)) } else { 0.0 };
        let (low, high) = (sphere.min_height - slack, sphere.max_height + slack);
        let in_zone = |t: f32| {
            let h = dot(along(f, t, d), axis);
            !sphere.clipped | ((h <= high) & (h >= low))
        };
        out[k] = first_root(roots, (t0, t1), (in_zone(t0), in_zone(t1)), tmin, tmax[k]);
    }
    out
}

dispatch! {
    /// Each lane's nearest hit distance on `quad` in (`tmin`, `tmax[k]`), +∞ where it misses;
    /// bit for bit [`Quad::intersect`] of that lane's ray.
    pub fn quad_hits(quad: &Quad, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes => quad_kernel
}

dispatch! {
    /// Each lane's nearest hit distance on `cylinder` in (`tmin`, `tmax[k]`), +∞ where it
    /// misses; bit for bit [`Cylinder::intersect`] of that lane's ray.
    pub fn cylinder_hits(cylinder: &Cylinder, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes => cylinder_kernel
}

dispatch! {
    /// Each lane's nearest hit distance on `disk` in (`tmin`, `tmax[k]`), +∞ where it misses;
    /// bit for bit [`Disk::intersect`] of that lane's ray.
    pub fn disk_hits(disk: &Disk, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes => disk_kernel
}

dispatch! {
    /// Each lane's nearest hit distance on `sphere` in (`tmin`, `tmax[k]`), +∞ where it misses;
    /// bit for bit [`Sphere::intersect`] of that lane's ray.
    pub fn sphere_hits(sphere: &Sphere, rays: &RayLanes, tmin: f32, tmax: &Lanes) -> Lanes => sphere_kernel
}

#[cfg(test)]
mod tests {
    use super::super::Isa;
    use super::*;
    use crate::geometry::Ray;
    use glam::Vec3;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg32;

    /// Rays from a cube around the shapes towards points of it, with grazing, axis-aligned,
    /// zero-component and tiny directions mixed in.
    fn rays(count: usize, seed: u64) -> Vec<Ray> {
        let mut rng = Pcg32::seed_from_u64(seed);
        let mut point = |s: f32| {
            Vec3::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5) * s
        };
        (0..count)
            .map(|k| {
                let o = point(6.0);
                let mut d = (point(2.0) - o).normalize();
                match k % 7 {
                    0 => d.y = 0.0, // parallel to the y planes
                    1 => d = Vec3::X * d.x.signum(),
                    2 => d *= 1e-20, // below the quadratic's threshold
                    _ => {}
                }
                Ray::new(o, d)
            })
            .collect()
    }

    /// Compares `lanes(isa, rays, tmin, tmax)` with `scalar(ray, tmin, tmax)` bit for bit over
    /// many batches and every instruction set this CPU runs.
    fn agrees(
        name: &str,
        lanes: impl Fn(Isa, &RayLanes, f32, &Lanes) -> Lanes,
        scalar: impl Fn(&Ray, f32, f32) -> Option<f32>,
    ) {
        let rays = rays(WIDTH * 400, 5);
        let mut hits = 0;
        for isa in Isa::available() {
            for (b, batch) in rays.chunks(WIDTH).enumerate() {
                let packed = RayLanes::gather(batch);
                let tmax: Lanes = std::array::from_fn(|k| if (b + k) % 3 == 0 { 2.5 } else { f32::INFINITY });
                let tmin = if b % 4 == 0 { 1e-3 } else { 0.0 };
                let got = lanes(isa, &packed, tmin, &tmax);
                for (k, ray) in batch.iter().enumerate() {
                    let want = scalar(ray, tmin, tmax[k]).unwrap_or(f32::INFINITY);
                    assert_eq!(
                        got[k].to_bits(),
                        want.to_bits(),
                        "{name} {isa:?} batch {b} lane {k}: {ray:?}"
                    );
                    hits += usize::from(want.is_finite());
                }
            }
        }
        assert!(hits > rays.len() / 10, "{name}: only {hits} hits: the test must hit often");
    }

    #[test]
    fn quad_lanes_are_the_scalar_test_bit_for_bit() {
        for quad in [
            Quad::new(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)),
            Quad::new(Vec3::new(-0.3, 0.2, -1.0), Vec3::new(1.5, 0.4, 0.2), Vec3::new(-0.1, 0.3, 1.8)),
            Quad::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 2.0), Vec3::new(2.0, 0.0, 0.0)),
        ] {
            agrees(
                "quad",
                |isa, r, tmin, tmax| quad_hits(isa, &quad, r, tmin, tmax),
                |r, a, b| quad.intersect(r, a, b),
            );
        }
    }

    #[test]
    fn sphere_lanes_are_the_scalar_test_bit_for_bit() {
        for sphere in [
            Sphere::new(Vec3::ZERO, 1.0),
            Sphere::new(Vec3::new(0.3, -0.2, 0.1), 0.45),
            Sphere::clipped(Vec3::ZERO, 1.0, Vec3::Y, 0.2),
            Sphere::zone(Vec3::new(0.0, 0.5, 0.0), 0.9, Vec3::new(0.2, 1.0, 0.1), -0.4, 0.3),
        ] {
            agrees(
                "sphere",
                |isa, r, tmin, tmax| sphere_hits(isa, &sphere, r, tmin, tmax),
                |r, a, b| sphere.intersect(r, a, b),
            );
        }
    }

    #[test]
    fn cylinder_lanes_are_the_scalar_test_bit_for_bit() {
        for cylinder in [
            Cylinder::new(Vec3::new(0.0, -1.0, 0.0), Vec3::Y, 0.5, 2.0),
            Cylinder::new(Vec3::new(0.2, -0.5, 0.1), Vec3::new(0.3, 1.0, -0.2), 0.7, 1.2),
        ] {
            agrees(
                "cylinder",
                |isa, r, tmin, tmax| cylinder_hits(isa, &cylinder, r, tmin, tmax),
                |r, a, b| cylinder.intersect(r, a, b),
            );
        }
    }

    #[test]
    fn disk_lanes_are_the_scalar_test_bit_for_bit() {
        for disk in [
            Disk::new(Vec3::ZERO, Vec3::Y, 1.2, 0.0),
            Disk::new(Vec3::new(0.1, 0.3, -0.2), Vec3::new(0.4, 1.0, 0.3), 1.5, 0.6),
        ] {
            agrees(
                "disk",
                |isa, r, tmin, tmax| disk_hits(isa, &disk, r, tmin, tmax),
                |r, a, b| disk.intersect(r, a, b),
            );
        }
    }

    #[test]
    fn the_detected_isa_runs_here_and_the_baseline_always_does() {
        assert!(Isa::detect().runs_here());
        assert!(Isa::available().contains(&Isa::Baseline));
        assert_eq!(Isa::available()[0], Isa::detect());
    }
}
