//! Mitsuba 3 XML export of a compiled scene (`vitrum export --format mitsuba`).
//!
//! `docs/mitsuba-export.md` has the full mapping table; in short:
//!
//! | vitrum | Mitsuba 3 |
//! |---|---|
//! | sphere | `sphere` |
//! | clipped sphere (a bowl's hemisphere), ellipsoid (Mitsuba 3 keeps spheres round) | `ply` mesh, smooth vertex normals |
//! | cylinder wall | `cylinder` (uncapped; caps are separate disks already) |
//! | disk / annulus | `disk` with `to_world` / flat `ply` ring |
//! | quad | `rectangle` with `to_world` |
//! | polygon, mesh triangles | flat `ply` mesh (`face_normals`); a mesh with OBJ `vn`: smooth vertex normals; with `vt`: `u v` per vertex (Mitsuba's PLY keeps v) |
//! | diffuse | `twosided` + `diffuse` (a checker on an axis-aligned quad: `checkerboard`); a `one_sided` one a bare `diffuse` |
//! | image texture (diffuse colour, mirror tint) | `bitmap` of the linear texels as EXR, `raw`, `to_uv` per shape kind |
//! | mirror | `twosided` + `conductor` / `roughconductor` (`material="none"`, GGX, α = roughness²) |
//! | dielectric | `dielectric` / `roughdielectric`, `int_ior` = inside (opposite the normal), `ext_ior` = outside |
//! | thin_dielectric | `thindielectric`, `int_ior` = the slab's index, `ext_ior` = the index around it |
//! | plastic | `plastic` (one-sided both; a `two_sided` one in `twosided`), `diffuse_reflectance`, `specular_reflectance`, `int_ior`, `ext_ior`, `nonlinear` |
//! | rough_plastic | `roughplastic` (likewise), `distribution`, `alpha` and the plastic's parameters |
//! | absorption | `homogeneous` interior/exterior media (pure absorbers) with `volpath` |
//! | point / quad / sphere light | `point` / `rectangle` + `area` / `sphere` + `area` |
//! | emissive surface (two-sided) | its shape + one-sided `area` emitter |
//! | environment light / background | `constant` emitter; with a map `envmap` (the same texels) |
//! | camera | `perspective` (`thinlens` with an aperture), `fov_axis="y"`, `near_clip`, `hdrfilm` with the crop window, `rfilter` `box`/`tent`/`gaussian` |
//! | `max_depth` d (bounces) | `max_depth` d + 1 (path segments) |
//!
//! Numbers are written in the shortest form that reads back as the same `f32` (Mitsuba stores
//! single precision), so nothing is rounded on the way.

use super::ExtraFile;
use crate::geometry::{Disk, Polygon, Quad, Shape, Sphere};
use crate::image::Image;
use crate::light::EnvironmentMap;
use crate::light::Light;
use crate::material::{Bsdf, Material, Texture};
use crate::pixel_filter::FilterKind;
use crate::scene::{Primitive, Scene};
use crate::texture::{Filter, ImageMap, ImageTexture, Wrap};
use glam::{DAffine3, DVec3, Vec3};
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Segments around the full circle of tessellated curved surfaces (clipped spheres, annuli).
/// A chord deviates from its circle by r·(1 − cos(π/256)) ≈ 7.5e-5·r.
pub const SEGMENTS: usize = 256;

/// Offset vitrum's checker texture adds to `p / size` before taking the floor (see
/// [`Texture::eval`]); repeated here so the exported checkerboard has the same cell edges.
const CHECKER_BIAS: f64 = 1e-4;

/// Russian roulette depth written as the XML default `rr_depth` (Mitsuba's own default).
pub const RR_DEPTH: u32 = 5;

/// The Mitsuba integrator to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MitsubaIntegrator {
    /// Unidirectional path tracing: `path`, or `volpath` when glass absorbs (media need it).
    Path,
    /// Light tracing: `ptracer` (the counterpart of vitrum's `light`).
    Ptracer,
}

impl MitsubaIntegrator {
    /// Parse `path` or `ptracer`.
    pub fn from_name(name: &str) -> Option<MitsubaIntegrator> {
        match name {
            "path" => Some(MitsubaIntegrator::Path),
            "ptracer" => Some(MitsubaIntegrator::Ptracer),
            _ => None,
        }
    }
}

/// What to write besides the scene itself.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Samples per pixel (the XML default `spp`).
    pub spp: u32,
    /// vitrum's maximum depth in bounces (as `path` counts them); written as
    /// [`mitsuba_max_depth`] of it.
    pub max_depth: u32,
    /// The integrator.
    pub integrator: MitsubaIntegrator,
    /// Image size (width, height).
    pub resolution: (u32, u32),
    /// Folder, relative to the XML file, for mesh files (written with `/` in the XML).
    pub mesh_folder: String,
    /// Folder, relative to the XML file, for image files: textures and environment maps.
    pub texture_folder: String,
}

impl Options {
    /// The scene's own settings (samples, depth, resolution) with the `path` integrator: the
    /// depth of `[render.path] max_depth`, else the default depth of vitrum's `path`. Mesh files
    /// go to `{stem}-meshes/`, images to `{stem}-textures/`, `stem` being the XML file's name
    /// without `.xml`.
    pub fn from_scene(scene: &Scene, stem: &str) -> Options {
        let path = crate::integrators::create("path").expect("`path` is registered");
        Options {
            spp: scene.settings.spp,
            max_depth: scene.settings.max_depth(path.as_ref(), None),
            integrator: MitsubaIntegrator::Path,
            resolution: (scene.camera.width, scene.camera.height),
            mesh_folder: format!("{stem}-meshes"),
            texture_folder: format!("{stem}-textures"),
        }
    }
}

/// The result of an export: the XML text, the mesh and image files it refers to, and what did
/// not translate exactly (also written as comments at the top of the XML).
#[derive(Clone, Debug)]
pub struct MitsubaExport {
    /// The scene as Mitsuba 3 XML.
    pub xml: String,
    /// Mesh files (binary little-endian PLY) with paths relative to the XML file's folder.
    pub meshes: Vec<ExtraFile>,
    /// Image files (float32 linear RGB OpenEXR: image textures and the environment map) with
    /// paths relative to the XML file's folder.
    pub textures: Vec<ExtraFile>,
    /// Approximations and dropped features, one sentence each.
    pub notes: Vec<String>,
}

/// Mitsuba's `max_depth` for vitrum's `max_depth` d.
///
/// vitrum's `path` counts bounces (scattering events): the camera ray has depth 0, a path
/// scatters at most d times, and next-event estimation happens only at vertices that may still
/// scatter. Its longest path, camera → d surface vertices → light, has d + 1 segments; with
/// d = 0 only emitters seen directly contribute. Mitsuba's `max_depth` counts segments (1 =
/// emitters seen directly, 2 = direct lighting), so it is d + 1. (`whitted` also gathers direct
/// light at its deepest hit: its d corresponds to d + 2 segments.)
pub fn mitsuba_max_depth(max_depth: u32) -> u32 {
    max_depth.saturating_add(1)
}

/// Export a compiled scene as Mitsuba 3 XML.
pub fn export(scene: &Scene, opts: &Options) -> MitsubaExport {
    Exporter::new(scene, opts).run()
}

// ---------- XML writing ----------

/// Indented XML text.
#[derive(Default)]
struct Xml {
    out: String,
    depth: usize,
}

impl Xml {
    fn line(&mut self, text: &str) {
        for _ in 0..self.depth {
            self.out.push_str("    ");
        }
        self.out.push_str(text);
        self.out.push('\n');
    }

    fn tag(name: &str, attrs: &[(&str, &str)], end: &str) -> String {
        let mut s = format!("<{name}");
        for (k, v) in attrs {
            let _ = write!(s, " {k}=\"{}\"", escape_attr(v));
        }
        s.push_str(end);
        s
    }

    fn open(&mut self, name: &str, attrs: &[(&str, &str)]) {
        self.line(&Xml::tag(name, attrs, ">"));
        self.depth += 1;
    }

    fn close(&mut self, name: &str) {
        self.depth -= 1;
        self.line(&format!("</{name}>"));
    }

    fn leaf(&mut self, name: &str, attrs: &[(&str, &str)]) {
        self.line(&Xml::tag(name, attrs, "/>"));
    }

    fn comment(&mut self, text: &str) {
        self.line(&format!("<!-- {} -->", escape_comment(text)));
    }

    fn float(&mut self, name: &str, x: f32) {
        self.leaf("float", &[("name", name), ("value", &num(x))]);
    }

    fn integer(&mut self, name: &str, value: &str) {
        self.leaf("integer", &[("name", name), ("value", value)]);
    }

    fn string(&mut self, name: &str, value: &str) {
        self.leaf("string", &[("name", name), ("value", value)]);
    }

    fn boolean(&mut self, name: &str, value: bool) {
        self.leaf("boolean", &[("name", name), ("value", if value { "true" } else { "false" })]);
    }

    fn rgb(&mut self, name: &str, c: Vec3) {
        self.leaf("rgb", &[("name", name), ("value", &triple(c))]);
    }

    fn point(&mut self, name: &str, p: Vec3) {
        self.leaf("point", &[("name", name), ("x", &num(p.x)), ("y", &num(p.y)), ("z", &num(p.z))]);
    }

    fn vector(&mut self, name: &str, v: Vec3) {
        self.leaf("vector", &[("name", name), ("x", &num(v.x)), ("y", &num(v.y)), ("z", &num(v.z))]);
    }

    /// `<transform name=...><matrix/></transform>` for the affine map with the given images of
    /// the local x, y, z axes and origin.
    fn affine(&mut self, name: &str, x: DVec3, y: DVec3, z: DVec3, origin: DVec3) {
        let rows = [[x.x, y.x, z.x, origin.x], [x.y, y.y, z.y, origin.y], [x.z, y.z, z.z, origin.z]];
        let mut value = String::new();
        for row in rows {
            for v in row {
                let _ = write!(value, "{} ", num64(v));
            }
        }
        value.push_str("0 0 0 1");
        self.open("transform", &[("name", name)]);
        self.leaf("matrix", &[("value", &value)]);
        self.close("transform");
    }
}

