//! The pinhole and thin-lens camera: placement, the pixel reconstruction filter that places its
//! samples on the film, the near clip plane and the crop window of the film it renders.

use crate::geometry::{try_unit, Ray};
use crate::lanes::{Real, Vector};
use crate::pixel_filter::PixelFilter;
use glam::{Vec2, Vec3};

/// A pinhole camera with a vertical field of view; pixel (0,0) is the top-left one.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Unit vector to the image's right.
    pub right: Vec3,
    /// Unit vector to the image's top.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_degrees: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Thin-lens radius in scene units (0: pinhole).
    pub aperture: f32,
    /// Distance from the lens to the plane in focus.
    pub focus_distance: f32,
    /// Shutter interval (open, close).
    pub shutter: (f32, f32),
    /// Half the image plane's height at distance 1.
    pub(crate) tan_half_fov: f32,
    /// The point looked at and the up vector as given (before they were made an orthonormal
    /// frame), which `vitrum export` writes back so that a round trip keeps the same frame.
    pub placement: (Vec3, Vec3),
    /// The pixel reconstruction filter: where a pixel's camera samples fall on the film and
    /// how a light path's film point is shared among pixels.
    pub filter: PixelFilter,
    /// Distance of the near clip plane along the view axis (Mitsuba's `near_clip`): camera rays
    /// start on it, and nothing closer to the camera is seen; 0 clips nothing.
    pub near_clip: f32,
    /// The part of the film that is rendered and written (the whole film by default).
    pub crop: CropWindow,
}

/// A rectangle of the film's pixels (Mitsuba's `crop_offset_x/y`, `crop_width/height`): the
/// camera sees the whole film; a render computes and writes only these pixels, each as the
/// whole film's render would (the same sample streams, which are keyed by the whole film's
/// pixel index).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CropWindow {
    /// Column of the window's left pixels.
    pub x: u32,
    /// Row of the window's top pixels.
    pub y: u32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl CropWindow {
    /// The whole film of `width`×`height` pixels.
    pub fn full(width: u32, height: u32) -> CropWindow {
        CropWindow { x: 0, y: 0, width, height }
    }

    /// Row-major index within the window of the film's pixel (`x`, `y`), if the window holds it.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> Option<u32> {
        let (cx, cy) = (x.wrapping_sub(self.x), y.wrapping_sub(self.y));
        (cx < self.width && cy < self.height).then_some(cy * self.width + cx)
    }

    /// The number of pixels in the window.
    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

impl Camera {
    /// A camera at `position` looking at `look_at`; `None` when `up` is parallel to the view
    /// direction or the view direction is zero.
    pub fn new(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_degrees: f32,
        width: u32,
        height: u32,
    ) -> Option<Camera> {
        let placement = (look_at, up);
        let forward = try_unit(look_at - position)?;
        let up = try_unit(up)?;
        if forward.cross(up).length() < 1e-6 {
            return None;
        }
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Some(Camera {
            position,
            forward,
            right,
            up,
            fov_degrees,
            width,
            height,
            aperture: 0.0,
            focus_distance: (look_at - position).length(),
            shutter: (0.0, 0.0),
            tan_half_fov: (0.5 * fov_degrees.to_radians()).tan(),
            placement,
            filter: PixelFilter::BOX,
            near_clip: 0.0,
            crop: CropWindow::full(width, height),
        })
    }

    /// The same camera with a thin lens of radius `aperture` focused at `focus_distance`.
    pub fn with_lens(mut self, aperture: f32, focus_distance: f32) -> Camera {
        self.aperture = aperture;
        self.focus_distance = focus_distance;
        self
    }

    /// The same camera with the shutter open over `[open, close]`.
    pub fn with_shutter(mut self, open: f32, close: f32) -> Camera {
        self.shutter = (open, close);
        self
    }

    /// The same camera with the pixel filter `filter`.
    pub fn with_filter(mut self, filter: PixelFilter) -> Camera {
        self.filter = filter;
        self
    }

    /// The same camera with its near clip plane at `near_clip` along the view axis.
    pub fn with_near_clip(mut self, near_clip: f32) -> Camera {
        self.near_clip = near_clip;
        self
    }

