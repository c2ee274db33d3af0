//! The pinhole camera.

use crate::geometry::{try_unit, Ray};
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

    /// The same camera at another resolution.
    pub fn with_resolution(mut self, width: u32, height: u32) -> Camera {
        self.width = width;
        self.height = height;
        self
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
    /// (ignored for a pinhole) at time `time`. Thin lens: the ray leaves a point of the lens disk
    /// (concentric mapping) towards the point of the focal plane the pinhole ray would reach.
    pub fn generate_ray_lens(&self, film: Vec2, lens: Vec2, time: f32) -> Ray {
        let pinhole = self.generate_ray(film);
        let mut ray = if self.has_lens() {
            let focus = pinhole.dir * (self.focus_distance / pinhole.dir.dot(self.forward));
            let disk = concentric_disk(lens) * self.aperture;
            let offset = self.right * disk.x + self.up * disk.y;
            Ray::new(self.position + offset, (focus - offset).normalize())
        } else {
            pinhole
        };
        ray.time = time;
        ray
    }

    /// The ray through film position `film` in pixel units (x right, y down; (0.5, 0.5) is the
    /// centre of the top-left pixel).
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        let aspect = self.width as f32 / self.height as f32;
        let ndc_x = (2.0 * film.x / self.width as f32 - 1.0) * aspect * self.tan_half_fov;
        let ndc_y = (1.0 - 2.0 * film.y / self.height as f32) * self.tan_half_fov;
        let dir = (self.forward + ndc_x * self.right + ndc_y * self.up).normalize();
        Ray::new(self.position, dir)
    }

    /// Area of the image plane at distance 1 from the pinhole: `(2·tan(fov/2))² · aspect`. The
    /// camera's importance is `W_e = 1/(A·cos⁴θ)` (pbrt); a pixel covers `A / (w·h)` of it.
    pub fn film_area(&self) -> f32 {
        let tan_half_fov = (0.5 * self.fov_degrees.to_radians()).tan();
        let aspect = self.width as f32 / self.height as f32;
        4.0 * tan_half_fov * tan_half_fov * aspect
    }

    /// The connection of the scene point `p` to the point `lens` of the lens (the camera's
    /// position for a pinhole): the pixel it lands in, where the camera pass's ray from that lens
    /// point through the focal plane comes from; `None` when `p` is behind the camera, off the
    /// film or at the lens point itself.
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
        Some(CameraConnection { pixel: y * self.width + x, dir, dist2, cos })
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
    /// Row-major index of the pixel the point lands in.
    pub pixel: u32,
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
    let (centre, r, theta) = concentric_polar(u);
    if centre {
        return Vec2::ZERO;
    }
    r * Vec2::new(theta.cos(), theta.sin())
}

/// [`concentric_disk`] up to its trigonometry: whether `u` maps to the disk's centre, else the
/// point's signed radius `r` and angle `theta` (the point is `r·(cos θ, sin θ)`). The wavefront
/// engine runs this across lanes and the cosines one lane at a time.
#[inline(always)]
pub fn concentric_polar(u: Vec2) -> (bool, f32, f32) {
    let o = 2.0 * u - Vec2::ONE;
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    (o == Vec2::ZERO, r, theta)
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

    #[test]
    fn up_parallel_to_view_is_refused() {
        assert!(Camera::new(Vec3::ZERO, Vec3::Y, Vec3::Y, 40.0, 8, 8).is_none());
        assert!(Camera::new(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 40.0, 8, 8).is_none());
    }
}
