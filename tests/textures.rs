//! Image textures and texture coordinates: the uv of every shape at known points (corners, poles,
//! seams), an image texture rendered texel for texel, one decode per file, the scene hash over the
//! image's bytes, and bad image input (exit 2 naming the scene line and the file, nothing written),
//! images declaring more pixels than vitrum reads among it.

mod common;

use glam::{Vec2, Vec3};
use std::fs;
use std::path::Path;
use std::process::Command;
use vitrum::geometry::{texture_frame, Ray};
use vitrum::material::{Bsdf, Texture};
use vitrum::scene::{load_str, Scene};

/// The uv of the first hit of the ray from `origin` along `dir` (normalised).
fn uv_at(scene: &Scene, origin: Vec3, dir: Vec3) -> Vec2 {
    let hit = scene.intersect(&Ray::new(origin, dir.normalize()), f32::INFINITY).expect("the ray hits");
    hit.hit.uv
}

/// A scene of one object (`object` is the body of its `[[objects]]` table) whose material is
/// `material` (the body of its table).
fn one_object_of(object: &str, material: &str) -> Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
         [materials.m]\n{material}\n[[objects]]\nmaterial = \"m\"\n{object}\n"
    );
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    load_str(&text, "uv", Some(&scenes)).unwrap()
}

/// A scene of one object with an image texture, so that its hits carry their uv.
fn one_object(object: &str) -> Scene {
    one_object_of(
        object,
        "type = \"diffuse\"\ntexture = { type = \"image\", file = \"textures/uv-grid.png\" }",
    )
}

#[test]
fn hits_skip_the_angular_uv_where_no_texture_reads_it() {
    // Spheres, cylinders and disks pay an atan2 for their uv; without an image texture anywhere
    // (a checker reads the position) their hits carry zero instead.
    let sphere = "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0";
    let disk = "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 1.0";
    let plain = "type = \"diffuse\"\ntexture = { type = \"checker\", color1 = [1.0, 1.0, 1.0], color2 = [0.0, 0.0, 0.0], size = 0.5 }";
    let origin = Vec3::new(0.3, 0.4, 5.0);
    for object in [sphere, disk] {
        assert_eq!(uv_at(&one_object_of(object, plain), origin, -Vec3::Z), Vec2::ZERO, "{object}");
        let uv = uv_at(&one_object(object), origin, -Vec3::Z);
        assert!(uv.x > 0.0 && uv.y > 0.0, "{object}: {uv}");
    }
}

fn close(a: Vec2, b: Vec2) -> bool {
    (a - b).abs().max_element() < 1e-5
}

#[test]
fn the_texture_frame_of_the_vertical_axis_is_x_then_minus_z() {
    // The documented longitude origins (scenes/README.md): +Y gives (+X, −Z), −Y gives (+X, +Z).
    assert_eq!(texture_frame(Vec3::Y), (Vec3::X, -Vec3::Z));
    assert_eq!(texture_frame(-Vec3::Y), (Vec3::X, Vec3::Z));
    assert_eq!(texture_frame(Vec3::Z), (Vec3::X, Vec3::Y));
    for axis in [Vec3::Y, -Vec3::Y, Vec3::Z, Vec3::new(1.0, 2.0, -3.0).normalize()] {
        let (t1, t2) = texture_frame(axis);
        assert!((t1.cross(t2) - axis).length() < 1e-6, "right-handed about {axis}");
    }
}

#[test]
fn quad_uv_runs_along_its_edges() {
    let s =
        one_object("shape = \"quad\"\ncorner = [-1.0, -0.5, 0.0]\nu = [2.0, 0.0, 0.0]\nv = [0.0, 1.0, 0.0]");
    let at = |x: f32, y: f32| uv_at(&s, Vec3::new(x, y, 1.0), -Vec3::Z);
    assert_eq!(at(-1.0, -0.5), Vec2::new(0.0, 0.0));
    assert_eq!(at(1.0, -0.5), Vec2::new(1.0, 0.0));
    assert_eq!(at(1.0, 0.5), Vec2::new(1.0, 1.0));
    assert_eq!(at(0.0, 0.0), Vec2::new(0.5, 0.5));
    assert_eq!(at(-0.5, 0.25), Vec2::new(0.25, 0.75));
}