/// A double as the shortest text that reads back to it (never `-0`): an affine map's entries
/// are sums of single-precision numbers, exact in double precision, so an import recovers the
/// single-precision corners and edges they came from.
fn num64(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x}")
    }
}

/// Escape text for a double-quoted attribute value.
fn escape_attr(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' => out.push_str("&#10;"),
            '\t' => out.push_str("&#9;"),
            c if (c as u32) < 0x20 => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// Make text safe inside `<!-- ... -->`: no `--`, no trailing `-`, no control characters.
fn escape_comment(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        let c = if (c as u32) < 0x20 { ' ' } else { c };
        if c == '-' && out.ends_with('-') {
            out.push(' ');
        }
        out.push(c);
    }
    if out.ends_with('-') {
        out.push(' ');
    }
    out
}

/// The shortest decimal that reads back as the same `f32` (exponent form for very small or
/// large magnitudes); never `-0`.
fn num(x: f32) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let a = x.abs();
    if (1e-4..1e9).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

fn triple(c: Vec3) -> String {
    format!("{}, {}, {}", num(c.x), num(c.y), num(c.z))
}

/// A name reduced to `[a-z0-9-]`, for ids and file names.
fn slug(name: &str) -> String {
    let mut s = String::new();
    for c in name.chars().flat_map(char::to_lowercase) {
        if c.is_ascii_alphanumeric() {
            s.push(c);
        } else if !s.is_empty() && !s.ends_with('-') {
            s.push('-');
        }
    }
    let s: String = s.trim_end_matches('-').chars().take(40).collect();
    s.trim_end_matches('-').to_string()
}

// ---------- meshes ----------

/// A triangle mesh for a PLY file.
#[derive(Default)]
struct Mesh {
    positions: Vec<Vec3>,
    /// Per-vertex shading normals (smooth surfaces); flat meshes use face normals.
    normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates (a mesh's `vt`), as vitrum reads them: Mitsuba's PLY
    /// loader keeps them as they are.
    uv: Option<Vec<glam::Vec2>>,
    faces: Vec<[u32; 3]>,
}

impl Mesh {
    /// Add a triangle, turned if needed so that its winding normal faces `outward`.
    fn triangle(&mut self, mut f: [u32; 3], outward: Vec3) {
        let p = |i: u32| self.positions[i as usize];
        if (p(f[1]) - p(f[0])).cross(p(f[2]) - p(f[0])).dot(outward) < 0.0 {
            f.swap(1, 2);
        }
        self.faces.push(f);
    }

