//! Readable descriptions of a compiled scene's materials, textures, media and lights, as text
//! and as JSON data with the same content (`vitrum info`, `vitrum info --json`).
//!
//! Each kind of thing has one function with one match arm per variant, which gives a
//! [`Description`]: its kind, the one-line text and the same facts as JSON fields. A new variant
//! (an image texture, an environment map) is one more arm.

use crate::dispersion::Ior;
use crate::light::{EmitterShape, Light};
use crate::material::{Bsdf, Material, Medium, Phong, Texture};
use crate::texture::{Filter, Wrap};
use glam::Vec3;
use serde_json::{json, Map, Value};

/// What something is, in words and as data.
#[derive(Clone, Debug, PartialEq)]
pub struct Description {
    /// The variant's name (`diffuse`, `checker`, `quad`, …).
    pub kind: &'static str,
    /// One line of text, starting with the kind.
    pub text: String,
    /// The same facts as JSON fields (without `kind` and `description`).
    pub fields: Map<String, Value>,
}

impl Description {
    fn new(kind: &'static str, text: String, fields: Value) -> Description {
        let Value::Object(fields) = fields else { unreachable!("the fields are a JSON object") };
        Description { kind, text, fields }
    }

    /// The JSON object: `kind`, `description` (the text) and the fields.
    pub fn json(&self) -> Value {
        let mut m = Map::new();
        m.insert("kind".into(), json!(self.kind));
        m.insert("description".into(), json!(self.text));
        m.extend(self.fields.clone());
        Value::Object(m)
    }
}

/// A number for JSON with the digits the text shows (f32's shortest round-trip form, not its
/// widened binary value: 1.8, not 1.7999999523).
fn num(x: impl std::borrow::Borrow<f32>) -> Value {
    let x = *x.borrow();
    format!("{x}").parse::<f64>().map_or(Value::Null, |v| json!(v))
}

/// A vector or colour for JSON, `[x, y, z]` as [`num`] writes each.
fn arr(v: impl std::borrow::Borrow<Vec3>) -> Value {
    let v = *v.borrow();
    json!([num(v.x), num(v.y), num(v.z)])
}

/// A vector or colour as `(x, y, z)`, shortest round-trip digits.
pub fn vec3(v: Vec3) -> String {
    format!("({}, {}, {})", v.x, v.y, v.z)
}

/// A refractive index: `1.52`, or a dispersive one with its name when it is a built-in glass
/// (`bk7 (dispersive: n_d 1.5168, Cauchy A 1.5046, B 4200 nm²)`).
pub fn ior(n: &Ior) -> (String, Value) {
    match *n {
        Ior::Constant(n) => (format!("{n}"), num(n)),
        Ior::Cauchy { a, b } => {
            let name = Ior::names().iter().find(|g| Ior::named(g).as_ref() == Some(n));
            let nd = n.nominal();
            let text = match name {
                Some(g) => format!("{g} (dispersive: n_d {nd}, Cauchy A {a}, B {b} nm²)"),
                None => format!("dispersive (n_d {nd}, Cauchy A {a}, B {b} nm²)"),
            };
            (text, json!({"name": name, "n_d": num(nd), "cauchy": [num(a), num(b)]}))
        }
    }
}

/// A medium: `ior 1.33`, with `absorption (r, g, b) per unit` when it absorbs.
pub fn medium(m: &Medium) -> (String, Value) {
    let (n, n_json) = ior(&m.ior);
    let text = if m.absorption == Vec3::ZERO {
        format!("ior {n}")
    } else {
        format!("ior {n}, absorption {} per unit", vec3(m.absorption))
    };
    (text, json!({"ior": n_json, "absorption": arr(m.absorption)}))
}

/// A colour's texture (a diffuse albedo, a mirror's tint).
pub fn texture(t: &Texture) -> Description {
    match t {
        Texture::Constant(c) => Description::new("constant", vec3(*c), json!({"color": arr(c)})),
        Texture::Checker { color1, color2, size } => Description::new(
            "checker",
            format!("checker {}/{} size {size}", vec3(*color1), vec3(*color2)),
            json!({"color1": arr(color1), "color2": arr(color2), "size": num(size)}),
        ),
        Texture::Image(t) => {
            let m = &t.map;
            let wrap = match t.wrap {
                Wrap::Repeat => "repeat",
                Wrap::Clamp => "clamp",
            };
            let filter = match t.filter {
                Filter::Bilinear => "bilinear",
                Filter::Nearest => "nearest",
            };
            Description::new(
                "image",
                format!(
                    "image {} ({}x{}, {}), scale ({}, {}), offset ({}, {}), {wrap}, {filter}",
                    m.file,
                    m.width,
                    m.height,
                    m.colorspace.name(),
                    t.scale.x,
                    t.scale.y,
                    t.offset.x,
                    t.offset.y
                ),
                json!({
                    "file": m.file, "width": m.width, "height": m.height, "colorspace": m.colorspace.name(),
                    "scale": [num(t.scale.x), num(t.scale.y)], "offset": [num(t.offset.x), num(t.offset.y)],
                    "wrap": wrap, "filter": filter,
                }),
            )
        }
    }
}

