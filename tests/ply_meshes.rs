//! PLY meshes: ASCII and binary files give the triangles, normals and uv an OBJ file of the same
//! mesh gives (the same image bits); a header that declares more elements than its file can
//! hold, or faces that name missing vertices, exit 2 before anything large is allocated.

use std::fs;
use std::path::Path;
use std::process::{Command, Output};

fn vitrum(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vitrum")).args(args).current_dir(dir).output().unwrap()
}

/// A square of side 2 in the plane y = 0.5 facing up, as one quad face (a fan of two triangles),
/// with normals and uv.
const VERTICES: [[f32; 8]; 4] = [
    [-1.0, 0.5, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0],
    [-1.0, 0.5, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0],
    [1.0, 0.5, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0],
    [1.0, 0.5, -1.0, 0.0, 1.0, 0.0, 1.0, 0.0],
];

fn header(format: &str, vertices: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

fn ascii() -> Vec<u8> {
    let mut s = header("ascii", 4);
    for v in VERTICES {
        s.push_str(&v.map(|x| x.to_string()).join(" "));
        s.push('\n');
    }
    s.push_str("4 0 1 2 3\n");
    s.into_bytes()
}

fn binary() -> Vec<u8> {
    let mut b = header("binary_little_endian", 4).into_bytes();
    for v in VERTICES {
        for x in v {
            b.extend(x.to_le_bytes());
        }
    }
    b.push(4);
    for i in [0i32, 1, 2, 3] {
        b.extend(i.to_le_bytes());
    }
    b
}

fn obj() -> String {
    let mut s = String::new();
    for v in VERTICES {
        s.push_str(&format!(
            "v {} {} {}\nvn {} {} {}\nvt {} {}\n",
            v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]
        ));
    }
    s + "f 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n"
}

fn scene(mesh: &str) -> String {
    format!(
        r#"[camera]
position = [0.3, 2.0, 2.5]
look_at = [0.0, 0.5, 0.0]
resolution = [16, 12]

[materials.checks]
type = "diffuse"
texture = {{ type = "checker", color1 = 0.8, color2 = 0.2, size = 0.25 }}

[[objects]]
shape = "mesh"
file = "{mesh}"
material = "checks"

[[lights]]
type = "point"
position = [0.0, 2.0, 0.0]
intensity = [3.0, 3.0, 3.0]
"#
    )
}

fn render(dir: &Path, mesh: &str) -> Vec<glam::Vec3> {
    let toml = format!("{mesh}.toml");
    fs::write(dir.join(&toml), scene(mesh)).unwrap();
    let exr = format!("{mesh}.exr");
    let out = vitrum(dir, &["render", &toml, "-i", "path", "--spp", "2", "-o", &exr, "--quiet"]);
    assert!(out.status.success(), "{mesh}: {}", String::from_utf8_lossy(&out.stderr));
    vitrum::output::exr::read_exr(&dir.join(exr)).unwrap().0.pixels
}

#[test]
fn ascii_and_binary_ply_are_the_obj_of_the_same_mesh() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("a.ply"), ascii()).unwrap();
    fs::write(dir.path().join("b.ply"), binary()).unwrap();
    fs::write(dir.path().join("c.obj"), obj()).unwrap();
    let reference = render(dir.path(), "c.obj");
    assert!(reference.iter().any(|p| p.max_element() > 0.0));
    assert_eq!(render(dir.path(), "a.ply"), reference);
    assert_eq!(render(dir.path(), "b.ply"), reference);
    let info = vitrum(dir.path(), &["info", "a.ply.toml"]);
    assert!(
        String::from_utf8_lossy(&info.stdout).contains("2 primitive(s)"),
        "{}",
        String::from_utf8_lossy(&info.stdout)
    );
}

#[test]
fn lying_headers_and_missing_vertices_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    // A tiny file declaring four billion vertices, and a face naming vertex 9 of 4.
    let lying = [header("binary_little_endian", 4_000_000_000).into_bytes(), vec![0u8; 64]].concat();
    fs::write(dir.path().join("lying.ply"), lying).unwrap();
    fs::write(
        dir.path().join("missing.ply"),
        String::from_utf8(ascii()).unwrap().replace("4 0 1 2 3", "4 0 1 2 9"),
    )
    .unwrap();
    fs::write(dir.path().join("garbage.ply"), "ply\nnot a header\n").unwrap();
    for (mesh, needle) in
        [("lying.ply", "declares"), ("missing.ply", "vertex 9"), ("garbage.ply", "garbage.ply")]
    {
        fs::write(dir.path().join("s.toml"), scene(mesh)).unwrap();
        let out = vitrum(dir.path(), &["info", "s.toml"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{mesh}: {err}");
        assert!(err.contains(needle) && err.contains("s.toml:"), "{mesh}: {err}");
    }
}

#[test]
fn face_normals_shade_with_the_triangles_own_normals() {
    // The same square with wrong vertex normals (tilted 45°): with `face_normals = true` it
    // renders as the file without normals.
    let dir = tempfile::tempdir().unwrap();
    let tilted = obj().replace("vn 0 1 0", "vn 1 1 0");
    let vertices: String = obj()
        .lines()
        .filter(|l| l.starts_with("v ") || l.starts_with("vt"))
        .map(|l| format!("{l}\n"))
        .collect();
    let bare = vertices + "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    fs::write(dir.path().join("tilted.obj"), tilted).unwrap();
    fs::write(dir.path().join("bare.obj"), bare).unwrap();
    let flat_scene =
        scene("tilted.obj").replace("material = \"checks\"", "material = \"checks\"\nface_normals = true");
    fs::write(dir.path().join("flat.toml"), flat_scene).unwrap();
    let out =
        vitrum(dir.path(), &["render", "flat.toml", "-i", "path", "--spp", "2", "-o", "flat.exr", "--quiet"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let flat = vitrum::output::exr::read_exr(&dir.path().join("flat.exr")).unwrap().0.pixels;
    assert_eq!(flat, render(dir.path(), "bare.obj"));
    assert_ne!(flat, render(dir.path(), "tilted.obj"), "the tilted normals do shade differently");
}
