//! A point light's caustic seen through glass, against a closed form: a point light above a
//! flat glass slab over a diffuse floor, and the camera looking at the floor through the same
//! slab (light → glass → glass → floor → glass → glass → camera, specular–diffuse–specular).
//!
//! Light crossing two parallel interfaces leaves in its original direction, displaced: a ray at
//! angle θ from the vertical meets the floor at `ρ(θ) = a·tan θ + d·tan θₜ` from the foot of the
//! light (`a` the air gap, `d` the slab's thickness, sin θ = n sin θₜ). The floor's irradiance is
//! the point light's intensity times the Fresnel transmittance of both interfaces times the
//! solid angle per floor area, `E(ρ) = I·T(θ)·sin θ / (ρ·dρ/dθ)`; the floor reflects `albedo/π·E`
//! and the camera sees it through the slab with the Fresnel transmittance of its own ray (the n²
//! of radiance entering and leaving the glass cancel). The test computes this mapping exactly,
//! in f64, independently of the renderer.
//!
//! Only photon merging can make these paths: a point light cannot be hit, shadow rays and camera
//! connections cannot bend through glass. A merge averages the irradiance over a disk of the
//! iteration's radius, so the expected value is computed as that same average (the exact merge
//! bias, not a bound), over the iterations' radii. `--max-depth 5` keeps the single crossing of
//! each interface (internal reflections and the floor–slab interreflections add vertices), so
//! the closed form is exact for what is rendered. `path` and `bpt` miss the caustic: they render
//! the floor black. (`vcm` and `ppm` give the same numbers here: merging is the only strategy
//! that can make these paths, so `vcm` weighs it 1, and both draw the same random numbers up to
//! the merge.)

mod common;

use common::render_with;
use std::f64::consts::PI;
use vitrum::integrators::iteration_radius;
use vitrum::scene::{load_str, Scene};

/// Index of the glass.
const N: f64 = 1.5;
/// Floor at y = 0, slab from `SLAB_BOTTOM` to `SLAB_TOP`, light at `LIGHT_Y`, camera at `CAMERA_Y`.
const SLAB_BOTTOM: f64 = 0.4;
const SLAB_TOP: f64 = 0.6;
const LIGHT_Y: f64 = 0.8;
const CAMERA_Y: f64 = 1.0;
const INTENSITY: f64 = 2.0;
const ALBEDO: f64 = 0.5;
const FOV_DEGREES: f64 = 2.0;
const RESOLUTION: u32 = 64;
const RADIUS: f64 = 0.05;
const ITERATIONS: u32 = 48;
const RENDERS: u64 = 16;

fn scene(method: &str) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, {CAMERA_Y}, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov = {FOV_DEGREES}
resolution = [{RESOLUTION}, {RESOLUTION}]
[render]
integrator = "{method}"
spectral = "off"
[render.path]
max_depth = 5
[render.bpt]
max_depth = 5
[render.ppm]
max_depth = 5
radius = {RADIUS}
[render.vcm]
max_depth = 5
radius = {RADIUS}
[materials.floor]
type = "diffuse"
color = {ALBEDO}
[materials.glass]
type = "dielectric"
ior = {N}
[[objects]]
name = "floor"
shape = "quad"
corner = [-10.0, 0.0, -10.0]
u = [0.0, 0.0, 20.0]
v = [20.0, 0.0, 0.0]
material = "floor"
[[objects]]
name = "slab-top"
shape = "quad"
corner = [-10.0, {SLAB_TOP}, -10.0]
u = [0.0, 0.0, 20.0]
v = [20.0, 0.0, 0.0]
material = "glass"
[[objects]]
name = "slab-bottom"
shape = "quad"
corner = [-10.0, {SLAB_BOTTOM}, -10.0]
u = [20.0, 0.0, 0.0]
v = [0.0, 0.0, 20.0]
material = "glass"
[[lights]]
type = "point"
position = [0.0, {LIGHT_Y}, 0.0]
intensity = {INTENSITY}
"#
    );
    load_str(&text, "slab-caustic.toml", None).unwrap()
}