#[test]
fn disk_and_annulus_uv_are_radial_position_and_angle() {
    // Mitsuba 3's disk uv. Normal +Z: u is 0 at the centre, 1 on the rim; the angle v is
    // measured from +X towards +Y.
    let s = one_object("shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 1.0");
    let at = |x: f32, y: f32| uv_at(&s, Vec3::new(x, y, 1.0), -Vec3::Z);
    assert!(close(at(0.5, 0.0), Vec2::new(0.5, 0.0)));
    assert!(close(at(0.0, 0.5), Vec2::new(0.5, 0.25)));
    assert!(close(at(-0.5, 0.0), Vec2::new(0.5, 0.5)));
    assert!(close(at(0.0, -0.999), Vec2::new(0.999, 0.75)));
    // The seam: just below the +X direction the angle is just under 1.
    assert!(at(0.5, -1e-3).y > 0.999);
    // An annulus: u = 0 on the inner rim, 1 on the outer one.
    let s = one_object(
        "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 1.0\ninner_radius = 0.5",
    );
    assert!(close(uv_at(&s, Vec3::new(0.75, 0.0, 1.0), -Vec3::Z), Vec2::new(0.5, 0.0)));
    assert!(close(uv_at(&s, Vec3::new(0.0, -0.999, 1.0), -Vec3::Z), Vec2::new(0.998, 0.75)));
}

#[test]
fn a_seam_sets_where_the_angle_starts() {
    // A disk facing +Z with its seam along +Y (and a tilt out of the plane, projected away):
    // the angle runs from +Y towards +Z × +Y = −X.
    let s = one_object(
        "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 1.0\nseam = [0.0, 2.0, 0.5]",
    );
    let at = |x: f32, y: f32| uv_at(&s, Vec3::new(x, y, 1.0), -Vec3::Z);
    assert!(close(at(0.0, 0.5), Vec2::new(0.5, 0.0)));
    assert!(close(at(-0.5, 0.0), Vec2::new(0.5, 0.25)));
    assert!(close(at(0.5, 0.0), Vec2::new(0.5, 0.75)));
    // A cylinder along +Y with its seam along +Z: u = 0 at +Z, ¼ at +Y × +Z = +X; v unchanged.
    let s = one_object(
        "shape = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\naxis = [0.0, 1.0, 0.0]\nradius = 0.5\nheight = 2.0\nseam = [0.0, 0.0, 1.0]",
    );
    assert!(close(uv_at(&s, Vec3::new(0.0, 0.5, 5.0), -Vec3::Z), Vec2::new(0.0, 0.25)));
    assert!(close(uv_at(&s, Vec3::new(5.0, 1.0, 0.0), -Vec3::X), Vec2::new(0.25, 0.5)));
    // Turned with the shape: rotated 90° about +Y, the seam +Z points to +X.
    let s = one_object(
        "shape = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\naxis = [0.0, 1.0, 0.0]\nradius = 0.5\nheight = 2.0\nseam = [0.0, 0.0, 1.0]\n\
         transform = { rotate = { axis = [0.0, 1.0, 0.0], angle = 90.0 } }",
    );
    assert!(close(uv_at(&s, Vec3::new(5.0, 0.5, 0.0), -Vec3::X), Vec2::new(0.0, 0.25)));
    // A seam along the axis has no direction across it: refused, naming the field.
    let text = "[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n[materials.m]\ntype = \"diffuse\"\n\
                [[objects]]\nmaterial = \"m\"\nshape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\n\
                radius = 1.0\nseam = [0.0, 0.0, -3.0]\n";
    let e = load_str(text, "seam", None).err().expect("a seam along the normal is refused").to_string();
    assert!(e.contains("seam") && e.contains("along the axis"), "{e}");
}

#[test]
fn sphere_uv_is_longitude_and_latitude_with_the_top_at_the_pole() {
    let s = one_object("shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0");
    // The poles: +Y is v = 1 (the top row of an image), −Y is v = 0.
    assert_eq!(uv_at(&s, Vec3::new(0.0, 5.0, 0.0), -Vec3::Y), Vec2::new(0.0, 1.0));
    assert_eq!(uv_at(&s, Vec3::new(0.0, -5.0, 0.0), Vec3::Y).y, 0.0);
    // The equator: u = 0 at +X, 1/4 at −Z, 1/2 at −X, 3/4 at +Z (right-handed about +Y).
    assert!(close(uv_at(&s, Vec3::new(5.0, 0.0, 0.0), -Vec3::X), Vec2::new(0.0, 0.5)));
    assert!(close(uv_at(&s, Vec3::new(0.0, 0.0, -5.0), Vec3::Z), Vec2::new(0.25, 0.5)));
    assert!(close(uv_at(&s, Vec3::new(-5.0, 0.0, 0.0), Vec3::X), Vec2::new(0.5, 0.5)));
    assert!(close(uv_at(&s, Vec3::new(0.0, 0.0, 5.0), -Vec3::Z), Vec2::new(0.75, 0.5)));
    // 45° north at +X: v = 3/4.
    let d = Vec3::new(1.0, 1.0, 0.0).normalize();
    assert!(close(uv_at(&s, d * 5.0, -d), Vec2::new(0.0, 0.75)));
    // The seam at +X: from the +Z side the longitude is just under 1.
    let d = Vec3::new(1.0, 0.0, 1e-3).normalize();
    assert!(uv_at(&s, d * 5.0, -d).x > 0.999);
}