    /// Binary little-endian PLY.
    fn to_ply(&self) -> Vec<u8> {
        let mut header = format!(
            "ply\nformat binary_little_endian 1.0\ncomment written by vitrum {}\nelement vertex {}\n\
             property float x\nproperty float y\nproperty float z\n",
            crate::VERSION,
            self.positions.len()
        );
        if self.normals.is_some() {
            header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
        }
        if self.uv.is_some() {
            header.push_str("property float u\nproperty float v\n");
        }
        let _ = write!(
            header,
            "element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
            self.faces.len()
        );
        let mut out = header.into_bytes();
        for (i, p) in self.positions.iter().enumerate() {
            for c in p.to_array() {
                out.extend_from_slice(&c.to_le_bytes());
            }
            if let Some(n) = &self.normals {
                for c in n[i].to_array() {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
            if let Some(uv) = &self.uv {
                for c in uv[i].to_array() {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        for f in &self.faces {
            out.push(3);
            for i in f {
                out.extend_from_slice(&i.to_le_bytes());
            }
        }
        out
    }
}

/// A right-handed orthonormal frame (t1, t2) around the unit `n`: t1 × t2 = n. Clipped spheres
/// and disks with the same axis get the same frame, so their tessellations share rim vertices.
fn frame(n: Vec3) -> (Vec3, Vec3) {
    let t1 = n.any_orthonormal_pair().0;
    (t1, n.cross(t1))
}

/// Point `k` of the circle of radius `rho` at height `z` along `axis` around `c`. Clipped
/// spheres and annuli both use this, so shared rims are bit-for-bit the same points.
fn ring_point(c: Vec3, (t1, t2): (Vec3, Vec3), axis: Vec3, rho: f32, z: f32, k: usize) -> Vec3 {
    let phi = std::f64::consts::TAU * (k % SEGMENTS) as f64 / SEGMENTS as f64;
    let (s, co) = (phi.sin() as f32, phi.cos() as f32);
    c + rho * (co * t1 + s * t2) + z * axis
}

/// The kept zone of a clipped sphere, `min_height <= (p − c)·axis <= max_height`, from the pole
/// at −axis (or the lower clipping circle) up to the upper clipping circle (or the pole at
/// +axis: a whole sphere), with outward vertex normals; `None` when nothing is kept.
fn sphere_zone(s: &Sphere, shift: Vec3) -> Option<Mesh> {
    let (c, r, axis) = (s.center() + shift, s.radius(), s.axis());
    let cos_max = (-(s.max_height() as f64) / r as f64).clamp(-1.0, 1.0);
    let cos_min = (-(s.min_height() as f64) / r as f64).clamp(-1.0, 1.0);
    if cos_max >= cos_min {
        return None;
    }
    let (theta_min, theta_max) = (cos_min.acos(), cos_max.acos());
    // A zone that starts (ends) at a pole is a fan around it; one at a circle is bands.
    let (pole, end_pole) = (theta_min == 0.0, cos_max == -1.0);
    let span = theta_max - theta_min;
    let rings = ((SEGMENTS as f64 / 2.0 * span / std::f64::consts::PI).ceil() as usize).max(4);
    let last = if end_pole { rings - 1 } else { rings };
    let fr = frame(axis);
    let mut mesh = Mesh { normals: Some(Vec::new()), ..Mesh::default() };
    let add = |mesh: &mut Mesh, p: Vec3, pole_normal: Vec3| {
        mesh.positions.push(p);
        mesh.normals.as_mut().expect("smooth mesh").push(((p - c) / r).normalize_or(pole_normal));
    };
    if pole {
        add(&mut mesh, c - r * axis, -axis);
    }
    let circle = |cos: f64| ((1.0 - cos * cos).max(0.0).sqrt(), cos);
    let first = if pole { 1 } else { 0 };
    for j in first..=last {
        let (sin, cos) = if j == rings {
            circle(cos_max)
        } else if j == 0 {
            circle(cos_min)
        } else {
            (theta_min + span * j as f64 / rings as f64).sin_cos()
        };
        let (rho, z) = ((r as f64 * sin) as f32, (-(r as f64) * cos) as f32);
        for k in 0..SEGMENTS {
            add(&mut mesh, ring_point(c, fr, axis, rho, z, k), -axis);
        }
    }
    let top = mesh.positions.len() as u32;
    if end_pole {
        add(&mut mesh, c + r * axis, axis);
    }
    // Vertex k of ring j (after the pole vertex, when there is one).
    let ring = |j: usize, k: usize| (first + (j - first) * SEGMENTS + k % SEGMENTS) as u32;
    for k in 0..SEGMENTS {
        if pole {
            let f = [0, ring(1, k), ring(1, k + 1)];
            let out = mesh.positions[f[1] as usize] - c;
            mesh.triangle(f, out);
        }
        for j in first..last {
            let (a, b, cc, d) = (ring(j, k), ring(j, k + 1), ring(j + 1, k + 1), ring(j + 1, k));
            let out = mesh.positions[a as usize] + mesh.positions[cc as usize] - 2.0 * c;
            mesh.triangle([a, b, cc], out);
            mesh.triangle([a, cc, d], out);
        }
        if end_pole {
            let f = [top, ring(last, k), ring(last, k + 1)];
            let out = mesh.positions[f[1] as usize] - c;
            mesh.triangle(f, out);
        }
    }
    Some(mesh)
}

/// `to_world` for a shape whose own frame has the images `columns` of the local axes and
/// `origin`, placed in the world by `map` (the identity for shapes not under a general map).
fn placed_frame(x: &mut Xml, map: &DAffine3, columns: [DVec3; 3], origin: DVec3) {
    let [a, b, c] = columns.map(|v| map.transform_vector3(v));
    x.affine("to_world", a, b, c, map.transform_point3(origin));
}

/// `mesh` placed by `map`: positions mapped, vertex normals by the inverse transpose (the
/// winding stays outward: the map does not mirror).
fn mapped(mut mesh: Mesh, map: DAffine3) -> Mesh {
    if map == DAffine3::IDENTITY {
        return mesh;
    }
    let normal_map = map.matrix3.inverse().transpose();
    for p in &mut mesh.positions {
        *p = map.transform_point3(p.as_dvec3()).as_vec3();
    }
    for n in mesh.normals.iter_mut().flatten() {
        *n = (normal_map * n.as_dvec3()).normalize().as_vec3();
    }
    mesh
}

/// An annulus as a flat ring of quads between its two circles (vertices on the circles).
fn annulus(d: &Disk, shift: Vec3) -> Mesh {
    let (c, n) = (d.center() + shift, d.normal());
    let fr = frame(n);
    let mut mesh = Mesh::default();
    for rho in [d.radius(), d.inner_radius()] {
        for k in 0..SEGMENTS {
            mesh.positions.push(ring_point(c, fr, n, rho, 0.0, k));
        }
    }
    for k in 0..SEGMENTS {
        let (a, b) = (k as u32, ((k + 1) % SEGMENTS) as u32);
        let (ai, bi) = (a + SEGMENTS as u32, b + SEGMENTS as u32);
        mesh.triangle([a, b, bi], n);
        mesh.triangle([a, bi, ai], n);
    }
    mesh
}

/// A convex polygon as a triangle fan.
fn polygon(p: &Polygon, shift: Vec3) -> Mesh {
    let mut mesh =
        Mesh { positions: p.vertices().into_iter().map(|v| v + shift).collect(), ..Mesh::default() };
    for i in 1..mesh.positions.len().saturating_sub(1) {
        mesh.triangle([0, i as u32, i as u32 + 1], p.normal());
    }
    mesh
}

// ---------- the scene ----------

/// A checker texture on an axis-aligned quad as Mitsuba's `checkerboard`: the `to_uv` scale and
/// offset, and the colours for Mitsuba's `color0` and `color1`.
struct CheckerMap {
    scale: (f64, f64),
    offset: (f64, f64),
    color0: Vec3,
    color1: Vec3,
}

/// The index and sign of the one non-zero component of `v`.
fn axis_aligned(v: Vec3) -> Option<(usize, f64)> {
    let nonzero: Vec<usize> = (0..3).filter(|&i| v[i] != 0.0).collect();
    match nonzero[..] {
        [i] => Some((i, v[i].signum() as f64)),
        _ => None,
    }
}

/// vitrum's world-space checker restricted to a quad whose edges are parallel to coordinate
/// axes, expressed in the quad's uv (Mitsuba's rectangle has uv = (a, b) of `corner + a·u + b·v`).
///
/// vitrum: colour1 where ⌊x/s + β⌋ + ⌊y/s + β⌋ + ⌊z/s + β⌋ is even. Mitsuba: color0 where
/// ⌊2u'⌋ + ⌊2v'⌋ is even, u' = `to_uv`(uv). With 2u' = σ_u (x_i/s + β) along the axis i of the
/// edge u (sign σ_u), ⌊2u'⌋ has the parity of the cell index along i, plus one if σ_u < 0; the
/// cell index across the plane is a constant. Exact up to the quad's own rounding.
fn checker_on_quad(q: &Quad, shift: Vec3, color1: Vec3, color2: Vec3, size: f32) -> Option<CheckerMap> {
    let (i, su) = axis_aligned(q.u())?;
    let (k, sv) = axis_aligned(q.v())?;
    if i == k {
        return None;
    }
    let m = 3 - i - k;
    let s = size as f64;
    let corner = (q.corner() + shift).as_dvec3();
    let along = |axis: usize, sign: f64, len: f32| {
        (len.abs() as f64 / (2.0 * s), sign * (corner[axis] / s + CHECKER_BIAS) / 2.0)
    };
    let (sx, tx) = along(i, su, q.u()[i]);
    let (sy, ty) = along(k, sv, q.v()[k]);
    let across = (corner[m] / s + CHECKER_BIAS).floor() as i64;
    let flips = (su < 0.0) as i64 + (sv < 0.0) as i64;
    let (color0, color1) =
        if (across + flips).rem_euclid(2) == 0 { (color1, color2) } else { (color2, color1) };
    Some(CheckerMap { scale: (sx, sy), offset: (tx, ty), color0, color1 })
}

/// How a Mitsuba shape's texture coordinates relate to vitrum's on the same surface: vitrum's
/// uv = `m` · Mitsuba's uv + `t` (rows of `m` give u and v). Each exported shape kind has a fixed
/// one, measured against Mitsuba 3.9 (docs/mitsuba-export.md, "Textures").
#[derive(Clone, Copy, Debug, PartialEq)]
struct UvFrame {
    m: [[f64; 2]; 2],
    t: [f64; 2],
}

impl UvFrame {
    /// `rectangle` with `to_world` [u/2, v/2, n, centre]: Mitsuba's uv is ((x + 1)/2, (y + 1)/2)
    /// of its local square, which is (a, b) of `corner + a·u + b·v`, vitrum's quad uv.
    /// `cylinder` with `to_world` [r·t₁, r·t₂, h·axis, base]: Mitsuba's (φ/2π from local x
    /// towards y, local z) is vitrum's (angle from t₁ towards t₂, height fraction).
    /// `disk` with `to_world` [r·t₁, r·t₂, n, centre]: Mitsuba's (radius fraction, φ/2π) is
    /// vitrum's.
    const SAME: UvFrame = UvFrame { m: [[1.0, 0.0], [0.0, 1.0]], t: [0.0, 0.0] };
    /// `sphere` with `to_world` [r·t₁, r·t₂, r·axis, centre]: Mitsuba's (φ/2π, θ/π from local
    /// +z) is vitrum's (u, 1 − v).
    const SPHERE: UvFrame = UvFrame { m: [[1.0, 0.0], [0.0, -1.0]], t: [0.0, 1.0] };
}

/// Mitsuba's `bitmap` `to_uv` for `image` on a shape with uv frame `frame`, as the images of
/// the uv axes x, y and of the origin (2-D, in the xy plane).
///
/// vitrum reads the image at st = uv·scale + offset, s from the left edge and t **up** from the
/// bottom edge; Mitsuba's bitmap reads the image at (x, y) with y **down** from the top row
/// (measured: uv (0, 0) is the top-left texel). So (x, y) = (s, 1 − t) with st from vitrum's uv,
/// itself `frame` of Mitsuba's uv.
fn bitmap_to_uv(image: &ImageTexture, frame: UvFrame) -> (DVec3, DVec3, DVec3) {
    let (su, sv) = (image.scale.x as f64, image.scale.y as f64);
    let (ou, ov) = (image.offset.x as f64, image.offset.y as f64);
    let UvFrame { m, t } = frame;
    let x = DVec3::new(su * m[0][0], -sv * m[1][0], 0.0);
    let y = DVec3::new(su * m[0][1], -sv * m[1][1], 0.0);
    let origin = DVec3::new(su * t[0] + ou, 1.0 - ov - sv * t[1], 0.0);
    (x, y, origin)
}

/// The texels of `map` as an image for Mitsuba's `bitmap`, which up-samples (with a tent
/// filter) images narrower or lower than 2 texels: such images get their one column or row
/// repeated, which reads the same under nearest and bilinear lookups and either wrap mode.
fn bitmap_texels(map: &ImageMap) -> Image {
    let (w, h) = (map.width.max(2), map.height.max(2));
    let mut image = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            image.pixels[y * w + x] = map.texel(x.min(map.width - 1), y.min(map.height - 1));
        }
    }
    image
}

/// vitrum's environment map as texels for Mitsuba's `envmap`, times `tint`.
///
/// Both read a map alike (bilinear between texels, columns at texel centres wrapping in u, the
/// first and last rows on the poles: see [`crate::light::environment_map`]), so the texels are
/// written as they are. Mitsuba refuses maps narrower than 2 texels or lower than 3; such a map
/// is written with the same radiance in every direction: its one column twice, its one row three
/// times, and a two-row map with the mean of its rows between them (on the equator, where
/// vitrum's map holds that mean).
fn envmap_texels(map: &ImageMap, tint: Vec3) -> Image {
    let (w, h) = (map.width.max(2), map.height.max(3));
    let mut image = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let x0 = x.min(map.width - 1);
            let texel = match map.height {
                1 => map.texel(x0, 0),
                2 if y == 1 => 0.5 * (map.texel(x0, 0) + map.texel(x0, 1)),
                2 => map.texel(x0, y / 2),
                _ => map.texel(x0, y),
            };
            image.pixels[y * w + x] = texel * tint;
        }
    }
    image
}

/// Everything that belongs to one exported shape element.
/// The round shapes carry their texture frame (pole or normal, tangents); disks and cylinders
/// also `map`, the general affine map an elliptic one applies to them (identity otherwise; an
/// ellipsoid is a mesh, since Mitsuba 3 keeps a sphere round under any `to_world`).
enum Geometry {
    Sphere { center: Vec3, radius: f32, frame: (Vec3, (Vec3, Vec3)) },
    Cylinder { p0: Vec3, p1: Vec3, radius: f32, frame: (Vec3, (Vec3, Vec3)), map: DAffine3 },
    Disk { center: Vec3, normal: Vec3, radius: f32, frame: (Vec3, Vec3), map: DAffine3 },
    Rectangle { corner: Vec3, u: Vec3, v: Vec3 },
    Mesh { mesh: Mesh, smooth: bool },
}

/// How to write a texture on one shape: the checkerboard on an axis-aligned quad, and the uv
/// frame of the shape kind (a mesh's PLY carries its texture coordinates when it has any: `None`
/// for one without).
struct TextureSite {
    checker: Option<CheckerMap>,
    uv: Option<UvFrame>,
    /// The object's name, for notes.
    object: String,
}

/// The material's colour texture when it varies over the surface (a diffuse colour or a
/// mirror tint).
fn varying_texture(m: &Material) -> Option<&Texture> {
    match &m.bsdf {
        Bsdf::Diffuse { albedo: t, .. } | Bsdf::Mirror { color: t, .. } if t.varies() => Some(t),
        _ => None,
    }
}

struct Exporter<'a> {
    scene: &'a Scene,
    opts: &'a Options,
    notes: Vec<String>,
    meshes: Vec<ExtraFile>,
    textures: Vec<ExtraFile>,
    /// Image files written so far: the map (by address) and its path in the XML.
    image_files: Vec<(*const ImageMap, String)>,
    /// Shared BSDFs referenced by shapes (material indices).
    used_materials: BTreeSet<usize>,
    /// Absorption coefficients of media, by id number.
    media: Vec<Vec3>,
    /// Whether absorption is exported as media (`volpath`).
    with_media: bool,
}

impl<'a> Exporter<'a> {
    fn new(scene: &'a Scene, opts: &'a Options) -> Exporter<'a> {
        Exporter {
            scene,
            opts,
            notes: Vec::new(),
            meshes: Vec::new(),
            textures: Vec::new(),
            image_files: Vec::new(),
            used_materials: BTreeSet::new(),
            media: Vec::new(),
            with_media: false,
        }
    }

    fn note(&mut self, text: String) {
        if !self.notes.contains(&text) {
            self.notes.push(text);
        }
    }

    fn object_name(&self, prim: &Primitive) -> String {
        self.scene.objects.get(prim.object as usize).map_or_else(|| "object".into(), |o| o.name.clone())
    }

    fn material_id(&self, index: usize) -> String {
        format!("mat{index}-{}", slug(&self.scene.materials[index].name))
    }

