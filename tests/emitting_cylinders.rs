//! Emitting cylinders: a cylinder whose diffuse material emits is one light, sampled uniformly
//! by area over its wall (and its caps, with caps), emitting on both sides or, with
//! `emission_one_sided` (Mitsuba's `area` emitter), on the side its normal faces. The analytic
//! closed cylinder (emission ½, albedo ½: radiance 1 everywhere inside) holds for every unbiased
//! method, and the bidirectional methods render what path tracing renders of a one-sided open
//! tube lighting a floor, so that their emission densities agree with the hit's. Tolerances are in
//! standard errors of the mean over independent renders (`common::mean_and_error`).

mod common;

use common::{assert_uniformly_one, largest_block_z, mean_and_error};
use glam::Vec3;
use vitrum::scene::{load_str, Scene};

fn load(text: &str) -> Scene {
    load_str(text, "emitting cylinders", None).unwrap_or_else(|e| panic!("{e}"))
}

/// The camera inside a closed cylinder (caps on), wall and caps emitting ½ with albedo ½.
fn closed_cylinder() -> Scene {
    load(
        r#"
[camera]
position = [0.1, 0.4, 0.2]
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
shape = "cylinder"
base = [0.0, -0.8, 0.0]
axis = [0.1, 1.0, 0.05]
radius = 0.7
height = 2.0
material = "wall"
"#,
    )
}

#[test]
fn a_closed_emitting_cylinder_is_uniformly_one_inside_for_every_unbiased_method() {
    let scene = closed_cylinder();
    assert_eq!(scene.lights.len(), 1, "wall and caps are one light");
    for method in ["path", "light", "bpt", "vcm"] {
        assert_uniformly_one(&scene, method, method);
    }
}

/// A floor lit by a tilted open tube, emitting on the side `sides` names, seen so that the
/// camera looks into the tube's mouth (its inside, dark when one-sided) and at its outside.
fn lit_floor(one_sided: bool) -> Scene {
    load(&format!(
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
emission_one_sided = {one_sided}
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, 2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
material = "floor"
[[objects]]
shape = "cylinder"
base = [-0.2, 0.3, -0.3]
axis = [0.5, 0.4, 0.6]
radius = 0.2
height = 0.8
caps = false
material = "lamp"
"#
    ))
}

#[test]
fn the_bidirectional_methods_render_what_path_tracing_renders_of_a_tube_lamp() {
    for one_sided in [true, false] {
        let scene = lit_floor(one_sided);
        let (a, sa) = mean_and_error(&scene, "path", 64, 6);
        assert!(a.iter().any(|p| p.max_element() > 0.1), "the floor is lit");
        for method in ["light", "bpt", "vcm"] {
            let (b, sb) = mean_and_error(&scene, method, 64, 6);
            let z = largest_block_z(&a, &sa, &b, &sb, 12, 3);
            eprintln!("one-sided {one_sided}, {method}: worst 3×3 block differs by {z:.2} standard errors");
            assert!(z <= 4.5, "one-sided {one_sided}, {method}: differs from path by {z} standard errors");
        }
    }
    // One-sided, the tube sends half the power: its inside is dark.
    let one = lit_floor(true).lights[0].strength().value();
    let two = lit_floor(false).lights[0].strength().value();
    assert!((2.0 * one - two).length() <= 1e-5 * two.length(), "{one} vs {two}");
}

#[test]
fn the_deterministic_methods_see_an_emitting_cylinder_as_a_finite_point() {
    let scene = lit_floor(true);
    for method in ["raycast", "whitted"] {
        let (mean, _) = mean_and_error(&scene, method, 1, 2);
        assert!(mean.iter().all(|p| p.is_finite()), "{method}");
        assert!(mean.iter().any(|p| p.max_element() > 0.05), "{method}: the floor is lit");
    }
}