#[test]
fn cylinder_uv_is_angle_and_height_and_its_caps_are_disks() {
    let s = one_object(
        "shape = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\naxis = [0.0, 1.0, 0.0]\nradius = 0.5\nheight = 2.0\ncaps = true",
    );
    // The wall: u from +X towards −Z, v up from the base.
    assert!(close(uv_at(&s, Vec3::new(5.0, 0.5, 0.0), -Vec3::X), Vec2::new(0.0, 0.25)));
    assert!(close(uv_at(&s, Vec3::new(0.0, 1.5, -5.0), Vec3::Z), Vec2::new(0.25, 0.75)));
    assert!(close(uv_at(&s, Vec3::new(0.0, 1.0, 5.0), -Vec3::Z), Vec2::new(0.75, 0.5)));
    // The top cap (normal +Y, angle from +X towards −Z) and the bottom cap (normal −Y, angle
    // from +X towards +Z): u is 0 at the centre, 1 on the rim.
    assert!(close(uv_at(&s, Vec3::new(0.25, 5.0, 0.0), -Vec3::Y), Vec2::new(0.5, 0.0)));
    assert!(close(uv_at(&s, Vec3::new(0.0, 5.0, -0.25), -Vec3::Y), Vec2::new(0.5, 0.25)));
    assert!(close(uv_at(&s, Vec3::new(0.0, -5.0, 0.25), Vec3::Y), Vec2::new(0.5, 0.25)));
}

#[test]
fn polygon_uv_spans_its_planar_bounding_box() {
    // A triangle in the plane z = 0 with its first edge along +X: u along the first edge, v along
    // normal × u, both over the bounding box of the vertices.
    let s = one_object("shape = \"polygon\"\nvertices = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]]");
    assert!(close(uv_at(&s, Vec3::new(0.5, 0.25, 1.0), -Vec3::Z), Vec2::new(0.25, 0.25)));
    assert!(close(uv_at(&s, Vec3::new(1.0, 0.5, 1.0), -Vec3::Z), Vec2::new(0.5, 0.5)));
    assert!(close(uv_at(&s, Vec3::new(0.0, 0.0, 1.0), -Vec3::Z), Vec2::ZERO));
}

#[test]
fn composite_bodies_use_the_uv_of_their_surfaces() {
    // A hollow sphere: the outer sphere's uv seen from outside.
    let s =
        one_object("shape = \"hollow_sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\ninner_radius = 0.9");
    assert!(close(uv_at(&s, Vec3::new(0.0, 0.0, -5.0), Vec3::Z), Vec2::new(0.25, 0.5)));
    // ... and the inner sphere's from its centre: the same longitude and latitude.
    assert!(close(uv_at(&s, Vec3::ZERO, -Vec3::Z), Vec2::new(0.25, 0.5)));
    assert_eq!(uv_at(&s, Vec3::ZERO, Vec3::Y).y, 1.0);
    // A bowl opening upwards: the outer hemisphere's pole is the axis (v = 1 on the rim plane's
    // normal side is clipped away; the bottom is v = 0).
    let s = one_object(
        "shape = \"bowl\"\ncenter = [0.0, 0.0, 0.0]\naxis = [0.0, 1.0, 0.0]\nradius = 1.0\nthickness = 0.1",
    );
    assert_eq!(uv_at(&s, Vec3::new(0.0, -5.0, 0.0), Vec3::Y).y, 0.0);
    assert!(close(uv_at(&s, Vec3::new(0.0, -0.5, -5.0), Vec3::Z), Vec2::new(0.25, 1.0 / 3.0)));
}

