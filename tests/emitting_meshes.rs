//! Emitting triangle meshes: a mesh whose diffuse material emits is one light, sampled uniformly
//! by area over its triangles. The analytic closed box (emission ½, albedo ½: radiance 1
//! everywhere inside) holds for every unbiased method, and a mesh of two triangles renders what
//! the quad of the same corners renders. With `emission_one_sided` only the side the winding
//! normal faces emits, for every method; `flip_normals` turns a mesh over. Tolerances are in
//! standard errors of the mean over independent renders (`common::mean_and_error`).

mod common;

use common::{assert_uniformly_one, largest_block_z, mean_and_error, render_with};
use glam::Vec3;
use std::path::Path;
use vitrum::scene::{load_str, Scene};

/// The box [−1, 1]³ as 12 triangles wound outwards.
const BOX_OBJ: &str = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
f 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";

fn load(dir: &Path, text: &str) -> Scene {
    load_str(text, "emitting meshes", Some(dir)).unwrap_or_else(|e| panic!("{e}"))
}

/// The camera inside the closed box mesh, every wall emitting ½ with albedo ½.
fn closed_box(dir: &Path) -> Scene {
    std::fs::write(dir.join("box.obj"), BOX_OBJ).unwrap();
    load(
        dir,
        r#"
[camera]
position = [0.1, 0.2, 0.3]
look_at = [1.0, 0.0, 0.0]
fov = 120.0
resolution = [12, 12]
[render.vcm]
radius = 0.1
[materials.wall]
type = "diffuse"
color = 0.5
emission = 0.5
[[objects]]
shape = "mesh"
file = "box.obj"
material = "wall"
"#,
    )
}

#[test]
fn a_closed_emitting_mesh_is_uniformly_one_inside_for_every_unbiased_method() {
    let dir = tempfile::tempdir().unwrap();
    let scene = closed_box(dir.path());
    for method in ["path", "light", "bpt", "vcm"] {
        assert_uniformly_one(&scene, method, method);
    }
}

/// A floor lit by a tilted two-sided emitter, given as a `quad` or as a mesh of its two
/// triangles.
fn lit_floor(dir: &Path, as_mesh: bool) -> Scene {
    let (c, u, v) = (Vec3::new(-0.3, 0.8, -0.2), Vec3::new(0.6, 0.1, 0.0), Vec3::new(0.0, 0.2, 0.5));
    let emitter = if as_mesh {
        let [a, b, d, e] = [c, c + u, c + u + v, c + v];
        let obj = format!(
            "v {} {} {}\nv {} {} {}\nv {} {} {}\nv {} {} {}\nf 1 2 3\nf 1 3 4\n",
            a.x, a.y, a.z, b.x, b.y, b.z, d.x, d.y, d.z, e.x, e.y, e.z
        );
        std::fs::write(dir.join("lamp.obj"), obj).unwrap();
        "shape = \"mesh\"\nfile = \"lamp.obj\"".to_string()
    } else {
        format!(
            "shape = \"quad\"\ncorner = {:?}\nu = {:?}\nv = {:?}",
            c.to_array(),
            u.to_array(),
            v.to_array()
        )
    };
    load(
        dir,
        &format!(
            r#"
[camera]
position = [0.0, 1.5, 2.5]
look_at = [0.0, 0.3, 0.0]
fov = 50.0
resolution = [12, 12]
[materials.floor]
type = "diffuse"
color = 0.8
[materials.lamp]
type = "diffuse"
color = 0.0
emission = [4.0, 3.0, 2.0]
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, 2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
material = "floor"
[[objects]]
material = "lamp"
{emitter}
"#
        ),
    )
}

#[test]
fn a_mesh_emitter_renders_what_the_quad_of_the_same_corners_renders() {
    let dir = tempfile::tempdir().unwrap();
    let quad = lit_floor(dir.path(), false);
    let mesh = lit_floor(dir.path(), true);
    assert_eq!(mesh.lights.len(), 1, "the mesh is one light");
    for method in ["path", "bpt"] {
        let (a, sa) = mean_and_error(&quad, method, 32, 6);
        let (b, sb) = mean_and_error(&mesh, method, 32, 6);
        assert!(a.iter().any(|p| p.max_element() > 0.1), "{method}: the floor is lit");
        let z = largest_block_z(&a, &sa, &b, &sb, 12, 3);
        eprintln!("{method}: worst 3×3 block differs by {z:.2} standard errors");
        assert!(z <= 4.5, "{method}: mesh and quad emitters differ by {z} standard errors");
    }
}

#[test]
fn an_emitting_mesh_is_described_and_its_texture_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = closed_box(dir.path());
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(text.contains("mesh of 12 triangles, area 24"), "{text}");
    let err = load_str(
        "[camera]\nposition = [0.0, 0.0, 0.0]\nlook_at = [1.0, 0.0, 0.0]\n\
         [materials.wall]\ntype = \"diffuse\"\nemission = 1.0\nemission_texture = { type = \"checker\", color1 = 0.2, color2 = 1.0, size = 0.5 }\n\
         [[objects]]\nshape = \"mesh\"\nfile = \"box.obj\"\nmaterial = \"wall\"\n",
        "textured",
        Some(dir.path()),
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(err.contains("emission_texture") && err.contains("cannot be textured"), "{err}");
}

