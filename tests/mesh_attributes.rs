//! OBJ texture coordinates (`vt`) and vertex normals (`vn`): a mesh hit's uv is the
//! interpolated vt (barycentrics without vt), its shading normal the interpolated vn turned to the
//! geometric normal's side (the geometric normal without vn), carried through transforms.

use glam::{Vec2, Vec3};
use std::path::Path;
use vitrum::geometry::{Ray, SurfaceHit};
use vitrum::scene::mesh::{load_obj, MeshPlacement};
use vitrum::scene::{load_str, Scene};

fn scene(dir: &Path, file: &str, extra: &str) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
resolution = [8, 8]
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
material = "glass"
shape = "mesh"
file = "{file}"
{extra}
"#
    );
    load_str(&text, "mesh attributes", Some(dir)).unwrap_or_else(|e| panic!("{e}"))
}

/// The hit of a ray straight down −z through (x, y).
fn hit_at(scene: &Scene, x: f32, y: f32) -> SurfaceHit {
    let ray = Ray::new(Vec3::new(x, y, 5.0), -Vec3::Z);
    scene.intersect(&ray, f32::INFINITY).unwrap_or_else(|| panic!("no hit at ({x}, {y})")).hit
}

/// The unit square [0, 1]² at z = 0 as two triangles, with `vt` and `vn` lines appended.
fn square(vt: &str, vn: &str, faces: &str) -> String {
    format!("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n{vt}{vn}{faces}")
}

/// Points of the square away from its diagonal and edges, and on them.
fn points() -> Vec<(f32, f32)> {
    let mut p = Vec::new();
    for i in 0..=8 {
        for j in 0..=8 {
            p.push((0.02 + 0.12 * i as f32, 0.01 + 0.1225 * j as f32));
        }
    }
    p.extend([(0.5, 0.5), (0.25, 0.25), (0.0, 0.5), (1.0, 0.3)]);
    p
}

#[test]
fn texture_coordinates_are_interpolated_by_barycentrics() {
    let dir = tempfile::tempdir().unwrap();
    // An affine map of the square: u = 0.1 + 0.8x, v = 0.2 + 0.5y, exact on both triangles.
    let vt = "vt 0.1 0.2\nvt 0.9 0.2\nvt 0.9 0.7\nvt 0.1 0.7\n";
    std::fs::write(dir.path().join("affine.obj"), square(vt, "", "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")).unwrap();
    let s = scene(dir.path(), "affine.obj", "");
    let mut worst = 0f32;
    for (x, y) in points() {
        let uv = hit_at(&s, x, y).uv;
        let expected = Vec2::new(0.1 + 0.8 * x, 0.2 + 0.5 * y);
        worst = worst.max((uv - expected).abs().max_element());
        assert!(uv.abs_diff_eq(expected, 2e-6), "at ({x}, {y}): uv {uv} vs {expected}");
    }
    println!("affine vt: largest difference {worst:e}");

    // Arbitrary vt per vertex (not affine across the square): on each triangle the uv is
    // b0·vt0 + b1·vt1 + b2·vt2 with the point's barycentrics in that triangle.
    let vt = "vt 0.0 0.0\nvt 1.0 0.25\nvt 0.3 0.9\nvt 0.75 0.6\n";
    std::fs::write(dir.path().join("warped.obj"), square(vt, "", "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")).unwrap();
    let s = scene(dir.path(), "warped.obj", "");
    let t = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.25), Vec2::new(0.3, 0.9), Vec2::new(0.75, 0.6)];
    for (x, y) in points() {
        if (x - y).abs() < 1e-3 {
            continue; // on the diagonal both triangles give the same uv, either may be hit
        }
        // Lower triangle (0,0) (1,0) (1,1): b1 = x − y, b2 = y; upper (0,0) (1,1) (0,1): b1 = x, b2 = y − x.
        let expected = if x > y {
            (1.0 - x) * t[0] + (x - y) * t[1] + y * t[2]
        } else {
            (1.0 - y) * t[0] + x * t[2] + (y - x) * t[3]
        };
        let uv = hit_at(&s, x, y).uv;
        assert!(uv.abs_diff_eq(expected, 2e-6), "at ({x}, {y}): uv {uv} vs {expected}");
    }

    // Without vt, the barycentrics (b1, b2) of the hit triangle, as before.
    std::fs::write(dir.path().join("plain.obj"), square("", "", "f 1 2 3\nf 1 3 4\n")).unwrap();
    let s = scene(dir.path(), "plain.obj", "");
    let (x, y) = (0.7, 0.2);
    assert!(hit_at(&s, x, y).uv.abs_diff_eq(Vec2::new(x - y, y), 1e-6));

    // Whether a mesh has uv (and normals) is known after loading.
    let plain = load_obj(&dir.path().join("plain.obj"), &MeshPlacement::IDENTITY).unwrap();
    assert!(!plain.has_uv && !plain.has_normals);
    let warped = load_obj(&dir.path().join("warped.obj"), &MeshPlacement::IDENTITY).unwrap();
    assert!(warped.has_uv && !warped.has_normals);
    assert_eq!(warped.attributes.len(), warped.triangles.len());
    // A transform moves the vertices, not the texture coordinates.
    let s = scene(dir.path(), "affine.obj", "transform = { scale = 2.0, translate = [1.0, 0.0, 0.0] }");
    let uv = hit_at(&s, 1.0 + 2.0 * 0.3, 2.0 * 0.6).uv;
    assert!(uv.abs_diff_eq(Vec2::new(0.1 + 0.8 * 0.3, 0.2 + 0.5 * 0.6), 2e-6), "{uv}");
}

