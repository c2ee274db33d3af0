//! Rays spawned by reflection and refraction never re-hit the surface they leave, on every
//! shape kind, including a hollow sphere whose wall is 1e-4 of its radius.

use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;
use vitrum::geometry::{spawn_origin, Ray};
use vitrum::lighting::crossing;
use vitrum::optics::{reflect, refract};
use vitrum::scene::{load_str, Scene};

const HITS_PER_SHAPE: usize = 10_000;

fn scene_with(object: &str, dir: Option<&std::path::Path>) -> Scene {
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
{object}
"#
    );
    load_str(&text, "test", dir).unwrap()
}

fn random_unit(rng: &mut Pcg32) -> Vec3 {
    let z = 1.0 - 2.0 * rng.random::<f32>();
    let phi = std::f32::consts::TAU * rng.random::<f32>();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Shoot rays from a sphere around the object towards random points near it; at each hit spawn
/// the reflected and (if any) refracted ray and check that the next hit is not the surface left
/// behind at a tiny distance. Returns how many spawned rays were checked.
fn check(scene: &Scene, size: f32, min_gap: f32) -> usize {
    let mut rng = Pcg32::seed_from_u64(7);
    let mut hits = 0;
    let mut checked = 0;
    let mut attempts = 0;
    while hits < HITS_PER_SHAPE {
        attempts += 1;
        assert!(attempts < 50 * HITS_PER_SHAPE, "too few hits");
        let origin = random_unit(&mut rng) * 4.0 * size;
        let target = random_unit(&mut rng) * size * rng.random::<f32>();
        let ray = Ray::new(origin, (target - origin).normalize());
        let Some(first) = scene.intersect(&ray, f32::INFINITY) else { continue };
        hits += 1;
        let hit = first.hit;
        let wo = -ray.dir;
        let n = if hit.n.dot(wo) >= 0.0 { hit.n } else { -hit.n };
        let c = crossing(&scene.material_of(first.primitive).bsdf, ray.dir, hit.n, None).unwrap();
        let (n_i, n_t) = (c.n_i, c.n_t);
        let mut spawned = vec![reflect(wo, n)];
        spawned.extend(refract(wo, n, n_t / n_i));
        for dir in spawned {
            let next = Ray::new(spawn_origin(&hit, dir), dir);
            checked += 1;
            if let Some(h) = scene.intersect(&next, f32::INFINITY) {
                let same = h.primitive == first.primitive;
                assert!(
                    !(same && h.hit.t < min_gap),
                    "re-hit the surface it left: t = {} from p = {} dir = {dir}",
                    h.hit.t,
                    hit.p
                );
                assert!(h.hit.t.is_finite() && h.hit.p.is_finite());
            }
        }
    }
    checked
}

#[test]
fn sphere() {
    let s = scene_with("shape = \"sphere\"\ncenter = [0.3, -0.2, 0.1]\nradius = 1.0", None);
    assert!(check(&s, 1.0, 1e-2) > HITS_PER_SHAPE);
}

#[test]
fn capped_cylinder() {
    let s = scene_with(
        "shape = \"cylinder\"\nbase = [0.0, -0.8, 0.0]\naxis = [0.3, 1.0, 0.2]\nradius = 0.6\nheight = 1.6",
        None,
    );
    check(&s, 1.0, 1e-3);
}

#[test]
fn disk_and_annulus() {
    let s = scene_with(
        "shape = \"disk\"\ncenter = [0.1, 0.0, 0.0]\nnormal = [0.2, 1.0, 0.4]\nradius = 1.0",
        None,
    );
    check(&s, 1.0, 1e-3);
    let s = scene_with(
        "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 1.0\ninner_radius = 0.3",
        None,
    );
    check(&s, 1.0, 1e-3);
}

#[test]
fn quad_and_polygon() {
    let s = scene_with(
        "shape = \"quad\"\ncorner = [-1.0, -1.0, 0.2]\nu = [2.0, 0.3, 0.0]\nv = [0.0, 2.0, 0.5]",
        None,
    );
    check(&s, 1.0, 1e-3);
    let s = scene_with(
        "shape = \"polygon\"\nvertices = [[1.0, 0.0, 0.0], [0.31, 0.95, 0.0], [-0.81, 0.59, 0.0], [-0.81, -0.59, 0.0], [0.31, -0.95, 0.0]]",
        None,
    );
    check(&s, 1.0, 1e-3);
}

#[test]
fn triangle_mesh() {
    let dir = tempfile::tempdir().unwrap();
    // An octahedron: a closed mesh whose vertices lie on the axes.
    let obj = "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
               f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";
    std::fs::write(dir.path().join("octa.obj"), obj).unwrap();
    let s = scene_with("shape = \"mesh\"\nfile = \"octa.obj\"", Some(dir.path()));
    check(&s, 1.0, 1e-3);
}

#[test]
fn thin_hollow_sphere_wall_of_1e_4_radius() {
    let s = scene_with(
        "shape = \"hollow_sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\ninner_radius = 0.9999",
        None,
    );
    // The wall is 1e-4 thick: a spawned ray must find the other face of the wall, not itself.
    check(&s, 1.0, 5e-5);
}