#[test]
fn a_mitsuba_area_emitter_on_an_obj_is_one_mesh_light() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("box.obj"), BOX_OBJ).unwrap();
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, 0, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="obj">
        <string name="filename" value="box.obj"/>
        <transform name="to_world"><scale value="0.5"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf></bsdf>
        <emitter type="area"><rgb name="radiance" value="2, 1, 0.5"/></emitter>
    </shape>
</scene>"#;
    let scene = vitrum::scene::mitsuba::load_str(xml, "obj light", Some(dir.path()), false)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.lights.len(), 1);
    let text = vitrum::scene::describe::light(&scene.lights[0]).text;
    assert!(text.contains("mesh of 12 triangles, area 6"), "{text}");
}

/// Two triangles of the quad `corner + a·u + b·v` as OBJ text, wound around `u × v` (or against
/// it with `reversed`), with texture coordinates and tilted vertex normals (`vn`, given along the
/// winding) so that the flipped attributes are exercised too.
fn quad_obj(corner: Vec3, u: Vec3, v: Vec3, reversed: bool) -> String {
    let [a, b, c, d] = [corner, corner + u, corner + u + v, corner + v];
    let n = u.cross(v).normalize();
    let mut obj = String::new();
    for p in [a, b, c, d] {
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    obj += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
    for k in 0..4 {
        let tilt = (n + 0.2 * (k as f32 - 1.5) * u.normalize()).normalize();
        let tilt = if reversed { -tilt } else { tilt };
        obj += &format!("vn {} {} {}\n", tilt.x, tilt.y, tilt.z);
    }
    obj += if reversed {
        "f 1/1/1 3/3/3 2/2/2\nf 1/1/1 4/4/4 3/3/3\n"
    } else {
        "f 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n"
    };
    obj
}

/// A lamp (a horizontal quad mesh at y = 1, wound to face down) above a black floor and below a
/// grey ceiling at y = 2, seen from y = 1.5 looking up at the ceiling: the ceiling gets the light
/// the lamp sends up and nothing else (the lamp and the floor reflect nothing).
fn lamp_under_ceiling(dir: &Path, one_sided: bool, flip: bool) -> Scene {
    let obj = quad_obj(Vec3::new(-0.5, 1.0, -0.5), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0), false);
    std::fs::write(dir.join("lamp.obj"), obj).unwrap();
    load(
        dir,
        &format!(
            r#"
[camera]
position = [0.0, 1.5, 0.2]
look_at = [0.1, 3.0, 0.0]
fov = 90.0
resolution = [8, 8]
[render.vcm]
radius = 0.05
[materials.grey]
type = "diffuse"
color = 0.8
[materials.black]
type = "diffuse"
color = 0.0
[materials.lamp]
type = "diffuse"
color = 0.0
emission = [2.0, 1.5, 1.0]
emission_one_sided = {one_sided}
[[objects]]
shape = "quad"
corner = [-3.0, 0.0, 3.0]
u = [6.0, 0.0, 0.0]
v = [0.0, 0.0, -6.0]
material = "black"
[[objects]]
shape = "quad"
corner = [-3.0, 2.0, -3.0]
u = [6.0, 0.0, 0.0]
v = [0.0, 0.0, 6.0]
material = "grey"
[[objects]]
shape = "mesh"
file = "lamp.obj"
material = "lamp"
flip_normals = {flip}
"#
        ),
    )
}

#[test]
fn a_one_sided_emitting_mesh_lights_only_its_front() {
    let dir = tempfile::tempdir().unwrap();
    // (case, one-sided, flipped, whether the ceiling above the lamp is lit)
    let cases = [
        ("one-sided, facing down", true, false, false),
        ("two-sided", false, false, true),
        ("one-sided, flipped to face up", true, true, true),
    ];
    for (what, one_sided, flip, lit) in cases {
        let scene = lamp_under_ceiling(dir.path(), one_sided, flip);
        for method in ["path", "light", "bpt", "vcm", "ppm", "bpm", "distributed", "whitted"] {
            let image = render_with(&scene, method, 16, 1);
            let count = image.pixels.iter().filter(|p| p.max_element() > 0.0).count();
            eprintln!("{what}, {method}: {count} of {} pixels of the ceiling lit", image.pixels.len());
            if lit {
                // (The photon methods' merges at 16 iterations are too sparse to count pixels.)
                if !method.ends_with("pm") {
                    assert!(count > image.pixels.len() / 2, "{what}, {method}: the ceiling is lit");
                }
            } else {
                assert_eq!(count, 0, "{what}, {method}: the ceiling behind the lamp gets no light");
            }
        }
    }
}