#[test]
fn an_emitting_cylinder_is_described_and_an_elliptic_one_is_an_affine_emitter() {
    let scene = closed_cylinder();
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(
        text.contains("cylinder") && text.contains("with caps") && text.contains("on both sides"),
        "{text}"
    );
    let text = vitrum::scene::describe::light(&lit_floor(true).lights[0]).text;
    assert!(text.contains("open (no caps)") && text.contains("on the side its normal points to"), "{text}");
    // Under a per-axis scale it is an elliptic cylinder, an affine emitter (tests/emitting_affine.rs).
    let scene = load_str(
        "[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\n\
         [materials.lamp]\ntype = \"diffuse\"\nemission = 1.0\n\
         [[objects]]\nshape = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\nradius = 0.5\nheight = 1.0\nmaterial = \"lamp\"\n\
         transform = { scale = [1.0, 2.0, 1.0] }\n",
        "elliptic",
        None,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(text.contains("cylinder") && text.contains("affine map"), "{text}");
}

#[test]
fn a_mitsuba_area_emitter_on_a_cylinder_is_one_sided_and_with_flip_normals_emits_inwards() {
    let xml = |flip: bool| {
        format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="cylinder">
        <point name="p0" value="0, -1, 0"/>
        <point name="p1" value="0, 1, 0"/>
        <float name="radius" value="0.3"/>
        <boolean name="flip_normals" value="{flip}"/>
        <emitter type="area"><rgb name="radiance" value="2, 1, 0.5"/></emitter>
    </shape>
    <shape type="disk">
        <transform name="to_world"><translate y="-2"/></transform>
        <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter>
    </shape>
</scene>"#
        )
    };
    let scene =
        vitrum::scene::mitsuba::load_str(&xml(false), "tube", None, false).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.lights.len(), 2);
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(text.contains("open (no caps)") && text.contains("on the side its normal points to"), "{text}");
    // A disk's area emitter is one-sided too (along its normal, +z here).
    let text = vitrum::scene::describe::light(&scene.lights[1]).text;
    assert!(text.contains("disk") && text.contains("on the side its normal points to"), "{text}");
    assert!(!text.contains("inwards"), "{text}");
    let scene = vitrum::scene::mitsuba::load_str(&xml(true), "inwards", None, false)
        .unwrap_or_else(|e| panic!("{e}"));
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(text.contains("facing inwards") && text.contains("on the side its normal points to"), "{text}");
    // Its sampled points face the axis: the normal points from the point towards the axis.
    let vitrum::light::Light::Surface { shape, .. } = &scene.lights[0] else { panic!("a surface light") };
    for k in 0..16 {
        let (p, n) = shape.sample(glam::Vec2::new(k as f32 / 16.0, (k as f32 * 0.618).fract()));
        let towards_axis = -Vec3::new(p.x, 0.0, p.z).normalize();
        assert!(n.dot(towards_axis) > 0.999, "{p} {n}");
    }
}

/// The tube lamp of `lit_floor` (one-sided) turned inside out: it emits inwards, out of its
/// mouths only.
fn inward_lamp() -> Scene {
    let text = r#"
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
one_sided = true
emission = [3.0, 2.0, 1.0]
emission_one_sided = true
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, 2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
material = "floor"
[[objects]]
shape = "cylinder"
base = [-0.2, 0.3, -0.3]
axis = [0.5, 0.4, 0.6]
radius = 0.2
height = 0.8
caps = false
flip_normals = true
material = "lamp"
"#;
    load(text)
}

#[test]
fn the_bidirectional_methods_render_what_path_tracing_renders_of_a_tube_emitting_inwards() {
    let scene = inward_lamp();
    let (a, sa) = mean_and_error(&scene, "path", 64, 6);
    assert!(a.iter().any(|p| p.max_element() > 0.05), "the floor is lit through the mouths");
    for method in ["light", "bpt", "vcm"] {
        let (b, sb) = mean_and_error(&scene, method, 64, 6);
        let z = largest_block_z(&a, &sa, &b, &sb, 12, 3);
        eprintln!("inwards, {method}: worst 3×3 block differs by {z:.2} standard errors");
        assert!(z <= 4.5, "inwards, {method}: differs from path by {z} standard errors");
    }
    // Outwards, the same tube renders brighter (its whole outside faces the floor and the camera;
    // measured 36 against 21 summed over the image).
    let outwards = lit_floor(true);
    let (c, _) = mean_and_error(&outwards, "path", 16, 2);
    let total = |m: &[Vec3]| m.iter().map(|p| p.element_sum()).sum::<f32>();
    assert!(total(&c) > total(&a), "outwards {} vs inwards {}", total(&c), total(&a));
}
