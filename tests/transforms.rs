//! Object transforms (`transform = { scale, rotate, translate }`): a transformed shape or mesh
//! intersects exactly like the same geometry written out by hand.
//!
//! With a scale by a power of two, quarter turns about coordinate axes and translations by
//! short binary fractions, every transformed number is exact, so the two scenes hold the same
//! numbers and every hit must be bit-identical. A general transform (an angle of 37° about a
//! skew axis, an uneven scale) rounds each transformed coordinate once in single precision, while
//! the hand-written geometry is computed in double precision and rounded once: the coordinates
//! differ by about an ulp of the scene's size (≈ 5e-7 here), and so do the hits. The rays are
//! aimed at points well inside faces (not at edges, not grazing), where a perturbation δ of the
//! geometry moves t by at most about δ/cos θ and tilts the normal by about δ/(edge length): the
//! stated bounds, relative 1e-5 in t and 1e-5 in the normal, leave a factor of ten or more.

use glam::{DMat3, DVec3, Vec3};
use std::fmt::Write;
use std::path::Path;
use vitrum::geometry::Ray;
use vitrum::scene::{load_str, Scene};

const HEADER: &str = r#"
[camera]
position = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
resolution = [8, 8]
[materials.glass]
type = "dielectric"
ior = 1.5
[materials.lamp]
type = "diffuse"
emission = 2.0
"#;