/// Write a PNG of `width` × `height` 8-bit texels, row by row from the top.
fn write_png(path: &Path, width: u32, height: u32, texels: &[[u8; 3]]) {
    let mut img = image::RgbImage::new(width, height);
    for (p, v) in img.pixels_mut().zip(texels) {
        p.0 = *v;
    }
    img.save(path).unwrap();
}

/// A scene whose camera sees only a quad filling the view, lit by ambient light of radiance 1
/// alone: `raycast` renders its colour exactly.
fn framed_quad(texture: &str) -> String {
    format!(
        "[camera]\nposition = [0.0, 0.0, 1.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 90.0\nresolution = [4, 4]\n\
         [render]\nambient = 1.0\n\
         [materials.m]\ntype = \"diffuse\"\ntexture = {texture}\n\
         [[objects]]\nshape = \"quad\"\ncorner = [-1.0, -1.0, 0.0]\nu = [2.0, 0.0, 0.0]\nv = [0.0, 2.0, 0.0]\nmaterial = \"m\"\n"
    )
}

#[test]
fn an_image_on_a_quad_renders_texel_for_texel() {
    let dir = tempfile::tempdir().unwrap();
    // 4 × 4 texels, each a different colour; the camera's 4 × 4 pixels each see one texel.
    let texels: Vec<[u8; 3]> = (0..16u8).map(|i| [i * 16, 255 - i * 16, (i % 4) * 80]).collect();
    write_png(&dir.path().join("t.png"), 4, 4, &texels);
    let text = framed_quad("{ type = \"image\", file = \"t.png\", filter = \"nearest\" }");
    let scene = load_str(&text, "scene.toml", Some(dir.path())).unwrap();
    let image = common::render_with(&scene, "raycast", 1, 0);
    for (i, (pixel, texel)) in image.pixels.iter().zip(&texels).enumerate() {
        let expected = Vec3::from_array(texel.map(|c| vitrum::texture::srgb_to_linear(c as f32 / 255.0)));
        assert!((*pixel - expected).abs().max_element() < 1e-6, "pixel {i}: {pixel} vs {expected}");
    }
    // The same file read as linear values.
    let text =
        framed_quad("{ type = \"image\", file = \"t.png\", filter = \"nearest\", colorspace = \"linear\" }");
    let scene = load_str(&text, "scene.toml", Some(dir.path())).unwrap();
    let image = common::render_with(&scene, "raycast", 1, 0);
    let expected = Vec3::from_array(texels[5].map(|c| c as f32 / 255.0));
    assert!((image.pixels[5] - expected).abs().max_element() < 1e-6);
}

#[test]
fn a_file_is_decoded_once_and_its_bytes_are_in_the_scene_hash() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("t.png");
    write_png(&png, 2, 2, &[[10, 20, 30], [40, 50, 60], [70, 80, 90], [100, 110, 120]]);
    let two = "[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nresolution = [8, 8]\n\
        [materials.a]\ntype = \"diffuse\"\ntexture = { type = \"image\", file = \"t.png\" }\n\
        [materials.b]\ntype = \"mirror\"\ntexture = { type = \"image\", file = \"t.png\", scale = [2.0, 3.0] }\n\
        [[objects]]\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"a\"\n\
        [[objects]]\nshape = \"sphere\"\ncenter = [3.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"b\"\n";
    let scene = load_str(two, "scene.toml", Some(dir.path())).unwrap();
    let map = |name: &str| {
        let m = scene.materials.iter().find(|m| m.name == name).unwrap();
        match &m.bsdf {
            Bsdf::Diffuse { albedo: Texture::Image(t), .. }
            | Bsdf::Mirror { color: Texture::Image(t), .. } => t.map.clone(),
            other => panic!("{other:?}"),
        }
    };
    assert!(std::sync::Arc::ptr_eq(&map("a"), &map("b")), "one decode for both materials");
    assert!(scene.effects.has(vitrum::scene::Effect::Textures));
    let before = scene.origin.hash.clone();
    write_png(&png, 2, 2, &[[10, 20, 30], [40, 50, 60], [70, 80, 90], [100, 110, 121]]);
    let after = load_str(two, "scene.toml", Some(dir.path())).unwrap().origin.hash;
    assert_ne!(before, after, "the scene hash covers the image's bytes");
}