/// The Phong terms, `phong ka 1, kd 1, ks 0, h 1`.
fn phong(p: &Phong) -> (String, Value) {
    (
        format!("phong ka {}, kd {}, ks {}, h {}", p.ambient, p.diffuse, p.specular, p.shininess),
        json!({"ambient": num(p.ambient), "diffuse": num(p.diffuse), "specular": num(p.specular), "shininess": num(p.shininess)}),
    )
}

/// A material: `diffuse, checker (…)/(…) size 0.25`, `dielectric, inside ior 1.52, outside ior
/// 1, roughness 0`, followed by its Phong terms.
pub fn material(m: &Material) -> Description {
    let (phong_text, phong_json) = phong(&m.phong);
    let mut d = match &m.bsdf {
        Bsdf::Diffuse { albedo, one_sided } => {
            let t = texture(albedo);
            let sides = if *one_sided { ", one-sided" } else { "" };
            Description::new(
                "diffuse",
                format!("diffuse, {}{sides}", t.text),
                json!({"texture": t.json(), "one_sided": one_sided}),
            )
        }
        Bsdf::Mirror { color, roughness } => {
            let t = texture(color);
            Description::new(
                "mirror",
                format!("mirror, colour {}, roughness {roughness}", t.text),
                json!({"texture": t.json(), "roughness": num(roughness)}),
            )
        }
        Bsdf::Conductor(c) => {
            let source = c.index.metal.map_or("eta/k".to_string(), |m| format!("metal {}", m.name));
            let surface = if c.is_rough() {
                format!("{} alpha {}", c.distribution.name(), c.alpha)
            } else {
                "smooth".into()
            };
            Description::new(
                "conductor",
                format!(
                    "conductor, {source}, eta {}, k {}, outside ior {}, specular reflectance {}, {surface}; \
                     reflectance at normal incidence {}",
                    vec3(c.index.eta),
                    vec3(c.index.k),
                    c.ior_outside,
                    vec3(c.specular_reflectance),
                    vec3(c.normal_reflectance())
                ),
                json!({
                    "metal": c.index.metal.map(|m| m.name),
                    "eta": arr(c.index.eta),
                    "k": arr(c.index.k),
                    "ior_outside": num(c.ior_outside),
                    "specular_reflectance": arr(c.specular_reflectance),
                    "alpha": num(c.alpha),
                    "distribution": c.distribution.name(),
                    "normal_reflectance": arr(c.normal_reflectance()),
                }),
            )
        }
        Bsdf::Dielectric { inside, outside, roughness, distribution } => {
            let ((i, ij), (o, oj)) = (medium(inside), medium(outside));
            let mut d = Description::new(
                "dielectric",
                format!("dielectric, inside {i}, outside {o}, roughness {roughness}"),
                json!({"inside": ij, "outside": oj, "roughness": num(roughness)}),
            );
            if *distribution == crate::conductor::Distribution::Beckmann && *roughness > 0.0 {
                d.text = format!("{}, beckmann (alpha {})", d.text, roughness * roughness);
                d.fields.insert("distribution".into(), json!("beckmann"));
            }
            d
        }
        Bsdf::ThinDielectric { ior, ior_outside } => Description::new(
            "thin_dielectric",
            format!("thin dielectric slab, ior {ior}, outside ior {ior_outside}"),
            json!({"ior": num(ior), "ior_outside": num(ior_outside)}),
        ),
        Bsdf::Plastic { diffuse, specular, ior, ior_outside, nonlinear, two_sided } => Description::new(
            "plastic",
            format!(
                "plastic ({}), diffuse reflectance {}, specular reflectance {}, ior {ior}, outside ior \
                 {ior_outside}{}",
                if *two_sided { "two-sided" } else { "one-sided" },
                vec3(*diffuse),
                vec3(*specular),
                if *nonlinear { ", nonlinear" } else { "" }
            ),
            json!({
                "diffuse_reflectance": arr(diffuse),
                "specular_reflectance": arr(specular),
                "ior": num(ior),
                "ior_outside": num(ior_outside),
                "nonlinear": nonlinear,
                "two_sided": two_sided,
            }),
        ),
        Bsdf::RoughPlastic {
            diffuse, specular, ior, ior_outside, nonlinear, two_sided, alpha, distribution, ..
        } => Description::new(
            "rough_plastic",
            format!(
                "rough plastic ({}), {} (alpha {alpha}), diffuse reflectance {}, specular reflectance {}, ior \
                 {ior}, outside ior {ior_outside}{}",
                if *two_sided { "two-sided" } else { "one-sided" },
                distribution.name(),
                vec3(*diffuse),
                vec3(*specular),
                if *nonlinear { ", nonlinear" } else { "" }
            ),
            json!({
                "diffuse_reflectance": arr(diffuse),
                "specular_reflectance": arr(specular),
                "ior": num(ior),
                "ior_outside": num(ior_outside),
                "nonlinear": nonlinear,
                "two_sided": two_sided,
                "alpha": num(alpha),
                "distribution": distribution.name(),
            }),
        ),
    };
    d.text = format!("{}; {phong_text}", d.text);
    d.fields.insert("phong".into(), phong_json);
    d
}

