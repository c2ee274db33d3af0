//! Emission on round shapes under a general affine map: ellipsoids, elliptic disks and elliptic
//! (oblique) cylinders. Such an emitter is sampled as its object-space shape (uniformly by
//! object area) and mapped, so its world area density varies over the surface:
//! `1/(A_o·J)`, `J = det M·|M⁻ᵀ n_o|`. Checked three ways: the closed furnace (emission ½,
//! albedo ½: radiance 1 everywhere inside) for every unbiased method; path, light, bpt and vcm
//! agreeing on a floor lit by an elliptic disk and an oblique elliptic cylinder (each method
//! weighs the point density differently: next-event estimation, emission, hits); and the
//! density integrating to the world area. Tolerances are in standard errors of the mean over
//! independent renders (`common::mean_and_error`) or over the samples.

mod common;

use common::{assert_uniformly_one, largest_block_z, mean_and_error};
use glam::Vec2;
use vitrum::light::{EmitterShape, Light};
use vitrum::scene::{load_str, Scene};

fn load(text: &str) -> Scene {
    load_str(text, "emitting affine shapes", None).unwrap_or_else(|e| panic!("{e}"))
}

/// The camera inside a closed emitter (`shape` and its `transform`), emitting ½ with albedo ½.
fn furnace(shape: &str) -> Scene {
    load(&format!(
        r#"
[camera]
position = [0.1, 0.2, 0.1]
look_at = [1.0, 0.1, -0.3]
fov = 120.0
resolution = [12, 12]
[render.vcm]
radius = 0.05
[materials.wall]
type = "diffuse"
color = 0.5
emission = 0.5
[[objects]]
{shape}
material = "wall"
"#
    ))
}

/// An ellipsoid: a sphere under a per-axis scale.
const ELLIPSOID: &str = r#"shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
transform = { scale = [1.6, 0.7, 1.1], rotate = { axis = [1.0, 0.5, 0.0], angle = 35.0 } }"#;

/// A closed oblique elliptic cylinder: a sheared, unevenly scaled cylinder with caps.
const SHEARED_CYLINDER: &str = r#"shape = "cylinder"
base = [0.0, -1.0, 0.0]
axis = [0.0, 1.0, 0.0]
radius = 1.0
height = 2.0
transform = { matrix = [1.5, 0.3, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.2, 0.1, 0.8, 0.0, 0.0, 0.0, 0.0, 1.0] }"#;

#[test]
fn closed_affine_emitters_are_uniformly_one_inside_for_every_unbiased_method() {
    for (what, shape) in [("ellipsoid", ELLIPSOID), ("oblique cylinder", SHEARED_CYLINDER)] {
        let scene = furnace(shape);
        assert_eq!(scene.lights.len(), 1, "{what}: one light");
        for method in ["path", "light", "bpt", "vcm"] {
            assert_uniformly_one(&scene, method, &format!("{what}, {method}"));
        }
    }
}

/// A floor lit by an elliptic disk (two-sided) and a one-sided, sheared elliptic tube.
fn lit_floor() -> Scene {
    load(
        r#"
[camera]
position = [0.0, 1.6, 2.4]
look_at = [0.0, 0.3, 0.0]
fov = 55.0
resolution = [12, 12]
[render.vcm]
radius = 0.03
[materials.floor]
type = "diffuse"
color = 0.8
[materials.lamp]
type = "diffuse"
color = 0.3
emission = [3.0, 2.0, 1.0]
[materials.tube]
type = "diffuse"
color = 0.2
emission = [1.0, 2.0, 3.0]
emission_one_sided = true
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, 2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
material = "floor"
[[objects]]
shape = "disk"
center = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
radius = 1.0
transform = { scale = [0.6, 0.2, 1.0], rotate = { axis = [1.0, 0.0, 0.3], angle = 70.0 }, translate = [-0.4, 0.8, -0.2] }
material = "lamp"
[[objects]]
shape = "cylinder"
base = [0.0, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
radius = 1.0
height = 1.0
caps = false
transform = { matrix = [0.3, 0.1, 0.0, 0.5, 0.0, 0.0, 0.5, 0.3, 0.0, -0.15, 0.1, -0.2, 0.0, 0.0, 0.0, 1.0] }
material = "tube"
"#,
    )
}

#[test]
fn the_bidirectional_methods_render_what_path_tracing_renders_of_affine_lamps() {
    let scene = lit_floor();
    assert_eq!(scene.lights.len(), 2);
    let (a, sa) = mean_and_error(&scene, "path", 64, 6);
    assert!(a.iter().any(|p| p.max_element() > 0.1), "the floor is lit");
    for method in ["light", "bpt", "vcm"] {
        let (b, sb) = mean_and_error(&scene, method, 64, 6);
        let z = largest_block_z(&a, &sa, &b, &sb, 12, 3);
        eprintln!("{method}: worst 3×3 block differs by {z:.2} standard errors");
        assert!(z <= 4.5, "{method}: differs from path by {z} standard errors");
    }
}

#[test]
fn the_deterministic_methods_see_affine_lamps_as_finite_points() {
    let scene = lit_floor();
    for method in ["raycast", "whitted"] {
        let (mean, _) = mean_and_error(&scene, method, 1, 2);
        assert!(mean.iter().all(|p| p.is_finite()), "{method}");
        assert!(mean.iter().any(|p| p.max_element() > 0.05), "{method}: the floor is lit");
    }
}

/// The mean of `point_area` over `n × n` stratified samples (E[1/pdf], which is the world area
/// for a correct density) and its standard error as if the samples were independent (an upper
/// bound for stratified ones).
fn inverse_density_mean(shape: &EmitterShape, n: usize) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let (_, normal) = shape.sample(u);
            let x = f64::from(shape.point_area(normal));
            sum += x;
            sum2 += x * x;
        }
    }
    let count = (n * n) as f64;
    let mean = sum / count;
    (mean, ((sum2 / count - mean * mean).max(0.0) / count).sqrt())
}