#[test]
fn vertex_normals_become_interpolated_shading_normals() {
    let dir = tempfile::tempdir().unwrap();
    // Normals tilted towards the corners (not unit length in the file), and one wound inwards:
    // the shading normal is normalised and on the side of the geometric normal (+z).
    let vn = "vn -1 -1 2\nvn 2 -2 4\nvn 1 1 -2\nvn -1 1 2\n";
    std::fs::write(dir.path().join("smooth.obj"), square("", vn, "f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n"))
        .unwrap();
    let s = scene(dir.path(), "smooth.obj", "");
    let n = [
        Vec3::new(-1.0, -1.0, 2.0),
        Vec3::new(2.0, -2.0, 4.0),
        Vec3::new(1.0, 1.0, -2.0),
        Vec3::new(-1.0, 1.0, 2.0),
    ]
    .map(Vec3::normalize);
    for (x, y) in points() {
        if (x - y).abs() < 1e-3 {
            continue;
        }
        let expected = if x > y {
            (1.0 - x) * n[0] + (x - y) * n[1] + y * n[2]
        } else {
            (1.0 - y) * n[0] + x * n[2] + (y - x) * n[3]
        };
        let Some(expected) = expected.try_normalize() else { continue };
        let expected = if expected.z < 0.0 { -expected } else { expected };
        let hit = hit_at(&s, x, y);
        assert_eq!(hit.n, Vec3::Z, "the geometric normal stays the face's");
        assert!(hit.shading_n.abs_diff_eq(expected, 1e-5), "at ({x}, {y}): {} vs {expected}", hit.shading_n);
        assert!((hit.shading_n.length() - 1.0).abs() < 1e-6);
    }
    // Without vn the shading normal is the geometric one, exactly.
    std::fs::write(dir.path().join("flat.obj"), square("", "", "f 1 2 3\nf 1 3 4\n")).unwrap();
    let hit = hit_at(&scene(dir.path(), "flat.obj", ""), 0.3, 0.6);
    assert_eq!(hit.shading_n, hit.n);

    // Normals go through a transform by its inverse transpose: vn equal to the face normals of
    // a tilted square stay equal to them after an uneven scale and a rotation.
    let tilted = "v 0 0 0\nv 1 0 1\nv 1 1 1\nv 0 1 0\nvn -1 0 1\nf 1//1 2//1 3//1\nf 1//1 3//1 4//1\n";
    std::fs::write(dir.path().join("tilted.obj"), tilted).unwrap();
    let s = scene(
        dir.path(),
        "tilted.obj",
        "transform = { scale = [3.0, 0.5, 1.0], rotate = { axis = [0.0, 0.0, 1.0], angle = 20.0 } }",
    );
    let mut checked = 0;
    for k in 0..50 {
        let (x, y) = (0.3 + 0.03 * k as f32, 0.2 + 0.01 * k as f32);
        let ray = Ray::new(Vec3::new(x, y, 10.0), -Vec3::Z);
        if let Some(i) = s.intersect(&ray, f32::INFINITY) {
            assert!(i.hit.shading_n.abs_diff_eq(i.hit.n, 1e-5), "{} vs {}", i.hit.shading_n, i.hit.n);
            checked += 1;
        }
    }
    assert!(checked > 10, "only {checked} rays hit the tilted square");
}