/// Which sides of an emitting surface emit, in words.
fn sides(one_sided: bool) -> &'static str {
    if one_sided {
        "on the side its normal points to"
    } else {
        "on both sides"
    }
}

/// The geometry of an emitting object.
fn emitter_shape(s: &EmitterShape) -> (String, Value) {
    match s {
        EmitterShape::Sphere { center, radius, .. } => (
            format!("sphere, centre {}, radius {radius}", vec3(*center)),
            json!({"shape": "sphere", "center": arr(center), "radius": num(radius)}),
        ),
        EmitterShape::Quad { corner, u, v } => (
            format!("quad, corner {}, u {}, v {}", vec3(*corner), vec3(*u), vec3(*v)),
            json!({"shape": "quad", "corner": arr(corner), "u": arr(u), "v": arr(v)}),
        ),
        EmitterShape::Disk { center, normal, radius, inner_radius, .. } => (
            format!(
                "disk, centre {}, normal {}, radius {radius}, inner radius {inner_radius}",
                vec3(*center),
                vec3(*normal)
            ),
            json!({"shape": "disk", "center": arr(center), "normal": arr(normal),
                   "radius": num(radius), "inner_radius": num(inner_radius)}),
        ),
        EmitterShape::Cylinder { base, axis, radius, height, caps, inward, .. } => (
            format!(
                "cylinder, base {}, axis {}, radius {radius}, height {height}, {}{}",
                vec3(*base),
                vec3(*axis),
                if caps.is_some() { "with caps" } else { "open (no caps)" },
                if *inward { ", facing inwards" } else { "" }
            ),
            json!({"shape": "cylinder", "base": arr(base), "axis": arr(axis), "radius": num(radius),
                   "height": num(height), "caps": caps.is_some(), "inward": inward}),
        ),
        EmitterShape::Mesh(mesh) => (
            format!("mesh of {} triangles, area {}", mesh.len(), mesh.area()),
            json!({"shape": "mesh", "triangles": mesh.len(), "area": num(mesh.area())}),
        ),
        EmitterShape::Affine(a) => {
            let (text, object) = emitter_shape(&a.object);
            let rows = a.linear.transpose().to_cols_array_2d();
            (
                format!("{text} under the affine map {:?} + {}, area {}", rows, vec3(a.translate), s.area()),
                json!({"shape": "affine", "object": object, "linear": rows,
                       "translate": arr(a.translate), "area": num(s.area())}),
            )
        }
    }
}

