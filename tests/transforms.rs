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
//!
//! Under a general affine map (a per-axis scale, a `matrix`) round shapes are ellipsoids and
//! elliptic cylinders and disks: checked against the analytic ellipsoid (hits, normals,
//! silhouette area), against the same map written both ways (bit for bit), by finite
//! differences (normals), in the white furnace, by every method (no NaN) and on both engines of
//! `path`. A rotation turns the texture frame of round shapes (and of emitters) with them.

mod common;

use glam::{DMat3, DVec3, Vec3};
use std::fmt::Write;
use std::path::Path;
use vitrum::geometry::{Ray, Shape};
use vitrum::light::{EmitterShape, Light};
use vitrum::scene::{load_str, Intersection, Scene};

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

/// The texture coordinates of `hit` (of `ray` in `scene`), computed whether or not the scene's
/// materials read them (a scene computes them for its hits only where one does).
fn uv_of(scene: &Scene, ray: &Ray, hit: &Intersection) -> glam::Vec2 {
    scene.primitives[hit.primitive as usize].shape.surface(ray, hit.hit.t).uv
}

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
/// bit-identical (`bound` `None`; the texture coordinates too where `same_uv`) or within relative
/// `bound.0` in t and `bound.1` in the normal. Returns the number of rays that hit and the
/// largest differences seen.
fn compare(
    a: &Scene,
    b: &Scene,
    rays: &[Ray],
    bound: Option<(f32, f32)>,
    same_uv: bool,
    what: &str,
) -> (usize, f32, f32) {
    let (mut hits, mut dt, mut dn) = (0, 0f32, 0f32);
    for ray in rays {
        match (a.intersect(ray, f32::INFINITY), b.intersect(ray, f32::INFINITY)) {
            (None, None) => {}
            (Some(x), Some(y)) => {
                hits += 1;
                if same_uv && bound.is_none() {
                    assert_eq!(uv_of(a, ray, &x), uv_of(b, ray, &y), "{what}: uv of {ray:?}");
                }
                let (x, y) = (x.hit, y.hit);
                match bound {
                    None => {
                        assert_eq!(x.t.to_bits(), y.t.to_bits(), "{what}: t of {ray:?}: {x:?} vs {y:?}");
                        assert_eq!(x.p, y.p, "{what}: point of {ray:?}");
                        assert_eq!(x.n, y.n, "{what}: normal of {ray:?}");
                        assert_eq!(x.uv, y.uv, "{what}: uv of {ray:?} as the scenes give them");
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

/// [`EXACT`] undone: the preimage of a point.
fn exact_inverse(p: Vec3) -> Vec3 {
    Vec3::new(-(p.z + 1.0) / 2.0, (p.y - 0.25) / 2.0, (p.x - 0.5) / 2.0)
}

/// The distance of two texture coordinates, each taken around the circle (the angle is a
/// disk's v and the other round shapes' u; a linear coordinate's 0 and 1 are the only points this
/// reads as close that are not).
fn uv_distance(a: glam::Vec2, b: glam::Vec2) -> f32 {
    let around = |x: f32, y: f32| {
        let d = (x - y).abs();
        d.min(1.0 - d)
    };
    around(a.x, b.x).max(around(a.y, b.y))
}

/// Checks that every hit of `rays` in `placed` (a scene transformed by [`EXACT`]) has the uv of
/// the same ray's preimage hit in `unplaced`; returns the number of hits.
fn same_uv_at_preimages(placed: &Scene, unplaced: &Scene, rays: &[Ray], what: &str) -> usize {
    let mut checked = 0;
    for ray in rays {
        let Some(x) = placed.intersect(ray, f32::INFINITY) else { continue };
        let origin = exact_inverse(ray.origin);
        let back = Ray::new(origin, (exact_inverse(ray.origin + ray.dir) - origin).normalize());
        let y = unplaced.intersect(&back, f32::INFINITY).expect("the preimage ray hits");
        let (a, b) = (uv_of(placed, ray, &x), uv_of(unplaced, &back, &y));
        // (Near a tangent the hit moves along the ray by about √ε of the radius: 1e-3 allows for it.)
        assert!(uv_distance(a, b) < 1e-3, "{what}: uv {a} of the placed hit vs {b} at its preimage");
        checked += 1;
    }
    checked
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
        // The texture frame turns with a round shape (a sphere's, cylinder's or disk's uv is
        // measured in its turned frame; hand-written, the frame follows the new axis instead).
        let turns = !matches!(*what, "quad" | "polygon");
        let (hits, _, _) = compare(&a, &b, &rays, None, !turns, what);
        println!("{what}: {hits} of {} rays hit, all bit-identical", rays.len());
        if turns {
            // The uv of a hit is the uv the untransformed shape has at the point's preimage.
            let c = scene(&format!("[[objects]]\nmaterial = \"glass\"\n{shape}\n"), None);
            let checked = same_uv_at_preimages(&a, &c, &rays, what);
            println!("{what}: {checked} hits have the uv of their preimage");
        }
    }
    // An emitter's light moves with it, its texture frame turned as the sphere's.
    let lamp = |shape: &str| scene(&format!("[[objects]]\nmaterial = \"lamp\"\n{shape}\n"), None);
    let a = lamp(&format!("{}\n{EXACT}", cases[0].1));
    let b = lamp(&cases[0].2);
    match (&a.lights[0], &b.lights[0], &a.primitives[0].shape) {
        (
            Light::Surface { shape: EmitterShape::Sphere { center, radius, frame }, .. },
            Light::Surface { shape: EmitterShape::Sphere { center: c, radius: r, .. }, .. },
            Shape::Sphere(s),
        ) => {
            assert_eq!((center, radius), (c, r));
            assert_eq!(*frame, s.texture_frame());
            // A quarter turn about +y keeps the pole and turns the longitude's origin +x to −z.
            assert_eq!(frame.0, Vec3::Y);
            assert_eq!(frame.1 .0, Vec3::new(0.0, 0.0, -1.0));
        }
        other => panic!("not a sphere light: {other:?}"),
    }
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
    let (hits, _, _) = compare(&a, &b, &rays, None, true, "mesh");
    println!("mesh: {hits} of {} rays hit, all bit-identical", rays.len());
    // The mesh's own `scale` and `translate` come first, then the transform: 4·(p/2 + x/4) = 2p + x
    // and the quarter turn takes x to −z, so this is EXACT again.
    let c = scene(
        "[[objects]]\nmaterial = \"glass\"\nshape = \"mesh\"\nfile = \"a.obj\"\nscale = 0.5\ntranslate = [0.25, 0.0, 0.0]\ntransform = { scale = 4.0, rotate = { axis = [0.0, 1.0, 0.0], angle = 90.0 }, translate = [0.5, 0.25, 0.0] }\n",
        Some(dir.path()),
    );
    compare(&c, &b, &rays, None, true, "mesh with scale and translate");
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
    compare(&d, &e, &grid_rays(Vec3::new(0.1, 0.2, 0.3), 12.0, 0.8), None, true, "mesh scale and translate");
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
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, true, "quad");
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
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, true, "polygon");
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
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, true, "mesh");
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
    let (hits, dt, dn) = compare(&a, &b, &rays, bound, true, "sphere");
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
    let (hits, dt, dn) = compare(&a, &b, &grid_rays(middle, 10.0, 0.3), bound, true, "cylinder");
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
    // Every shape takes a per-axis scale (the round ones become ellipsoids, elliptic disks and
    // cylinders), and a matrix.
    for shape in [
        "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0",
        "shape = \"cylinder\"\nbase = [0.0, 0.0, 0.0]\nradius = 1.0\nheight = 1.0",
        "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 0.0, 1.0]\nradius = 1.0",
        "shape = \"hollow_sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\ninner_radius = 0.5",
        "shape = \"bowl\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nthickness = 0.1",
        "shape = \"drinking_glass\"\nbase = [0.0, 0.0, 0.0]\nradius = 1.0\nheight = 2.0\nwall = 0.1\nbottom = 0.2",
        "shape = \"quad\"\ncorner = [0.0, 0.0, 0.0]\nu = [1.0, 0.0, 0.0]\nv = [0.0, 1.0, 0.0]",
    ] {
        for transform in ["{ scale = [1.0, 2.0, 1.0] }", &format!("{{ matrix = {SHEAR} }}")] {
            let text = format!("{HEADER}[[objects]]\nmaterial = \"glass\"\n{shape}\ntransform = {transform}\n");
            if let Err(e) = load_str(&text, "scene.toml", None) {
                panic!("{shape} under {transform}: {e}");
            }
        }
    }
    let sphere = "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0";
    for (transform, field, needle) in [
        ("{ scale = 0.0 }", "transform.scale", "every factor must be greater than 0 (got 0)"),
        ("{ scale = -2.0 }", "transform.scale", "mirrors"),
        ("{ scale = [1.0, 0.0, 1.0] }", "transform.scale", "greater than 0"),
        ("{ rotate = { axis = [0.0, 0.0, 0.0], angle = 30.0 } }", "transform.rotate.axis", "non-zero"),
        ("{ rotate = { axis = [0.0, 0.0, 1.0] } }", "transform.rotate", "angle"),
        ("{ scale = \"big\" }", "transform.scale", "expected a scale"),
        ("{ shift = [1.0, 0.0, 0.0] }", "transform.shift", "unknown field `shift`"),
        ("{ matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0] }", "transform.matrix", "singular"),
        ("{ matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 2.0, 1e-9, 0.0, 0.0, 0.0, 0.0, 1.0] }", "transform.matrix", "singular"),
        ("{ matrix = [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0] }", "transform.matrix", "mirrors"),
        ("{ matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, inf, 0.0, 0.0, 0.0, 1.0] }", "transform.matrix[11]", "finite"),
        ("{ matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0, 1.0] }", "transform.matrix", "last row"),
        ("{ matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0] }", "transform.matrix", "16"),
        ("{ matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0], scale = 2.0 }", "transform.matrix", "alone"),
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
    // An emitting ellipsoid is one light (its sampling: tests/emitting_affine.rs).
    let text = format!("{HEADER}[[objects]]\nmaterial = \"lamp\"\nshape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\ntransform = {{ scale = [2.0, 1.0, 1.0] }}\n");
    let s = load_str(&text, "scene.toml", None).unwrap_or_else(|e| panic!("an emitting ellipsoid: {e}"));
    assert_eq!(s.lights.len(), 1);
    // A transformed shape's numbers are checked as written.
    let e =
        refused("shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = -1.0\ntransform = { scale = 3.0 }");
    assert!(e.contains("objects[0].radius") && e.contains("got -1"), "{e}");
}

/// A shear with an uneven scale and a translation, as a `matrix` (row-major): x' = 1.5x + 0.5y,
/// y' = 0.75y + 0.25z, z' = z, moved by (0.25, −0.5, 0.5).
const SHEAR: &str = "[1.5, 0.5, 0.0, 0.25, 0.0, 0.75, 0.25, -0.5, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 1.0]";

/// One object of `material` with the given shape and transform lines.
fn object(material: &str, shape: &str, transform: &str) -> String {
    format!("[[objects]]\nmaterial = \"{material}\"\n{shape}\ntransform = {transform}\n")
}

#[test]
fn an_ellipsoid_is_hit_where_the_analytic_surface_is() {
    // Semi-axes (a, b, c) = (1, 0.5, 0.25) about C = (1, 0.25, −1): the sphere of radius 0.5 at
    // (0.25, 0, 0) scaled by (2, 1, 0.5), then moved. Rays along −z over a grid of the xy plane.
    let s = scene(
        &object(
            "glass",
            "shape = \"sphere\"\ncenter = [0.25, 0.0, 0.0]\nradius = 0.5",
            "{ scale = [2.0, 1.0, 0.5], translate = [0.5, 0.25, -1.0] }",
        ),
        None,
    );
    let (c, axes) = (glam::DVec3::new(1.0, 0.25, -1.0), glam::DVec3::new(1.0, 0.5, 0.25));
    let (n, half) = (300, glam::DVec2::new(1.1, 0.6));
    let cell = 4.0 * half.x * half.y / (n * n) as f64;
    let (mut hits, mut worst_t, mut worst_n) = (0usize, 0f64, 0f64);
    for i in 0..n {
        for j in 0..n {
            let x = c.x - half.x + 2.0 * half.x * (i as f64 + 0.5) / n as f64;
            let y = c.y - half.y + 2.0 * half.y * (j as f64 + 0.5) / n as f64;
            let ray = Ray::new(Vec3::new(x as f32, y as f32, 10.0), -Vec3::Z);
            let (x, y) = (f64::from(ray.origin.x), f64::from(ray.origin.y));
            let rho2 = ((x - c.x) / axes.x).powi(2) + ((y - c.y) / axes.y).powi(2);
            let hit = s.intersect(&ray, f32::INFINITY);
            if rho2 > 1.0 - 1e-4 && rho2 < 1.0 + 1e-4 {
                continue; // on the silhouette either answer is right
            }
            assert_eq!(hit.is_some(), rho2 < 1.0, "ray at ({x}, {y}): ρ² = {rho2}");
            let Some(hit) = hit else { continue };
            hits += 1;
            let z = c.z + axes.z * (1.0 - rho2).sqrt();
            let t = 10.0 - z;
            worst_t = worst_t.max((f64::from(hit.hit.t) - t).abs());
            let normal = glam::DVec3::new(
                (x - c.x) / (axes.x * axes.x),
                (y - c.y) / (axes.y * axes.y),
                (z - c.z) / (axes.z * axes.z),
            )
            .normalize();
            if rho2 < 0.98 {
                worst_n = worst_n.max((hit.hit.n.as_dvec3() - normal).length());
            }
        }
    }
    // The silhouette is the ellipse of area π·a·b.
    let area = hits as f64 * cell;
    let exact = std::f64::consts::PI * axes.x * axes.y;
    println!("silhouette {area:.5} vs π·a·b = {exact:.5}; largest error in t {worst_t:e}, in the normal {worst_n:e}");
    assert!((area / exact - 1.0).abs() < 5e-3, "silhouette area {area} vs {exact}");
    assert!(worst_t < 1e-5, "t off by {worst_t}");
    assert!(worst_n < 1e-4, "normal off by {worst_n}");
}

#[test]
fn a_per_axis_scale_and_the_same_matrix_are_the_same_ellipsoid_bit_for_bit() {
    // Scale (2, 1, 1), a quarter turn about +z, a translation: R·S has the rows (0, −1, 0),
    // (2, 0, 0), (0, 0, 1), exactly.
    let written = "{ scale = [2.0, 1.0, 1.0], rotate = { axis = [0.0, 0.0, 1.0], angle = 90.0 }, translate = [0.5, 0.25, -1.0] }";
    let matrix =
        "{ matrix = [0.0, -1.0, 0.0, 0.5, 2.0, 0.0, 0.0, 0.25, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, 1.0] }";
    for shape in [
        "shape = \"sphere\"\ncenter = [0.25, 0.0, 0.125]\nradius = 0.5",
        "shape = \"bowl\"\ncenter = [0.0, 0.0, 0.25]\naxis = [1.0, 1.0, 0.0]\nradius = 1.0\nthickness = 0.125\nfill = 0.25",
        "shape = \"cylinder\"\nbase = [0.0, -0.5, 0.25]\naxis = [1.0, 0.5, 0.0]\nradius = 0.5\nheight = 1.25",
    ] {
        let a = scene(&object("glass", shape, written), None);
        let b = scene(&object("glass", shape, matrix), None);
        let what = shape.lines().next().unwrap();
        let (hits, _, _) = compare(&a, &b, &grid_rays(Vec3::new(0.5, 0.25, -1.0), 10.0, 1.5), None, true, what);
        println!("{what}: {hits} hits, bit-identical");
    }
}

#[test]
fn sheared_normals_are_unit_and_perpendicular_to_the_surface() {
    // Rays a small step to either side of a ray hit points whose differences are tangent to the
    // surface at the middle hit (central differences: to second order in the step), so the
    // normal there is perpendicular to them.
    for shape in [
        "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.75",
        "shape = \"cylinder\"\nbase = [0.0, -0.5, 0.0]\naxis = [0.3, 1.0, 0.2]\nradius = 0.5\nheight = 1.0\ncaps = false",
        "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.2, 0.3, 1.0]\nradius = 0.8",
    ] {
        let s = scene(&object("glass", shape, &format!("{{ matrix = {SHEAR} }}")), None);
        let centre = Vec3::new(0.25, -0.5, 0.5);
        let (mut checked, mut worst) = (0, 0f32);
        let step = 1e-3;
        for ray in grid_rays(centre, 6.0, 0.8) {
            let (side, up) = ray.dir.any_orthonormal_pair();
            let hits: Vec<_> = [Vec3::ZERO, side * step, -side * step, up * step, -up * step]
                .iter()
                .map(|&shift| s.intersect(&Ray::new(ray.origin + shift, ray.dir), f32::INFINITY))
                .collect();
            let [Some(a), Some(b), Some(c), Some(d), Some(e)] = hits.as_slice() else { continue };
            if [b, c, d, e].iter().any(|h| h.primitive != a.primitive) {
                continue;
            }
            let n = a.hit.n;
            assert!((n.length() - 1.0).abs() < 1e-6, "{shape}: |n| = {}", n.length());
            for tangent in [b.hit.p - c.hit.p, d.hit.p - e.hit.p] {
                // Near the silhouette the step along the surface grows long: skip those.
                if tangent.length() > 8.0 * step {
                    continue;
                }
                let cos = n.dot(tangent.normalize()).abs();
                worst = worst.max(cos);
                checked += 1;
            }
        }
        println!("{shape}: {checked} tangents, largest |cos(n, tangent)| {worst:e}");
        assert!(checked > 200, "{shape}: {checked}");
        assert!(worst < 1e-3, "{shape}: |cos| {worst}");
    }
}

#[test]
fn a_rotated_sphere_turns_its_texture() {
    // A quarter turn about +x carries the uv pole (+y, v = 1) to +z: the point facing a camera
    // on +z is the pole now, the sphere's equator before (v = 0.5).
    let shape = "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0";
    let turned =
        scene(&object("glass", shape, "{ rotate = { axis = [1.0, 0.0, 0.0], angle = 90.0 } }"), None);
    let plain = scene(&format!("[[objects]]\nmaterial = \"glass\"\n{shape}\n"), None);
    let ray = Ray::new(Vec3::new(0.0, 0.0, 10.0), -Vec3::Z);
    let uv = |s: &Scene| uv_of(s, &ray, &s.intersect(&ray, f32::INFINITY).unwrap());
    assert_eq!(uv(&plain).y, 0.5);
    assert_eq!(uv(&turned).y, 1.0);
    // The hits themselves are unchanged, bit for bit (only the texture frame turned).
    let rays = grid_rays(Vec3::ZERO, 8.0, 1.2);
    compare(&turned, &plain, &rays, None, false, "turned sphere");
    // An image on it: the renders differ, and the turned sphere's picture is the plain
    // sphere's seen by the camera turned back.
    let textures = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let textured = |transform: &str, camera: &str| {
        let text = format!(
            "[camera]\n{camera}\nresolution = [24, 24]\nfov = 30.0\n[render]\nambient = 1.0\n\
             [materials.grid]\ntype = \"diffuse\"\ntexture = {{ type = \"image\", file = \"textures/uv-grid.png\" }}\n\
             [[objects]]\nmaterial = \"grid\"\n{shape}\n{transform}\n"
        );
        let s = load_str(&text, "textured", Some(&textures)).unwrap_or_else(|e| panic!("{e}"));
        let integrator = vitrum::integrators::create("raycast").unwrap();
        let opts = vitrum::render::RenderOptions::for_method(&s, integrator.as_ref(), 1);
        vitrum::render::render(&s, integrator.as_ref(), &opts, &|_, _| {}).image
    };
    let front = "position = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 1.0, 0.0]";
    let plain_image = textured("", front);
    let turned_image = textured("transform = { rotate = { axis = [1.0, 0.0, 0.0], angle = 90.0 } }", front);
    let differing = plain_image.pixels.iter().zip(&turned_image.pixels).filter(|(a, b)| a != b).count();
    assert!(differing > 50, "only {differing} pixels differ");
    // Seen from above with −z up (the preimage of the front view under the quarter turn, lit
    // by the ambient light alone), the plain sphere shows what the turned one shows from the
    // front.
    let below = "position = [0.0, 5.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]";
    let from_below = textured("", below);
    let close = turned_image
        .pixels
        .iter()
        .zip(&from_below.pixels)
        .filter(|(a, b)| (**a - **b).abs().max_element() < 1e-3)
        .count();
    assert!(
        close >= turned_image.pixels.len() * 95 / 100,
        "{close} of {} pixels agree",
        turned_image.pixels.len()
    );
}

/// Glass under every kind of general map: an ellipsoid (per-axis scale and a turn), a sheared
/// bowl filled with water and a stretched drinking glass, over a diffuse floor lit by a quad
/// lamp and a point light.
fn ellipsoid_scene(resolution: u32) -> Scene {
    let text = format!(
        r#"
[camera]
position = [0.0, 1.0, 3.8]
look_at = [0.0, 0.8, 0.0]
fov = 39.0
resolution = [{resolution}, {resolution}]
[materials.white]
type = "diffuse"
color = 0.73
[materials.glass]
type = "dielectric"
ior = 1.5
[materials.lamp]
type = "diffuse"
emission = 4.0
[[objects]]
shape = "quad"
corner = [-1.0, 0.0, -1.0]
u = [0.0, 0.0, 2.0]
v = [2.0, 0.0, 0.0]
material = "white"
[[objects]]
shape = "quad"
corner = [-0.3, 1.99, -0.3]
u = [0.6, 0.0, 0.0]
v = [0.0, 0.0, 0.6]
material = "lamp"
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 0.3
material = "glass"
transform = {{ scale = [2.0, 1.0, 0.75], rotate = {{ axis = [0.0, 0.0, 1.0], angle = 30.0 }}, translate = [0.0, 1.0, 0.0] }}
[[objects]]
shape = "bowl"
center = [0.0, 0.0, 0.0]
radius = 0.3
thickness = 0.05
fill = 0.1
material = "glass"
transform = {{ matrix = [1.0, 0.3, 0.0, 0.5, 0.0, 0.6, 0.0, 0.3, 0.0, 0.0, 1.2, 0.0, 0.0, 0.0, 0.0, 1.0] }}
[[objects]]
shape = "drinking_glass"
base = [-0.6, 0.0, 0.0]
radius = 0.15
height = 0.5
wall = 0.02
bottom = 0.05
material = "glass"
transform = {{ scale = [1.0, 1.0, 2.0] }}
[[lights]]
type = "point"
position = [0.0, 1.8, 0.5]
intensity = 2.0
"#
    );
    load_str(&text, "ellipsoids", None).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_method_renders_ellipsoids_without_nan() {
    let scene = ellipsoid_scene(32);
    for method in ["raycast", "whitted", "ssaa", "distributed", "path", "light", "bpt", "ppm", "bpm", "vcm"] {
        // `render_with` asserts that every sample is finite.
        let image = common::render_with(&scene, method, 4, 7);
        let mean =
            image.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>() / image.pixels.len() as f64;
        println!("{method}: image mean {mean:.4}");
        assert!(mean > 0.0 && mean.is_finite(), "{method}: mean {mean}");
    }
}

#[test]
fn glass_ellipsoids_keep_the_white_furnace_white() {
    // Lossless glass under a white sky: every pixel's expectation is 1 (analytic normals: no
    // shading-normal loss). An ellipsoid and a sheared, filled bowl side by side.
    let text = format!(
        r#"
[camera]
position = [0.0, 0.0, 4.0]
look_at = [0.0, 0.0, 0.0]
fov = 30.0
resolution = [24, 24]
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 0.4
material = "glass"
transform = {{ scale = [1.5, 0.75, 1.0], rotate = {{ axis = [1.0, 1.0, 0.0], angle = 40.0 }}, translate = [-0.3, 0.2, 0.0] }}
[[objects]]
shape = "bowl"
center = [0.0, 0.0, 0.0]
radius = 0.3
thickness = 0.06
fill = 0.05
material = "glass"
transform = {{ matrix = {SHEAR} }}
[[lights]]
type = "environment"
radiance = 1.0
"#
    );
    let scene = load_str(&text, "furnace", None).unwrap_or_else(|e| panic!("{e}"));
    let (mean, error) = common::image_mean_and_error(&scene, "path", 16, 8);
    println!("path: {mean:.5} ± {error:.5}");
    assert!((mean - 1.0).abs() < 2e-3 && (mean - 1.0).abs() < 4.0 * error + 1e-4, "furnace {mean} ± {error}");
}

#[test]
fn the_wavefront_engine_renders_ellipsoids_lane_by_lane_to_the_scalar_bits() {
    use vitrum::integrators::{create, EngineOption};
    use vitrum::render::RenderOptions;
    let scene = ellipsoid_scene(20);
    let path = create("path").unwrap();
    let describe = |engine| {
        let mut opts = RenderOptions::for_method(&scene, path.as_ref(), 1);
        opts.params.engine = engine;
        path.engine(&scene, &opts).describe()
    };
    let auto = describe(EngineOption::Auto);
    // Elliptic shapes have no lane kernel: their hits and records go lane by lane, the rest of
    // every stage across lanes.
    assert!(auto.starts_with("wavefront") && auto.contains("no lane kernel"), "{auto}");
    let mut images = Vec::new();
    for engine in [EngineOption::Scalar, EngineOption::Wavefront] {
        let mut opts = RenderOptions::for_method(&scene, path.as_ref(), 4);
        opts.params.engine = engine;
        let (out, _) = vitrum::render::camera_pass(&scene, path.as_ref(), &opts, &|_, _| {});
        images.push(out.image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>());
    }
    assert_eq!(images[0], images[1], "the wavefront engine (through the BVH) renders other bits");
}

#[test]
fn a_rotated_textured_emitter_samples_points_with_the_uv_its_hits_get() {
    // The light's sampled points read the emission texture at the uv a ray's hit there gets: the
    // emitter's texture frame turns with the object as the shape's does.
    let textures = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for shape in [
        "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 0.5",
        "shape = \"disk\"\ncenter = [0.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\nradius = 0.5\ninner_radius = 0.1",
        // The wall and both caps of a closed cylinder.
        "shape = \"cylinder\"\nbase = [0.0, -0.3, 0.0]\naxis = [0.2, 1.0, 0.1]\nradius = 0.4\nheight = 0.6",
    ] {
        let text = format!(
            "{HEADER}[materials.poster]\ntype = \"diffuse\"\nemission = 1.0\n\
             emission_texture = {{ type = \"image\", file = \"textures/uv-grid.png\" }}\n\
             [[objects]]\nmaterial = \"poster\"\n{shape}\n\
             transform = {{ rotate = {{ axis = [1.0, 2.0, 0.5], angle = 63.0 }}, translate = [0.2, 0.1, 0.0] }}\n"
        );
        let s = load_str(&text, "emitter", Some(&textures)).unwrap_or_else(|e| panic!("{e}"));
        let Light::Surface { shape: emitter, .. } = &s.lights[0] else { panic!("not a surface light") };
        let mut checked = 0;
        for k in 0..400 {
            let u = glam::Vec2::new((k as f32 + 0.5) / 400.0, (k as f32 * 0.618_034).fract());
            let (p, n) = emitter.sample(u);
            let origin = p + n * 2.0;
            let ray = Ray::new(origin, (p - origin).normalize());
            let Some(hit) = s.intersect(&ray, f32::INFINITY) else { continue };
            let (a, b) = (emitter.uv_at(u, p, n), uv_of(&s, &ray, &hit));
            assert!(uv_distance(a, b) < 1e-3, "{shape}: sampled uv {a} vs hit uv {b} at {p}");
            checked += 1;
        }
        assert!(checked > 300, "{shape}: {checked}");
    }
}