fn surface_shape(light: &Light) -> &EmitterShape {
    match light {
        Light::Surface { shape, .. } => shape,
        other => panic!("a surface light, not {other:?}"),
    }
}

#[test]
fn the_sampling_density_integrates_to_the_world_area() {
    // An elliptic disk of semi-axes 0.6 and 0.2 (radius 1 scaled): area π·0.6·0.2; its density
    // is constant, so every sample gives the area.
    let scene = lit_floor();
    let disk = surface_shape(&scene.lights[0]);
    assert!(matches!(disk, EmitterShape::Affine(_)));
    let (mean, _) = inverse_density_mean(disk, 64);
    let exact = std::f64::consts::PI * 0.6 * 0.2;
    eprintln!("elliptic disk: E[1/pdf] = {mean}, π·a·b = {exact}");
    assert!((mean / exact - 1.0).abs() < 1e-5, "{mean} vs {exact}");
    assert!((f64::from(disk.area()) / exact - 1.0).abs() < 1e-5, "{} vs {exact}", disk.area());

    // The ellipsoid: no closed form; a fine tessellation of the mapped sphere (2·512² triangles,
    // relative error below 1e-5) gives the area.
    let scene = furnace(ELLIPSOID);
    let shape = surface_shape(&scene.lights[0]);
    let EmitterShape::Affine(a) = shape else { panic!("an affine emitter") };
    let m = a.linear.as_dmat3();
    const N: usize = 512;
    let point = |i: usize, j: usize| {
        let theta = std::f64::consts::PI * i as f64 / N as f64;
        let phi = std::f64::consts::TAU * j as f64 / N as f64;
        m * glam::DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
    };
    let mut tessellated = 0.0;
    for i in 0..N {
        for j in 0..N {
            let (p00, p10, p01, p11) = (point(i, j), point(i + 1, j), point(i, j + 1), point(i + 1, j + 1));
            tessellated +=
                0.5 * (p10 - p00).cross(p11 - p00).length() + 0.5 * (p11 - p00).cross(p01 - p00).length();
        }
    }
    let (mean, error) = inverse_density_mean(shape, 1024);
    eprintln!(
        "ellipsoid: E[1/pdf] = {mean} ± {error}, tessellated {tessellated}, quadrature {}",
        shape.area()
    );
    assert!((mean - tessellated).abs() <= 4.0 * error, "{mean} ± {error} vs {tessellated}");
    assert!((f64::from(shape.area()) / tessellated - 1.0).abs() < 1e-4, "{} vs {tessellated}", shape.area());
    // The density is not constant: the uniform 1/area would be wrong.
    let (lo, hi) = (0..64).fold((f32::INFINITY, 0.0f32), |(lo, hi), k| {
        let (_, n) = shape.sample(Vec2::new((k as f32 + 0.5) / 64.0, (k as f32 * 0.618).fract()));
        let x = shape.point_area(n);
        (lo.min(x), hi.max(x))
    });
    assert!(hi > 1.5 * lo, "{lo} {hi}");
}

#[test]
fn an_affine_emitter_is_described_with_its_map_and_its_power() {
    let scene = furnace(ELLIPSOID);
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(text.contains("sphere") && text.contains("affine map"), "{text}");
    // Power: 2π·A·L (two-sided), with the world area.
    let power = scene.lights[0].strength().value();
    let area = surface_shape(&scene.lights[0]).area();
    assert!((power.x / (2.0 * std::f32::consts::PI * area * 0.5) - 1.0).abs() < 1e-6, "{power}");
}

#[test]
fn a_mitsuba_area_emitter_on_a_disk_under_a_non_uniform_scale_is_an_elliptic_light() {
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="disk">
        <transform name="to_world"><scale x="2" y="0.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
    </shape>
</scene>"#;
    let scene =
        vitrum::scene::mitsuba::load_str(xml, "ellipse", None, false).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.lights.len(), 1);
    let shape = surface_shape(&scene.lights[0]);
    assert!(matches!(shape, EmitterShape::Affine(_)));
    assert!((shape.area() / std::f32::consts::PI - 1.0).abs() < 1e-6, "{}", shape.area());
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(text.contains("on the side its normal points to"), "{text}");
}