/// A floor lit by a tilted one-sided quad mesh lamp that the camera sees from its back (the
/// lamp's edge hides part of the floor behind it) and the floor under its front.
fn one_sided_lamp(dir: &Path) -> Scene {
    let obj = quad_obj(Vec3::new(-0.4, 0.9, 0.3), Vec3::new(0.8, 0.0, 0.0), Vec3::new(0.0, -0.5, 0.3), false);
    std::fs::write(dir.join("tilted.obj"), obj).unwrap();
    load(
        dir,
        r#"
[camera]
position = [0.0, 1.5, 2.5]
look_at = [0.0, 0.4, 0.0]
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
emission = [4.0, 3.0, 2.0]
emission_one_sided = true
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, 2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
material = "floor"
[[objects]]
shape = "mesh"
file = "tilted.obj"
material = "lamp"
"#,
    )
}

#[test]
fn the_bidirectional_methods_render_what_path_tracing_renders_of_a_one_sided_mesh_lamp() {
    let dir = tempfile::tempdir().unwrap();
    let scene = one_sided_lamp(dir.path());
    let (a, sa) = mean_and_error(&scene, "path", 64, 6);
    assert!(a.iter().any(|p| p.max_element() > 0.1), "the floor is lit");
    let n = a.len() as f32;
    let mean = |m: &[Vec3]| m.iter().map(|p| p.element_sum()).sum::<f32>() / (3.0 * n);
    let error = |e: &[Vec3]| e.iter().map(|p| p.length_squared()).sum::<f32>().sqrt() / (3.0 * n);
    for method in ["light", "bpt", "vcm"] {
        let (b, sb) = mean_and_error(&scene, method, 64, 6);
        let (d, s) = (mean(&b) - mean(&a), (error(&a).powi(2) + error(&b).powi(2)).sqrt());
        eprintln!("{method}: image mean {} differs from path's {} by {d} ± {s}", mean(&b), mean(&a));
        assert!(d.abs() <= 4.0 * s, "{method}: image mean differs from path's by {d} ± {s}");
        let z = largest_block_z(&a, &sa, &b, &sb, 12, 3);
        eprintln!("{method}: worst 3×3 block differs by {z:.2} standard errors");
        assert!(z <= 4.5, "{method}: differs from path by {z} standard errors");
    }
}

#[test]
fn a_flipped_mesh_renders_like_the_mesh_with_reversed_winding_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let (c, u, v) = (Vec3::new(-0.6, 0.2, 0.4), Vec3::new(1.2, 0.3, 0.0), Vec3::new(0.0, 0.6, -0.8));
    std::fs::write(dir.path().join("forward.obj"), quad_obj(c, u, v, false)).unwrap();
    std::fs::write(dir.path().join("reversed.obj"), quad_obj(c, u, v, true)).unwrap();
    let (lc, lu, lv) = (Vec3::new(-0.3, 1.6, -0.6), Vec3::new(0.6, 0.0, 0.0), Vec3::new(0.0, -0.2, 0.5));
    std::fs::write(dir.path().join("lamp.obj"), quad_obj(lc, lu, lv, false)).unwrap();
    std::fs::write(dir.path().join("lamp-reversed.obj"), quad_obj(lc, lu, lv, true)).unwrap();
    // A one-sided textured diffuse mesh and a one-sided emitting mesh, each given flipped or as
    // the file with the reversed winding (and negated normals).
    let scene = |file: &str, lamp: &str, flip: bool| {
        load(
            dir.path(),
            &format!(
                r#"
[camera]
position = [0.2, 1.0, 2.5]
look_at = [0.0, 0.5, 0.0]
fov = 60.0
resolution = [16, 16]
[materials.card]
type = "diffuse"
one_sided = true
texture = {{ type = "checker", color1 = 0.2, color2 = 0.9, size = 0.25 }}
[materials.lamp]
type = "diffuse"
color = 0.4
emission = [3.0, 2.5, 2.0]
emission_one_sided = true
[materials.floor]
type = "diffuse"
color = 0.7
[[objects]]
shape = "quad"
corner = [-2.0, 0.0, 2.0]
u = [4.0, 0.0, 0.0]
v = [0.0, 0.0, -4.0]
material = "floor"
[[objects]]
shape = "mesh"
file = "{file}"
material = "card"
flip_normals = {flip}
[[objects]]
shape = "mesh"
file = "{lamp}"
material = "lamp"
flip_normals = {flip}
[[lights]]
type = "point"
position = [0.5, 2.0, 1.5]
intensity = 2.0
"#
            ),
        )
    };
    let flipped = scene("forward.obj", "lamp.obj", true);
    let reversed = scene("reversed.obj", "lamp-reversed.obj", false);
    let forward = scene("forward.obj", "lamp.obj", false);
    for method in ["path", "light", "bpt", "whitted"] {
        let a = render_with(&flipped, method, 4, 3);
        let b = render_with(&reversed, method, 4, 3);
        let differing = a.pixels.iter().zip(&b.pixels).filter(|(x, y)| x != y).count();
        assert_eq!(differing, 0, "{method}: {differing} pixels differ");
        // Flipping changes the image (the card and the lamp face the other way).
        let c = render_with(&forward, method, 4, 3);
        assert!(a.pixels != c.pixels, "{method}: flipping changed nothing");
    }
}