    /// The same camera rendering only the window `crop` of its film (which must lie on it).
    pub fn with_crop(mut self, crop: CropWindow) -> Camera {
        self.crop = crop;
        self
    }

    /// The same camera at another resolution; a crop window keeps its place on the film in
    /// proportion (its edges rounded outwards to whole pixels).
    pub fn with_resolution(mut self, width: u32, height: u32) -> Camera {
        let c = self.crop;
        self.crop = if c == CropWindow::full(self.width, self.height) {
            CropWindow::full(width, height)
        } else {
            let scale = |v: u32, from: u32, to: u32, up: bool| {
                let exact = v as f64 * to as f64 / from as f64;
                (if up { exact.ceil() } else { exact.floor() } as u32).min(to)
            };
            let (x0, y0) = (scale(c.x, self.width, width, false), scale(c.y, self.height, height, false));
            let x1 = scale(c.x + c.width, self.width, width, true).max(x0 + 1).min(width);
            let y1 = scale(c.y + c.height, self.height, height, true).max(y0 + 1).min(height);
            let (x0, y0) = (x0.min(x1 - 1), y0.min(y1 - 1));
            CropWindow { x: x0, y: y0, width: x1 - x0, height: y1 - y0 }
        };
        self.width = width;
        self.height = height;
        self
    }

    /// The film position (pixel units) of camera sample `u` in [0, 1)² of the film's pixel
    /// (`x`, `y`), placed by the pixel filter ([`PixelFilter::film_point`]).
    #[inline]
    pub fn film_point(&self, x: u32, y: u32, u: Vec2) -> Vec2 {
        self.filter.film_point(x, y, u, self.width, self.height)
    }

    /// `ray` from the camera moved forward to the near clip plane (unchanged without one).
    #[inline]
    pub fn clip(&self, mut ray: Ray) -> Ray {
        if self.near_clip > 0.0 {
            ray.origin += ray.dir * (self.near_clip / ray.dir.dot(self.forward));
        }
        ray
    }

    /// Whether the camera has a lens with an aperture (depth of field).
    pub fn has_lens(&self) -> bool {
        self.aperture > 0.0
    }

    /// The point of the lens disk for the lens sample `u` in [0,1)² (concentric mapping), where
    /// a connection to the camera ends; the camera's position for a pinhole.
    pub fn lens_point(&self, u: Vec2) -> Vec3 {
        if !self.has_lens() {
            return self.position;
        }
        let d = concentric_disk(u) * self.aperture;
        self.position + self.right * d.x + self.up * d.y
    }

    /// The ray through film position `film` (pixel units) from lens sample `lens` in [0,1)²
    /// (ignored for a pinhole) at time `time`: [`Camera::ray_through`] for one ray.
    pub fn generate_ray_lens(&self, film: Vec2, lens: Vec2, time: f32) -> Ray {
        let (origin, dir) = self.ray_through::<Vec3>(film.x, film.y, lens.x, lens.y);
        Ray { origin, dir, time }
    }

    /// The origin and unit direction (negative zeros cleared, as [`Ray::new`] clears them) of the
    /// camera ray through film position (`fx`, `fy`) (pixel units) from lens sample (`lx`, `ly`)
    /// in [0,1)², for one ray or across lanes. Thin lens: the ray leaves a point of the lens disk (concentric mapping) towards
    /// the point of the focal plane the pinhole ray would reach; a pinhole ignores the lens
    /// sample. With a near clip plane the ray starts where it crosses that plane
    /// ([`Camera::clip`]).
    #[inline(always)]
    pub fn ray_through<V: Vector>(&self, fx: V::Real, fy: V::Real, lx: V::Real, ly: V::Real) -> (V, V) {
        let zero = V::splat(Vec3::ZERO);
        let pinhole = self.pinhole_direction::<V>(fx, fy) + zero;
        let (mut origin, dir) = if self.has_lens() {
            let focus = pinhole * (V::Real::splat(self.focus_distance) / pinhole.dot(V::splat(self.forward)));
            let (dx, dy) = concentric_disk_point(lx, ly);
            let offset =
                V::splat(self.right) * (dx * self.aperture) + V::splat(self.up) * (dy * self.aperture);
            (V::splat(self.position) + offset, (focus - offset).normalize() + zero)
        } else {
            (V::splat(self.position), pinhole)
        };
        if self.near_clip > 0.0 {
            origin = origin + dir * (V::Real::splat(self.near_clip) / dir.dot(V::splat(self.forward)));
        }
        (origin, dir)
    }