#[test]
fn broken_texture_coordinates_and_normals_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.obj"), square("vt 0 0\n", "", "f 1/1 2/5 3/1\n")).unwrap();
    let text = r#"
[camera]
position = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
material = "glass"
shape = "mesh"
file = "bad.obj"
"#;
    let e = load_str(text, "scene.toml", Some(dir.path())).err().expect("refused").to_string();
    assert!(e.contains("objects[0].file") && e.contains("bad.obj"), "{e}");
}

#[test]
fn info_says_which_meshes_carry_texture_coordinates_and_normals() {
    let run = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stdout).unwrap()
    };
    let dir = env!("CARGO_MANIFEST_DIR");
    let text = run(&["info", &format!("{dir}/scenes/smooth-glass.toml")]);
    assert!(text.lines().any(|l| l.contains("mesh") && l.contains("with vt and vn")), "{text}");
    let gallery = run(&["info", &format!("{dir}/scenes/shapes-gallery.toml")]);
    assert!(!gallery.contains("with vt"), "the icosahedron has neither: {gallery}");
    let json: serde_json::Value =
        serde_json::from_str(&run(&["info", &format!("{dir}/scenes/smooth-glass.toml"), "--json"])).unwrap();
    let mesh = json["objects"].as_array().unwrap().iter().find(|o| o["kind"] == "mesh").unwrap();
    assert_eq!(
        (mesh["texture_coordinates"].as_bool(), mesh["vertex_normals"].as_bool()),
        (Some(true), Some(true))
    );
}

#[test]
fn smooth_normals_are_recomputed_from_the_faces_and_replace_placeholders() {
    let dir = tempfile::tempdir().unwrap();
    // A roof: two faces meeting at the ridge x = 0.5, rising to z = 0.5 (slopes of 45°), each
    // split in two triangles, every file normal a placeholder `0 1 0`. Recomputed, the ridge's
    // vertices get the faces' (equal-area) average +z, the eaves' the faces' own normals, and a
    // hit in between their interpolation.
    let roof = "v 0 0 0\nv 0.5 0 0.5\nv 0.5 1 0.5\nv 0 1 0\nv 1 0 0\nv 1 1 0\nvn 0 1 0\n\
                f 1//1 2//1 3//1\nf 1//1 3//1 4//1\nf 2//1 5//1 6//1\nf 2//1 6//1 3//1\n";
    std::fs::write(dir.path().join("roof.obj"), roof).unwrap();
    let placeholder = hit_at(&scene(dir.path(), "roof.obj", ""), 0.25, 0.5);
    assert!(placeholder.shading_n.abs_diff_eq(Vec3::Y, 1e-6), "read as given: {}", placeholder.shading_n);
    let s = scene(dir.path(), "roof.obj", "smooth_normals = true");
    let (left, right) = (Vec3::new(-1.0, 0.0, 1.0).normalize(), Vec3::new(1.0, 0.0, 1.0).normalize());
    for (x, face) in [(0.1f32, left), (0.25, left), (0.4, left), (0.6, right), (0.9, right)] {
        let hit = hit_at(&s, x, 0.37);
        // The ridge (weight 2·distance from the eave) has +z, the eave the face's normal.
        let ridge_weight = 1.0 - (x - 0.5).abs() * 2.0;
        let expected = ((1.0 - ridge_weight) * face + ridge_weight * Vec3::Z).normalize();
        assert!(hit.n.abs_diff_eq(face, 1e-5), "the geometric normal stays the face's");
        assert!(hit.shading_n.abs_diff_eq(expected, 1e-5), "at x = {x}: {} vs {expected}", hit.shading_n);
    }
    // With face_normals too, the scene is refused at the field.
    let text = "[camera]\nposition = [0.0, 0.0, 10.0]\nlook_at = [0.0, 0.0, 0.0]\n[materials.m]\ntype = \"diffuse\"\n\
         [[objects]]\nmaterial = \"m\"\nshape = \"mesh\"\nfile = \"roof.obj\"\nface_normals = true\nsmooth_normals = true\n";
    let err = load_str(text, "both", Some(dir.path())).err().expect("refused").to_string();
    assert!(err.contains("smooth_normals") && err.contains("exclude"), "{err}");
}

