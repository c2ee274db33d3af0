//! Property test: random *valid* scenes — one to four spheres, quads, cylinders, disks and
//! hollow spheres at random places, diffuse (plain, checker, emissive), mirror and glass
//! materials (random constant, named and Abbe indices inside and outside, roughness from 0 and
//! 1e-8 up to 1, absorption), one or two point, quad, sphere or environment lights, sometimes a
//! thin lens, motion, spectral rendering, a camera inside an object; the whole scene in a unit
//! from 1e-6 to 1e6 — compile, and every integrator renders them at 8×8 with one or two samples
//! per pixel without panicking and with every sample and pixel finite.
//!
//! The scene is generated as TOML text and loaded through `scene::load_str`, so a failure
//! prints a scene file that reproduces it (`vitrum render failing.toml -i NAME`); proptest
//! shrinks it towards the smallest such scene. Deterministic by default (fixed seed, 400
//! cases, about a second); explore more with e.g. `PROPTEST_CASES=5000 PROPTEST_RNG_SEED=7
//! cargo test --release --test property`.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::fmt::Write;
use vitrum::integrators::{create, names};
use vitrum::render::{render, RenderOptions};
use vitrum::scene::load_str;

/// A point or vector.
type V3 = [f32; 3];

fn fmt3(v: V3) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