fn scene(objects: &str, dir: Option<&Path>) -> Scene {
    let text = format!("{HEADER}{objects}");
    load_str(&text, "transforms", dir).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// Rays from a sphere of origins around `center` (radius `distance`) towards points of the box
/// `center ± reach` on a grid.
fn grid_rays(center: Vec3, distance: f32, reach: f32) -> Vec<Ray> {
    let mut rays = Vec::new();
    // The 26 directions of the 3×3×3 lattice around its centre, slightly skewed.
    let origins: Vec<Vec3> = (0..27)
        .filter(|&k| k != 13)
        .map(|k| {
            let (x, y, z) = ((k % 3) as f32 - 1.0, ((k / 3) % 3) as f32 - 1.0, (k / 9) as f32 - 1.0);
            let d = Vec3::new(x + 0.013, y - 0.021, z + 0.017);
            center + d.normalize() * distance
        })
        .collect();
    for o in origins {
        for i in 0..9 {
            for j in 0..9 {
                for k in [0.0f32, 0.37] {
                    let q = Vec3::new(i as f32 / 4.0 - 1.0, j as f32 / 4.0 - 1.0, k - 0.2) * reach;
                    rays.push(Ray::new(o, (center + q - o).normalize()));
                }
            }
        }
    }
    rays
}

/// The closest hits of `rays` in `a` and `b`: the same rays must hit, and the hits must be
/// bit-identical (`bound` `None`) or within relative `bound.0` in t and `bound.1` in the normal.
/// Returns the number of rays that hit and the largest differences seen.
fn compare(a: &Scene, b: &Scene, rays: &[Ray], bound: Option<(f32, f32)>, what: &str) -> (usize, f32, f32) {
    let (mut hits, mut dt, mut dn) = (0, 0f32, 0f32);
    for ray in rays {
        match (a.intersect(ray, f32::INFINITY), b.intersect(ray, f32::INFINITY)) {
            (None, None) => {}
            (Some(x), Some(y)) => {
                hits += 1;
                let (x, y) = (x.hit, y.hit);
                match bound {
                    None => {
                        assert_eq!(x.t.to_bits(), y.t.to_bits(), "{what}: t of {ray:?}: {x:?} vs {y:?}");
                        assert_eq!(x.p, y.p, "{what}: point of {ray:?}");
                        assert_eq!(x.n, y.n, "{what}: normal of {ray:?}");
                        assert_eq!(x.uv, y.uv, "{what}: uv of {ray:?}");
                        assert_eq!(x.p_error, y.p_error, "{what}: error bound of {ray:?}");
                    }
                    Some((bt, bn)) => {
                        let et = (x.t - y.t).abs() / y.t;
                        let en = (x.n - y.n).length();
                        assert!(et <= bt, "{what}: t {} vs {} (relative {et:e}) for {ray:?}", x.t, y.t);
                        assert!(en <= bn, "{what}: normal {} vs {} ({en:e}) for {ray:?}", x.n, y.n);
                        dt = dt.max(et);
                        dn = dn.max(en);
                    }
                }
            }
            (x, y) => {
                panic!("{what}: {ray:?} hits {:?} in one scene, {:?} in the other", x.is_some(), y.is_some())
            }
        }
    }
    assert!(hits >= 40, "{what}: only {hits} of {} rays hit", rays.len());
    (hits, dt, dn)
}

/// Scale by 2, a quarter turn about +y ((x, y, z) ↦ (z, y, −x)), then a translation: exact.
const EXACT: &str = "transform = { scale = 2.0, rotate = { axis = [0.0, 1.0, 0.0], angle = 90.0 }, translate = [0.5, 0.25, -1.0] }";

/// [`EXACT`] by hand.
fn exact(p: [f32; 3]) -> [f32; 3] {
    [2.0 * p[2] + 0.5, 2.0 * p[1] + 0.25, -2.0 * p[0] - 1.0]
}

/// [`EXACT`] on a direction (`0 − x`, not `−x`: the rotation gives +0 for a zero, and the sign
/// of a zero in a disk's normal chooses the tangent frame of its uv).
fn exact_dir(d: [f32; 3]) -> [f32; 3] {
    [d[2], d[1], 0.0 - d[0]]
}

fn v(p: [f32; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", p[0], p[1], p[2])
}

#[test]
fn exactly_transformed_shapes_hit_bit_identically() {
    type Case = (&'static str, String, String);
    let s = 2.0f32;
    let cases: Vec<Case> = vec![
        (
            "sphere",
            "shape = \"sphere\"\ncenter = [0.25, -0.5, 0.125]\nradius = 0.75".into(),
            format!("shape = \"sphere\"\ncenter = {}\nradius = {:?}", v(exact([0.25, -0.5, 0.125])), 0.75 * s),
        ),
        (
            "cylinder",
            "shape = \"cylinder\"\nbase = [0.0, -0.5, 0.25]\naxis = [1.0, 0.5, 0.0]\nradius = 0.5\nheight = 1.25".into(),
            format!(
                "shape = \"cylinder\"\nbase = {}\naxis = {}\nradius = {:?}\nheight = {:?}",
                v(exact([0.0, -0.5, 0.25])),
                v(exact_dir([1.0, 0.5, 0.0])),
                0.5 * s,
                1.25 * s
            ),
        ),
        (
            "disk",
            "shape = \"disk\"\ncenter = [0.5, 0.0, 0.0]\nnormal = [0.0, 0.5, 1.0]\nradius = 1.0\ninner_radius = 0.25".into(),
            format!(
                "shape = \"disk\"\ncenter = {}\nnormal = {}\nradius = {:?}\ninner_radius = {:?}",
                v(exact([0.5, 0.0, 0.0])),
                v(exact_dir([0.0, 0.5, 1.0])),
                s,
                0.25 * s
            ),
        ),
        (
            "quad",
            "shape = \"quad\"\ncorner = [-0.5, -0.5, 0.0]\nu = [1.0, 0.0, 0.25]\nv = [0.0, 1.0, 0.0]".into(),
            format!(
                "shape = \"quad\"\ncorner = {}\nu = {}\nv = {}",
                v(exact([-0.5, -0.5, 0.0])),
                v(exact_dir([2.0, 0.0, 0.5])),
                v(exact_dir([0.0, 2.0, 0.0]))
            ),
        ),
        (
            "polygon",
            "shape = \"polygon\"\nvertices = [[0.0, 0.0, 0.5], [1.0, 0.0, 0.5], [1.0, 0.75, 0.5], [0.25, 1.0, 0.5]]".into(),
            format!(
                "shape = \"polygon\"\nvertices = [{}]",
                [[0.0, 0.0, 0.5], [1.0, 0.0, 0.5], [1.0, 0.75, 0.5], [0.25, 1.0, 0.5]]
                    .map(|p| v(exact(p)))
                    .join(", ")
            ),
        ),
        (
            "hollow_sphere",
            "shape = \"hollow_sphere\"\ncenter = [0.0, 0.25, 0.0]\nradius = 1.0\ninner_radius = 0.75".into(),
            format!(
                "shape = \"hollow_sphere\"\ncenter = {}\nradius = {:?}\ninner_radius = {:?}",
                v(exact([0.0, 0.25, 0.0])),
                s,
                0.75 * s
            ),
        ),
        (
            "bowl",
            "shape = \"bowl\"\ncenter = [0.0, 0.0, 0.25]\naxis = [1.0, 1.0, 0.0]\nradius = 1.0\nthickness = 0.125".into(),
            format!(
                "shape = \"bowl\"\ncenter = {}\naxis = {}\nradius = {:?}\nthickness = {:?}",
                v(exact([0.0, 0.0, 0.25])),
                v(exact_dir([1.0, 1.0, 0.0])),
                s,
                0.125 * s
            ),
        ),
        (
            "drinking_glass",
            "shape = \"drinking_glass\"\nbase = [0.0, -0.75, 0.0]\naxis = [0.0, 1.0, 1.0]\nradius = 0.5\nheight = 1.5\nwall = 0.0625\nbottom = 0.25".into(),
            format!(
                "shape = \"drinking_glass\"\nbase = {}\naxis = {}\nradius = {:?}\nheight = {:?}\nwall = {:?}\nbottom = {:?}",
                v(exact([0.0, -0.75, 0.0])),
                v(exact_dir([0.0, 1.0, 1.0])),
                0.5 * s,
                1.5 * s,
                0.0625 * s,
                0.25 * s
            ),
        ),
    ];
    let center = Vec3::from_array(exact([0.0, 0.0, 0.0]));
    let rays = grid_rays(center, 12.0, 3.0);
    for (what, shape, by_hand) in &cases {
        let a = scene(&format!("[[objects]]\nmaterial = \"glass\"\n{shape}\n{EXACT}\n"), None);
        let b = scene(&format!("[[objects]]\nmaterial = \"glass\"\n{by_hand}\n"), None);
        let (hits, _, _) = compare(&a, &b, &rays, None, what);
        println!("{what}: {hits} of {} rays hit, all bit-identical", rays.len());
    }
    // An emitter's light moves with it.
    let lamp = |shape: &str| scene(&format!("[[objects]]\nmaterial = \"lamp\"\n{shape}\n"), None);
    let a = lamp(&format!("{}\n{EXACT}", cases[0].1));
    let b = lamp(&cases[0].2);
    assert_eq!(format!("{:?}", a.lights), format!("{:?}", b.lights));
    let a = lamp(&format!("{}\n{EXACT}", cases[3].1));
    let b = lamp(&cases[3].2);
    assert_eq!(format!("{:?}", a.lights), format!("{:?}", b.lights));
}

/// An OBJ text of `vertices` and 1-based `faces`.
fn obj(vertices: &[[f32; 3]], faces: &[[usize; 3]]) -> String {
    let mut s = String::new();
    for p in vertices {
        writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]).unwrap();
    }
    for f in faces {
        writeln!(s, "f {} {} {}", f[0], f[1], f[2]).unwrap();
    }
    s
}

/// A closed octahedron with a point pulled out, wound outwards (1-based faces).
fn octahedron() -> (Vec<[f32; 3]>, Vec<[usize; 3]>) {
    let vertices = vec![
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.25, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -0.75],
    ];
    let faces = vec![[1, 3, 5], [3, 2, 5], [2, 4, 5], [4, 1, 5], [3, 1, 6], [2, 3, 6], [4, 2, 6], [1, 4, 6]];
    (vertices, faces)
}