    /// The ray through film position `film` in pixel units (x right, y down; (0.5, 0.5) is the
    /// centre of the top-left pixel).
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        Ray::new(self.position, self.pinhole_direction(film.x, film.y))
    }

    /// The unit direction of [`generate_ray`](Self::generate_ray) through the film position
    /// (`fx`, `fy`), for one ray or across lanes (−0 components are left for the ray to clear).
    #[inline(always)]
    pub fn pinhole_direction<V: Vector>(&self, fx: V::Real, fy: V::Real) -> V {
        let (w, h) = (self.width as f32, self.height as f32);
        let aspect = w / h;
        let two = V::Real::splat(2.0);
        let ndc_x = (two * fx / w - 1.0) * aspect * self.tan_half_fov;
        let ndc_y = (V::Real::splat(1.0) - two * fy / h) * self.tan_half_fov;
        (V::splat(self.forward) + V::splat(self.right) * ndc_x + V::splat(self.up) * ndc_y).normalize()
    }

    /// Area of the image plane at distance 1 from the pinhole: `(2·tan(fov/2))² · aspect`. The
    /// camera's importance is `W_e = 1/(A·cos⁴θ)` (pbrt); a pixel covers `A / (w·h)` of it.
    pub fn film_area(&self) -> f32 {
        let tan_half_fov = (0.5 * self.fov_degrees.to_radians()).tan();
        let aspect = self.width as f32 / self.height as f32;
        4.0 * tan_half_fov * tan_half_fov * aspect
    }

    /// The connection of the scene point `p` to the point `lens` of the lens (the camera's
    /// position for a pinhole): the film point it lands on, where the camera pass's ray from that
    /// lens point through the focal plane comes from; `None` when `p` is behind the camera or
    /// before its near clip plane, off the film or at the lens point itself.
    pub fn connection(&self, p: Vec3, lens: Vec3) -> Option<CameraConnection> {
        let to_vertex = p - lens;
        let dist2 = to_vertex.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        let dir = to_vertex / dist2.sqrt();
        let cos = dir.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        if self.near_clip > 0.0 && (p - self.position).dot(self.forward) < self.near_clip {
            return None;
        }
        let film = if self.has_lens() {
            self.project(lens + dir * (self.focus_distance / cos))
        } else {
            self.project(p)
        }?;
        if !(film.x >= 0.0 && film.y >= 0.0) {
            return None;
        }
        let (x, y) = (film.x as u32, film.y as u32);
        if x >= self.width || y >= self.height {
            return None;
        }
        // The camera's ray toward p begins at the lens point or, with a near clip plane, where
        // it crosses that plane.
        let start = if self.near_clip > 0.0 { lens + dir * (self.near_clip / cos) } else { lens };
        Some(CameraConnection { film, start, dir, dist2, cos })
    }

    /// The film position (pixel units) where the point `p` projects, if it is in front of the
    /// camera.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let d = p - self.position;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let aspect = self.width as f32 / self.height as f32;
        let ndc_x = d.dot(self.right) / (z * self.tan_half_fov * aspect);
        let ndc_y = d.dot(self.up) / (z * self.tan_half_fov);
        Some(Vec2::new((ndc_x + 1.0) * 0.5 * self.width as f32, (1.0 - ndc_y) * 0.5 * self.height as f32))
    }
}

/// A scene point connected to the camera ([`Camera::connection`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraConnection {
    /// The film position (pixel units, on the film) the point lands on.
    pub film: Vec2,
    /// Where the camera's ray toward the point starts: the lens point, or its crossing of the
    /// near clip plane.
    pub start: Vec3,
    /// Unit direction from the lens point to the scene point.
    pub dir: Vec3,
    /// Squared distance between them.
    pub dist2: f32,
    /// Cosine between `dir` and the view axis.
    pub cos: f32,
}