/// Unpolarised Fresnel reflectance from a medium of index `n1` at incidence `cos_i` into `n2`.
fn fresnel(cos_i: f64, n1: f64, n2: f64) -> f64 {
    let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).max(0.0).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    0.5 * (rs * rs + rp * rp)
}

/// Transmittance through both faces of the slab of a ray at angle `theta` to the normal.
fn slab_transmittance(theta: f64) -> f64 {
    let theta_t = (theta.sin() / N).asin();
    (1.0 - fresnel(theta.cos(), 1.0, N)) * (1.0 - fresnel(theta_t.cos(), N, 1.0))
}

/// Lateral distance at which a ray at angle `theta` from a point `air` above the slab (plus
/// `below` of air under it) meets the floor.
fn lateral(theta: f64, air: f64) -> f64 {
    let theta_t = (theta.sin() / N).asin();
    air * theta.tan() + (SLAB_TOP - SLAB_BOTTOM) * theta_t.tan()
}

/// The floor's irradiance at distance `rho` from the foot of the light.
fn irradiance(rho: f64) -> f64 {
    let air = (LIGHT_Y - SLAB_TOP) + SLAB_BOTTOM;
    let d = SLAB_TOP - SLAB_BOTTOM;
    if rho < 1e-9 {
        return INTENSITY * slab_transmittance(0.0) / (air + d / N).powi(2);
    }
    // ρ(θ) grows monotonically: bisection.
    let (mut lo, mut hi) = (0.0, 0.5 * PI - 1e-9);
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if lateral(mid, air) < rho {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let theta = 0.5 * (lo + hi);
    let theta_t = (theta.sin() / N).asin();
    let d_theta_t = theta.cos() / (N * theta_t.cos());
    let d_rho = air / theta.cos().powi(2) + d / theta_t.cos().powi(2) * d_theta_t;
    INTENSITY * slab_transmittance(theta) * theta.sin() / (rho * d_rho)
}

/// The irradiance tabulated on `0 ≤ ρ ≤ TABLE_EXTENT` for the disk averages (linear
/// interpolation between 40 001 exact values: relative error below 1e-7 on this smooth curve).
struct IrradianceTable(Vec<f64>);

const TABLE_EXTENT: f64 = 0.2;

impl IrradianceTable {
    fn new() -> IrradianceTable {
        let n = 40_000;
        IrradianceTable((0..=n).map(|i| irradiance(TABLE_EXTENT * i as f64 / n as f64)).collect())
    }

    fn at(&self, rho: f64) -> f64 {
        let x = rho / TABLE_EXTENT * (self.0.len() - 1) as f64;
        let i = (x as usize).min(self.0.len() - 2);
        let f = x - i as f64;
        self.0[i] * (1.0 - f) + self.0[i + 1] * f
    }

    /// Mean of the irradiance over the disk of radius `r` centred `c` from the foot of the light.
    fn disk_average(&self, c: f64, r: f64) -> f64 {
        let (rings, sectors) = (24, 32);
        let (mut sum, mut weight) = (0.0, 0.0);
        for i in 0..rings {
            let s = r * (i as f64 + 0.5) / rings as f64;
            for j in 0..sectors {
                let phi = 2.0 * PI * (j as f64 + 0.5) / sectors as f64;
                let (x, y) = (c + s * phi.cos(), s * phi.sin());
                sum += self.at((x * x + y * y).sqrt()) * s;
                weight += s;
            }
        }
        sum / weight
    }
}

/// The expected mean over the image of the merging methods' render: per pixel centre, the
/// disk average around the floor point it sees, over the iterations' radii.
fn expected_image_mean() -> f64 {
    let table = IrradianceTable::new();
    let tan_half = (0.5 * FOV_DEGREES).to_radians().tan();
    let radii: Vec<f64> = (0..ITERATIONS).map(|s| iteration_radius(RADIUS as f32, 0.75, s) as f64).collect();
    let n = RESOLUTION as usize;
    // The image is symmetric in both axes: one quadrant of pixel centres.
    let mut total = 0.0;
    for py in n / 2..n {
        for px in n / 2..n {
            let u = (2.0 * (px as f64 + 0.5) / n as f64 - 1.0) * tan_half;
            let v = (2.0 * (py as f64 + 0.5) / n as f64 - 1.0) * tan_half;
            let phi = (u * u + v * v).sqrt().atan();
            let c = lateral(phi, (CAMERA_Y - SLAB_TOP) + SLAB_BOTTOM);
            let e = radii.iter().map(|&r| table.disk_average(c, r)).sum::<f64>() / radii.len() as f64;
            total += slab_transmittance(phi) * ALBEDO / PI * e;
        }
    }
    total / (n * n / 4) as f64
}

/// The mean over the image of `RENDERS` independent renders, and its standard error.
fn image_means(method: &str) -> (f64, f64) {
    let scene = scene(method);
    let means: Vec<f64> = (0..RENDERS)
        .map(|seed| {
            let image = render_with(&scene, method, ITERATIONS, 500 + seed);
            image.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).sum::<f64>() / image.pixels.len() as f64
        })
        .collect();
    let k = means.len() as f64;
    let mean = means.iter().sum::<f64>() / k;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k - 1.0);
    (mean, (var / k).sqrt())
}