#[test]
fn exactly_transformed_meshes_hit_bit_identically() {
    let dir = tempfile::tempdir().unwrap();
    let (vertices, faces) = octahedron();
    std::fs::write(dir.path().join("a.obj"), obj(&vertices, &faces)).unwrap();
    let moved: Vec<[f32; 3]> = vertices.iter().map(|p| exact(*p)).collect();
    std::fs::write(dir.path().join("b.obj"), obj(&moved, &faces)).unwrap();
    let rays = grid_rays(Vec3::from_array(exact([0.0; 3])), 12.0, 2.5);
    let a = scene(
        &format!("[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"a.obj\"\n{EXACT}\n"),
        Some(dir.path()),
    );
    let b =
        scene("[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"b.obj\"\n", Some(dir.path()));
    let (hits, _, _) = compare(&a, &b, &rays, None, "mesh");
    println!("mesh: {hits} of {} rays hit, all bit-identical", rays.len());
    // The mesh's own `scale` and `translate` come first, then the transform: 4·(p/2 + x/4) = 2p + x
    // and the quarter turn takes x to −z, so this is EXACT again.
    let c = scene(
        "[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"a.obj\"\nscale = 0.5\ntranslate = [0.25, 0.0, 0.0]\ntransform = { scale = 4.0, rotate = { axis = [0.0, 1.0, 0.0], angle = 90.0 }, translate = [0.5, 0.25, 0.0] }\n",
        Some(dir.path()),
    );
    compare(&c, &b, &rays, None, "mesh with scale and translate");
    // Without a transform, `scale` and `translate` do what they always did: scale·p + translate.
    let d = scene(
        "[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"a.obj\"\nscale = 0.3\ntranslate = [0.1, 0.2, 0.3]\n",
        Some(dir.path()),
    );
    let placed: Vec<[f32; 3]> =
        vertices.iter().map(|p| (Vec3::from_array(*p) * 0.3 + Vec3::new(0.1, 0.2, 0.3)).to_array()).collect();
    std::fs::write(dir.path().join("d.obj"), obj(&placed, &faces)).unwrap();
    let e =
        scene("[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"d.obj\"\n", Some(dir.path()));
    compare(&d, &e, &grid_rays(Vec3::new(0.1, 0.2, 0.3), 12.0, 0.8), None, "mesh scale and translate");
}