/// Shirley–Chiu concentric map from the unit square to the unit disk (area preserving).
#[inline(always)]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let (x, y) = concentric_disk_point(u.x, u.y);
    Vec2::new(x, y)
}

/// [`concentric_disk`] for one sample or across lanes: the point of the disk for (`ux`, `uy`).
/// Its angle θ is π/4·q or π/2 − π/4·q with |q| ≤ 1, so its cosine and sine are those of
/// a = π/4·q, in that order or swapped ([`cos_sin_quarter`]): the map is the same arithmetic for
/// one sample and for every lane, and vectorises.
#[inline(always)]
pub fn concentric_disk_point<R: Real>(ux: R, uy: R) -> (R, R) {
    let (centre, wide, r, a) = concentric_polar(ux, uy);
    let (c, s) = cos_sin_quarter(a);
    let (cos, sin) = (R::select(wide, c, s), R::select(wide, s, c));
    let zero = R::splat(0.0);
    (R::select(centre, zero, r * cos), R::select(centre, zero, r * sin))
}

/// [`concentric_disk`] up to its trigonometry, for one sample or across lanes: whether
/// (`ux`, `uy`) maps to the disk's centre; whether it lies in the wide (left and right) wedges;
/// the point's signed radius `r`; and the angle `a` in [−π/4, π/4] of the point
/// `r·(cos a, sin a)` (wide) or `r·(sin a, cos a)` (the top and bottom wedges, θ = π/2 − a).
#[inline(always)]
pub fn concentric_polar<R: Real>(ux: R, uy: R) -> (R::Mask, R::Mask, R, R) {
    use std::f32::consts::FRAC_PI_4;
    let (ox, oy) = (R::splat(2.0) * ux - 1.0, R::splat(2.0) * uy - 1.0);
    let wide = ox.abs().gt(oy.abs());
    let r = R::select(wide, ox, oy);
    let a = R::splat(FRAC_PI_4) * R::select(wide, oy / ox, ox / oy);
    let zero = R::splat(0.0);
    (ox.eq(zero) & oy.eq(zero), wide, r, a)
}

