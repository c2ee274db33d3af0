//! What the benchmarks (and `tests/wavefront.rs`, for its terrains) share: procedural terrains of any triangle count, paired timing, and the
//! closest hit by testing every primitive in turn.
#![allow(dead_code)] // each benchmark uses a subset

use glam::Vec3;
use std::path::{Path, PathBuf};
use vitrum::geometry::Ray;
use vitrum::scene::Scene;

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

/// The ratio of times of `a` and `b`, measured in alternating pairs (so that the machine's
/// drift over a run affects both alike): the median and the range over `rounds` pairs.
pub fn paired_ratio(rounds: usize, mut a: impl FnMut(), mut b: impl FnMut()) -> (f64, f64, f64) {
    let time = |f: &mut dyn FnMut()| {
        let start = std::time::Instant::now();
        f();
        start.elapsed().as_secs_f64()
    };
    let mut ratios: Vec<f64> = (0..rounds)
        .map(|k| {
            // Alternate which goes first.
            let (ta, tb) = if k % 2 == 0 {
                let ta = time(&mut a);
                (ta, time(&mut b))
            } else {
                let tb = time(&mut b);
                (time(&mut a), tb)
            };
            ta / tb
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    (ratios[rounds / 2], ratios[0], ratios[rounds - 1])
}

/// The closest hit of `ray` by testing every primitive of `scene` in turn (no BVH) and the
/// distance of the hit record of the nearest (no uv, as for a scene without image textures),
/// with its primitive: the per-ray work of the "many rays against one shape" loop of a wavefront
/// engine, one ray at a time.
pub fn closest_by_every_primitive(scene: &Scene, ray: &Ray) -> Option<(f32, usize)> {
    let mut nearest: Option<(f32, usize)> = None;
    for (k, prim) in scene.primitives.iter().enumerate() {
        let limit = nearest.map_or(f32::INFINITY, |(t, _)| t);
        if let Some(t) = prim.shape.intersect(ray, 0.0, limit) {
            nearest = Some((t, k));
        }
    }
    nearest.map(|(t, k)| (scene.primitives[k].shape.surface_with(ray, t, None, false).t, k))
}