/// 37° about [1, 2, 3], an uneven scale and a translation, in double precision.
struct General {
    scale: DVec3,
    rotation: DMat3,
    translate: DVec3,
}

impl General {
    fn new(uniform: bool) -> General {
        let scale = if uniform { DVec3::splat(1.5) } else { DVec3::new(1.5, 0.75, 2.0) };
        let rotation = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 37f64.to_radians());
        General { scale, rotation, translate: DVec3::new(0.3, -0.2, 0.7) }
    }

    fn toml(&self) -> String {
        let s = self.scale;
        let scale = if s.x == s.y && s.y == s.z {
            format!("{:?}", s.x)
        } else {
            format!("[{:?}, {:?}, {:?}]", s.x, s.y, s.z)
        };
        format!("transform = {{ scale = {scale}, rotate = {{ axis = [1.0, 2.0, 3.0], angle = 37.0 }}, translate = [0.3, -0.2, 0.7] }}")
    }

    fn point(&self, p: [f32; 3]) -> [f32; 3] {
        (self.rotation * (Vec3::from_array(p).as_dvec3() * self.scale) + self.translate).as_vec3().to_array()
    }

    fn vector(&self, p: [f32; 3]) -> [f32; 3] {
        (self.rotation * (Vec3::from_array(p).as_dvec3() * self.scale)).as_vec3().to_array()
    }
}

/// Rays at interior points of each triangle `[a, b, c]` (barycentrics at least 0.15 from every
/// edge), from outside along the normal tilted by up to about 30°.
fn face_rays(triangles: &[[Vec3; 3]]) -> Vec<Ray> {
    let mut rays = Vec::new();
    for &[a, b, c] in triangles {
        let n = (b - a).cross(c - a).normalize();
        let (s, t) = n.any_orthonormal_pair();
        for (b1, b2) in [(0.2, 0.2), (0.6, 0.2), (0.2, 0.6), (0.33, 0.33), (0.45, 0.25), (0.25, 0.45)] {
            let p = a + (b - a) * b1 + (c - a) * b2;
            for tilt in [Vec3::ZERO, 0.5 * s, -0.4 * t, 0.3 * (s + t)] {
                let o = p + (n + tilt) * 3.0;
                rays.push(Ray::new(o, (p - o).normalize()));
            }
        }
    }
    rays
}

