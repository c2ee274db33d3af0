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

/// Distance along `dir` from `origin` to the sphere (`center`, `radius`), the far root when
/// `origin` is inside, in f64.
fn sphere_distance(origin: Vec3, dir: Vec3, center: Vec3, radius: f32, far: bool) -> Option<f64> {
    let f = (origin - center).as_dvec3();
    let d = dir.as_dvec3();
    let b = f.dot(d);
    let c = f.length_squared() - (radius as f64).powi(2);
    let disc = b * b - c;
    (disc >= 0.0).then(|| if far { -b + disc.sqrt() } else { -b - disc.sqrt() })
}

#[test]
fn thin_hollow_sphere_holds_its_light_far_from_the_origin() {
    // A wall of 1e-4 radius, even 170 units from the origin (about 13 ulps thick there): every
    // refracted ray meets the other face of the wall at the analytic distance, and rays inside
    // the wall or the cavity meet the surface they should.
    for center in [Vec3::ZERO, Vec3::splat(30.0), Vec3::splat(100.0)] {
        let (r_out, r_in) = (1.0f32, 0.9999f32);
        let s = scene_with(
            &format!(
                "shape = \"hollow_sphere\"\ncenter = [{}, {}, {}]\nradius = {r_out}\ninner_radius = {r_in}",
                center.x, center.y, center.z
            ),
            None,
        );
        let is_inner = |prim: u32| s.material_of(prim).name.ends_with("(inner)");
        let mut rng = Pcg32::seed_from_u64(11);
        for _ in 0..2000 {
            // Aim close to the centre so the refracted ray must cross the cavity.
            let origin = center + random_unit(&mut rng) * 4.0;
            let target = center + random_unit(&mut rng) * 0.4 * rng.random::<f32>();
            let ray = Ray::new(origin, (target - origin).normalize());
            let outer = s.intersect(&ray, f32::INFINITY).expect("aimed at the sphere");
            assert!(!is_inner(outer.primitive));
            let wo = -ray.dir;
            let c = crossing(&s.material_of(outer.primitive).bsdf, ray.dir, outer.hit.n, None).unwrap();
            let into_wall = refract(wo, outer.hit.n, c.n_t / c.n_i).unwrap();
            let start = spawn_origin(&outer.hit, into_wall);
            let wall = s.intersect(&Ray::new(start, into_wall), f32::INFINITY).unwrap();
            let expected = sphere_distance(start, into_wall, center, r_in, false).unwrap();
            assert!(
                is_inner(wall.primitive),
                "centre {center}: the refracted ray tunnelled through the wall"
            );
            assert!((wall.hit.t as f64 - expected).abs() < 1e-2 * expected + 1e-5, "centre {center}");
            // From inside the wall into the cavity: the next hit is the cavity's far side.
            let wo = -into_wall;
            let c = crossing(&s.material_of(wall.primitive).bsdf, into_wall, wall.hit.n, None).unwrap();
            let n = if wall.hit.n.dot(wo) > 0.0 { wall.hit.n } else { -wall.hit.n };
            if let Some(into_cavity) = refract(wo, n, c.n_t / c.n_i) {
                let start = spawn_origin(&wall.hit, into_cavity);
                let far = s.intersect(&Ray::new(start, into_cavity), f32::INFINITY).unwrap();
                let expected = sphere_distance(start, into_cavity, center, r_in, true).unwrap();
                assert!(is_inner(far.primitive) && (far.hit.t as f64 - expected).abs() < 1e-3 * expected);
            }
            // Reflected back into the wall: the next hit is the outer face, inside the wall.
            let back = reflect(wo, n);
            let start = spawn_origin(&wall.hit, back);
            let out = s.intersect(&Ray::new(start, back), f32::INFINITY).unwrap();
            assert!(!is_inner(out.primitive), "centre {center}: reflection inside the wall escaped");
            let expected = sphere_distance(start, back, center, r_out, true).unwrap();
            assert!((out.hit.t as f64 - expected).abs() < 1e-2 * expected + 1e-5, "centre {center}");
        }
    }
}