    fn run(mut self) -> MitsubaExport {
        let scene = self.scene;
        let used: BTreeSet<u32> = scene.primitives.iter().map(|p| p.material).collect();
        self.material_notes(&used);

        let mut shapes = Xml { depth: 1, ..Xml::default() };
        self.shapes(&mut shapes);
        let mut emitters = Xml { depth: 1, ..Xml::default() };
        self.emitters(&mut emitters);

        let s = &scene.settings;
        if s.ambient != Vec3::ZERO {
            self.note(format!(
                "the scene ambient ({}) is dropped: it is part of the empirical Phong model of raycast and whitted",
                triple(s.ambient)
            ));
        }
        self.note(
            "the empirical Phong terms of every material (k_a, k_d, k_s, h) are dropped: Mitsuba renders \
             the physical description only"
                .into(),
        );
        if let Some(r) = s.reflectance {
            self.note(format!(
                "the constant dielectric reflectance {r} (render.reflectance) is dropped: Mitsuba uses exact Fresnel"
            ));
        }

        let mut head = Xml { depth: 1, ..Xml::default() };
        self.head(&mut head);
        let mut defs = Xml { depth: 1, ..Xml::default() };
        self.definitions(&mut defs);

        let mut xml = Xml::default();
        xml.line("<?xml version=\"1.0\" encoding=\"utf-8\"?>");
        xml.comment(&format!(
            "Mitsuba 3 scene exported by vitrum {} from {} (hash {})",
            crate::VERSION,
            scene.origin.name,
            scene.origin.hash
        ));
        xml.comment(
            "Load with mi.load_file(path, spp=..., res=...) (width=..., height=... for non-square images), \
             then mi.render(scene). See docs/mitsuba-export.md for the mapping.",
        );
        for n in &self.notes {
            xml.comment(&format!("Not exact: {n}"));
        }
        xml.open("scene", &[("version", "3.0.0")]);
        xml.out.push_str(&head.out);
        xml.out.push_str(&defs.out);
        xml.out.push_str(&shapes.out);
        xml.out.push_str(&emitters.out);
        xml.close("scene");
        MitsubaExport { xml: xml.out, meshes: self.meshes, textures: self.textures, notes: self.notes }
    }

    /// Notes on materials that do not translate exactly, and whether media are needed.
    fn material_notes(&mut self, used: &BTreeSet<u32>) {
        let mut absorbs = false;
        for &i in used {
            let m = &self.scene.materials[i as usize];
            if let Bsdf::Dielectric { inside, outside, .. } = &m.bsdf {
                for (side, medium) in [("inside", inside), ("outside", outside)] {
                    if medium.ior.is_dispersive() {
                        self.note(format!(
                            "material `{}`: the dispersive index on its {side} is written as its nominal n_d = {} \
                             (Mitsuba 3 has no dispersion)",
                            m.name,
                            num(medium.ior.nominal())
                        ));
                    }
                }
                absorbs |= inside.absorption != Vec3::ZERO || outside.absorption != Vec3::ZERO;
            }
        }
        if absorbs {
            match self.opts.integrator {
                MitsubaIntegrator::Path => {
                    self.with_media = true;
                    self.note(
                        "absorbing glass: Beer-Lambert absorption is written as homogeneous media (pure absorbers, \
                         albedo 0) inside/outside the glass surfaces, rendered with volpath (path with media); \
                         volpath samples the absorption stochastically instead of weighting by the exact \
                         transmittance: same mean, more noise"
                            .into(),
                    );
                }
                MitsubaIntegrator::Ptracer => self.note(
                    "absorbing glass: absorption is dropped with ptracer (export with --integrator path to get \
                     volpath with media)"
                        .into(),
                ),
            }
        }
    }

    /// Defaults, integrator and sensor.
    fn head(&mut self, x: &mut Xml) {
        let (w, h) = self.opts.resolution;
        let mi_depth = mitsuba_max_depth(self.opts.max_depth);
        x.leaf("default", &[("name", "spp"), ("value", &self.opts.spp.to_string())]);
        if w == h {
            x.leaf("default", &[("name", "res"), ("value", &w.to_string())]);
        } else {
            x.leaf("default", &[("name", "width"), ("value", &w.to_string())]);
            x.leaf("default", &[("name", "height"), ("value", &h.to_string())]);
        }
        x.leaf("default", &[("name", "max_depth"), ("value", &mi_depth.to_string())]);
        x.leaf("default", &[("name", "rr_depth"), ("value", &RR_DEPTH.to_string())]);
        let seed = self.scene.settings.seed;
        if seed > u32::MAX as u64 {
            self.note(format!("the seed {seed} is written modulo 2^32 (Mitsuba's sampler seed is 32-bit)"));
        }
        x.leaf("default", &[("name", "seed"), ("value", &(seed & 0xffff_ffff).to_string())]);

        let kind = match self.opts.integrator {
            MitsubaIntegrator::Path if self.with_media => "volpath",
            MitsubaIntegrator::Path => "path",
            MitsubaIntegrator::Ptracer => "ptracer",
        };
        x.comment(&format!(
            "vitrum max_depth {} counts bounces (scattering events) as its path integrator does; \
             Mitsuba's max_depth counts path segments: {} = {} + 1",
            self.opts.max_depth, mi_depth, self.opts.max_depth
        ));
        x.open("integrator", &[("type", kind)]);
        x.integer("max_depth", "$max_depth");
        x.integer("rr_depth", "$rr_depth");
        x.close("integrator");

        let cam = &self.scene.camera;
        let lens = cam.has_lens();
        let reach = {
            let (lo, hi) = self.scene.bvh_stats.bounds;
            let far = (0..8)
                .map(|i| {
                    let corner = Vec3::new(
                        if i & 1 == 0 { lo.x } else { hi.x },
                        if i & 2 == 0 { lo.y } else { hi.y },
                        if i & 4 == 0 { lo.z } else { hi.z },
                    );
                    (corner - cam.position).length()
                })
                .fold(0.0f32, f32::max);
            if far.is_finite() && far > 0.0 {
                far
            } else {
                1.0
            }
        };
        if cam.shutter.1 > cam.shutter.0 && self.scene.primitives.iter().any(|p| p.velocity.is_some()) {
            self.note(format!(
                "motion blur: moving objects are written where they are at mid-shutter (t = {}) and render sharp \
                 (Mitsuba 3 shapes do not move)",
                num(0.5 * (cam.shutter.0 + cam.shutter.1))
            ));
        }
        x.open("sensor", &[("type", if lens { "thinlens" } else { "perspective" })]);
        x.string("fov_axis", "y");
        x.float("fov", cam.fov_degrees);
        if lens {
            x.float("aperture_radius", cam.aperture);
            x.float("focus_distance", cam.focus_distance);
        }
        if cam.near_clip > 0.0 {
            x.comment(
                "vitrum's near clip plane (along the view axis, as Mitsuba's); far clip beyond the scene",
            );
            x.float("near_clip", cam.near_clip);
            x.float("far_clip", (1e2 * reach).max(2.0 * cam.near_clip));
        } else {
            x.comment("clipping planes scaled to the scene: nothing in it is closer or farther");
            x.float("near_clip", 1e-4 * reach);
            x.float("far_clip", 1e2 * reach);
        }
        x.open("transform", &[("name", "to_world")]);
        // The point and up vector the scene gave: both renderers make the same frame of them.
        let (target, up) = cam.placement;
        x.leaf(
            "lookat",
            &[("origin", &triple(cam.position)), ("target", &triple(target)), ("up", &triple(up))],
        );
        x.close("transform");
        x.open("sampler", &[("type", "independent")]);
        x.integer("sample_count", "$spp");
        x.integer("seed", "$seed");
        x.close("sampler");
        x.open("film", &[("type", "hdrfilm")]);
        let (wv, hv) = if w == h { ("$res", "$res") } else { ("$width", "$height") };
        x.integer("width", wv);
        x.integer("height", hv);
        x.string("pixel_format", "rgb");
        x.string("component_format", "float32");
        let crop = cam.crop;
        if (crop.width, crop.height) != (cam.width, cam.height) {
            x.comment("the crop window: only these pixels are rendered");
            x.integer("crop_offset_x", &crop.x.to_string());
            x.integer("crop_offset_y", &crop.y.to_string());
            x.integer("crop_width", &crop.width.to_string());
            x.integer("crop_height", &crop.height.to_string());
        }
        match cam.filter.kind {
            FilterKind::Box => {
                x.comment("a one-pixel box filter: uniform sampling over each pixel's area, as vitrum");
                x.leaf("rfilter", &[("type", "box")]);
            }
            FilterKind::Tent { radius } => {
                x.comment("vitrum's tent filter (footprints cut at the film's edge: sample_border false)");
                x.open("rfilter", &[("type", "tent")]);
                x.float("radius", radius);
                x.close("rfilter");
            }
            FilterKind::Gaussian { stddev } => {
                x.comment(
                    "vitrum's Gaussian filter (footprints cut at the film's edge: sample_border false)",
                );
                x.open("rfilter", &[("type", "gaussian")]);
                x.float("stddev", stddev);
                x.close("rfilter");
            }
        }
        x.close("film");
        x.close("sensor");
    }

    /// Shared BSDFs and media, after the shapes that use them have been written.
    fn definitions(&mut self, x: &mut Xml) {
        for (i, sigma) in self.media.clone().into_iter().enumerate() {
            x.comment(&format!("absorption coefficient {} per scene unit (pure absorber)", triple(sigma)));
            x.open("medium", &[("type", "homogeneous"), ("id", &format!("medium{i}"))]);
            // Mitsuba reads an RGB sigma_t as a reflectance in [0, 1]: normalise it and scale.
            let scale = sigma.max_element();
            x.rgb("sigma_t", sigma / scale);
            x.float("scale", scale);
            x.rgb("albedo", Vec3::ZERO);
            x.close("medium");
        }
        for i in self.used_materials.clone() {
            let id = self.material_id(i);
            let m = &self.scene.materials[i];
            x.comment(&format!("material `{}`", m.name));
            self.bsdf(x, m, Some(&id), None);
        }
    }