/// A light: `point at (…), intensity (…) W/sr`, `quad, corner (…), …, radiance (…) W/(m²·sr)`.
pub fn light(l: &Light) -> Description {
    match l {
        Light::Point { position, intensity } => Description::new(
            "point",
            format!("point at {}, intensity {} W/sr", vec3(*position), vec3(*intensity)),
            json!({"position": arr(position), "intensity": arr(intensity)}),
        ),
        Light::Spot { position, direction, intensity, beam } => Description::new(
            "spot",
            format!(
                "spot at {}, towards {}, intensity {} W/sr on the axis, cutoff {}°, beam width {}°",
                vec3(*position),
                vec3(*direction),
                vec3(*intensity),
                num(beam.cutoff_degrees()),
                num(beam.beam_width_degrees())
            ),
            json!({"position": arr(position), "direction": arr(direction), "intensity": arr(intensity),
                   "cutoff_angle": num(beam.cutoff_degrees()), "beam_width": num(beam.beam_width_degrees())}),
        ),
        Light::Directional { direction, irradiance } => Description::new(
            "directional",
            format!(
                "directional, travelling along {}, irradiance {} W/m²",
                vec3(*direction),
                vec3(*irradiance)
            ),
            json!({"direction": arr(direction), "irradiance": arr(irradiance)}),
        ),
        Light::Quad { corner, u, v, normal, radiance } => Description::new(
            "quad",
            format!(
                "quad, corner {}, u {}, v {}, emitting towards {}, radiance {} W/(m²·sr)",
                vec3(*corner),
                vec3(*u),
                vec3(*v),
                vec3(*normal),
                vec3(*radiance)
            ),
            json!({"corner": arr(corner), "u": arr(u), "v": arr(v),
                   "normal": arr(normal), "radiance": arr(radiance)}),
        ),
        Light::Sphere { center, radius, radiance } => Description::new(
            "sphere",
            format!(
                "sphere, centre {}, radius {radius}, radiance {} W/(m²·sr)",
                vec3(*center),
                vec3(*radiance)
            ),
            json!({"center": arr(center), "radius": num(radius), "radiance": arr(radiance)}),
        ),
        Light::Surface { shape, radiance, texture: None, one_sided } => {
            let (s, sj) = emitter_shape(shape);
            Description::new(
                "surface",
                format!(
                    "emitting surface: {s}, radiance {} W/(m²·sr) {}",
                    vec3(*radiance),
                    sides(*one_sided)
                ),
                json!({"geometry": sj, "radiance": arr(radiance), "one_sided": one_sided}),
            )
        }
        Light::Surface { shape, radiance, texture: Some(t), one_sided } => {
            let ((s, sj), t) = (emitter_shape(shape), texture(t));
            Description::new(
                "surface",
                format!(
                    "emitting surface: {s}, radiance {} × {} W/(m²·sr) {}",
                    vec3(*radiance),
                    t.text,
                    sides(*one_sided)
                ),
                json!({"geometry": sj, "radiance": arr(radiance), "texture": t.json(),
                       "one_sided": one_sided}),
            )
        }
        Light::Environment { radiance, map: None } => Description::new(
            "environment",
            format!("environment, radiance {} W/(m²·sr) from every direction", vec3(*radiance)),
            json!({"radiance": arr(radiance)}),
        ),
        Light::Environment { radiance, map: Some(map) } => {
            let image = map.image();
            Description::new(
                "environment map",
                format!(
                    "environment map {} ({}x{}), scale {}, rotation {}°, mean radiance {} W/(m²·sr)",
                    image.file,
                    image.width,
                    image.height,
                    vec3(*radiance),
                    map.rotation_degrees(),
                    vec3(*radiance * map.mean())
                ),
                json!({
                    "file": image.file, "width": image.width, "height": image.height,
                    "scale": arr(radiance), "rotation_degrees": num(map.rotation_degrees()),
                    "mean_radiance": arr(*radiance * map.mean()),
                }),
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptions_read_as_text_and_carry_the_same_numbers_as_data() {
        let floor = Texture::Checker { color1: Vec3::splat(0.8), color2: Vec3::splat(0.1), size: 0.25 };
        let bsdf = Bsdf::Diffuse { albedo: floor, one_sided: false };
        let m = Material { name: "floor".into(), phong: Material::default_phong(&bsdf), bsdf };
        let d = material(&m);
        assert_eq!(d.kind, "diffuse");
        assert!(
            d.text.starts_with("diffuse, checker (0.8, 0.8, 0.8)/(0.1, 0.1, 0.1) size 0.25; phong"),
            "{}",
            d.text
        );
        assert_eq!(d.json()["texture"]["kind"], "checker");
        assert_eq!(d.json()["texture"]["size"], 0.25);
        let glass = Bsdf::Dielectric {
            inside: Medium { ior: Ior::named("bk7").unwrap(), absorption: Vec3::new(0.5, 0.0, 0.0) },
            outside: Medium::clear(1.0),
            roughness: 0.0,
            distribution: crate::conductor::Distribution::Ggx,
        };
        let m = Material { name: "glass".into(), phong: Material::default_phong(&glass), bsdf: glass };
        let d = material(&m);
        assert!(d.text.starts_with("dielectric, inside ior bk7 (dispersive: n_d 1.516"), "{}", d.text);
        assert!(d.text.contains("absorption (0.5, 0, 0) per unit, outside ior 1, roughness 0"), "{}", d.text);
        assert_eq!(d.json()["inside"]["ior"]["name"], "bk7");
        assert_eq!(d.json()["outside"]["ior"], 1.0);
        let l = light(&Light::Point { position: Vec3::new(0.0, 1.8, 0.0), intensity: Vec3::splat(5.0) });
        assert_eq!(l.text, "point at (0, 1.8, 0), intensity (5, 5, 5) W/sr");
        assert_eq!(l.json()["kind"], "point");
        for text in [&d.text, &l.text] {
            assert!(!text.contains("Vec3(") && !text.contains("Constant("), "{text}");
        }
    }
}