/// A refractive index as written in a scene file.
#[derive(Clone, Debug)]
enum Ior {
    Constant(f32),
    Named(&'static str),
    Abbe(f32, f32),
}

impl Ior {
    fn toml(&self) -> String {
        match self {
            Ior::Constant(n) => format!("{n:?}"),
            Ior::Named(name) => format!("{name:?}"),
            Ior::Abbe(n, v) => format!("{{ abbe = [{n:?}, {v:?}] }}"),
        }
    }
}

#[derive(Clone, Debug)]
enum Material {
    Diffuse { color: V3, checker: bool, emission: Option<f32> },
    Mirror { color: V3, roughness: f32 },
    Dielectric { ior: Ior, ior_outside: Ior, roughness: f32, absorption: V3 },
}

#[derive(Clone, Debug)]
enum Shape {
    Sphere { center: V3, radius: f32 },
    Quad { corner: V3, u: V3, v: V3 },
    Cylinder { base: V3, axis: V3, radius: f32, height: f32, caps: bool },
    Disk { center: V3, normal: V3, radius: f32, hole: f32 },
    HollowSphere { center: V3, radius: f32, wall: f32 },
}

#[derive(Clone, Debug)]
struct Object {
    shape: Shape,
    /// Index into the scene's materials (taken modulo their number).
    material: usize,
    velocity: Option<V3>,
}

#[derive(Clone, Debug)]
enum Light {
    Point { position: V3, intensity: f32 },
    Quad { corner: V3, u: V3, v: V3, radiance: f32 },
    Sphere { center: V3, radius: f32, radiance: f32 },
    Environment { radiance: f32 },
}

#[derive(Clone, Debug)]
struct Spec {
    /// Every position and length is multiplied by this (the scene's unit).
    scale: f32,
    eye: V3,
    fov: f32,
    lens: Option<(f32, f32)>,
    spp: u32,
    /// `None`: the integrator's default (256 for `path` and `light`).
    max_depth: Option<u32>,
    spectral: &'static str,
    materials: Vec<Material>,
    objects: Vec<Object>,
    lights: Vec<Light>,
}

impl Spec {
    /// The scene file.
    fn toml(&self) -> String {
        let k = self.scale;
        // Positions and lengths in the scene's unit; colours as they are.
        let p = |v: V3| fmt3(v.map(|x| x * k));
        let l = |x: f32| x * k;
        let mut s = String::new();
        let w = &mut s;
        writeln!(w, "[camera]\nposition = {}\nlook_at = [0.0, 0.0, 0.0]", p(self.eye)).unwrap();
        writeln!(w, "fov = {:?}\nresolution = [8, 8]", self.fov).unwrap();
        if let Some((aperture, focus)) = self.lens {
            writeln!(w, "aperture = {:?}\nfocus_distance = {:?}", l(aperture), l(focus)).unwrap();
        }
        writeln!(w, "[render]\nspp = {}", self.spp).unwrap();
        writeln!(w, "spectral = {:?}\nambient = 0.05", self.spectral).unwrap();
        if let Some(depth) = self.max_depth {
            // The scene's integrator (`whitted`) is the one `RenderOptions::from_scene` reads.
            writeln!(w, "[render.whitted]\nmax_depth = {depth}").unwrap();
        }
        for (i, m) in self.materials.iter().enumerate() {
            writeln!(w, "[materials.m{i}]").unwrap();
            match m {
                Material::Diffuse { color, checker, emission } => {
                    writeln!(w, "type = \"diffuse\"").unwrap();
                    if *checker {
                        let (c, size) = (fmt3(*color), l(0.3));
                        writeln!(
                            w,
                            "texture = {{ type = \"checker\", color1 = {c}, color2 = 0.2, size = {size:?} }}"
                        )
                        .unwrap();
                    } else {
                        writeln!(w, "color = {}", fmt3(*color)).unwrap();
                    }
                    if let Some(e) = emission {
                        writeln!(w, "emission = {e:?}").unwrap();
                    }
                }
                Material::Mirror { color, roughness } => {
                    writeln!(w, "type = \"mirror\"\ncolor = {}\nroughness = {roughness:?}", fmt3(*color))
                        .unwrap();
                }
                Material::Dielectric { ior, ior_outside, roughness, absorption } => {
                    writeln!(
                        w,
                        "type = \"dielectric\"\nior = {}\nior_outside = {}",
                        ior.toml(),
                        ior_outside.toml()
                    )
                    .unwrap();
                    // Absorption is per unit length.
                    let absorption = fmt3(absorption.map(|a| a / k));
                    writeln!(w, "roughness = {roughness:?}\nabsorption = {absorption}").unwrap();
                }
            }
        }
        for o in &self.objects {
            let m = o.material % self.materials.len();
            writeln!(w, "[[objects]]\nmaterial = \"m{m}\"").unwrap();
            // Emitters cannot move, and only spheres, quads and disks emit: an emitting
            // cylinder or hollow sphere becomes a sphere in the same place.
            let emits = matches!(self.materials[m], Material::Diffuse { emission: Some(_), .. });
            if let (Some(v), false) = (o.velocity, emits) {
                writeln!(w, "velocity = {}", p(v)).unwrap();
            }
            let shape = match (&o.shape, emits) {
                (Shape::Cylinder { base, radius, .. }, true) => {
                    Shape::Sphere { center: *base, radius: *radius }
                }
                (Shape::HollowSphere { center, radius, .. }, true) => {
                    Shape::Sphere { center: *center, radius: *radius }
                }
                (s, _) => s.clone(),
            };
            match shape {
                Shape::Sphere { center, radius } => {
                    writeln!(w, "shape = \"sphere\"\ncenter = {}\nradius = {:?}", p(center), l(radius))
                        .unwrap()
                }
                Shape::Quad { corner, u, v } => {
                    writeln!(w, "shape = \"quad\"\ncorner = {}\nu = {}\nv = {}", p(corner), p(u), p(v))
                        .unwrap()
                }
                Shape::Cylinder { base, axis, radius, height, caps } => writeln!(
                    w,
                    "shape = \"cylinder\"\nbase = {}\naxis = {}\nradius = {:?}\nheight = {:?}\ncaps = {caps}",
                    p(base),
                    fmt3(axis),
                    l(radius),
                    l(height)
                )
                .unwrap(),
                Shape::Disk { center, normal, radius, hole } => writeln!(
                    w,
                    "shape = \"disk\"\ncenter = {}\nnormal = {}\nradius = {:?}\ninner_radius = {:?}",
                    p(center),
                    fmt3(normal),
                    l(radius),
                    l(radius * hole)
                )
                .unwrap(),
                Shape::HollowSphere { center, radius, wall } => writeln!(
                    w,
                    "shape = \"hollow_sphere\"\ncenter = {}\nradius = {:?}\ninner_radius = {:?}",
                    p(center),
                    l(radius),
                    l(radius * (1.0 - wall))
                )
                .unwrap(),
            }
        }
        let mut environment = false;
        for light in &self.lights {
            match light {
                Light::Point { position, intensity } => {
                    // The same irradiance at any scale: intensity in W/sr grows with distance².
                    let intensity = intensity * k * k;
                    writeln!(
                        w,
                        "[[lights]]\ntype = \"point\"\nposition = {}\nintensity = {intensity:?}",
                        p(*position)
                    )
                    .unwrap()
                }
                Light::Quad { corner, u, v, radiance } => writeln!(
                    w,
                    "[[lights]]\ntype = \"quad\"\ncorner = {}\nu = {}\nv = {}\nradiance = {radiance:?}",
                    p(*corner),
                    p(*u),
                    p(*v)
                )
                .unwrap(),
                Light::Sphere { center, radius, radiance } => writeln!(
                    w,
                    "[[lights]]\ntype = \"sphere\"\ncenter = {}\nradius = {:?}\nradiance = {radiance:?}",
                    p(*center),
                    l(*radius)
                )
                .unwrap(),
                // At most one environment light.
                Light::Environment { radiance } if !environment => {
                    environment = true;
                    writeln!(w, "[[lights]]\ntype = \"environment\"\nradiance = {radiance:?}").unwrap()
                }
                Light::Environment { .. } => {}
            }
        }
        s
    }
}

fn coord() -> impl Strategy<Value = f32> {
    -1.0f32..1.0
}

fn point() -> impl Strategy<Value = V3> {
    [coord(), coord(), coord()]
}

/// A vector of length 0.2 … 1.7 (no component dominates zero length).
fn vector() -> impl Strategy<Value = V3> {
    point().prop_filter("not too short", |v| v.iter().map(|x| x * x).sum::<f32>() > 0.04)
}

/// Two edges that span a parallelogram (sine of their angle > 0.2).
fn edges() -> impl Strategy<Value = (V3, V3)> {
    (vector(), vector()).prop_filter("edges not parallel", |(u, v)| {
        let c = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
        let len = |a: &V3| a.iter().map(|x| x * x).sum::<f32>().sqrt();
        len(&c) > 0.2 * len(u) * len(v)
    })
}

fn colour() -> impl Strategy<Value = V3> {
    [0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0]
}

fn ior() -> impl Strategy<Value = Ior> {
    prop_oneof![
        4 => (1.0f32..2.5).prop_map(Ior::Constant),
        1 => prop::sample::select(vec!["bk7", "sf11", "water", "diamond", "f2", "fused-silica"]).prop_map(Ior::Named),
        1 => (1.3f32..2.0, 20.0f32..80.0).prop_map(|(n, v)| Ior::Abbe(n, v)),
    ]
}

/// Roughness 0 half the time (smooth surfaces take other code paths), else in (0, 1].
fn roughness() -> impl Strategy<Value = f32> {
    prop_oneof![Just(0.0f32), (-8.0f32..0.0).prop_map(|e| 10f32.powf(e)), 0.001f32..=1.0]
}

fn material() -> impl Strategy<Value = Material> {
    prop_oneof![
        (colour(), any::<bool>(), prop::option::weighted(0.2, 0.1f32..5.0))
            .prop_map(|(color, checker, emission)| Material::Diffuse { color, checker, emission }),
        (colour(), roughness()).prop_map(|(color, roughness)| Material::Mirror { color, roughness }),
        (
            ior(),
            prop_oneof![3 => Just(Ior::Constant(1.0)), 1 => ior()],
            roughness(),
            prop_oneof![Just([0.0; 3]), [0.0f32..5.0, 0.0f32..5.0, 0.0f32..5.0]]
        )
            .prop_map(|(ior, ior_outside, roughness, absorption)| Material::Dielectric {
                ior,
                ior_outside,
                roughness,
                absorption
            }),
    ]
}

fn shape() -> impl Strategy<Value = Shape> {
    prop_oneof![
        (point(), 0.001f32..1.0).prop_map(|(center, radius)| Shape::Sphere { center, radius }),
        (point(), edges()).prop_map(|(corner, (u, v))| Shape::Quad { corner, u, v }),
        (point(), vector(), 0.05f32..0.6, 0.05f32..1.5, any::<bool>()).prop_map(
            |(base, axis, radius, height, caps)| Shape::Cylinder { base, axis, radius, height, caps }
        ),
        (point(), vector(), 0.05f32..1.0, prop_oneof![Just(0.0f32), 0.1f32..0.9])
            .prop_map(|(center, normal, radius, hole)| Shape::Disk { center, normal, radius, hole }),
        (point(), 0.1f32..1.0, 0.05f32..0.9).prop_map(|(center, radius, wall)| Shape::HollowSphere {
            center,
            radius,
            wall
        }),
    ]
}

fn object() -> impl Strategy<Value = Object> {
    (shape(), 0usize..8, prop::option::weighted(0.2, point()))
        .prop_map(|(shape, material, velocity)| Object { shape, material, velocity })
}

fn light() -> impl Strategy<Value = Light> {
    // Lights around the objects, mostly above them.
    let around = [-2.0f32..2.0, 0.5f32..3.0, -2.0f32..2.0];
    prop_oneof![
        3 => (around.clone(), 0.5f32..20.0).prop_map(|(position, intensity)| Light::Point { position, intensity }),
        2 => (around.clone(), edges(), 0.5f32..20.0)
            .prop_map(|(corner, (u, v), radiance)| Light::Quad { corner, u, v, radiance }),
        2 => (around, 0.02f32..0.5, 0.5f32..20.0)
            .prop_map(|(center, radius, radiance)| Light::Sphere { center, radius, radiance }),
        1 => (0.05f32..2.0).prop_map(|radiance| Light::Environment { radiance }),
    ]
}

fn spec() -> impl Strategy<Value = Spec> {
    // The camera at 0.5 … 6 from the origin (at times inside an object), not straight above it (the
    // default up vector would be parallel to the view direction).
    let eye =
        [-1.0f32..1.0, -0.6f32..0.6, -1.0f32..1.0, 0.5f32..6.0].prop_filter_map("eye", |[x, y, z, d]| {
            let len = (x * x + y * y + z * z).sqrt();
            (len > 0.2 && (x * x + z * z).sqrt() > 0.3 * len).then(|| [x / len * d, y / len * d, z / len * d])
        });
    (
        prop::sample::select(vec![1.0f32, 1e-6, 1e-4, 1e-3, 0.01, 0.1, 10.0, 100.0, 1e3, 1e4, 1e6]),
        eye,
        20.0f32..90.0,
        prop::option::weighted(0.25, (0.001f32..0.3, 1.0f32..8.0)),
        1u32..=2,
        prop::option::weighted(0.8, 1u32..=12),
        prop::sample::select(vec!["auto", "on", "off"]),
        prop::collection::vec(material(), 1..=4),
        prop::collection::vec(object(), 1..=4),
        prop::collection::vec(light(), 1..=2),
    )
        .prop_map(|(scale, eye, fov, lens, spp, max_depth, spectral, materials, objects, lights)| Spec {
            scale,
            eye,
            fov,
            lens,
            spp,
            max_depth,
            spectral,
            materials,
            objects,
            lights,
        })
}

/// Fixed seed and case count unless `PROPTEST_RNG_SEED` / `PROPTEST_CASES` say otherwise.
fn config() -> ProptestConfig {
    let from_env = ProptestConfig::default();
    ProptestConfig {
        cases: if std::env::var_os("PROPTEST_CASES").is_some() { from_env.cases } else { 400 },
        rng_seed: if std::env::var_os("PROPTEST_RNG_SEED").is_some() {
            from_env.rng_seed
        } else {
            RngSeed::Fixed(0x7669_7472_756d)
        },
        ..from_env
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn random_valid_scenes_render_finite_with_every_integrator(spec in spec()) {
        let text = spec.toml();
        let scene = match load_str(&text, "random.toml", None) {
            Ok(scene) => scene,
            Err(e) => panic!("a valid scene was refused: {e}\n{text}"),
        };
        for name in names() {
            let integrator = create(name).unwrap();
            let opts = RenderOptions::from_scene(&scene, spec.spp);
            let out = render(&scene, integrator.as_ref(), &opts, &|_, _| {});
            prop_assert_eq!((out.image.width, out.image.height), (8, 8));
            prop_assert_eq!(
                out.non_finite_samples, 0,
                "{}: {} non-finite samples; scene:\n{}", name, out.non_finite_samples, text
            );
            prop_assert_eq!(
                out.image.non_finite_count(), 0,
                "{}: non-finite pixels; scene:\n{}", name, text
            );
        }
    }
}