/// Render `text` as `scene.toml` in `dir` with the CLI: (exit code, stderr, whether any output
/// file was written).
fn render_cli(dir: &Path, text: &str) -> (Option<i32>, String, bool) {
    fs::write(dir.join("scene.toml"), text).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_vitrum"))
        .current_dir(dir)
        .args(["render", "scene.toml", "-i", "raycast", "-o", "out.exr", "--png", "out.png"])
        .output()
        .unwrap();
    let written = dir.join("out.exr").exists() || dir.join("out.png").exists();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned(), written)
}

#[test]
fn bad_images_exit_2_naming_the_line_and_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_png(&d.join("good.png"), 2, 2, &[[1, 2, 3]; 4]);
    let good = fs::read(d.join("good.png")).unwrap();
    fs::write(d.join("cut.png"), &good[..good.len() / 2]).unwrap();
    fs::write(d.join("empty.png"), b"").unwrap();
    fs::write(d.join("anim.gif"), b"GIF89a\x01\x00\x01\x00\x00\x00\x00;").unwrap();
    fs::create_dir(d.join("folder.png")).unwrap();
    // The texture is on line 10 of the scene text (`framed_quad`).
    let cases = [
        ("{ type = \"image\", file = \"missing.png\" }", "missing.png"),
        ("{ type = \"image\", file = \"cut.png\" }", "cut.png"),
        ("{ type = \"image\", file = \"empty.png\" }", "empty.png"),
        ("{ type = \"image\", file = \"anim.gif\" }", "anim.gif"),
        ("{ type = \"image\", file = \"folder.png\" }", "folder.png"),
        ("{ type = \"image\", file = \"good.png\", scale = [0.0, 1.0] }", "scale"),
        ("{ type = \"image\", file = \"good.png\", wrap = \"mirror\" }", "repeat"),
        ("{ type = \"image\", file = \"good.png\", filter = \"cubic\" }", "bilinear"),
    ];
    for (texture, named) in cases {
        let (code, stderr, written) = render_cli(d, &framed_quad(texture));
        assert_eq!(code, Some(2), "{texture}: {stderr}");
        assert!(stderr.contains("scene.toml:10:"), "{texture}: the line is named: {stderr}");
        assert!(stderr.contains(named), "{texture}: `{named}` is named: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!written, "{texture}: nothing is written");
    }
    // Unreadable (permissions) where the test does not run as root.
    let locked = d.join("locked.png");
    fs::write(&locked, &good).unwrap();
    use std::os::unix::fs::PermissionsExt;
    fs::set_permissions(&locked, fs::Permissions::from_mode(0o000)).unwrap();
    if fs::read(&locked).is_err() {
        let (code, stderr, written) =
            render_cli(d, &framed_quad("{ type = \"image\", file = \"locked.png\" }"));
        assert_eq!(code, Some(2), "{stderr}");
        assert!(stderr.contains("locked.png") && !written, "{stderr}");
    }
    // And the good file renders.
    let (code, stderr, written) = render_cli(d, &framed_quad("{ type = \"image\", file = \"good.png\" }"));
    assert_eq!(code, Some(0), "{stderr}");
    assert!(written);
}

#[test]
fn images_declaring_too_many_pixels_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (width, height) = common::oversized::DECLARED;
    common::oversized::write_png_declaring(&d.join("huge.png"), width, height);
    common::oversized::write_exr_declaring(&d.join("huge.exr"), width, height);
    for file in ["huge.png", "huge.exr"] {
        let texture = format!("{{ type = \"image\", file = \"{file}\" }}");
        fs::write(d.join("scene.toml"), framed_quad(&texture)).unwrap();
        let out =
            common::oversized::vitrum_capped(d, &["render", "scene.toml", "-i", "raycast", "-o", "out.exr"]);
        common::oversized::assert_refused_as_too_large(&out, file);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("scene.toml:10:"), "{file}: the line is named: {stderr}");
        assert!(!d.join("out.exr").exists(), "{file}: nothing is written");
    }
}

/// A scene text of a diffuse floor lit from 1 m above by `emitters` (objects), seen from below
/// the emitters looking down at the floor only.
fn lit_floor(emitters: &str) -> String {
    format!(
        "[camera]\nposition = [0.0, 0.6, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 60.0\nresolution = [16, 16]\n\
         [materials.floor]\ntype = \"diffuse\"\ncolor = 0.5\n\
         [[objects]]\nshape = \"quad\"\ncorner = [-2.0, 0.0, 2.0]\nu = [4.0, 0.0, 0.0]\nv = [0.0, 0.0, -4.0]\nmaterial = \"floor\"\n{emitters}"
    )
}