#[test]
fn missing_normals_are_recomputed_per_vertex_with_its_uv_as_mitsuba_does() {
    let dir = tempfile::tempdir().unwrap();
    // The roof of the test above without normals, its two faces given separate texture
    // coordinates along the ridge (vt 2, 3 on the left, 5, 6 on the right): a uv seam.
    let roof = "v 0 0 0\nv 0.5 0 0.5\nv 0.5 1 0.5\nv 0 1 0\nv 1 0 0\nv 1 1 0\n\
                vt 0 0\nvt 0.5 0\nvt 0.5 1\nvt 0 1\nvt 0.6 0\nvt 0.6 1\nvt 1 0\nvt 1 1\n\
                f 1/1 2/2 3/3\nf 1/1 3/3 4/4\nf 2/5 5/7 6/8\nf 2/5 6/8 3/6\n";
    std::fs::write(dir.path().join("seam.obj"), roof).unwrap();
    // The same roof with one texture coordinate set across the ridge: no seam.
    let joined = roof.replace("f 2/5 5/7 6/8\nf 2/5 6/8 3/6", "f 2/2 5/7 6/8\nf 2/2 6/8 3/3");
    std::fs::write(dir.path().join("joined.obj"), joined).unwrap();
    let (left, right) = (Vec3::new(-1.0, 0.0, 1.0).normalize(), Vec3::new(1.0, 0.0, 1.0).normalize());
    let seam = scene(dir.path(), "seam.obj", "smooth_normals = \"missing\"");
    let joined = scene(dir.path(), "joined.obj", "smooth_normals = \"missing\"");
    for (x, face) in [(0.1f32, left), (0.4, left), (0.6, right), (0.9, right)] {
        // Across a seam each side's ridge vertices see only their own face: flat shading.
        let split = hit_at(&seam, x, 0.37);
        assert!(split.shading_n.abs_diff_eq(face, 1e-5), "seam at x = {x}: {}", split.shading_n);
        // Joined, the ridge is one vertex with the faces' average (+z), as `true` gives.
        let ridge_weight = 1.0 - (x - 0.5).abs() * 2.0;
        let expected = ((1.0 - ridge_weight) * face + ridge_weight * Vec3::Z).normalize();
        let hit = hit_at(&joined, x, 0.37);
        assert!(
            hit.shading_n.abs_diff_eq(expected, 1e-5),
            "joined at x = {x}: {} vs {expected}",
            hit.shading_n
        );
    }
    // A file with vertex normals keeps them, placeholders included.
    let given = "v 0 0 0\nv 0.5 0 0.5\nv 0.5 1 0.5\nv 0 1 0\nvn 0 1 0\nf 1//1 2//1 3//1\nf 1//1 3//1 4//1\n";
    std::fs::write(dir.path().join("given.obj"), given).unwrap();
    let kept = hit_at(&scene(dir.path(), "given.obj", "smooth_normals = \"missing\""), 0.25, 0.5);
    assert!(kept.shading_n.abs_diff_eq(Vec3::Y, 1e-6), "the file's normal: {}", kept.shading_n);
    // Any other value is refused at the field, naming what is allowed.
    let text = "[camera]\nposition = [0.0, 0.0, 10.0]\nlook_at = [0.0, 0.0, 0.0]\n[materials.m]\ntype = \"diffuse\"\n\
         [[objects]]\nmaterial = \"m\"\nshape = \"mesh\"\nfile = \"given.obj\"\nsmooth_normals = \"always\"\n";
    let err = load_str(text, "bad", Some(dir.path())).err().expect("refused").to_string();
    assert!(err.contains("smooth_normals") && err.contains("\"missing\""), "{err}");
}