    /// One BSDF element (with `id` when shared; `site` for a texture that varies, written inline
    /// in its shape).
    fn bsdf(&mut self, x: &mut Xml, m: &Material, id: Option<&str>, site: Option<&TextureSite>) {
        let with_id = |kind: &'static str| -> Vec<(&'static str, String)> {
            let mut a = vec![("type", kind.to_string())];
            if let Some(id) = id {
                a.push(("id", id.to_string()));
            }
            a
        };
        let open = |x: &mut Xml, attrs: Vec<(&'static str, String)>| {
            let refs: Vec<(&str, &str)> = attrs.iter().map(|(k, v)| (*k, v.as_str())).collect();
            x.open("bsdf", &refs);
        };
        match &m.bsdf {
            Bsdf::Diffuse { albedo, one_sided: true } => {
                // Mitsuba's diffuse is one-sided itself.
                open(x, with_id("diffuse"));
                self.texture(x, "reflectance", m, albedo, site);
                x.close("bsdf");
            }
            Bsdf::Diffuse { albedo, one_sided: false } => {
                open(x, with_id("twosided"));
                x.open("bsdf", &[("type", "diffuse")]);
                self.texture(x, "reflectance", m, albedo, site);
                x.close("bsdf");
                x.close("bsdf");
            }
            Bsdf::Mirror { color, roughness } => {
                open(x, with_id("twosided"));
                if *roughness > 0.0 {
                    x.open("bsdf", &[("type", "roughconductor")]);
                    x.string("distribution", "ggx");
                    x.float("alpha", roughness * roughness);
                } else {
                    x.open("bsdf", &[("type", "conductor")]);
                }
                x.string("material", "none");
                self.texture(x, "specular_reflectance", m, color, site);
                x.close("bsdf");
                x.close("bsdf");
            }
            Bsdf::Conductor(c) => {
                // vitrum's conductors reflect on both sides, Mitsuba's on the front only.
                open(x, with_id("twosided"));
                if c.is_rough() {
                    x.open("bsdf", &[("type", "roughconductor")]);
                    x.string("distribution", c.distribution.name());
                    x.float("alpha", c.alpha);
                } else {
                    x.open("bsdf", &[("type", "conductor")]);
                }
                // vitrum's own RGB values, so that an RGB variant renders exactly vitrum's index.
                if let Some(metal) = c.index.metal {
                    x.comment(&format!(
                        "metal {0}: vitrum's RGB of the spectrum Mitsuba's material=\"{0}\" reads",
                        metal.name
                    ));
                }
                if c.ior_outside != 1.0 {
                    x.comment("eta and k relative to the outside medium (vitrum's ior_outside)");
                }
                x.rgb("eta", c.index.eta / c.ior_outside);
                x.rgb("k", c.index.k / c.ior_outside);
                x.rgb("specular_reflectance", c.specular_reflectance);
                x.close("bsdf");
                x.close("bsdf");
            }
            Bsdf::Dielectric { inside, outside, roughness, distribution } => {
                let (n_in, n_out) = (inside.ior.nominal(), outside.ior.nominal());
                if n_in == n_out {
                    x.comment("an index-matched interface (the same index on both sides) lets light pass");
                    open(x, with_id("null"));
                } else if *roughness > 0.0 {
                    open(x, with_id("roughdielectric"));
                    x.string("distribution", distribution.name());
                    x.float("alpha", roughness * roughness);
                } else {
                    open(x, with_id("dielectric"));
                }
                if n_in != n_out {
                    x.comment(
                        "int_ior: the side opposite the surface normal; ext_ior: the side it points to",
                    );
                    x.float("int_ior", n_in);
                    x.float("ext_ior", n_out);
                }
                x.close("bsdf");
            }
            Bsdf::ThinDielectric { ior, ior_outside } => {
                open(x, with_id("thindielectric"));
                x.float("int_ior", *ior);
                x.float("ext_ior", *ior_outside);
                x.close("bsdf");
            }
            Bsdf::Plastic { diffuse, specular, ior, ior_outside, nonlinear, two_sided }
            | Bsdf::RoughPlastic { diffuse, specular, ior, ior_outside, nonlinear, two_sided, .. } => {
                // Mitsuba's plastics are one-sided: a two-sided one is wrapped in `twosided`.
                let plugin = if matches!(m.bsdf, Bsdf::Plastic { .. }) { "plastic" } else { "roughplastic" };
                if *two_sided {
                    open(x, with_id("twosided"));
                    x.open("bsdf", &[("type", plugin)]);
                } else {
                    open(x, with_id(plugin));
                }
                if let Bsdf::RoughPlastic { alpha, distribution, .. } = &m.bsdf {
                    x.string("distribution", distribution.name());
                    x.float("alpha", *alpha);
                }
                x.rgb("diffuse_reflectance", *diffuse);
                x.rgb("specular_reflectance", *specular);
                x.float("int_ior", *ior);
                x.float("ext_ior", *ior_outside);
                if *nonlinear {
                    x.boolean("nonlinear", true);
                }
                x.close("bsdf");
                if *two_sided {
                    x.close("bsdf");
                }
            }
            #[allow(unreachable_patterns)]
            other => {
                // New BSDF kinds: extend here.
                self.note(format!("material `{}`: {other:?} is written as black diffuse", m.name));
                open(x, with_id("diffuse"));
                x.rgb("reflectance", Vec3::ZERO);
                x.close("bsdf");
            }
        }
    }

    /// The colour property `name` of material `m` from `texture` (a constant, or a texture
    /// element when `site` says how to place it on its shape).
    fn texture(
        &mut self,
        x: &mut Xml,
        name: &str,
        m: &Material,
        texture: &Texture,
        site: Option<&TextureSite>,
    ) {
        let object = site.map_or("", |s| s.object.as_str());
        match texture {
            Texture::Constant(c) => x.rgb(name, *c),
            Texture::Checker { color1, color2, size } => match site.and_then(|s| s.checker.as_ref()) {
                Some(map) => {
                    x.comment(&format!(
                        "vitrum's 3-D checker (cells of {} scene units) on this axis-aligned quad, \
                         mapped exactly onto its uv",
                        num(*size)
                    ));
                    x.open("texture", &[("type", "checkerboard"), ("name", name)]);
                    x.rgb("color0", map.color0);
                    x.rgb("color1", map.color1);
                    x.affine(
                        "to_uv",
                        DVec3::new(map.scale.0, 0.0, 0.0),
                        DVec3::new(0.0, map.scale.1, 0.0),
                        DVec3::Z,
                        DVec3::new(map.offset.0, map.offset.1, 0.0),
                    );
                    x.close("texture");
                }
                None => {
                    self.note(format!(
                        "material `{}`: the 3-D world-space checker texture is written as its mean colour \
                         where it lies on anything but an axis-aligned quad (Mitsuba's checkerboard is \
                         uv-based)",
                        m.name
                    ));
                    x.comment("vitrum's 3-D checker texture, as its mean colour");
                    x.rgb(name, 0.5 * (*color1 + *color2));
                }
            },
            Texture::Image(image) => {
                let file = match site.and_then(|s| s.uv) {
                    Some(frame) => self.texture_file(&image.map).map(|f| (f, frame)),
                    None => {
                        self.note(format!(
                            "{object}: the image texture {} of material `{}` is written as the image's mean \
                             colour (the exported mesh has no texture coordinates)",
                            image.map.file, m.name
                        ));
                        None
                    }
                };
                let Some((file, frame)) = file else {
                    x.comment(&format!("image texture {}, as its mean colour", image.map.file));
                    x.rgb(name, texture.mean());
                    return;
                };
                x.comment(&format!(
                    "image texture {} ({}x{}, {}): its linear texels as float32 EXR (raw: no colour conversion); \
                     to_uv maps this shape's uv to vitrum's image coordinates (scale, offset, t up)",
                    image.map.file,
                    image.map.width,
                    image.map.height,
                    image.map.colorspace.name()
                ));
                x.open("texture", &[("type", "bitmap"), ("name", name)]);
                x.string("filename", &file);
                x.boolean("raw", true);
                x.string(
                    "filter_type",
                    match image.filter {
                        Filter::Nearest => "nearest",
                        Filter::Bilinear => "bilinear",
                    },
                );
                x.string(
                    "wrap_mode",
                    match image.wrap {
                        Wrap::Repeat => "repeat",
                        Wrap::Clamp => "clamp",
                    },
                );
                let (ux, uy, origin) = bitmap_to_uv(image, frame);
                x.affine("to_uv", ux, uy, DVec3::Z, origin);
                x.close("texture");
            }
            #[allow(unreachable_patterns)]
            other => {
                // New texture kinds: extend here.
                self.note(format!("material `{}`: texture {other:?} is written as grey 0.5", m.name));
                x.rgb(name, Vec3::splat(0.5));
            }
        }
    }

    /// The id of the medium with absorption `sigma`, added if new.
    fn medium(&mut self, sigma: Vec3) -> String {
        let i = match self.media.iter().position(|&m| m == sigma) {
            Some(i) => i,
            None => {
                self.media.push(sigma);
                self.media.len() - 1
            }
        };
        format!("medium{i}")
    }

    /// Store a mesh file and return its path as the XML refers to it.
    fn mesh_file(&mut self, name: &str, mesh: &Mesh) -> String {
        let base = slug(name);
        let file = format!("{:03}-{}.ply", self.meshes.len(), if base.is_empty() { "mesh" } else { &base });
        self.meshes.push(ExtraFile {
            path: PathBuf::from(&self.opts.mesh_folder).join(&file),
            contents: mesh.to_ply(),
        });
        format!("{}/{file}", self.opts.mesh_folder)
    }

    /// Store an image file (float32 linear RGB EXR) named after `name` and return its path as
    /// the XML refers to it; `None` (with a note) if it cannot be encoded.
    fn image_file(&mut self, name: &str, image: &Image) -> Option<String> {
        let base = slug(name);
        let file =
            format!("{:03}-{}.exr", self.textures.len(), if base.is_empty() { "image" } else { &base });
        let path = PathBuf::from(&self.opts.texture_folder).join(&file);
        match crate::output::exr::encode_exr_rgb(&path, image) {
            Ok(contents) => {
                self.textures.push(ExtraFile { path, contents });
                Some(format!("{}/{file}", self.opts.texture_folder))
            }
            Err(e) => {
                self.note(format!("{name}: the image could not be encoded ({e})"));
                None
            }
        }
    }

    /// The file of an image texture's texels, written once per map.
    fn texture_file(&mut self, map: &std::sync::Arc<ImageMap>) -> Option<String> {
        let key = std::sync::Arc::as_ptr(map);
        if let Some((_, path)) = self.image_files.iter().find(|(k, _)| *k == key) {
            return Some(path.clone());
        }
        let stem = std::path::Path::new(&map.file)
            .file_stem()
            .map_or_else(|| "texture".to_string(), |s| s.to_string_lossy().into_owned());
        let path = self.image_file(&stem, &bitmap_texels(map))?;
        self.image_files.push((key, path.clone()));
        Some(path)
    }

    /// Where a primitive is drawn: its position at mid-shutter.
    fn shift(&self, prim: &Primitive) -> Vec3 {
        let (open, close) = self.scene.camera.shutter;
        prim.velocity.map_or(Vec3::ZERO, |v| v * (0.5 * (open + close)))
    }

    /// Every primitive, in scene-object order; triangles of one object and material form one mesh.
    fn shapes(&mut self, x: &mut Xml) {
        let scene = self.scene;
        let mut order: Vec<usize> = (0..scene.primitives.len()).collect();
        // By object, each in the order it was compiled (an emitting mesh's triangles in its
        // file's order: the order its light picks them in; and the export compiles to the same
        // BVH).
        order.sort_by_key(|&i| (scene.primitives[i].object, scene.compile_rank(i as u32)));
        let mut done = vec![false; order.len()];
        for (pos, &i) in order.iter().enumerate() {
            if done[pos] {
                continue;
            }
            let prim = &scene.primitives[i];
            let shift = self.shift(prim);
            let name = self.object_name(prim);
            // An ellipsoid (elliptic disk, cylinder) is its object-space shape under `map`.
            let (shape, map, round_shift) = match &prim.shape {
                Shape::Affine(a) => (
                    a.object(),
                    DAffine3::from_mat3_translation(
                        a.linear().as_dmat3(),
                        (a.translation() + shift).as_dvec3(),
                    ),
                    Vec3::ZERO,
                ),
                other => (other, DAffine3::IDENTITY, shift),
            };
            let geometry = match shape {
                // Mitsuba 3 keeps a sphere round under any to_world: an ellipsoid is tessellated.
                Shape::Sphere(s) if s.is_clipped() || map != DAffine3::IDENTITY => {
                    match sphere_zone(s, round_shift) {
                        Some(mesh) => Geometry::Mesh { mesh: mapped(mesh, map), smooth: true },
                        None => continue,
                    }
                }
                Shape::Sphere(s) => Geometry::Sphere {
                    center: s.center() + round_shift,
                    radius: s.radius(),
                    frame: s.texture_frame(),
                },
                Shape::Cylinder(c) => Geometry::Cylinder {
                    p0: c.base() + round_shift,
                    p1: c.top() + round_shift,
                    radius: c.radius(),
                    frame: (c.axis(), c.texture_frame()),
                    map,
                },
                Shape::Disk(d) if d.inner_radius() > 0.0 => {
                    Geometry::Mesh { mesh: mapped(annulus(d, round_shift), map), smooth: false }
                }
                Shape::Disk(d) => Geometry::Disk {
                    center: d.center() + round_shift,
                    // As given (the import reads a unit one back unchanged).
                    normal: d.given_normal(),
                    radius: d.radius(),
                    frame: d.texture_frame(),
                    map,
                },
                Shape::Affine(_) => unreachable!("an affine shape holds a sphere, disk or cylinder"),
                Shape::Quad(q) => Geometry::Rectangle { corner: q.corner() + shift, u: q.u(), v: q.v() },
                Shape::Polygon(p) => Geometry::Mesh { mesh: polygon(p, shift), smooth: false },
                Shape::Triangle(_) => {
                    // All triangles of this object with this material (and this light: an
                    // emitting mesh is one light), as one mesh.
                    let mut mesh = Mesh::default();
                    // Corners' shading normals (OBJ `vn`), the face's where a triangle has none.
                    let mut normals = Vec::new();
                    let mut smooth = false;
                    // Corners' texture coordinates (OBJ `vt`), the barycentric ones vitrum gives
                    // a triangle without them ((0, 0), (1, 0), (0, 1)).
                    let mut uvs = Vec::new();
                    let mut textured = false;
                    for (later, &j) in order.iter().enumerate().skip(pos) {
                        let other = &scene.primitives[j];
                        if other.object != prim.object
                            || other.material != prim.material
                            || other.light != prim.light
                        {
                            continue;
                        }
                        if let Shape::Triangle(t) = &other.shape {
                            let base = mesh.positions.len() as u32;
                            mesh.positions.extend(t.vertices().map(|v| v + shift));
                            mesh.faces.push([base, base + 1, base + 2]);
                            let face = t.normal();
                            match scene.vertex_attributes(j as u32).and_then(|a| a.normals) {
                                Some(ns) => {
                                    smooth = true;
                                    // Written as stored (unit already), so that they read back
                                    // to the same bits; a zero one as the face's.
                                    normals.extend(ns.map(|n| {
                                        let n = if n.length_squared() > 0.0 { n } else { face };
                                        if n.dot(face) < 0.0 {
                                            -n
                                        } else {
                                            n
                                        }
                                    }));
                                }
                                None => normals.extend([face; 3]),
                            }
                            match scene.vertex_attributes(j as u32).and_then(|a| a.uv) {
                                Some(uv) => {
                                    textured = true;
                                    uvs.extend(uv);
                                }
                                None => uvs.extend([glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y]),
                            }
                            done[later] = true;
                        }
                    }
                    if smooth {
                        mesh.normals = Some(normals);
                    }
                    if textured {
                        mesh.uv = Some(uvs);
                    }
                    Geometry::Mesh { mesh, smooth }
                }
            };
            self.shape(x, prim, &name, geometry, shift);
        }
    }

    /// One `<shape>` with its BSDF, emitter and media.
    fn shape(&mut self, x: &mut Xml, prim: &Primitive, name: &str, geometry: Geometry, shift: Vec3) {
        let material = &self.scene.materials[prim.material as usize];
        let texture = varying_texture(material);
        // Spheres and cylinders are placed by a frame only when an image needs their uv.
        let image = matches!(texture, Some(Texture::Image(_)));
        let mut checker = None;
        let uv = match &geometry {
            Geometry::Sphere { center, radius, frame: (axis, (t1, t2)) } => {
                x.comment(&format!("{name}: sphere"));
                x.open("shape", &[("type", "sphere")]);
                if image {
                    x.comment("to_world [r·t1, r·t2, r·axis, centre]: Mitsuba's uv (φ/2π, θ/π) is vitrum's (u, 1 − v)");
                    let r = *radius as f64;
                    placed_frame(
                        x,
                        &DAffine3::IDENTITY,
                        [t1.as_dvec3() * r, t2.as_dvec3() * r, axis.as_dvec3() * r],
                        center.as_dvec3(),
                    );
                } else {
                    x.point("center", *center);
                    x.float("radius", *radius);
                }
                Some(UvFrame::SPHERE)
            }
            Geometry::Cylinder { p0, p1, radius, frame: (axis, (t1, t2)), map } => {
                x.comment(&format!("{name}: cylinder wall (Mitsuba's cylinder has no caps; caps are disks)"));
                x.open("shape", &[("type", "cylinder")]);
                // Mitsuba's cylinder from p0 to p1 has the texture (and sampling) frame of its
                // axis that vitrum's has by default; another frame goes in the to_world.
                let default_frame = (*t1, *t2) == crate::geometry::texture_frame(*axis);
                if image || *map != DAffine3::IDENTITY || !default_frame {
                    x.comment("to_world [r·t1, r·t2, p1 − p0, p0]: Mitsuba's uv (φ/2π, height fraction) is vitrum's");
                    // t1 and t2 normalised in double precision and the end points' difference
                    // exact, so that the import reads back the same radius, frame and end points.
                    let r = *radius as f64;
                    let along = p1.as_dvec3() - p0.as_dvec3();
                    placed_frame(
                        x,
                        map,
                        [t1.as_dvec3().normalize() * r, t2.as_dvec3().normalize() * r, along],
                        p0.as_dvec3(),
                    );
                } else {
                    x.point("p0", *p0);
                    x.point("p1", *p1);
                    x.float("radius", *radius);
                }
                Some(UvFrame::SAME)
            }
            Geometry::Disk { center, normal, radius, frame: (t1, t2), map } => {
                x.comment(&format!("{name}: disk (Mitsuba's unit disk in the xy plane, normal +z)"));
                x.open("shape", &[("type", "disk")]);
                // vitrum's texture frame: Mitsuba's disk uv is then a fixed map of vitrum's.
                let r = *radius as f64;
                placed_frame(
                    x,
                    map,
                    [t1.as_dvec3() * r, t2.as_dvec3() * r, normal.as_dvec3()],
                    center.as_dvec3(),
                );
                Some(UvFrame::SAME)
            }
            Geometry::Rectangle { corner, u, v } => {
                x.comment(&format!(
                    "{name}: quad (Mitsuba's rectangle is [-1, 1]² in the xy plane, normal +z)"
                ));
                x.open("shape", &[("type", "rectangle")]);
                let (u, v) = (u.as_dvec3(), v.as_dvec3());
                let n = u.cross(v).normalize_or_zero();
                let centre = corner.as_dvec3() + 0.5 * (u + v);
                x.affine("to_world", 0.5 * u, 0.5 * v, n, centre);
                if let (Shape::Quad(q), Some(Texture::Checker { color1, color2, size })) =
                    (&prim.shape, texture)
                {
                    checker = checker_on_quad(q, shift, *color1, *color2, *size);
                }
                Some(UvFrame::SAME)
            }
            Geometry::Mesh { mesh, smooth } => {
                let what = match prim.shape {
                    Shape::Sphere(_) => "clipped sphere, tessellated (smooth vertex normals)",
                    Shape::Disk(_) => "annulus, tessellated",
                    Shape::Affine(_) => {
                        "ellipsoid, clipped sphere or annulus under an affine map, tessellated"
                    }
                    Shape::Polygon(_) => "convex polygon as a triangle fan",
                    _ => "triangle mesh",
                };
                x.comment(&format!("{name}: {what}, {} triangles", mesh.faces.len()));
                let file = self.mesh_file(name, mesh);
                x.open("shape", &[("type", "ply")]);
                x.string("filename", &file);
                x.boolean("face_normals", !smooth);
                // A PLY's uv is Mitsuba's as it is: the same frame as a rectangle's.
                mesh.uv.is_some().then_some(UvFrame::SAME)
            }
        };
        // A two-sided emissive sphere around the camera is seen from inside: emit inwards. A
        // cylinder facing inwards is Mitsuba's with flipped normals.
        let flip = match (prim.light.map(|l| &self.scene.lights[l as usize]), &prim.shape) {
            (Some(Light::Surface { one_sided: false, .. }), Shape::Sphere(s)) => {
                (self.scene.camera.position - s.center()).length() < s.radius()
            }
            (_, Shape::Cylinder(c)) => c.inward(),
            (_, Shape::Affine(a)) => matches!(a.object(), Shape::Cylinder(c) if c.inward()),
            _ => false,
        };
        if flip {
            x.boolean("flip_normals", true);
        }
        let m = material;
        if texture.is_some() {
            // A varying texture depends on the shape (its uv frame, a checker's cells): inline.
            let site = TextureSite { checker, uv, object: name.to_string() };
            self.bsdf(x, m, None, Some(&site));
        } else {
            self.used_materials.insert(prim.material as usize);
            x.leaf("ref", &[("id", &self.material_id(prim.material as usize))]);
        }
        if self.with_media {
            if let Bsdf::Dielectric { inside, outside, .. } = &m.bsdf {
                for (side, medium) in [("interior", inside), ("exterior", outside)] {
                    if medium.absorption != Vec3::ZERO {
                        let id = self.medium(medium.absorption);
                        x.leaf("ref", &[("name", side), ("id", &id)]);
                    }
                }
            }
        }
        if let Some(light) = prim.light {
            match &self.scene.lights[light as usize] {
                Light::Quad { radiance, .. } | Light::Sphere { radiance, .. } => {
                    x.comment("one-sided area emitter on the side the normal points to, as vitrum's");
                    x.open("emitter", &[("type", "area")]);
                    x.rgb("radiance", *radiance);
                    x.close("emitter");
                }
                Light::Surface { radiance, texture, one_sided, .. } => {
                    if !one_sided {
                        self.note(format!(
                            "{name}: vitrum's emissive surface emits on both sides, Mitsuba's area emitter on \
                             one: written emitting {}",
                            if flip { "inwards" } else { "along its normal" }
                        ));
                    }
                    let radiance = match texture {
                        Some(t) => {
                            self.note(format!("{name}: the emission texture is written as its mean colour"));
                            *radiance * t.mean()
                        }
                        None => *radiance,
                    };
                    x.comment(if *one_sided {
                        "emissive material: one-sided area emitter, as vitrum's emission_one_sided"
                    } else {
                        "emissive material: one-sided area emitter (vitrum's emits on both sides)"
                    });
                    x.open("emitter", &[("type", "area")]);
                    x.rgb("radiance", radiance);
                    x.close("emitter");
                }
                #[allow(unreachable_patterns)]
                other => {
                    // New emitting surfaces: extend here.
                    self.note(format!("{name}: the emission of light {other:?} is not exported"));
                }
            }
        }
        x.close("shape");
    }

    /// An environment map light as Mitsuba's `envmap`: the map's texels (see [`envmap_texels`])
    /// as a float32 EXR, the scale `radiance` (as `scale` when grey,
    /// else multiplied into the texels) and the rotation about +Y as `to_world`.
    fn envmap(&mut self, x: &mut Xml, radiance: Vec3, map: &EnvironmentMap) {
        let grey = radiance.x == radiance.y && radiance.y == radiance.z;
        let tint = if grey { Vec3::ONE } else { radiance };
        let texels = envmap_texels(map.image(), tint);
        let (w, h) = (map.image().width, map.image().height);
        if (texels.width, texels.height) != (w, h) {
            self.note(format!(
                "environment map {} ({w}x{h}): written {}x{} (Mitsuba's envmap needs at least 2x3 texels), \
                 the same radiance in every direction",
                map.image().file,
                texels.width,
                texels.height
            ));
        }
        let Some(file) = self.image_file("environment", &texels) else { return };
        x.comment(&format!(
            "environment map {} ({w}x{h}, the direction layout and bilinear lookup of Mitsuba's envmap, +Y up); \
             rotated {} degrees about +Y",
            map.image().file,
            num(map.rotation_degrees())
        ));
        x.open("emitter", &[("type", "envmap")]);
        x.string("filename", &file);
        x.float("scale", if grey { radiance.x } else { 1.0 });
        let (c, s) = map.rotation_cos_sin();
        let (c, s) = (f64::from(c), f64::from(s));
        x.affine("to_world", DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c), DVec3::ZERO);
        x.close("emitter");
    }

    /// Lights without a surface of their own, and the background.
    fn emitters(&mut self, x: &mut Xml) {
        for light in &self.scene.lights {
            match light {
                Light::Point { position, intensity } => {
                    x.comment("point light: intensity in W/sr");
                    x.open("emitter", &[("type", "point")]);
                    x.point("position", *position);
                    x.rgb("intensity", *intensity);
                    x.close("emitter");
                }
                Light::Spot { position, direction, intensity, beam } => {
                    x.comment("spot light: intensity in W/sr on the axis (local +z), angles in degrees");
                    x.open("emitter", &[("type", "spot")]);
                    x.rgb("intensity", *intensity);
                    x.float("cutoff_angle", beam.cutoff_degrees());
                    x.float("beam_width", beam.beam_width_degrees());
                    let frame = crate::bsdf::Frame::from_normal(*direction);
                    let d = |v: Vec3| v.as_dvec3();
                    x.affine("to_world", d(frame.s), d(frame.t), d(frame.n), d(*position));
                    x.close("emitter");
                }
                Light::Directional { direction, irradiance } => {
                    x.comment("directional light: irradiance in W/m² on a surface facing it");
                    x.open("emitter", &[("type", "directional")]);
                    x.vector("direction", *direction);
                    x.rgb("irradiance", *irradiance);
                    x.close("emitter");
                }
                // Written with their surface (the primitive that carries the light).
                Light::Quad { .. } | Light::Sphere { .. } | Light::Surface { .. } => {}
                Light::Environment { radiance, map: Some(map) } => self.envmap(x, *radiance, map),
                // The compiled scene's background is the environment's radiance: written below.
                Light::Environment { map: None, .. } => {}
                #[allow(unreachable_patterns)]
                other => {
                    // New light kinds: extend here.
                    self.note(format!("light {other:?} is not exported"));
                }
            }
        }
        let background = self.scene.settings.background;
        let map = self.scene.lights.iter().any(|l| matches!(l, Light::Environment { map: Some(_), .. }));
        // With a map the background is the map's mean radiance: the envmap is written instead.
        if background != Vec3::ZERO && !map {
            x.comment("environment light (render.background): radiance of every ray that leaves the scene");
            x.open("emitter", &[("type", "constant")]);
            x.rgb("radiance", background);
            x.close("emitter");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::texture_frame;

    #[test]
    fn numbers_read_back_exactly_and_never_as_negative_zero() {
        for x in [0.1f32, 1.52, 39.0, 1.0 / 3.0, 7.5e-5, 1e-30, 3.4e38, -0.42] {
            assert_eq!(num(x).parse::<f32>().unwrap(), x, "{}", num(x));
        }
        assert_eq!(num(-0.0), "0");
        assert_eq!(num(39.0), "39");
    }

    #[test]
    fn comments_and_attributes_are_escaped() {
        assert_eq!(escape_comment("a--b-"), "a- -b- ");
        assert!(!escape_comment("---").contains("--"));
        assert_eq!(escape_attr("<\"a\" & 'b'>"), "&lt;&quot;a&quot; &amp; &apos;b&apos;&gt;");
        assert_eq!(slug("Glass bowl (inner) #2"), "glass-bowl-inner-2");
    }

    #[test]
    fn depth_counts_segments() {
        assert_eq!(mitsuba_max_depth(0), 1);
        assert_eq!(mitsuba_max_depth(5), 6);
    }

    /// vitrum's checker and the exported checkerboard agree at random points of a floor and of a
    /// wall with a negative edge.
    #[test]
    fn checkerboard_matches_the_world_space_checker() {
        let (c1, c2) = (Vec3::ONE, Vec3::ZERO);
        let texture = Texture::Checker { color1: c1, color2: c2, size: 0.25 };
        let quads = [
            Quad::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 2.0), Vec3::new(2.0, 0.0, 0.0)),
            Quad::new(Vec3::new(1.0, 0.3, 0.9), Vec3::new(0.0, 0.0, -1.7), Vec3::new(0.0, 1.3, 0.0)),
            Quad::new(Vec3::new(0.6, 1.0, -0.4), Vec3::new(-1.1, 0.0, 0.0), Vec3::new(0.0, 0.0, -0.7)),
        ];
        for q in quads {
            let map = checker_on_quad(&q, Vec3::ZERO, c1, c2, 0.25).unwrap();
            for i in 0..40 {
                for j in 0..40 {
                    let (a, b) = ((i as f64 + 0.37) / 40.0, (j as f64 + 0.61) / 40.0);
                    let p = q.corner() + q.u() * a as f32 + q.v() * b as f32;
                    let (u, v) = (map.scale.0 * a + map.offset.0, map.scale.1 * b + map.offset.1);
                    let same = ((u - u.floor()) > 0.5) == ((v - v.floor()) > 0.5);
                    let mitsuba = if same { map.color0 } else { map.color1 };
                    assert_eq!(mitsuba, texture.eval(p, glam::Vec2::ZERO), "quad {q:?} at ({a}, {b})");
                }
            }
        }
    }

    /// Mitsuba 3's texture coordinates of a point `p` on a shape whose `to_world` has the
    /// columns `x`, `y`, `z` and origin `o` (sphere.cpp, disk.cpp, cylinder.cpp; measured with
    /// the `aov` integrator on 3.9.1).
    fn mitsuba_uv(kind: &str, p: Vec3, (x, y, z, o): (Vec3, Vec3, Vec3, Vec3)) -> (f64, f64) {
        let m = glam::Mat3::from_cols(x, y, z).inverse();
        let l = (m * (p - o)).as_dvec3();
        let phi = l.y.atan2(l.x).rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
        match kind {
            "sphere" => (phi, (l.z / l.length()).clamp(-1.0, 1.0).acos() / std::f64::consts::PI),
            "disk" => ((l.x * l.x + l.y * l.y).sqrt(), phi),
            "cylinder" => (phi, l.z),
            _ => ((l.x + 1.0) / 2.0, (l.y + 1.0) / 2.0),
        }
    }

    /// The uv frames turn Mitsuba's uv on the exported shape into vitrum's uv at the same point,
    /// for spheres, disks and cylinders with tilted axes and for quads.
    #[test]
    fn uv_frames_map_mitsubas_uv_to_vitrums() {
        use crate::geometry::{Cylinder, Ray};
        let apply = |f: UvFrame, (a, b): (f64, f64)| {
            (f.m[0][0] * a + f.m[0][1] * b + f.t[0], f.m[1][0] * a + f.m[1][1] * b + f.t[1])
        };
        let mut rng = rand_pcg::Pcg32::new(3, 5);
        use rand::RngExt;
        for _ in 0..200 {
            let axis = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let c = Vec3::new(0.3, -0.2, 0.5);
            let dir = -Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let (t1, t2) = texture_frame(axis);
            let circle = |a: f32| a.cos() * t1 + a.sin() * t2;
            // sphere of radius 0.7 around c with its pole along `axis`
            let sphere = Sphere::clipped(c, 0.7, axis, f32::INFINITY);
            let ray = Ray::new(c - 3.0 * dir, dir);
            let hit = sphere.surface(&ray, sphere.intersect(&ray, 0.0, 10.0).unwrap());
            let mi = mitsuba_uv("sphere", hit.p, (0.7 * t1, 0.7 * t2, 0.7 * axis, c));
            let (u, v) = apply(UvFrame::SPHERE, mi);
            assert!(
                (u - hit.uv.x as f64).abs() < 1e-4 && (v - hit.uv.y as f64).abs() < 1e-4,
                "sphere {mi:?} {}",
                hit.uv
            );
            // disk of radius 0.6 facing `axis`, hit at a random point
            let disk = Disk::new(c, axis, 0.6, 0.0);
            let q = c + 0.6
                * rng.random_range(0.05f32..0.95)
                * circle(rng.random_range(0.0..std::f32::consts::TAU)).normalize();
            let ray = Ray::new(q + axis, -axis);
            let hit = disk.surface(&ray, disk.intersect(&ray, 0.0, 10.0).unwrap());
            let mi = mitsuba_uv("disk", hit.p, (0.6 * t1, 0.6 * t2, axis, c));
            let (u, v) = apply(UvFrame::SAME, mi);
            assert!(
                (u - hit.uv.x as f64).abs() < 1e-4 && (v - hit.uv.y as f64).abs() < 1e-4,
                "disk {mi:?} {}",
                hit.uv
            );
            // cylinder wall of radius 0.4, height 1.3 along `axis`, hit from outside
            let cyl = Cylinder::new(c, axis, 0.4, 1.3);
            let side = circle(rng.random_range(0.0..std::f32::consts::TAU)).normalize();
            let q = c + rng.random_range(0.05f32..1.25) * axis + 0.4 * side;
            let ray = Ray::new(q + side, -side);
            let hit = cyl.surface(&ray, cyl.intersect(&ray, 0.0, 10.0).unwrap());
            let mi = mitsuba_uv("cylinder", hit.p, (0.4 * t1, 0.4 * t2, 1.3 * axis, c));
            let (u, v) = apply(UvFrame::SAME, mi);
            assert!(
                (u - hit.uv.x as f64).abs() < 1e-4 && (v - hit.uv.y as f64).abs() < 1e-4,
                "cylinder {mi:?} {}",
                hit.uv
            );
        }
    }

    /// A bitmap lookup through the exported `to_uv` reads the texel vitrum's lookup reads, for
    /// scaled, offset and clamped textures (Mitsuba's nearest lookup: texel ⌊x·W⌋, ⌊y·H⌋ with y
    /// down from the top row).
    #[test]
    fn bitmap_to_uv_reads_vitrums_texels() {
        use crate::texture::ColorSpace;
        let (w, h) = (5usize, 3usize);
        let texels = (0..w * h).map(|i| Vec3::new(i as f32, 0.0, 1.0)).collect();
        let map = std::sync::Arc::new(ImageMap {
            width: w,
            height: h,
            texels,
            file: "t".into(),
            colorspace: ColorSpace::Linear,
        });
        let mut rng = rand_pcg::Pcg32::new(9, 1);
        use rand::RngExt;
        for wrap in [Wrap::Repeat, Wrap::Clamp] {
            let image = ImageTexture {
                map: map.clone(),
                scale: glam::Vec2::new(1.7, 0.6),
                offset: glam::Vec2::new(-0.3, 0.45),
                wrap,
                filter: Filter::Nearest,
            };
            for frame in [UvFrame::SAME, UvFrame::SPHERE] {
                let (ux, uy, o) = bitmap_to_uv(&image, frame);
                for _ in 0..500 {
                    let (a, b) = (rng.random_range(0.0..1.0f64), rng.random_range(0.0..1.0f64));
                    let uv = glam::Vec2::new(
                        (frame.m[0][0] * a + frame.m[0][1] * b + frame.t[0]) as f32,
                        (frame.m[1][0] * a + frame.m[1][1] * b + frame.t[1]) as f32,
                    );
                    let (x, y) = (ux.x * a + uy.x * b + o.x, ux.y * a + uy.y * b + o.y);
                    let index = |c: f64, n: usize| match wrap {
                        Wrap::Repeat => ((c * n as f64).floor() as i64).rem_euclid(n as i64) as usize,
                        Wrap::Clamp => ((c * n as f64).floor() as i64).clamp(0, n as i64 - 1) as usize,
                    };
                    let (i, j) = (index(x, w), index(y, h));
                    // Points within roundoff of a texel edge may fall either way.
                    let near_edge = |c: f64, n: usize| ((c * n as f64) - (c * n as f64).round()).abs() < 1e-4;
                    if near_edge(x, w) || near_edge(y, h) {
                        continue;
                    }
                    assert_eq!(map.texel(i, j), image.lookup(uv), "{wrap:?} {frame:?} at ({a}, {b})");
                }
            }
        }
    }

    /// The environment map is written as it is (times the tint); maps below Mitsuba's 2x3 are
    /// padded so that Mitsuba's bilinear lookup of the padded map is vitrum's of the original.
    #[test]
    fn environment_maps_are_written_as_they_are_and_small_ones_padded_to_the_same_radiance() {
        use crate::texture::ColorSpace;
        let image = |w: usize, h: usize| {
            let texels = (0..w * h).map(|i| Vec3::new((i % 7) as f32, (i / w) as f32, 1.0)).collect();
            std::sync::Arc::new(ImageMap {
                width: w,
                height: h,
                texels,
                file: "sky".into(),
                colorspace: ColorSpace::Linear,
            })
        };
        let tint = Vec3::new(1.0, 2.0, 0.5);
        let sky = image(8, 4);
        let out = envmap_texels(&sky, tint);
        assert_eq!((out.width, out.height), (8, 4));
        assert!(out.pixels.iter().zip(&sky.texels).all(|(o, t)| *o == *t * tint));
        // Small maps: Mitsuba's reading of the padded texels (a vitrum map of them: the same
        // lookup) gives vitrum's radiance of the original in every direction.
        for (w, h) in [(1, 1), (1, 2), (3, 1), (3, 2), (1, 5)] {
            let small = image(w, h);
            let out = envmap_texels(&small, Vec3::ONE);
            assert_eq!((out.width, out.height), (w.max(2), h.max(3)), "{w}x{h}");
            let padded = ImageMap {
                width: out.width,
                height: out.height,
                texels: out.pixels.clone(),
                file: "padded".into(),
                colorspace: ColorSpace::Linear,
            };
            let (a, b) =
                (EnvironmentMap::new(small, 0.0), EnvironmentMap::new(std::sync::Arc::new(padded), 0.0));
            for k in 0..200 {
                let (phi, z) = (k as f32 * 2.399, 1.0 - (k as f32 + 0.5) / 100.0);
                let s = (1.0 - z * z).sqrt();
                let dir = Vec3::new(phi.sin() * s, z, -phi.cos() * s);
                let (x, y) = (a.radiance(dir), b.radiance(dir));
                assert!(
                    (x - y).abs().max_element() <= 1e-6 * x.max_element().max(1.0),
                    "{w}x{h} {dir}: {x} vs {y}"
                );
            }
        }
    }

    #[test]
    fn a_sphere_zone_starts_where_the_cap_below_it_ends() {
        // A bowl's inner wall split at a liquid level 0.15 below the rim.
        let (c, axis) = (Vec3::new(0.0, 0.5, 0.0), Vec3::Y);
        let cap = sphere_zone(&Sphere::clipped(c, 0.46, axis, -0.15), Vec3::ZERO).unwrap();
        let zone = sphere_zone(&Sphere::zone(c, 0.46, axis, -0.15, 0.0), Vec3::ZERO).unwrap();
        assert_eq!(cap.positions[cap.positions.len() - SEGMENTS..], zone.positions[..SEGMENTS]);
        let top = zone.positions[zone.positions.len() - SEGMENTS..].to_vec();
        assert!(top.iter().all(|p| (p.y - c.y).abs() < 1e-6), "the zone ends at the rim plane");
        for f in &zone.faces {
            let p = f.map(|i| zone.positions[i as usize]);
            assert!((p[1] - p[0]).cross(p[2] - p[0]).dot(p[0] + p[1] + p[2] - 3.0 * c) > 0.0);
        }
    }

    #[test]
    fn a_bowl_rim_shares_its_vertices_with_the_hemispheres() {
        let (c, axis) = (Vec3::new(0.1, 0.55, -0.1), Vec3::Y);
        let outer = sphere_zone(&Sphere::clipped(c, 0.55, axis, 0.0), Vec3::ZERO).unwrap();
        let inner = sphere_zone(&Sphere::clipped(c, 0.51, axis, 0.0), Vec3::ZERO).unwrap();
        let rim = annulus(&Disk::new(c, axis, 0.55, 0.51), Vec3::ZERO);
        let last = |m: &Mesh| m.positions[m.positions.len() - SEGMENTS..].to_vec();
        assert_eq!(last(&outer), rim.positions[..SEGMENTS]);
        assert_eq!(last(&inner), rim.positions[SEGMENTS..]);
        // every face of the zone faces away from the centre, every rim face along the axis
        for f in &outer.faces {
            let p = f.map(|i| outer.positions[i as usize]);
            assert!((p[1] - p[0]).cross(p[2] - p[0]).dot(p[0] + p[1] + p[2] - 3.0 * c) > 0.0);
            assert!(p.iter().all(|q| (*q - c).dot(axis) <= 1e-6));
        }
        for f in &rim.faces {
            let p = f.map(|i| rim.positions[i as usize]);
            assert!((p[1] - p[0]).cross(p[2] - p[0]).dot(axis) > 0.0);
        }
    }
}