#[test]
fn the_closed_form_is_consistent() {
    // Near the axis the mapping is linear: E(0) = I·T(0)/(a + d/n)², continuous with E(ρ → 0).
    let e0 = irradiance(0.0);
    assert!((irradiance(1e-4) / e0 - 1.0).abs() < 1e-6, "{} vs {e0}", irradiance(1e-4));
    // Without glass (n = 1 would give I/H²): the slab focuses, E(0) > I/H².
    assert!(e0 > INTENSITY / LIGHT_Y.powi(2));
    // Energy: the power on the whole floor is I·∫T dω over the lower hemisphere (ρ to 200).
    let (steps, far) = (100_000, 200.0f64);
    let floor_power: f64 = (0..steps)
        .map(|i| {
            let rho = far * (i as f64 + 0.5) / steps as f64;
            irradiance(rho) * 2.0 * PI * rho * far / steps as f64
        })
        .sum();
    let hemisphere: f64 = (0..steps)
        .map(|i| {
            let theta = 0.5 * PI * (i as f64 + 0.5) / steps as f64;
            INTENSITY * slab_transmittance(theta) * 2.0 * PI * theta.sin() * 0.5 * PI / steps as f64
        })
        .sum();
    // The floor beyond ρ = 200 (θ > 89.8°) receives a negligible share.
    assert!((floor_power / hemisphere - 1.0).abs() < 2e-3, "{floor_power} vs {hemisphere}");
}

#[test]
fn merging_finds_the_point_light_caustic_seen_through_glass() {
    let expected = expected_image_mean();
    let at_centre = slab_transmittance(0.0) * ALBEDO / PI * irradiance(0.0);
    println!("expected {expected:.6} (the unblurred value at the centre {at_centre:.6})");
    for method in ["vcm", "ppm"] {
        let (mean, error) = image_means(method);
        let z = (mean - expected) / error;
        println!("{method}: {mean:.6} ± {error:.6} ({z:+.2} standard errors)");
        assert!(z.abs() < 4.0, "{method}: {mean} ± {error} vs the closed form {expected}");
        assert!(error < 0.03 * expected, "{method}: the test must resolve 3% ({error})");
    }
    // Path tracing and bidirectional path tracing cannot make these paths.
    for method in ["path", "bpt"] {
        let image = render_with(&scene(method), method, 4, 1);
        let mean = image.pixels.iter().map(|p| p.element_sum() as f64 / 3.0).sum::<f64>()
            / image.pixels.len() as f64;
        println!("{method}: {mean:e}");
        assert!(mean < 1e-3 * expected, "{method} should miss the caustic seen through glass: {mean}");
    }
}