#[test]
fn generally_transformed_shapes_and_meshes_hit_within_roundoff() {
    let bound = Some((1e-5, 1e-5));
    // Shapes that take any scale.
    let g = General::new(false);
    let quad = ([-0.5f32, -0.25, 0.1], [1.0f32, 0.0, 0.2], [0.0f32, 1.25, 0.0]);
    let a = scene(
        &format!(
            "[[objects]]\nmaterial = \"glass\"\nshape = \"quad\"\ncorner = {}\nu = {}\nv = {}\n{}\n",
            v(quad.0),
            v(quad.1),
            v(quad.2),
            g.toml()
        ),
        None,
    );
    let (corner, u, ev) = (g.point(quad.0), g.vector(quad.1), g.vector(quad.2));
    let b = scene(
        &format!(
            "[[objects]]\nmaterial = \"glass\"\nshape = \"quad\"\ncorner = {}\nu = {}\nv = {}\n",
            v(corner),
            v(u),
            v(ev)
        ),
        None,
    );
    let (c, u, ev) = (Vec3::from_array(corner), Vec3::from_array(u), Vec3::from_array(ev));
    let rays = face_rays(&[[c, c + u, c + ev], [c + u + ev, c + ev, c + u]]);
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, "quad");
    println!("quad: {hits} hits, largest relative difference in t {dt:e}, in the normal {dn:e}");

    let polygon = [[0.0f32, 0.0, 0.5], [1.0, 0.0, 0.5], [1.0, 0.75, 0.5], [0.25, 1.0, 0.5]];
    let to_list = |ps: &[[f32; 3]]| ps.iter().map(|p| v(*p)).collect::<Vec<_>>().join(", ");
    let a = scene(
        &format!(
            "[[objects]]\nmaterial = \"glass\"\nshape = \"polygon\"\nvertices = [{}]\n{}\n",
            to_list(&polygon),
            g.toml()
        ),
        None,
    );
    let placed: Vec<[f32; 3]> = polygon.iter().map(|p| g.point(*p)).collect();
    let b = scene(
        &format!(
            "[[objects]]\nmaterial = \"glass\"\nshape = \"polygon\"\nvertices = [{}]\n",
            to_list(&placed)
        ),
        None,
    );
    let p: Vec<Vec3> = placed.iter().map(|p| Vec3::from_array(*p)).collect();
    let rays = face_rays(&[[p[0], p[1], p[2]], [p[0], p[2], p[3]]]);
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, "polygon");
    println!("polygon: {hits} hits, largest relative difference in t {dt:e}, in the normal {dn:e}");

    // A mesh.
    let dir = tempfile::tempdir().unwrap();
    let (vertices, faces) = octahedron();
    std::fs::write(dir.path().join("a.obj"), obj(&vertices, &faces)).unwrap();
    let moved: Vec<[f32; 3]> = vertices.iter().map(|p| g.point(*p)).collect();
    std::fs::write(dir.path().join("b.obj"), obj(&moved, &faces)).unwrap();
    let a = scene(
        &format!("[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"a.obj\"\n{}\n", g.toml()),
        Some(dir.path()),
    );
    let b =
        scene("[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"b.obj\"\n", Some(dir.path()));
    let triangles: Vec<[Vec3; 3]> = faces.iter().map(|f| f.map(|i| Vec3::from_array(moved[i - 1]))).collect();
    let rays = face_rays(&triangles);
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, "mesh");
    assert_eq!(hits, rays.len(), "every ray aims at a face");
    println!("mesh: {hits} hits, largest relative difference in t {dt:e}, in the normal {dn:e}");

    // Round shapes take a uniform scale.
    let g = General::new(true);
    let a = scene(&format!("[[objects]]\nmaterial = \"glass\"\nshape = \"sphere\"\ncenter = [0.25, -0.5, 0.1]\nradius = 0.75\n{}\n", g.toml()), None);
    let center = g.point([0.25, -0.5, 0.1]);
    let b = scene(
        &format!(
            "[[objects]]\nmaterial = \"glass\"\nshape = \"sphere\"\ncenter = {}\nradius = 1.125\n",
            v(center)
        ),
        None,
    );
    let rays = grid_rays(Vec3::from_array(center), 10.0, 0.5);
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, "sphere");
    println!("sphere: {hits} hits, largest relative difference in t {dt:e}, in the normal {dn:e}");
    let a = scene(
        &format!(
            "[[objects]]\nmaterial = \"glass\"\nshape = \"cylinder\"\nbase = [0.0, -0.5, 0.0]\naxis = [0.0, 1.0, 0.0]\nradius = 0.5\nheight = 1.0\n{}\n",
            g.toml()
        ),
        None,
    );
    let (base, axis) = (g.point([0.0, -0.5, 0.0]), g.vector([0.0, 1.0, 0.0]));
    let b = scene(
        &format!("[[objects]]\nmaterial = \"glass\"\nshape = \"cylinder\"\nbase = {}\naxis = {}\nradius = 0.75\nheight = 1.5\n", v(base), v(axis)),
        None,
    );
    // Aimed at the middle of the body, away from the rims.
    let middle = Vec3::from_array(base) + Vec3::from_array(axis) * 0.5;
    let (hits, dt, dn) = compare(&a, &b, &grid_rays(middle, 10.0, 0.3), bound, "cylinder");
    println!("cylinder: {hits} hits, largest relative difference in t {dt:e}, in the normal {dn:e}");
}