#[test]
fn a_textured_emitter_lights_as_its_texels_would_one_by_one() {
    // An emitting quad of 1 m × 1 m at y = 1 whose image is two texels, left (−x) and right
    // (+x), against the same light made of two constant halves: the floor below must look the
    // same within noise (`path`: next-event estimation reads the texel at the sampled point, BSDF
    // sampling at the hit, and MIS joins them).
    let dir = tempfile::tempdir().unwrap();
    write_png(&dir.path().join("halves.png"), 2, 1, &[[255, 64, 0], [0, 128, 255]]);
    let textured = lit_floor(
        "[materials.glow]\ntype = \"diffuse\"\ncolor = 0.0\nemission = 3.0\n\
         emission_texture = { type = \"image\", file = \"halves.png\", filter = \"nearest\", colorspace = \"linear\" }\n\
         [[objects]]\nshape = \"quad\"\ncorner = [-0.5, 1.0, -0.5]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 0.0, 1.0]\nmaterial = \"glow\"\n",
    );
    let (a, b) = ([255.0f32, 64.0, 0.0], [0.0f32, 128.0, 255.0]);
    let c = |t: [f32; 3]| format!("[{}, {}, {}]", 3.0 * t[0] / 255.0, 3.0 * t[1] / 255.0, 3.0 * t[2] / 255.0);
    let halves = lit_floor(&format!(
        "[materials.left]\ntype = \"diffuse\"\ncolor = 0.0\nemission = {}\n\
         [materials.right]\ntype = \"diffuse\"\ncolor = 0.0\nemission = {}\n\
         [[objects]]\nshape = \"quad\"\ncorner = [-0.5, 1.0, -0.5]\nu = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 1.0]\nmaterial = \"left\"\n\
         [[objects]]\nshape = \"quad\"\ncorner = [0.0, 1.0, -0.5]\nu = [0.5, 0.0, 0.0]\nv = [0.0, 0.0, 1.0]\nmaterial = \"right\"\n",
        c(a),
        c(b)
    ));
    let textured = load_str(&textured, "textured.toml", Some(dir.path())).unwrap();
    let halves = load_str(&halves, "halves.toml", Some(dir.path())).unwrap();
    assert!(textured.effects.has(vitrum::scene::Effect::Textures));
    let k = 16;
    let (ma, sa) = common::mean_and_error(&textured, "path", 4, k);
    let (mb, sb) = common::mean_and_error(&halves, "path", 4, k);
    // 4 × 4 blocks: every block and channel within 4.5 standard errors of the difference.
    let worst = common::largest_block_z(&ma, &sa, &mb, &sb, 16, 4);
    println!("textured emitter vs two constant halves: largest block difference {worst:.2} standard errors");
    assert!(worst < 4.5, "{worst}");
    // The left and right halves of the floor differ in colour as the texels do (the image is not
    // mirrored: +x, the image's right, is the right of the picture).
    let left: Vec3 = (0..16).flat_map(|y| (0..4).map(move |x| y * 16 + x)).map(|i| ma[i]).sum();
    let right: Vec3 = (0..16).flat_map(|y| (12..16).map(move |x| y * 16 + x)).map(|i| ma[i]).sum();
    assert!(left.x > 1.3 * right.x && right.z > 1.3 * left.z, "{left} {right}");
}

#[test]
fn an_image_on_a_mesh_needs_its_texture_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_png(&d.join("t.png"), 2, 2, &[[10, 20, 30]; 4]);
    fs::write(d.join("plain.obj"), "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    fs::write(
        d.join("mapped.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0.5 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    let scene = |obj: &str| {
        format!(
            "[camera]\nposition = [0.0, 0.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nresolution = [4, 4]\n\
             [materials.m]\ntype = \"diffuse\"\ntexture = {{ type = \"image\", file = \"t.png\" }}\n\
             [[objects]]\nshape = \"mesh\"\nfile = \"{obj}\"\nmaterial = \"m\"\n\
             [[lights]]\ntype = \"point\"\nposition = [0.0, 0.0, 2.0]\nintensity = 1.0\n"
        )
    };
    let (code, stderr, written) = render_cli(d, &scene("plain.obj"));
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("plain.obj") && stderr.contains("vt") && stderr.contains("t.png"), "{stderr}");
    assert!(stderr.contains("objects[0].file") && !written, "{stderr}");
    let (code, stderr, written) = render_cli(d, &scene("mapped.obj"));
    assert_eq!(code, Some(0), "{stderr}");
    assert!(written);
}
