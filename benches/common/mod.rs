//! Scenes shared by the benchmarks: procedural terrains of any triangle count.
#![allow(dead_code)] // each benchmark uses a subset

use glam::Vec3;
use std::path::{Path, PathBuf};

/// A bumpy terrain over [-1, 1]² of about `triangles` triangles: its vertices and faces.
pub fn terrain(triangles: usize) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    let n = ((triangles / 2) as f64).sqrt().round() as usize;
    let height =
        |x: f32, z: f32| 0.15 * (7.0 * x).sin() * (5.0 * z).cos() + 0.05 * (23.0 * x + 17.0 * z).sin();
    let mut vertices = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (2.0 * i as f32 / n as f32 - 1.0, 2.0 * j as f32 / n as f32 - 1.0);
            vertices.push(Vec3::new(x, height(x, z), z));
        }
    }
    let mut faces = Vec::with_capacity(2 * n * n);
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            faces.push([a, c, b]);
            faces.push([b, c, d]);
        }
    }
    (vertices, faces)
}

/// The terrain as a vitrum scene file (with its OBJ) in `dir`: a grey diffuse mesh seen from
/// above at an angle, lit by a point light.
pub fn write_terrain_scene(dir: &Path, vertices: &[Vec3], faces: &[[usize; 3]]) -> PathBuf {
    use std::fmt::Write;
    let mut obj = String::with_capacity(40 * (vertices.len() + faces.len()));
    for v in vertices {
        writeln!(obj, "v {} {} {}", v.x, v.y, v.z).unwrap();
    }
    for f in faces {
        writeln!(obj, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1).unwrap();
    }
    std::fs::write(dir.join("terrain.obj"), obj).unwrap();
    let toml = r#"
[camera]
position = [0.0, 2.0, 3.0]
look_at = [0.0, 0.0, 0.0]
[materials.grey]
type = "diffuse"
color = 0.5
[[objects]]
shape = "mesh"
file = "terrain.obj"
material = "grey"
[[lights]]
type = "point"
position = [0.0, 3.0, 0.0]
intensity = 10.0
"#;
    let path = dir.join("terrain.toml");
    std::fs::write(&path, toml).unwrap();
    path
}