/// `(cos a, sin a)` for |a| ≤ π/4, by the minimax polynomials of Cephes's single-precision
/// `cosf` and `sinf` kernels (Moshier): for one number or across lanes with the same operations,
/// so every lane has the one-number bits and the lanes vectorise (libm's functions, one call per
/// lane, do not). Measured within 1.25 ulp (cosine) and 0.76 ulp (sine) of the
/// exact values on that range, libm 0.88 and 0.64 (the test allows 2).
#[inline(always)]
pub fn cos_sin_quarter<R: Real>(a: R) -> (R, R) {
    let z = a * a;
    let sin = a + a * z * (R::splat(-1.666_665_5e-1) + z * (R::splat(8.332_161e-3) + z * -1.951_529_6e-4));
    let cos = R::splat(1.0) - z * 0.5
        + z * z * (R::splat(4.166_664_6e-2) + z * (R::splat(-1.388_731_6e-3) + z * 2.443_315_7e-5));
    (cos, sin)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::new(Vec3::new(0.0, 1.0, 4.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 40.0, 64, 32).unwrap()
    }

    #[test]
    fn the_centre_ray_looks_at_the_target_without_negative_zeros() {
        let r = cam().generate_ray(Vec2::new(32.0, 16.0));
        assert!(r.dir.abs_diff_eq(-Vec3::Z, 1e-6));
        assert!(r.dir.to_array().iter().all(|c| !(*c == 0.0 && c.is_sign_negative())));
    }

    #[test]
    fn top_edge_ray_makes_half_the_field_of_view() {
        let r = cam().generate_ray(Vec2::new(32.0, 0.0));
        let angle = r.dir.dot(-Vec3::Z).acos().to_degrees();
        assert!((angle - 20.0).abs() < 1e-3, "{angle}");
        assert!(r.dir.y > 0.0, "row 0 is the top of the image");
    }

    #[test]
    fn projection_inverts_ray_generation() {
        let c = cam();
        let film = Vec2::new(10.3, 27.9);
        let r = c.generate_ray(film);
        let back = c.project(r.at(3.7)).unwrap();
        assert!((back - film).length() < 1e-3);
    }

    #[test]
    fn thin_lens_rays_converge_on_the_focal_plane() {
        let c = cam().with_lens(0.2, 3.0);
        let film = Vec2::new(20.0, 9.0);
        let target = c.generate_ray(film);
        let focus = target.at(3.0 / target.dir.dot(c.forward));
        for (i, j) in [(0.1f32, 0.2f32), (0.9, 0.5), (0.5, 0.99), (0.0, 0.0)] {
            let r = c.generate_ray_lens(film, Vec2::new(i, j), 0.25);
            assert_eq!(r.time, 0.25);
            let t = (focus - r.origin).dot(r.dir);
            assert!((r.at(t) - focus).length() < 1e-5, "lens ({i}, {j})");
            assert!((r.origin - c.position).length() <= 0.2 + 1e-6);
        }
    }

    #[test]
    fn concentric_mapping_stays_in_the_disk_and_covers_it() {
        let mut max_r = 0.0f32;
        for i in 0..64 {
            for j in 0..64 {
                let p = concentric_disk(Vec2::new(i as f32 / 63.0, j as f32 / 63.0));
                assert!(p.length() <= 1.0 + 1e-6);
                max_r = max_r.max(p.length());
            }
        }
        assert!(max_r > 0.999);
    }

    /// The distance in units in the last place between `got` and the exact `want`.
    fn ulps(got: f32, want: f64) -> f64 {
        let w = want as f32;
        let ulp = (w.abs().next_up() - w.abs()) as f64;
        (got as f64 - want).abs() / ulp
    }

    #[test]
    fn quarter_cosine_and_sine_are_within_two_ulp() {
        let (mut worst_cos, mut worst_sin) = (0.0f64, 0.0f64);
        let n = 1 << 20;
        for i in -n..=n {
            let a = std::f32::consts::FRAC_PI_4 * (i as f32 / n as f32);
            let (c, s) = cos_sin_quarter(a);
            worst_cos = worst_cos.max(ulps(c, (a as f64).cos()));
            if a != 0.0 {
                worst_sin = worst_sin.max(ulps(s, (a as f64).sin()));
            } else {
                assert_eq!(s.to_bits(), a.to_bits(), "sin ±0 = ±0");
            }
        }
        assert!(worst_cos <= 2.0 && worst_sin <= 2.0, "cos {worst_cos} ulp, sin {worst_sin} ulp");
    }

    /// The map is area-preserving: each of 8×8 equal cells of the square covers 1/64 of the disk.
    /// Counted on a 1024² grid of the square mapped to 64 sectors of 8 rings of equal area, each
    /// cell's points are where the polar mapping puts them (the ring of its radius, the sector of
    /// its angle), with no point outside the disk.
    #[test]
    fn concentric_mapping_keeps_area() {
        let n = 1024;
        let mut count = [[0u32; 64]; 8];
        for i in 0..n {
            for j in 0..n {
                let p = concentric_disk(Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32));
                let r2 = p.length_squared();
                assert!(r2 <= 1.0 + 1e-6, "{p}");
                let ring = ((r2 * 8.0) as usize).min(7);
                let angle = p.y.atan2(p.x).rem_euclid(std::f32::consts::TAU);
                let sector = ((angle / std::f32::consts::TAU * 64.0) as usize).min(63);
                count[ring][sector] += 1;
            }
        }
        // Every (ring, sector) cell has area π/512 of the disk: (1024²)/512 = 2048 points each,
        // give or take the points on cell boundaries (a boundary crosses about 2·1024/8 grid rows).
        for (ring, sectors) in count.iter().enumerate() {
            for (sector, &c) in sectors.iter().enumerate() {
                assert!((c as i64 - 2048).abs() <= 130, "ring {ring}, sector {sector}: {c}");
            }
        }
    }

    #[test]
    fn up_parallel_to_view_is_refused() {
        assert!(Camera::new(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, 8, 8).is_none());
        assert!(Camera::new(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 40.0, 8, 8).is_none());
    }
}