/// The error of a scene with one object `object`.
fn refused(object: &str) -> String {
    let text = format!("{HEADER}[[objects]]\nmaterial = \"glass\"\n{object}\n");
    match load_str(&text, "scene.toml", None) {
        Ok(_) => panic!("accepted:\n{object}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_transforms_are_refused_at_their_field() {
    let line = HEADER.lines().count() + 2;
    for shape in [
        "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0",
        "shape = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\nradius = 1.0\nheight = 1.0",
        "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 1.0",
        "shape = \"hollow_sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\ninner_radius = 0.5",
        "shape = \"bowl\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nthickness = 0.1",
        "shape = \"drinking_glass\"\nbase = [0.0, 0.0, 0.0]\nradius = 1.0\nheight = 2.0\nwall = 0.1\nbottom = 0.2",
    ] {
        let lines = shape.lines().count();
        let e = refused(&format!("{shape}\ntransform = {{ scale = [1.0, 2.0, 1.0] }}"));
        let kind = shape.split('"').nth(1).unwrap();
        assert!(e.contains(&format!("scene.toml:{}:", line + lines + 1)), "{e}");
        assert!(e.contains("field `objects[0].transform.scale`"), "{e}");
        assert!(e.contains(&format!("a {kind} cannot be scaled by different factors per axis")), "{e}");
    }
    // Quads, polygons and meshes take it.
    assert!(load_str(
        &format!("{HEADER}[[objects]]\nmaterial = \"glass\"\nshape = \"quad\"\ncorner = [0.0, 0.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 1.0, 0.0]\ntransform = {{ scale = [1.0, 2.0, 3.0] }}\n"),
        "scene.toml",
        None
    )
    .is_ok());
    let sphere = "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0";
    for (transform, field, needle) in [
        ("{ scale = 0.0 }", "transform.scale", "every factor must be greater than 0 (got 0)"),
        ("{ scale = -2.0 }", "transform.scale", "mirrors"),
        ("{ scale = [1.0, 0.0, 1.0] }", "transform.scale", "greater than 0"),
        ("{ rotate = { axis = [0.0, 0.0, 0.0], angle = 30.0 } }", "transform.rotate.axis", "non-zero"),
        ("{ rotate = { axis = [0.0, 0.0, 1.0] } }", "transform.rotate", "angle"),
        ("{ scale = \"big\" }", "transform.scale", "expected a scale"),
        ("{ shift = [1.0, 0.0, 0.0] }", "transform.shift", "unknown field `shift`"),
    ] {
        let e = refused(&format!("{sphere}\ntransform = {transform}"));
        assert!(e.contains(&format!("scene.toml:{}:", line + 4)), "{transform}: {e}");
        assert!(e.contains(&format!("field `objects[0].{field}`")), "{transform}: {e}");
        assert!(e.contains(needle), "{transform}: {e}");
    }
    // A transform that makes a valid shape invalid, or too large, is named.
    let e = refused(
        "shape = \"quad\"\ncorner = [0.0, 0.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 1e-15, 0.0]\ntransform = { scale = 1e-35 }",
    );
    assert!(
        e.contains("field `objects[0].transform`") && e.contains("the transformed shape is invalid"),
        "{e}"
    );
    let e =
        refused("shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1e15\ntransform = { scale = 1e15 }");
    assert!(e.contains("field `objects[0].transform`") && e.contains("beyond"), "{e}");
    // A transformed shape's numbers are checked as written.
    let e =
        refused("shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = -1.0\ntransform = { scale = 3.0 }");
    assert!(e.contains("objects[0].radius") && e.contains("got -1"), "{e}");
}
