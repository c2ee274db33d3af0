//! Scene compilation: text → [`SceneDesc`] → validated, expanded, BVH-accelerated [`Scene`].

use super::bodies::{self, BodySurface, Interface, Liquid};
use super::desc::{
    ColorSpaceDesc, CropDesc, DistributionDesc, FilterDesc, IorDesc, LightDesc, LiquidDesc, ManifoldDesc,
    MaterialDesc, MetropolisDesc, PhongDesc, PixelFilterDesc, Rgb, SceneDesc, ShapeDesc, SmoothNormals,
    TextureDesc, TransformDesc, Vec3Desc, WrapDesc, BIDIRECTIONAL_METHODS, IOR_TABLE_ERROR, LIQUIDS,
    METHOD_TABLES, MOVED_MAX_DEPTH,
};
use super::effects::{Effect, Effects};
use super::mesh::MeshPlacement;
use super::source::{FieldPath, SceneError, Source};
use super::transform::{rotation, Transform};
use super::{
    BvhStats, ObjectSummary, Primitive, RenderSettings, Scene, SceneOrigin, SpectralMode, DEFAULT_SCENE,
    NO_ATTRIBUTES,
};
use crate::camera::{Camera, CropWindow};
use crate::conductor::{ComplexIor, Conductor, Distribution, METAL_NAMES};
use crate::dispersion::Ior;
use crate::geometry::{
    parallelogram_normal, try_unit, AffineShape, Bounds, Disk, Polygon, Quad, Shape, Sphere, VertexAttributes,
};
use crate::light::{AffineEmitter, EmitterMesh, EmitterShape, EnvironmentMap, Light, SpotBeam, Strength};
use crate::material::{Bsdf, Material, Medium, Phong, Texture};
use crate::params::{ManifoldParams, MergeParams, MetropolisParams, Seeding, SsaaParams};
use crate::pixel_filter::{FilterKind, PixelFilter, DEFAULT_GAUSSIAN_STDDEV, DEFAULT_TENT_RADIUS};
use crate::sampler::SamplerKind;
use crate::texture::{ColorSpace, Filter, ImageMap, ImageTexture, Wrap};
use glam::{Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::BvhBuildParams;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Largest image the renderer accepts, in pixels (checked before any allocation).
pub const MAX_PIXELS: u64 = 1 << 26;
pub use crate::methods::MAX_DEPTH;
/// Largest image side in pixels.
pub const MAX_SIDE: u32 = 65536;
/// `camera` without its near clip plane when the plane lies before the whole scene (every
/// corner of the scene's bounds `(min, max)` at least `near_clip` deep along the view axis): it
/// then clips nothing, and the camera's rays start at the lens as without it, bit for bit, and
/// keep the wavefront engine's camera across lanes. (Mitsuba's default 0.01 usually is such a
/// plane.)
fn drop_idle_near_clip(mut camera: Camera, (min, max): (Vec3, Vec3)) -> Camera {
    if camera.near_clip > 0.0 {
        let nearest = (0..8)
            .map(|i| {
                let corner = Vec3::new(
                    if i & 1 == 0 { min.x } else { max.x },
                    if i & 2 == 0 { min.y } else { max.y },
                    if i & 4 == 0 { min.z } else { max.z },
                );
                (corner - camera.position).dot(camera.forward)
            })
            .fold(f32::INFINITY, f32::min);
        if nearest >= camera.near_clip {
            camera.near_clip = 0.0;
        }
    }
    camera
}

/// Largest footprint radius of a pixel filter, in pixels.
pub const MAX_FILTER_RADIUS: f32 = 16.0;
/// Largest magnitude of a number in a scene file (`render.seed` excepted). Products of two
/// such numbers (squared distances in the intersection tests, areas, radiance times area) stay
/// far inside the single-precision range.
pub const MAX_MAGNITUDE: f64 = 1e15;
/// Every object stays within this distance of the origin along each axis, over the whole
/// shutter interval (composite bodies, meshes and moving objects can reach beyond
/// [`MAX_MAGNITUDE`] although each of their numbers is within it).
pub const MAX_EXTENT: f32 = 1e16;
/// Most candidate keys [`culprit`] re-parses the document for (it costs a parse each).
const MAX_CULPRITS: usize = 16;

/// Relative padding of primitive boxes in the BVH (a few times the shapes' seam slack).
const BOX_PADDING: f32 = 4e-6;

/// Display name of the embedded default scene.
pub const DEFAULT_SCENE_NAME: &str = "<embedded default scene>";

/// Largest scene file read, in bytes: scene files are hand-written text, and a device such as
/// `/dev/zero` given as the scene must not be read forever.
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// Load and compile a scene file: vitrum's TOML, or Mitsuba XML (`.xml`, read through
/// [`super::mitsuba`], leniently after [`super::mitsuba::set_lenient`]).
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    use std::io::Read;
    if super::mitsuba::is_mitsuba(path) {
        return super::mitsuba::load(path, super::mitsuba::lenient());
    }
    let io_error = |source| SceneError::Io { path: path.to_path_buf(), source };
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_SCENE_BYTES + 1).read_to_end(&mut bytes))
        .map_err(io_error)?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(io_error(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("the file is larger than {} MiB", MAX_SCENE_BYTES >> 20),
        )));
    }
    let name = path.display().to_string();
    let text = match String::from_utf8(bytes) {
        Ok(text) => text,
        Err(e) => {
            // Point at the first byte that is not UTF-8.
            let valid = e.utf8_error().valid_up_to();
            let before = String::from_utf8_lossy(&e.as_bytes()[..valid]);
            let (line, column) = Source::new(name.as_str(), &before).line_column(valid);
            return Err(SceneError::Invalid {
                file: name,
                line,
                column,
                field: String::new(),
                message: "the file is not UTF-8 text (TOML files must be UTF-8)".into(),
            });
        }
    };
    load_str(&text, &name, path.parent())
}

/// Compile the embedded default scene.
pub fn load_default() -> Scene {
    load_str(DEFAULT_SCENE, DEFAULT_SCENE_NAME, None).expect("the embedded default scene is valid")
}

/// Compile scene text; `name` is used in messages and `dir` resolves relative mesh paths.
pub fn load_str(text: &str, name: &str, dir: Option<&Path>) -> Result<Scene, SceneError> {
    let source = Source::new(name, text);
    let desc = parse(&source)?;
    Compiler { source: &source, dir: dir.map(Path::to_path_buf), images: Default::default() }
        .compile(&desc, text)
}

/// Parse the text into a [`SceneDesc`], with located errors.
pub fn parse(source: &Source) -> Result<SceneDesc, SceneError> {
    if let Err(e) = toml_edit::ImDocument::parse(source.text) {
        let offset = e.span().map_or(0, |s| s.start);
        return Err(source.error_at_offset(offset, format!("TOML syntax error: {}", e.message())));
    }
    source.check_numbers()?;
    toml::from_str::<SceneDesc>(source.text).map_err(|e| {
        let message = e.message().to_string();
        let offset = e.span().map_or(0, |range| {
            // Inside a flattened or internally tagged table (objects, materials, lights, textures)
            // serde reports the error at the whole table: find the one key or value it is about.
            let found = source.find_in(range.clone(), |key, value| names(&message, key, value));
            match found[..] {
                [one] => one,
                [] => range.start,
                _ => culprit(source, &found, &message).unwrap_or(range.start),
            }
        });
        let path = source.path_at(offset);
        // An unknown key is its own culprit; any other error is about the value.
        let offset = match source.span_of(&path) {
            Some(span) if !message.starts_with("unknown field") && !path.0.is_empty() => span.start,
            _ => offset,
        };
        source.error_at_offset(offset, plain_message(&message, &path, source.is_table(&path)))
    })
}

/// A serde error message in the words of the scene format: "expected a number, found the
/// string "big"" instead of "invalid type: string "big", expected f32"; an unknown
/// `[render.NAME]` table is an unknown method. `path` is the field the message is about, and
/// `table` whether it is a table.
fn plain_message(message: &str, path: &FieldPath, table: bool) -> String {
    let keys: Vec<&str> = path
        .0
        .iter()
        .map(|s| match s {
            super::source::Segment::Key(k) => k.as_str(),
            super::source::Segment::Index(_) => "",
        })
        .collect();
    let whole_numbers = keys.last() == Some(&"resolution");
    if let Some(rest) = message.strip_prefix("unknown field `") {
        let name = rest.split('`').next().unwrap_or("");
        return match keys[..] {
            ["render", method] if table && method == name => format!(
                "unknown method `{name}`: a [render.METHOD] table holds the settings of one of {}",
                METHOD_TABLES.join(", ")
            ),
            ["render", "raycast", ..] => format!(
                "unknown field `{name}`: [render.raycast] takes no parameters (ray casting shades the \
                 first hit only, so it has no depth)"
            ),
            // `[render] max_depth` is read only to refuse it: not an allowed key.
            ["render", _] => message.replace("`max_depth`, ", ""),
            _ => message.replace(", there are no fields", ": this table takes no fields"),
        };
    }
    let (kind, rest) = match ["invalid type: ", "invalid value: ", "invalid length "]
        .iter()
        .find_map(|p| message.strip_prefix(p).map(|rest| (*p, rest)))
    {
        Some(found) => found,
        None => return message.to_string(),
    };
    let Some((found, expected)) = rest.rsplit_once(", expected ") else { return message.to_string() };
    let found = match kind {
        "invalid length " => format!("a list of {found} values"),
        _ => plain_found(found),
    };
    let expected = plain_expected(expected, kind == "invalid value: ", whole_numbers);
    format!("expected {expected}, found {found}")
}

/// What serde's `Unexpected` text (`string "big"`, `floating point `1.5``) says, in words.
fn plain_found(found: &str) -> String {
    let quoted = |prefix: &str| found.strip_prefix(prefix).map(|v| v.trim_matches('`').to_string());
    if let Some(v) = found.strip_prefix("string ") {
        format!("the string {v}")
    } else if let Some(v) = quoted("floating point ") {
        format!("the number {v}")
    } else if let Some(v) = quoted("integer ") {
        format!("the whole number {v}")
    } else if let Some(v) = quoted("boolean ") {
        v
    } else {
        match found {
            "sequence" => "a list".into(),
            "map" => "a table".into(),
            other => other.into(),
        }
    }
}

/// What serde's expectation (`f32`, `an array of length 3`, `struct CameraDesc`) asks for, in
/// words; `range`: say the range of a whole number (the value was out of it); `whole`: the list
/// holds whole numbers (a resolution).
fn plain_expected(expected: &str, range: bool, whole: bool) -> String {
    let count = |n: &str| {
        match n {
            "2" => "two",
            "3" => "three",
            "4" => "four",
            _ => n,
        }
        .to_string()
    };
    match expected {
        "f32" | "f64" => "a number".into(),
        "u32" if range => format!("a whole number from 0 to {}", u32::MAX),
        "u64" if range => format!("a whole number from 0 to {}", u64::MAX),
        "u8" | "u16" | "u32" | "u64" | "usize" | "i32" | "i64" => "a whole number".into(),
        "a boolean" => "true or false".into(),
        "a sequence" => "a list".into(),
        "a map" => "a table".into(),
        _ => {
            if let Some(n) = expected.strip_prefix("an array of length ") {
                let numbers = if whole { "whole numbers" } else { "numbers" };
                format!("a list of {} {numbers}", count(n))
            } else if expected.starts_with("struct ") || expected.starts_with("internally tagged enum ") {
                "a table".into()
            } else {
                expected.into()
            }
        }
    }
}

/// Of several candidate keys (byte offsets) for a serde error, the one whose removal makes the
/// error go away (serde then complains about something else, such as the missing key), if
/// exactly one does.
fn culprit(source: &Source, candidates: &[usize], message: &str) -> Option<usize> {
    if candidates.len() > MAX_CULPRITS {
        return None;
    }
    let mut hits = candidates.iter().copied().filter(|&offset| {
        source.without(&source.path_at(offset)).is_some_and(|text| match toml::from_str::<SceneDesc>(&text) {
            Ok(_) => true,
            Err(e) => e.message() != message,
        })
    });
    let first = hits.next()?;
    hits.next().is_none().then_some(first)
}

/// Whether a serde error `message` is about the entry `key = value` (`key` is `None` for array
/// elements, `value` is `None` for tables).
fn names(message: &str, key: Option<&str>, value: Option<&toml_edit::Value>) -> bool {
    if message.starts_with(IOR_TABLE_ERROR) {
        let table = value.and_then(|v| v.as_inline_table());
        return matches!(key, Some("ior" | "ior_outside"))
            && table.is_some_and(|t| t.contains_key("cauchy") == t.contains_key("abbe"));
    }
    if let Some(rest) = message.strip_prefix("unknown field `") {
        return key.is_some() && rest.split('`').next() == key;
    }
    let Some(value) = value else { return false };
    if let Some(rest) = message.strip_prefix("unknown variant `") {
        return value.as_str().is_some_and(|s| rest.split('`').next() == Some(s));
    }
    if let Some(rest) = message.strip_prefix("invalid length ") {
        let len = rest.split(',').next().and_then(|n| n.parse::<usize>().ok());
        return len.is_some() && value.as_array().map(|a| a.len()) == len;
    }
    let unexpected = ["invalid type: ", "invalid value: "]
        .iter()
        .find_map(|p| message.strip_prefix(p))
        .and_then(|rest| rest.rsplit_once(", expected "))
        .map(|(u, _)| u);
    unexpected.is_some_and(|u| serde_unexpected(value).is_some_and(|d| d == u))
}

/// How serde describes a TOML value in "invalid type" messages (`serde::de::Unexpected`).
fn serde_unexpected(value: &toml_edit::Value) -> Option<String> {
    use toml_edit::Value;
    Some(match value {
        Value::String(s) => format!("string {:?}", s.value()),
        Value::Integer(i) => format!("integer `{}`", i.value()),
        Value::Float(f) => {
            let x = *f.value();
            let text = x.to_string();
            let point = if x.is_finite() && !text.contains('.') { ".0" } else { "" };
            format!("floating point `{text}{point}`")
        }
        Value::Boolean(b) => format!("boolean `{}`", b.value()),
        Value::Array(_) => "sequence".to_string(),
        Value::InlineTable(_) => "map".to_string(),
        Value::Datetime(_) => return None,
    })
}

/// 64-bit FNV-1a of a text, in hex.
pub fn content_hash(text: &str) -> String {
    content_hash_bytes(text.as_bytes())
}

/// The hash of a scene: of its text alone, or with the content hashes of the files it reads.
fn scene_hash(text: &str, inputs: &[String]) -> String {
    if inputs.is_empty() {
        return content_hash(text);
    }
    content_hash(&format!("{text}\n{}", inputs.join("\n")))
}

/// 64-bit FNV-1a of bytes, in hex.
pub fn content_hash_bytes(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("{h:016x}")
}

struct Compiler<'a> {
    source: &'a Source<'a>,
    dir: Option<PathBuf>,
    /// The image files read so far, by path and colour space (each is decoded once however many
    /// textures use it), with their content hashes in the order first read.
    images: std::cell::RefCell<ImageCache>,
}

/// Decoded image files of a scene being compiled.
#[derive(Default)]
struct ImageCache {
    maps: HashMap<(PathBuf, Option<ColorSpace>), Arc<ImageMap>>,
    hashes: BTreeMap<PathBuf, String>,
}

/// Checks of scalar values, reported at their field.
impl Compiler<'_> {
    fn err(&self, path: &FieldPath, message: impl Into<String>) -> SceneError {
        self.source.error_at(path, message)
    }

    fn positive(&self, path: &FieldPath, x: f32) -> Result<f32, SceneError> {
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(path, format!("must be greater than 0 (got {x})")))
        }
    }

    fn non_zero(&self, path: &FieldPath, x: f32) -> Result<f32, SceneError> {
        if x != 0.0 && x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(path, format!("must be a finite number other than 0 (got {x})")))
        }
    }

    fn finite(&self, path: &FieldPath, x: f32) -> Result<f32, SceneError> {
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(path, format!("must be a finite number (got {x})")))
        }
    }

    fn non_negative(&self, path: &FieldPath, x: f32) -> Result<f32, SceneError> {
        if x >= 0.0 {
            Ok(x)
        } else {
            Err(self.err(path, format!("must be 0 or greater (got {x})")))
        }
    }

    fn color(&self, path: &FieldPath, c: Rgb) -> Result<Vec3, SceneError> {
        let v = Vec3::from_array(c.channels());
        if v.min_element() < 0.0 {
            return Err(self.err(path, format!("colour channels must be 0 or greater (got {v})")));
        }
        Ok(v)
    }

    /// The error for a `seam` along the axis (or normal) it turns about.
    fn along_axis(&self, path: &FieldPath) -> SceneError {
        self.err(path, "must not lie along the axis (or normal): the texture seam is a direction across it")
    }

    fn direction(&self, path: &FieldPath, v: [f32; 3]) -> Result<Vec3, SceneError> {
        try_unit(Vec3::from_array(v)).ok_or_else(|| self.err(path, "must be a non-zero vector"))
    }

    fn compile(&self, desc: &SceneDesc, text: &str) -> Result<Scene, SceneError> {
        let camera = self.camera(desc)?;
        let mut settings = self.settings(desc)?;
        let mut effects = Effects::default();

        let mut materials = Vec::new();
        let mut material_index = HashMap::new();
        for (name, m) in &desc.materials {
            let path = FieldPath::from("materials").key(name);
            let material = self.material(&path, name, m)?;
            material_index.insert(name.clone(), materials.len() as u32);
            materials.push(material);
        }

        let mut primitives = Vec::new();
        let mut objects = Vec::new();
        let mut warnings = Vec::new();
        // The content hashes of the files the scene reads besides its own text (meshes).
        let mut inputs = Vec::new();
        let mut lights = Vec::new();
        // Mesh triangles' vertex attributes, and per primitive the index of its own (or
        // NO_ATTRIBUTES).
        let mut attributes = Vec::new();
        let mut attribute_index = Vec::new();
        for (i, object) in desc.objects.iter().enumerate() {
            let path = FieldPath::from("objects").index(i);
            let Some(&material) = material_index.get(&object.material) else {
                let known: Vec<&str> = desc.materials.keys().map(String::as_str).collect();
                return Err(self.err(
                    &path.key("material"),
                    format!(
                        "unknown material `{}`; defined materials: {}",
                        object.material,
                        if known.is_empty() { "none".to_string() } else { known.join(", ") }
                    ),
                ));
            };
            let kind = shape_kind(&object.shape);
            let transform = match &object.transform {
                Some(t) => Some(self.transform(&path.key("transform"), t)?),
                None => None,
            };
            // (NaN cannot reach here: the parser refuses it.) A transformed analytic shape's
            // numbers as written are checked first, so that messages quote the file's values.
            // Under a similarity it is the shape with transformed defining numbers (its texture
            // frame turned by the rotation); a round shape under a general affine map keeps its
            // numbers and is intersected in object space.
            let unplaced = match &transform {
                Some(_) if !matches!(object.shape, ShapeDesc::Mesh { .. }) => Some(self.shape(
                    &path,
                    &object.shape,
                    None,
                    &mut warnings,
                    &mut inputs,
                    &mut Vec::new(),
                )?),
                _ => None,
            };
            let general = transform.filter(|t| is_round(&object.shape) && t.uniform_scale().is_none());
            let placed = match (&transform, &unplaced) {
                (Some(t), Some(_)) if general.is_none() => {
                    std::borrow::Cow::Owned(self.placed(&object.shape, t))
                }
                _ => std::borrow::Cow::Borrowed(&object.shape),
            };
            // A mesh's per-triangle uv and normals, in the order of its surfaces.
            let mut mesh_attributes = Vec::new();
            let surfaces = match (general, unplaced) {
                (Some(t), Some(object_space)) => self.affine_surfaces(&path, object_space, &t)?,
                (_, unplaced) => {
                    let mut surfaces = self
                        .shape(
                            &path,
                            &placed,
                            transform.as_ref(),
                            &mut warnings,
                            &mut inputs,
                            &mut mesh_attributes,
                        )
                        .map_err(|e| match (e, &placed) {
                            // The numbers as written passed: the transform made the shape invalid.
                            (SceneError::Invalid { field, message, .. }, std::borrow::Cow::Owned(_)) => self
                                .err(
                                    &path.key("transform"),
                                    format!(
                                        "the transformed shape is invalid (`{field}` after the transform: \
                                         {message})"
                                    ),
                                ),
                            (e, _) => e,
                        })?;
                    if let (Some(rotation), Some(unplaced)) = (transform.and_then(|t| t.rotation), unplaced) {
                        turn_texture_frames(&mut surfaces, &unplaced, rotation);
                    }
                    surfaces
                }
            };
            if let ShapeDesc::Mesh { file, .. } = &object.shape {
                let image = match &materials[material as usize].bsdf {
                    Bsdf::Diffuse { albedo: Texture::Image(t), .. }
                    | Bsdf::Mirror { color: Texture::Image(t), .. } => Some(t),
                    _ => None,
                };
                if let Some(t) = image.filter(|_| mesh_attributes.iter().all(|a| a.uv.is_none())) {
                    return Err(self.err(
                        &path.key("file"),
                        format!(
                            "{file} has no texture coordinates (`vt` lines), which the image texture {} of \
                             material `{}` needs",
                            t.map.file, object.material
                        ),
                    ));
                }
            }
            if surfaces.iter().any(|(s, _)| !within_extent(s.bounds())) {
                // Only a mesh (vertices × scale) or a transform can get here: every other number
                // is checked.
                let at = match object.shape {
                    ShapeDesc::Mesh { .. } => path.key("file"),
                    _ if object.transform.is_some() => path.key("transform"),
                    _ => path.clone(),
                };
                return Err(self.err(
                    &at,
                    format!(
                        "the object reaches beyond ±{MAX_EXTENT:e} from the origin (the scene's size limit)"
                    ),
                ));
            }
            if matches!(object.shape, ShapeDesc::Mesh { .. }) {
                effects.add(Effect::Meshes, format!("objects[{i}] is a triangle mesh"));
            }
            material_effects(&mut effects, &materials[material as usize], i);
            let liquid = self.liquid(&path, &object.shape, &materials[material as usize])?;
            let velocity = match object.velocity {
                Some(v) => Some(self.finite_vector(&path.key("velocity"), v)?).filter(|v| *v != Vec3::ZERO),
                None => None,
            };
            if let Some(v) = velocity {
                let moved = |t: f32, b: Bounds| Bounds { min: b.min + v * t, max: b.max + v * t };
                let (open, close) = camera.shutter;
                if surfaces.iter().any(|(s, _)| {
                    !(within_extent(moved(open, s.bounds())) && within_extent(moved(close, s.bounds())))
                }) {
                    return Err(self.err(
                        &path.key("velocity"),
                        format!(
                            "the object moves beyond ±{MAX_EXTENT:e} from the origin while the shutter is \
                             open [{open:?}, {close:?}] (the scene's size limit)"
                        ),
                    ));
                }
            }
            if velocity.is_some() && camera.shutter.1 > camera.shutter.0 {
                effects.add(
                    Effect::MotionBlur,
                    format!("objects[{i}] moves (velocity) while the shutter is open"),
                );
            }
            let emitter = match &desc.materials[&object.material] {
                MaterialDesc::Diffuse { emission, emission_texture, emission_one_sided, .. }
                    if emission.is_some() || emission_texture.is_some() =>
                {
                    let material_path = FieldPath::from("materials").key(&object.material);
                    let m = material_path.key("emission");
                    let radiance = self.color(&m, emission.unwrap_or(Rgb::Grey(1.0)))?;
                    let texture = match emission_texture {
                        Some(t) => Some(self.texture_of(&material_path.key("emission_texture"), t)?),
                        None => None,
                    };
                    if velocity.is_some() {
                        return Err(self.err(&path.key("velocity"), "an emitting object cannot move"));
                    }
                    // Under a general map the object-space emitter (from the object-space
                    // surfaces) is wrapped with the map; otherwise the placed shape emits.
                    let shape = match general {
                        Some(_) => affine_emitter(&object.shape, &surfaces),
                        None => emitter_shape(&placed, &surfaces),
                    }
                    .ok_or_else(|| {
                        self.err(
                            &path.key("material"),
                            "emission is supported on spheres, quads, disks, cylinders and meshes",
                        )
                    })?;
                    if matches!(shape, EmitterShape::Mesh(_)) && emission_texture.is_some() {
                        return Err(self.err(
                            &material_path.key("emission_texture"),
                            "an emitting mesh's emission cannot be textured (spheres, quads, disks and cylinders can)",
                        ));
                    }
                    let size = match object.shape {
                        ShapeDesc::Quad { .. } => "u",
                        ShapeDesc::Mesh { .. } => "file",
                        _ => "radius",
                    };
                    self.emitter_area(&path.key(size), shape.area())?;
                    if texture.as_ref().is_some_and(Texture::varies) {
                        effects.add(
                            Effect::Textures,
                            format!("objects[{i}] emits through a texture (material `{}`)", object.material),
                        );
                    }
                    let light = Light::Surface { shape, radiance, texture, one_sided: *emission_one_sided };
                    self.finite_power(&m, &light)?;
                    effects.add(
                        Effect::SoftShadows,
                        format!("objects[{i}] emits light (material `{}`)", object.material),
                    );
                    lights.push(light);
                    Some(lights.len() as u32 - 1)
                }
                _ => None,
            };
            let object_id = objects.len() as u32;
            objects.push(ObjectSummary {
                name: object.name.clone().unwrap_or_else(|| format!("{kind} #{i}")),
                kind: kind.to_string(),
                material: object.material.clone(),
                primitives: surfaces.len(),
                mesh_attributes: (
                    mesh_attributes.iter().any(|a| a.uv.is_some()),
                    mesh_attributes.iter().any(|a| a.normals.is_some()),
                ),
            });
            for (k, (shape, interface)) in surfaces.into_iter().enumerate() {
                // Inner surfaces of hollow bodies use the interface seen from the other side,
                // filled vessels their liquid's interfaces: derived materials, made once each.
                let material = if interface == Interface::Material {
                    material
                } else {
                    let mut derived = interface.material(&materials[material as usize], liquid.as_ref());
                    match materials.iter().position(|m| *m == derived) {
                        Some(k) => k as u32,
                        None => {
                            if materials.iter().any(|m| m.name == derived.name) {
                                derived.name = format!("{} of objects[{i}]", derived.name);
                            }
                            material_effects(&mut effects, &derived, i);
                            materials.push(derived);
                            materials.len() as u32 - 1
                        }
                    }
                };
                match mesh_attributes.get(k).filter(|a| !a.is_empty()) {
                    Some(a) => {
                        attribute_index.push(attributes.len() as u32);
                        attributes.push(*a);
                    }
                    None => attribute_index.push(NO_ATTRIBUTES),
                }
                primitives.push(Primitive { shape, material, light: emitter, object: object_id, velocity });
            }
        }

        for (i, l) in desc.lights.iter().enumerate() {
            let path = FieldPath::from("lights").index(i);
            let light = self.light(&path, l)?;
            let emitter = match light {
                Light::Point { .. }
                | Light::Spot { .. }
                | Light::Directional { .. }
                | Light::Surface { .. } => None,
                Light::Environment { radiance, ref map } => {
                    effects.add(Effect::Environment, format!("lights[{i}] is an environment light"));
                    let radiance = radiance * map.as_ref().map_or(Vec3::ONE, |m| m.mean());
                    if settings.background != Vec3::ZERO {
                        return Err(self.err(
                            &path,
                            "an environment light is the background: remove `render.background`",
                        ));
                    }
                    settings.background = radiance;
                    None
                }
                Light::Quad { corner, u, v, .. } => {
                    Some((Shape::Quad(Box::new(Quad::new(corner, u, v))), "quad light"))
                }
                Light::Sphere { center, radius, .. } => {
                    Some((Shape::Sphere(Box::new(Sphere::new(center, radius))), "sphere light"))
                }
            };
            if let Some((shape, kind)) = emitter {
                effects.add(Effect::SoftShadows, format!("lights[{i}] is an area light ({kind})"));
                let emitter_material = materials.len() as u32;
                let bsdf = Bsdf::Diffuse { albedo: Texture::Constant(Vec3::ZERO), one_sided: false };
                let phong = Phong { ambient: 0.0, diffuse: 0.0, specular: 0.0, shininess: 1.0 };
                materials.push(Material { name: format!("light #{i}"), bsdf, phong });
                attribute_index.push(NO_ATTRIBUTES);
                primitives.push(Primitive {
                    shape,
                    material: emitter_material,
                    light: Some(lights.len() as u32),
                    object: objects.len() as u32,
                    velocity: None,
                });
                objects.push(ObjectSummary {
                    name: format!("area light #{i}"),
                    kind: kind.into(),
                    material: format!("light #{i}"),
                    primitives: 1,
                    mesh_attributes: (false, false),
                });
            }
            lights.push(light);
        }

        warnings.extend(super::overlap::coincident_surfaces(&primitives, &objects));
        if lights.is_empty() && settings.ambient == Vec3::ZERO {
            warnings
                .push("the scene has no lights and no ambient term: every method renders it black".into());
        }
        if camera.has_lens() {
            effects.add(
                Effect::DepthOfField,
                format!("camera.aperture = {} (focus at {})", camera.aperture, camera.focus_distance),
            );
        }
        // Image files (textures, environment maps), once each, in the order of their paths.
        inputs.extend(self.images.borrow().hashes.values().cloned());
        let (primitives, bvh, bvh_stats) = build_bvh(primitives, camera.shutter);
        let camera = drop_idle_near_clip(camera, bvh_stats.bounds);
        if attributes.is_empty() {
            // Scenes without uv or normals never look the index up.
            attribute_index = Vec::new();
        } else {
            permute_in_place(&mut attribute_index, &bvh.primitive_indices);
        }
        let has_motion = primitives.iter().any(|p| p.velocity.is_some());
        let reads_surface_uv = reads_surface_uv(&materials, &lights);
        let casters = casters(&primitives, &materials, objects.len(), camera.shutter);
        Ok(Scene {
            casters,
            primitives,
            materials,
            lights,
            camera,
            settings,
            effects,
            objects,
            // The scene text and every file it reads: an edited OBJ or image file is another scene.
            origin: SceneOrigin { name: self.source.name.clone(), hash: scene_hash(text, &inputs) },
            bvh_scale: bvh_stats.scale,
            has_motion,
            reads_surface_uv,
            bvh_stats,
            warnings,
            bvh,
            attributes,
            attribute_index,
        })
    }

    fn camera(&self, desc: &SceneDesc) -> Result<Camera, SceneError> {
        let c = &desc.camera;
        let path = FieldPath::from("camera");
        let [w, h] = c.resolution;
        if w == 0 || h == 0 {
            return Err(self
                .err(&path.key("resolution"), format!("width and height must be at least 1 (got {w}×{h})")));
        }
        if w > MAX_SIDE || h > MAX_SIDE || w as u64 * h as u64 > MAX_PIXELS {
            return Err(self.err(
                &path.key("resolution"),
                format!("{w}×{h} is too large: at most {MAX_SIDE} per side and {MAX_PIXELS} pixels in all"),
            ));
        }
        if !(c.fov > 0.0 && c.fov < 180.0) {
            return Err(self.err(
                &path.key("fov"),
                format!("must be between 0 and 180 degrees, exclusive (got {})", c.fov),
            ));
        }
        let position = Vec3::from_array(c.position);
        let look_at = Vec3::from_array(c.look_at);
        if look_at == position {
            return Err(self.err(&path.key("look_at"), "must differ from camera.position"));
        }
        let up = self.direction(&path.key("up"), c.up)?;
        let camera = Camera::new(position, look_at, up, c.fov, w, h).ok_or_else(|| {
            self.err(&path.key("up"), "must not be parallel to the view direction (look_at − position)")
        })?;
        let aperture = self.non_negative(&path.key("aperture"), c.aperture)?;
        let focus = match c.focus_distance {
            Some(f) => self.positive(&path.key("focus_distance"), f)?,
            None => camera.focus_distance,
        };
        let [open, close] = c.shutter;
        if open > close {
            return Err(self
                .err(&path.key("shutter"), format!("open must not be after close (got [{open}, {close}])")));
        }
        let near_clip = self.non_negative(&path.key("near_clip"), c.near_clip)?;
        let filter = match &c.filter {
            Some(f) => self.pixel_filter(&path.key("filter"), f)?,
            None => PixelFilter::BOX,
        };
        let crop = match &c.crop {
            Some(crop) => self.crop(&path.key("crop"), crop, w, h)?,
            None => CropWindow::full(w, h),
        };
        Ok(camera
            .with_lens(aperture, focus)
            .with_shutter(open, close)
            .with_near_clip(near_clip)
            .with_filter(filter)
            .with_crop(crop))
    }

    /// `[camera] filter`: a known name, with only its own parameters, each positive.
    fn pixel_filter(&self, path: &FieldPath, f: &PixelFilterDesc) -> Result<PixelFilter, SceneError> {
        let refuse = |param: &str, kind: &str| {
            self.err(&path.key(param), format!("`{param}` is not a parameter of the `{kind}` filter"))
        };
        match f.kind.as_str() {
            "box" => {
                if f.radius.is_some() {
                    return Err(refuse("radius", "box"));
                }
                if f.stddev.is_some() {
                    return Err(refuse("stddev", "box"));
                }
                Ok(PixelFilter::BOX)
            }
            "tent" => {
                if f.stddev.is_some() {
                    return Err(refuse("stddev", "tent"));
                }
                let radius = match f.radius {
                    Some(r) => self.positive(&path.key("radius"), r)?,
                    None => DEFAULT_TENT_RADIUS,
                };
                let radius = self.filter_reach(&path.key("radius"), radius, radius)?;
                Ok(PixelFilter::new(FilterKind::Tent { radius }))
            }
            "gaussian" => {
                if f.radius.is_some() {
                    return Err(self.err(
                        &path.key("radius"),
                        "the `gaussian` filter's radius is 4 × stddev (Mitsuba's); give `stddev`",
                    ));
                }
                let stddev = match f.stddev {
                    Some(s) => self.positive(&path.key("stddev"), s)?,
                    None => DEFAULT_GAUSSIAN_STDDEV,
                };
                let stddev = self.filter_reach(&path.key("stddev"), stddev, 4.0 * stddev)?;
                Ok(PixelFilter::new(FilterKind::Gaussian { stddev }))
            }
            other => Err(self.err(path, format!("unknown filter `{other}`: use box, tent or gaussian"))),
        }
    }

    /// A filter parameter `value` whose footprint radius is `radius` pixels: at most
    /// [`MAX_FILTER_RADIUS`], so that a splat touches a bounded number of pixels.
    fn filter_reach(&self, path: &FieldPath, value: f32, radius: f32) -> Result<f32, SceneError> {
        if radius > MAX_FILTER_RADIUS {
            return Err(self.err(
                path,
                format!("{value} makes a footprint of radius {radius} px; at most {MAX_FILTER_RADIUS} px"),
            ));
        }
        Ok(value)
    }

    /// `[camera] crop`: a window of at least one pixel inside the `w`×`h` film.
    fn crop(&self, path: &FieldPath, c: &CropDesc, w: u32, h: u32) -> Result<CropWindow, SceneError> {
        let ([x, y], [cw, ch]) = (c.offset, c.size);
        if cw == 0 || ch == 0 {
            return Err(
                self.err(&path.key("size"), format!("width and height must be at least 1 (got {cw}×{ch})"))
            );
        }
        if x as u64 + cw as u64 > w as u64 || y as u64 + ch as u64 > h as u64 {
            return Err(self.err(
                path,
                format!(
                    "the window {cw}×{ch} at [{x}, {y}] reaches past the {w}×{h} film (offset + size must be at most the resolution)"
                ),
            ));
        }
        Ok(CropWindow { x, y, width: cw, height: ch })
    }

    fn settings(&self, desc: &SceneDesc) -> Result<RenderSettings, SceneError> {
        let r = &desc.render;
        let path = FieldPath::from("render");
        if r.spp == 0 {
            return Err(self.err(&path.key("spp"), "must be at least 1"));
        }
        if r.max_depth.is_some() {
            return Err(self.err(&path.key("max_depth"), MOVED_MAX_DEPTH));
        }
        let mut max_depths = BTreeMap::new();
        for method in METHOD_TABLES {
            if let Some(depth) = r.max_depth_of(method) {
                if depth > MAX_DEPTH {
                    let at = path.key(method).key("max_depth");
                    return Err(self.err(&at, format!("must be at most {MAX_DEPTH} (got {depth})")));
                }
                max_depths.insert(method.to_string(), depth);
            }
        }
        let mut merging = BTreeMap::new();
        for method in BIDIRECTIONAL_METHODS {
            let at = path.key(method);
            let mut params = MergeParams::default();
            if let Some(cap) = r.max_light_paths_of(method) {
                if cap == 0 {
                    let msg = "must be at least 1 light sub-path per iteration (got 0)".to_string();
                    return Err(self.err(&at.key("max_light_paths"), msg));
                }
                params.max_light_paths = cap;
            }
            let Some(m) = r.merge_of(method) else {
                merging.insert(method.to_string(), params);
                continue;
            };
            if let Some(radius) = m.radius {
                if !(radius > 0.0 && radius.is_finite()) {
                    let msg = format!("must be a positive distance in scene units (got {radius})");
                    return Err(self.err(&at.key("radius"), msg));
                }
                params.radius = Some(radius);
            }
            if let Some(alpha) = m.radius_alpha {
                if !(alpha > 0.0 && alpha <= 1.0) {
                    let msg =
                        format!("must be in (0, 1]: the radius shrinks as (i + 1)^((α - 1)/2) (got {alpha})");
                    return Err(self.err(&at.key("radius_alpha"), msg));
                }
                params.alpha = alpha;
            }
            merging.insert(method.to_string(), params);
        }
        if !METHOD_TABLES.contains(&r.integrator.as_str()) {
            return Err(self.err(
                &path.key("integrator"),
                format!("unknown integrator `{}`; known: {}", r.integrator, METHOD_TABLES.join(", ")),
            ));
        }
        if let Some(rho) = r.reflectance {
            if !(0.0..=1.0).contains(&rho) {
                return Err(self.err(&path.key("reflectance"), format!("must be in [0, 1] (got {rho})")));
            }
        }
        let spectral = SpectralMode::from_name(&r.spectral).ok_or_else(|| {
            self.err(&path.key("spectral"), format!("`{}` is not one of auto, on, off", r.spectral))
        })?;
        let sampler = SamplerKind::from_name(&r.sampler).ok_or_else(|| {
            self.err(
                &path.key("sampler"),
                format!("`{}` is not one of sobol, stratified, independent", r.sampler),
            )
        })?;
        let q = path.key("ssaa");
        let adaptive = match r.ssaa.mode.as_str() {
            "adaptive" => true,
            "grid" => false,
            other => return Err(self.err(&q.key("mode"), format!("`{other}` is not one of adaptive, grid"))),
        };
        if !(1..=64).contains(&r.ssaa.grid) {
            return Err(self.err(&q.key("grid"), format!("must be in 1..=64 (got {})", r.ssaa.grid)));
        }
        if r.ssaa.levels > 6 {
            return Err(self.err(&q.key("levels"), format!("must be in 0..=6 (got {})", r.ssaa.levels)));
        }
        let threshold = self.non_negative(&q.key("threshold"), r.ssaa.threshold)?;
        let mut metropolis = BTreeMap::new();
        for (method, table) in
            [(crate::methods::Method::Pssmlt, &r.pssmlt), (crate::methods::Method::Mmlt, &r.mmlt)]
        {
            metropolis.insert(method.name().to_string(), self.metropolis(&path.key(method.name()), table)?);
        }
        let manifold = self.manifold(&path.key("mnee"), &r.mnee)?;
        Ok(RenderSettings {
            manifold,
            spectral,
            sampler,
            ssaa: SsaaParams { adaptive, grid: r.ssaa.grid, levels: r.ssaa.levels, threshold },
            metropolis,
            integrator: r.integrator.clone(),
            spp: r.spp,
            max_depths,
            merging,
            seed: r.seed,
            ambient: self.color(&path.key("ambient"), r.ambient)?,
            background: self.color(&path.key("background"), r.background)?,
            reflectance: r.reflectance,
            exposure: r.exposure,
        })
    }

    /// The Metropolis settings of the table `m` at `at` (`[render.pssmlt]`, `[render.mmlt]`), the defaults where
    /// a field is absent.
    fn metropolis(&self, at: &FieldPath, m: &MetropolisDesc) -> Result<MetropolisParams, SceneError> {
        let mut params = MetropolisParams::default();
        if let Some(p) = m.large_step {
            if !(p > 0.0 && p <= 1.0) {
                let msg =
                    format!("must be in (0, 1]: the probability that a proposal is a large step (got {p})");
                return Err(self.err(&at.key("large_step"), msg));
            }
            params.large_step = p;
        }
        if let Some(sigma) = m.sigma {
            if !(sigma > 0.0 && sigma <= 1.0) {
                let msg = format!(
                    "must be in (0, 1]: the deviation of a small step in primary sample space (got {sigma})"
                );
                return Err(self.err(&at.key("sigma"), msg));
            }
            params.sigma = sigma;
        }
        for (key, value, field) in
            [("bootstrap", m.bootstrap, &mut params.bootstrap), ("chains", m.chains, &mut params.chains)]
        {
            if let Some(n) = value {
                if n == 0 {
                    return Err(self.err(&at.key(key), "must be at least 1 (got 0)"));
                }
                *field = n;
            }
        }
        Ok(params)
    }

    /// The manifold settings of the table `m` at `at` (`[render.mnee]`), the defaults where a
    /// field is absent.
    fn manifold(&self, at: &FieldPath, m: &ManifoldDesc) -> Result<ManifoldParams, SceneError> {
        let mut params = ManifoldParams::default();
        if let Some(name) = &m.seeding {
            params.seeding = Seeding::from_name(name).ok_or_else(|| {
                self.err(&at.key("seeding"), format!("`{name}` is not one of sms, straight"))
            })?;
        }
        if let Some(n) = m.max_chain {
            if !(1..=crate::manifold::MAX_CHAIN as u32).contains(&n) {
                let msg = format!("must be in 1..={} (got {n})", crate::manifold::MAX_CHAIN);
                return Err(self.err(&at.key("max_chain"), msg));
            }
            params.max_chain = n;
        }
        if let Some(n) = m.max_trials {
            if n == 0 {
                return Err(self.err(&at.key("max_trials"), "must be at least 1 (got 0)"));
            }
            params.max_trials = n;
        }
        Ok(params)
    }

    fn roughness(&self, path: &FieldPath, r: f32) -> Result<f32, SceneError> {
        if (0.0..=1.0).contains(&r) {
            Ok(r)
        } else {
            Err(self.err(path, format!("must be in [0, 1] (got {r})")))
        }
    }

    fn finite_vector(&self, path: &FieldPath, v: [f32; 3]) -> Result<Vec3, SceneError> {
        let v = Vec3::from_array(v);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(path, "must be finite"))
        }
    }

    fn ior(&self, path: &FieldPath, ior: &IorDesc) -> Result<Ior, SceneError> {
        let ior = match ior {
            IorDesc::Constant(n) => Ior::Constant(self.positive(path, *n)?),
            IorDesc::Named(name) => Ior::named(name).ok_or_else(|| {
                self.err(path, format!("unknown glass `{name}`; known: {}", Ior::names().join(", ")))
            })?,
            IorDesc::Cauchy([a, b]) => Ior::Cauchy { a: *a, b: *b },
            IorDesc::Abbe([n_d, v_d]) => {
                if !(*n_d > 1.0 && *v_d > 0.0) {
                    return Err(self.err(
                        path,
                        format!("abbe = [n_d, V_d] needs n_d > 1 and V_d > 0 (got [{n_d}, {v_d}])"),
                    ));
                }
                Ior::from_abbe(*n_d, *v_d)
            }
        };
        let (lo, hi) = (ior.at(crate::spectrum::LAMBDA_MIN), ior.at(crate::spectrum::LAMBDA_MAX));
        if !(lo > 0.0 && hi > 0.0 && lo.is_finite() && hi.is_finite()) {
            return Err(
                self.err(path, format!("the index must be positive over 380–780 nm (got {lo} .. {hi})"))
            );
        }
        Ok(ior)
    }

    fn phong(&self, path: &FieldPath, p: &PhongDesc, bsdf: &Bsdf) -> Result<Phong, SceneError> {
        let d = Material::default_phong(bsdf);
        let path = path.key("phong");
        let get = |key: &str, v: Option<f32>, default: f32| match v {
            Some(x) => self.non_negative(&path.key(key), x),
            None => Ok(default),
        };
        Ok(Phong {
            ambient: get("ambient", p.ambient, d.ambient)?,
            diffuse: get("diffuse", p.diffuse, d.diffuse)?,
            specular: get("specular", p.specular, d.specular)?,
            shininess: get("shininess", p.shininess, d.shininess)?,
        })
    }

    /// The colour of material `path`: its `color` (or `default`), or its `texture`.
    fn texture(
        &self,
        path: &FieldPath,
        color: Option<Rgb>,
        texture: Option<&TextureDesc>,
        default: Rgb,
    ) -> Result<Texture, SceneError> {
        if color.is_some() && texture.is_some() {
            return Err(self.err(&path.key("texture"), "give either `color` or `texture`, not both"));
        }
        match texture {
            None => Ok(Texture::Constant(self.color(&path.key("color"), color.unwrap_or(default))?)),
            Some(t) => self.texture_of(&path.key("texture"), t),
        }
    }

    /// The texture described at `t`.
    fn texture_of(&self, t: &FieldPath, texture: &TextureDesc) -> Result<Texture, SceneError> {
        Ok(match texture {
            TextureDesc::Checker { color1, color2, size } => Texture::Checker {
                color1: self.color(&t.key("color1"), *color1)?,
                color2: self.color(&t.key("color2"), *color2)?,
                size: self.positive(&t.key("size"), *size)?,
            },
            TextureDesc::Image { file, scale, offset, wrap, filter, colorspace } => {
                let scale = Vec2::new(
                    self.non_zero(&t.key("scale").index(0), scale[0])?,
                    self.non_zero(&t.key("scale").index(1), scale[1])?,
                );
                let offset = Vec2::new(
                    self.finite(&t.key("offset").index(0), offset[0])?,
                    self.finite(&t.key("offset").index(1), offset[1])?,
                );
                let colorspace = colorspace.map(|c| match c {
                    ColorSpaceDesc::Srgb => ColorSpace::Srgb,
                    ColorSpaceDesc::Linear => ColorSpace::Linear,
                });
                let map = self.image(&t.key("file"), file, colorspace)?;
                Texture::Image(ImageTexture {
                    map,
                    scale,
                    offset,
                    wrap: match wrap {
                        WrapDesc::Repeat => Wrap::Repeat,
                        WrapDesc::Clamp => Wrap::Clamp,
                    },
                    filter: match filter {
                        FilterDesc::Bilinear => Filter::Bilinear,
                        FilterDesc::Nearest => Filter::Nearest,
                    },
                })
            }
        })
    }

    /// The path of a file named in the scene: relative to the scene file's folder.
    fn resolve(&self, file: &str) -> PathBuf {
        match &self.dir {
            Some(d) => d.join(file),
            None => PathBuf::from(file),
        }
    }

    /// The bytes of the regular file `full` named at `path` (a device or a pipe is refused: it
    /// might never end); `what` names the kind of file expected.
    fn read_input(&self, path: &FieldPath, full: &Path, what: &str) -> Result<Vec<u8>, SceneError> {
        self.regular_file(path, full, what, "")?;
        std::fs::read(full).map_err(|e| self.err(path, format!("cannot read {}: {e}", full.display())))
    }

    /// Whether the file `full` named at `path` is a regular file (a device such as `/dev/zero` or
    /// a pipe is refused: reading it might never end); `what` names the kind of file expected,
    /// `kind` prefixes the file in the message when it cannot be read (`"OBJ file "`).
    fn regular_file(&self, path: &FieldPath, full: &Path, what: &str, kind: &str) -> Result<(), SceneError> {
        match std::fs::metadata(full) {
            Ok(m) if m.is_file() => Ok(()),
            Ok(_) => {
                Err(self.err(path, format!("{} is not a regular file ({what} is expected)", full.display())))
            }
            Err(e) => Err(self.err(path, format!("cannot read {kind}{}: {e}", full.display()))),
        }
    }

    /// The texels of image `file` named at `path`, decoded once per scene and colour space.
    fn image(
        &self,
        path: &FieldPath,
        file: &str,
        colorspace: Option<ColorSpace>,
    ) -> Result<Arc<ImageMap>, SceneError> {
        let full = self.resolve(file);
        let key = (full.clone(), colorspace);
        if let Some(map) = self.images.borrow().maps.get(&key) {
            return Ok(map.clone());
        }
        let bytes = self.read_input(path, &full, "a PNG, JPEG or OpenEXR image")?;
        let map = Arc::new(ImageMap::decode(&full, &bytes, colorspace).map_err(|e| self.err(path, e))?);
        let mut cache = self.images.borrow_mut();
        cache.hashes.entry(full).or_insert_with(|| content_hash_bytes(&bytes));
        cache.maps.insert(key, map.clone());
        Ok(map)
    }

    fn material(&self, path: &FieldPath, name: &str, m: &MaterialDesc) -> Result<Material, SceneError> {
        let (bsdf, phong) = match m {
            MaterialDesc::Diffuse { color, texture, one_sided, phong, .. } => {
                let albedo = self.texture(path, *color, texture.as_ref(), Rgb::Grey(0.8))?;
                (Bsdf::Diffuse { albedo, one_sided: *one_sided }, phong)
            }
            MaterialDesc::Mirror { color, texture, roughness, phong } => {
                let color = self.texture(path, *color, texture.as_ref(), Rgb::Grey(1.0))?;
                (
                    Bsdf::Mirror { color, roughness: self.roughness(&path.key("roughness"), *roughness)? },
                    phong,
                )
            }
            MaterialDesc::Conductor {
                metal,
                eta,
                k,
                ior_outside,
                specular_reflectance,
                alpha,
                distribution,
                phong,
            } => {
                let conductor = Conductor {
                    index: self.complex_ior(path, metal.as_deref(), *eta, *k)?,
                    ior_outside: self.positive(&path.key("ior_outside"), *ior_outside)?,
                    specular_reflectance: self.reflectance(
                        &path.key("specular_reflectance"),
                        specular_reflectance.unwrap_or(Rgb::Grey(1.0)),
                    )?,
                    alpha: self.roughness(&path.key("alpha"), *alpha)?,
                    distribution: match distribution {
                        DistributionDesc::Beckmann => Distribution::Beckmann,
                        DistributionDesc::Ggx => Distribution::Ggx,
                    },
                };
                (Bsdf::Conductor(conductor), phong)
            }
            MaterialDesc::Dielectric {
                ior,
                ior_outside,
                absorption,
                absorption_outside,
                roughness,
                alpha,
                distribution,
                phong,
            } => {
                let inside = Medium {
                    ior: self.ior(&path.key("ior"), ior)?,
                    absorption: self.color(&path.key("absorption"), *absorption)?,
                };
                let outside = Medium {
                    ior: self.ior(&path.key("ior_outside"), ior_outside)?,
                    absorption: self.color(&path.key("absorption_outside"), *absorption_outside)?,
                };
                let roughness = match (roughness, alpha) {
                    (Some(_), Some(_)) => {
                        return Err(self.err(&path.key("alpha"), "give `roughness` or `alpha`, not both"))
                    }
                    (Some(r), None) => self.roughness(&path.key("roughness"), *r)?,
                    // α = roughness²: the distribution's width as Mitsuba gives it.
                    (None, Some(a)) => self.roughness(&path.key("alpha"), *a)?.sqrt(),
                    (None, None) => 0.0,
                };
                let distribution = match distribution {
                    None | Some(DistributionDesc::Ggx) => Distribution::Ggx,
                    Some(DistributionDesc::Beckmann) => Distribution::Beckmann,
                };
                (Bsdf::Dielectric { inside, outside, roughness, distribution }, phong)
            }
            MaterialDesc::ThinDielectric { ior, ior_outside, phong } => {
                let ior = self.positive(&path.key("ior"), *ior)?;
                let ior_outside = self.positive(&path.key("ior_outside"), *ior_outside)?;
                (Bsdf::ThinDielectric { ior, ior_outside }, phong)
            }
            MaterialDesc::Plastic {
                diffuse_reflectance,
                specular_reflectance,
                ior,
                ior_outside,
                nonlinear,
                two_sided,
                phong,
            } => {
                let (diffuse, specular, ior, ior_outside) =
                    self.plastic_layers(path, diffuse_reflectance, specular_reflectance, *ior, *ior_outside)?;
                (
                    Bsdf::Plastic {
                        diffuse,
                        specular,
                        ior,
                        ior_outside,
                        nonlinear: *nonlinear,
                        two_sided: *two_sided,
                    },
                    phong,
                )
            }
            MaterialDesc::RoughPlastic {
                diffuse_reflectance,
                specular_reflectance,
                ior,
                ior_outside,
                nonlinear,
                two_sided,
                alpha,
                distribution,
                phong,
            } => {
                let (diffuse, specular, ior, ior_outside) =
                    self.plastic_layers(path, diffuse_reflectance, specular_reflectance, *ior, *ior_outside)?;
                if ior == ior_outside {
                    return Err(self.err(
                        &path.key("ior"),
                        format!("the coating's index must differ from the outside's (both {ior})"),
                    ));
                }
                let alpha = self.roughness(&path.key("alpha"), *alpha)?;
                if alpha == 0.0 {
                    return Err(self
                        .err(&path.key("alpha"), "must be greater than 0 (a smooth coating is `plastic`)"));
                }
                let distribution = match distribution {
                    DistributionDesc::Beckmann => Distribution::Beckmann,
                    DistributionDesc::Ggx => Distribution::Ggx,
                };
                let bsdf = Bsdf::rough_plastic(
                    diffuse,
                    specular,
                    ior,
                    ior_outside,
                    *nonlinear,
                    *two_sided,
                    alpha,
                    distribution,
                );
                (bsdf, phong)
            }
        };
        let phong = self.phong(path, phong, &bsdf)?;
        Ok(Material { name: name.to_string(), bsdf, phong })
    }

    /// A conductor's complex index: a named metal, or `eta` and `k` together (η, k ≥ 0, not both
    /// 0 in a channel), or by default `none`.
    fn complex_ior(
        &self,
        path: &FieldPath,
        metal: Option<&str>,
        eta: Option<Rgb>,
        k: Option<Rgb>,
    ) -> Result<ComplexIor, SceneError> {
        match (metal, eta, k) {
            (Some(name), None, None) => ComplexIor::named(name).ok_or_else(|| {
                self.err(
                    &path.key("metal"),
                    format!("unknown metal `{name}`; the built-in ones are {}", METAL_NAMES.join(", ")),
                )
            }),
            (None, None, None) => Ok(ComplexIor::named("none").expect("`none` is built in")),
            (None, Some(eta), Some(k)) => {
                let eta = self.color(&path.key("eta"), eta)?;
                let k = self.color(&path.key("k"), k)?;
                if (eta + k).min_element() <= 0.0 {
                    return Err(self.err(&path.key("eta"), "η and k cannot both be 0 in a channel"));
                }
                Ok(ComplexIor::rgb(eta, k))
            }
            (Some(_), _, _) => {
                Err(self.err(&path.key("metal"), "give either `metal` or `eta` and `k`, not both"))
            }
            (None, _, _) => Err(self.err(
                &path.key(if eta.is_none() { "eta" } else { "k" }),
                "give `eta` and `k` together (or a `metal`)",
            )),
        }
    }

    /// The layers both plastics share, checked at the material `path`: the base's diffuse
    /// reflectance (default 0.5), the coating's specular scale (default 1), its index and the
    /// outside's.
    fn plastic_layers(
        &self,
        path: &FieldPath,
        diffuse: &Option<Rgb>,
        specular: &Option<Rgb>,
        ior: f32,
        ior_outside: f32,
    ) -> Result<(Vec3, Vec3, f32, f32), SceneError> {
        Ok((
            self.reflectance(&path.key("diffuse_reflectance"), diffuse.unwrap_or(Rgb::Grey(0.5)))?,
            self.reflectance(&path.key("specular_reflectance"), specular.unwrap_or(Rgb::Grey(1.0)))?,
            self.positive(&path.key("ior"), ior)?,
            self.positive(&path.key("ior_outside"), ior_outside)?,
        ))
    }

    /// A reflectance: every channel in [0, 1].
    fn reflectance(&self, path: &FieldPath, c: Rgb) -> Result<Vec3, SceneError> {
        let v = self.color(path, c)?;
        if v.max_element() > 1.0 {
            return Err(self.err(path, format!("must be in [0, 1] per channel (got {v})")));
        }
        Ok(v)
    }

    /// The `transform` table of an object, checked.
    fn transform(&self, path: &FieldPath, t: &TransformDesc) -> Result<Transform, SceneError> {
        if let Some(m) = &t.matrix {
            if t.scale.is_some() || t.rotate.is_some() || t.translate.is_some() {
                return Err(self.err(
                    &path.key("matrix"),
                    "a matrix is the whole transform: give `matrix` alone, or `scale`, `rotate` and \
                     `translate` without it",
                ));
            }
            return self.matrix(&path.key("matrix"), m);
        }
        let scale = match t.scale {
            None => Vec3::ONE,
            Some(s) => {
                let axes = s.axes();
                if let Some(bad) = axes.iter().find(|x| **x <= 0.0) {
                    return Err(self.err(
                        &path.key("scale"),
                        format!(
                            "every factor must be greater than 0 (got {bad}): a zero scale flattens the \
                             object and a negative one mirrors it inside out"
                        ),
                    ));
                }
                Vec3::from_array(axes)
            }
        };
        let rotation = match t.rotate {
            None => None,
            Some(r) => Some(rotation(self.direction(&path.key("rotate").key("axis"), r.axis)?, r.angle)),
        };
        let translate = t.translate.map_or(Vec3::ZERO, Vec3::from_array);
        Ok(Transform { scale, rotation, matrix: None, translate })
    }

    /// A `transform.matrix`, checked: 16 finite numbers, row by row, the last row `[0, 0, 0, 1]`
    /// and the 3×3 block invertible without mirroring.
    fn matrix(&self, path: &FieldPath, m: &[f32; 16]) -> Result<Transform, SceneError> {
        if let Some(bad) = m.iter().find(|x| !x.is_finite()) {
            return Err(self.err(path, format!("every entry must be a finite number (got {bad})")));
        }
        if m[12..] != [0.0, 0.0, 0.0, 1.0] {
            return Err(self.err(
                path,
                format!(
                    "the last row must be [0, 0, 0, 1] (an affine map; got {:?}): projective maps are not \
                     supported",
                    &m[12..]
                ),
            ));
        }
        let row = |i: usize| Vec3::new(m[4 * i], m[4 * i + 1], m[4 * i + 2]);
        let linear = glam::Mat3::from_cols(row(0), row(1), row(2)).transpose();
        let det = f64::from(linear.determinant());
        // The volume relative to the box of its rows: near 0 for a nearly singular matrix.
        let volume = f64::from(row(0).length()) * f64::from(row(1).length()) * f64::from(row(2).length());
        // (Finite entries: the determinant is finite, never NaN.)
        if det <= 1e-6 * volume || !linear.inverse().is_finite() {
            let what = if det < 0.0 && det.abs() > 1e-6 * volume {
                "mirrors (negative determinant), which turns an object inside out"
            } else {
                "is singular or nearly so (it flattens the object)"
            };
            return Err(self.err(path, format!("the 3×3 part of the matrix {what} (determinant {det:e})")));
        }
        Ok(Transform::affine(linear, Vec3::new(m[3], m[7], m[11])))
    }

    /// The surfaces of a round shape or body (`object_space`: as written) under the general
    /// affine map `t`, each intersected in its object space.
    fn affine_surfaces(
        &self,
        path: &FieldPath,
        object_space: Vec<BodySurface>,
        t: &Transform,
    ) -> Result<Vec<BodySurface>, SceneError> {
        object_space
            .into_iter()
            .map(|(shape, interface)| {
                let placed = AffineShape::new(shape, t.linear(), t.translate).ok_or_else(|| {
                    self.err(&path.key("transform"), "the transform is singular, mirrors or is not finite")
                })?;
                Ok((Shape::Affine(Box::new(placed)), interface))
            })
            .collect()
    }

    /// An analytic shape (or composite body) with `t` applied to its defining numbers: points
    /// transformed, directions rotated, lengths scaled. A quad's edges and a polygon's vertices
    /// take any transform; the round shapes (spheres, cylinders, disks and the bodies made of
    /// them) come here only under a similarity, whose one factor scales their lengths (a general
    /// map goes to [`AffineShape`]). A mesh is returned as it is (its vertices are transformed as
    /// it loads).
    fn placed(&self, shape: &ShapeDesc, t: &Transform) -> ShapeDesc {
        let point = |x: &Vec3Desc| t.point(Vec3::from_array(*x)).to_array();
        let edge = |x: &Vec3Desc| t.vector(Vec3::from_array(*x)).to_array();
        let direction = |x: &Vec3Desc| t.rotate(Vec3::from_array(*x)).to_array();
        let s = t.scale.x;
        debug_assert!(!is_round(shape) || t.uniform_scale().is_some(), "a round shape under a general map");
        match shape {
            ShapeDesc::Sphere { center, radius } => {
                ShapeDesc::Sphere { center: point(center), radius: radius * s }
            }
            ShapeDesc::Cylinder { base, top, axis, radius, height, caps, flip_normals, seam } => {
                ShapeDesc::Cylinder {
                    base: point(base),
                    top: top.as_ref().map(point),
                    axis: axis.as_ref().map(direction),
                    radius: radius * s,
                    height: height.map(|h| h * s),
                    caps: *caps,
                    flip_normals: *flip_normals,
                    seam: seam.as_ref().map(direction),
                }
            }
            ShapeDesc::Disk { center, normal, radius, inner_radius, seam } => ShapeDesc::Disk {
                center: point(center),
                normal: direction(normal),
                radius: radius * s,
                inner_radius: inner_radius * s,
                seam: seam.as_ref().map(direction),
            },
            ShapeDesc::Quad { corner, u, v } => {
                ShapeDesc::Quad { corner: point(corner), u: edge(u), v: edge(v) }
            }
            ShapeDesc::Polygon { vertices } => {
                ShapeDesc::Polygon { vertices: vertices.iter().map(point).collect() }
            }
            ShapeDesc::Mesh { .. } => shape.clone(),
            ShapeDesc::HollowSphere { center, radius, inner_radius } => ShapeDesc::HollowSphere {
                center: point(center),
                radius: radius * s,
                inner_radius: inner_radius * s,
            },
            ShapeDesc::Bowl { center, axis, radius, thickness, fill, liquid } => ShapeDesc::Bowl {
                center: point(center),
                axis: direction(axis),
                radius: radius * s,
                thickness: thickness * s,
                fill: fill.map(|f| f * s),
                liquid: liquid.clone(),
            },
            ShapeDesc::DrinkingGlass { base, axis, radius, height, wall, bottom, fill, liquid } => {
                ShapeDesc::DrinkingGlass {
                    base: point(base),
                    axis: direction(axis),
                    radius: radius * s,
                    height: height * s,
                    wall: wall * s,
                    bottom: bottom * s,
                    fill: fill.map(|f| f * s),
                    liquid: liquid.clone(),
                }
            }
        }
    }

    /// The surfaces of a shape; `transform` places a mesh (analytic shapes arrive placed).
    fn shape(
        &self,
        path: &FieldPath,
        shape: &ShapeDesc,
        transform: Option<&Transform>,
        warnings: &mut Vec<String>,
        inputs: &mut Vec<String>,
        attributes: &mut Vec<VertexAttributes>,
    ) -> Result<Vec<BodySurface>, SceneError> {
        let v = Vec3::from_array;
        Ok(match shape {
            ShapeDesc::Sphere { center, radius } => {
                let r = self.positive(&path.key("radius"), *radius)?;
                vec![(Shape::Sphere(Box::new(Sphere::new(v(*center), r))), Interface::Material)]
            }
            ShapeDesc::Cylinder { base, top, axis, radius, height, caps, flip_normals, seam } => {
                let r = self.positive(&path.key("radius"), *radius)?;
                let mut surfaces = match (top, height) {
                    (Some(top), None) if axis.is_none() => {
                        let top = self.finite_vector(&path.key("top"), *top)?;
                        if top == v(*base) {
                            return Err(self.err(&path.key("top"), "must differ from base"));
                        }
                        bodies::cylinder_between(v(*base), top, r, *caps, *flip_normals)
                    }
                    (None, Some(height)) => {
                        let axis = self
                            .direction(&path.key("axis"), axis.unwrap_or_else(super::desc::default_axis))?;
                        let h = self.positive(&path.key("height"), *height)?;
                        bodies::cylinder(v(*base), axis, r, h, *caps, *flip_normals)
                    }
                    (Some(_), _) => {
                        return Err(self
                            .err(&path.key("top"), "replaces axis and height: give top, or axis and height"))
                    }
                    (None, None) => {
                        return Err(
                            self.err(path, "a cylinder needs `height` (with `axis`, default +Y) or `top`")
                        )
                    }
                };
                if let (Some(seam), (Shape::Cylinder(wall), _)) = (seam, &mut surfaces[0]) {
                    **wall = wall.with_seam(v(*seam)).ok_or_else(|| self.along_axis(&path.key("seam")))?;
                }
                surfaces
            }
            ShapeDesc::Disk { center, normal, radius, inner_radius, seam } => {
                let n = self.direction(&path.key("normal"), *normal)?;
                let r = self.positive(&path.key("radius"), *radius)?;
                let ri = self.non_negative(&path.key("inner_radius"), *inner_radius)?;
                if ri >= r {
                    return Err(self.err(
                        &path.key("inner_radius"),
                        format!("must be smaller than radius {r} (got {ri})"),
                    ));
                }
                let mut disk = Disk::new(v(*center), n, r, ri).with_given_normal(v(*normal));
                if let Some(seam) = seam {
                    disk = disk.with_seam(v(*seam)).ok_or_else(|| self.along_axis(&path.key("seam")))?;
                }
                vec![(Shape::Disk(Box::new(disk)), Interface::Material)]
            }
            ShapeDesc::Quad { corner, u, v: edge_v } => {
                let (u, ev) = (v(*u), v(*edge_v));
                if parallelogram_normal(u, ev).is_none() {
                    return Err(self.err(
                        &path.key("u"),
                        "u and v must be non-zero and not parallel (the quad has no area)",
                    ));
                }
                vec![(Shape::Quad(Box::new(Quad::new(v(*corner), u, ev))), Interface::Material)]
            }
            ShapeDesc::Polygon { vertices } => {
                let verts = vertices.iter().map(|p| v(*p)).collect();
                let polygon = Polygon::new(verts).map_err(|e| self.err(&path.key("vertices"), e))?;
                vec![(Shape::Polygon(Box::new(polygon)), Interface::Material)]
            }
            ShapeDesc::Mesh { file, scale, translate, face_normals, smooth_normals, flip_normals } => {
                if *face_normals && *smooth_normals != SmoothNormals::Off {
                    return Err(self.err(
                        &path.key("smooth_normals"),
                        "face_normals and smooth_normals exclude each other: give at most one",
                    ));
                }
                let scale = self.positive(&path.key("scale"), *scale)?;
                let full = self.resolve(file);
                self.regular_file(&path.key("file"), &full, "an OBJ file", "OBJ file ")?;
                let placement =
                    MeshPlacement { scale, translate: v(*translate), transform: transform.copied() };
                let mesh =
                    super::mesh::load_mesh(&full, &placement).map_err(|e| self.err(&path.key("file"), e))?;
                let mut mesh = mesh;
                if *face_normals {
                    // Flat shading: the file's vertex normals are dropped, uv kept.
                    mesh.attributes.iter_mut().for_each(|a| a.normals = None);
                    mesh.has_normals = false;
                }
                match smooth_normals {
                    SmoothNormals::Off => {}
                    SmoothNormals::Replace => mesh.recompute_smooth_normals(false),
                    SmoothNormals::WhereMissing if !mesh.has_normals => mesh.recompute_smooth_normals(true),
                    SmoothNormals::WhereMissing => {}
                }
                if *flip_normals {
                    mesh.flip_normals();
                }
                let (triangles, degenerate) = (mesh.triangles, mesh.degenerate);
                if mesh.has_uv || mesh.has_normals {
                    *attributes = mesh.attributes;
                }
                inputs.push(mesh.hash);
                if degenerate > 0 {
                    warnings.push(format!(
                        "{path}: skipped {degenerate} degenerate triangle(s) in {}",
                        full.display()
                    ));
                }
                triangles.into_iter().map(|t| (Shape::Triangle(t), Interface::Material)).collect()
            }
            ShapeDesc::HollowSphere { center, radius, inner_radius } => {
                let r = self.positive(&path.key("radius"), *radius)?;
                let ri = self.positive(&path.key("inner_radius"), *inner_radius)?;
                if ri >= r {
                    return Err(self.err(
                        &path.key("inner_radius"),
                        format!("must be smaller than radius {r} (got {ri})"),
                    ));
                }
                bodies::hollow_sphere(v(*center), r, ri)
            }
            ShapeDesc::Bowl { center, axis, radius, thickness, fill, .. } => {
                let axis = self.direction(&path.key("axis"), *axis)?;
                let r = self.positive(&path.key("radius"), *radius)?;
                let t = self.positive(&path.key("thickness"), *thickness)?;
                if t >= r || r - t >= r {
                    return Err(self.err(
                        &path.key("thickness"),
                        format!("must be smaller than radius {r} and large enough to change it (got {t})"),
                    ));
                }
                let inner = r - t;
                if let Some(d) = *fill {
                    if !(d >= 0.0 && d < inner) {
                        return Err(self.err(
                            &path.key("fill"),
                            format!(
                                "the liquid's depth below the rim plane must be in [0, {inner}) (0: full to \
                                 the rim; the inner radius {inner}: empty) (got {d})"
                            ),
                        ));
                    }
                }
                bodies::bowl(v(*center), axis, r, t, *fill)
            }
            ShapeDesc::DrinkingGlass { base, axis, radius, height, wall, bottom, fill, .. } => {
                let axis = self.direction(&path.key("axis"), *axis)?;
                let r = self.positive(&path.key("radius"), *radius)?;
                let h = self.positive(&path.key("height"), *height)?;
                let w = self.positive(&path.key("wall"), *wall)?;
                let b = self.positive(&path.key("bottom"), *bottom)?;
                if w >= r || r - w >= r {
                    return Err(
                        self.err(&path.key("wall"), format!("must be smaller than radius {r} (got {w})"))
                    );
                }
                if b >= h || h - b >= h {
                    return Err(
                        self.err(&path.key("bottom"), format!("must be smaller than height {h} (got {b})"))
                    );
                }
                let cavity = h - b;
                if let Some(f) = *fill {
                    if !(f > 0.0 && f <= cavity) {
                        return Err(self.err(
                            &path.key("fill"),
                            format!(
                                "the liquid's height above the cavity floor must be in (0, {cavity}] \
                                 (height − bottom: full to the rim) (got {f})"
                            ),
                        ));
                    }
                }
                bodies::drinking_glass(v(*base), axis, [r, h, w, b], *fill)
            }
        })
    }

    /// The liquid of a filled vessel (`fill` and `liquid` of a bowl or drinking glass), checked:
    /// `None` for an empty one. The vessel's material must be a dielectric.
    fn liquid(
        &self,
        path: &FieldPath,
        shape: &ShapeDesc,
        body: &Material,
    ) -> Result<Option<Liquid>, SceneError> {
        let (fill, liquid) = match shape {
            ShapeDesc::Bowl { fill, liquid, .. } | ShapeDesc::DrinkingGlass { fill, liquid, .. } => {
                (fill, liquid)
            }
            _ => return Ok(None),
        };
        if fill.is_none() {
            return match liquid {
                Some(_) => {
                    Err(self
                        .err(&path.key("liquid"), "a liquid needs `fill`, the level it fills the vessel to"))
                }
                None => Ok(None),
            };
        }
        if !matches!(body.bsdf, Bsdf::Dielectric { .. }) {
            return Err(self.err(
                &path.key("material"),
                format!("a filled vessel must be made of a dielectric (`{}` is not one)", body.name),
            ));
        }
        let at = path.key("liquid");
        Ok(Some(match liquid.as_ref().unwrap_or(&LiquidDesc::Named("water".into())) {
            LiquidDesc::Named(name) => {
                let Some(&(name, n)) = LIQUIDS.iter().find(|(l, _)| l.eq_ignore_ascii_case(name)) else {
                    let known: Vec<&str> = LIQUIDS.iter().map(|l| l.0).collect();
                    return Err(self.err(
                        &at,
                        format!(
                            "unknown liquid `{name}`; known: {} (or a table {{ ior = 1.333, absorption = [r, g, b] }})",
                            known.join(", ")
                        ),
                    ));
                };
                Liquid { name: name.to_string(), medium: Medium::clear(n) }
            }
            LiquidDesc::Medium { ior, absorption } => Liquid {
                name: "liquid".into(),
                medium: Medium {
                    ior: self.ior(&at.key("ior"), ior)?,
                    absorption: self.color(&at.key("absorption"), *absorption)?,
                },
            },
        }))
    }

    /// A light's area must be a finite, normal positive number: sampling a point on it divides
    /// by it.
    fn emitter_area(&self, path: &FieldPath, area: f32) -> Result<(), SceneError> {
        if !area.is_finite() {
            Err(self.err(path, "the light is too large: its area overflows single precision"))
        } else if area < f32::MIN_POSITIVE {
            Err(self.err(
                path,
                format!(
                    "the light is too small: its area ({area:?}) underflows single precision (it must be at \
                     least {:e})",
                    f32::MIN_POSITIVE
                ),
            ))
        } else {
            Ok(())
        }
    }

    /// A light's power (the environment's mean radiance) must be finite (`vitrum info` shows it;
    /// light tracing starts from it).
    fn finite_power(&self, path: &FieldPath, light: &Light) -> Result<(), SceneError> {
        let strength = light.strength();
        if strength.value().is_finite() {
            return Ok(());
        }
        let message = match strength {
            Strength::Power(p) => {
                format!("the light's power ({p} W) overflows single precision: make it dimmer or smaller")
            }
            Strength::MeanRadiance(r) => format!(
                "the environment's mean radiance ({r} W/(m²·sr)) overflows single precision: lower its \
                 `scale` or its texels"
            ),
            Strength::Irradiance(e) => format!("the irradiance ({e} W/m²) must be finite"),
        };
        Err(self.err(path, message))
    }

    fn light(&self, path: &FieldPath, l: &LightDesc) -> Result<Light, SceneError> {
        let light = self.light_unchecked(path, l)?;
        match &light {
            Light::Quad { u, v, .. } => self.emitter_area(&path.key("u"), u.cross(*v).length())?,
            Light::Sphere { radius, .. } => {
                self.emitter_area(&path.key("radius"), 4.0 * std::f32::consts::PI * radius * radius)?
            }
            _ => {}
        }
        let strength = match l {
            LightDesc::Point { .. } | LightDesc::Spot { .. } => "intensity",
            LightDesc::Directional { .. } => "irradiance",
            LightDesc::Environment { file: Some(_), .. } => "file",
            _ => "radiance",
        };
        self.finite_power(&path.key(strength), &light)?;
        Ok(light)
    }

    fn light_unchecked(&self, path: &FieldPath, l: &LightDesc) -> Result<Light, SceneError> {
        let v = Vec3::from_array;
        Ok(match l {
            LightDesc::Point { position, intensity } => Light::Point {
                position: v(*position),
                intensity: self.color(&path.key("intensity"), *intensity)?,
            },
            LightDesc::Spot { position, direction, look_at, intensity, cutoff_angle, beam_width } => {
                let position = v(*position);
                let direction = match (direction, look_at) {
                    (Some(d), None) => self.direction(&path.key("direction"), *d)?,
                    (None, Some(target)) => try_unit(v(*target) - position).ok_or_else(|| {
                        self.err(&path.key("look_at"), "must differ from `position` (the beam needs an axis)")
                    })?,
                    (Some(_), Some(_)) => {
                        return Err(
                            self.err(&path.key("look_at"), "give either `direction` or `look_at`, not both")
                        )
                    }
                    (None, None) => {
                        return Err(self.err(path, "a spot light needs a `direction` or a `look_at` point"))
                    }
                };
                let cutoff = *cutoff_angle;
                if !(cutoff > 0.0 && cutoff <= 180.0) {
                    return Err(self.err(
                        &path.key("cutoff_angle"),
                        format!("must be an angle in degrees in (0, 180] (got {cutoff})"),
                    ));
                }
                let beam_width = beam_width.unwrap_or(SpotBeam::default_beam_width(cutoff));
                let beam = SpotBeam::from_degrees(cutoff, beam_width).ok_or_else(|| {
                    self.err(
                        &path.key("beam_width"),
                        format!(
                            "must be an angle in degrees in [0, cutoff_angle = {cutoff}] (got {beam_width})"
                        ),
                    )
                })?;
                Light::Spot {
                    position,
                    direction,
                    intensity: self.color(&path.key("intensity"), *intensity)?,
                    beam,
                }
            }
            LightDesc::Directional { direction, irradiance } => Light::Directional {
                direction: self.direction(&path.key("direction"), *direction)?,
                irradiance: self.color(&path.key("irradiance"), *irradiance)?,
            },
            LightDesc::Quad { corner, u, v: ev, radiance } => {
                let (u, ev) = (v(*u), v(*ev));
                let normal = parallelogram_normal(u, ev).ok_or_else(|| {
                    self.err(
                        &path.key("u"),
                        "u and v must be non-zero and not parallel (a light needs an area > 0)",
                    )
                })?;
                Light::Quad {
                    corner: v(*corner),
                    u,
                    v: ev,
                    normal,
                    radiance: self.color(&path.key("radiance"), *radiance)?,
                }
            }
            LightDesc::Environment { radiance, file, rotation, scale } => match (radiance, file) {
                (Some(radiance), None) => {
                    if *scale != 1.0 || *rotation != 0.0 {
                        let key = if *scale != 1.0 { "scale" } else { "rotation" };
                        return Err(
                            self.err(&path.key(key), "`scale` and `rotation` apply to a map (`file`)")
                        );
                    }
                    Light::Environment { radiance: self.color(&path.key("radiance"), *radiance)?, map: None }
                }
                (None, Some(file)) => {
                    let scale = self.positive(&path.key("scale"), *scale)?;
                    let rotation = self.finite(&path.key("rotation"), *rotation)?;
                    let image = self.image(&path.key("file"), file, None)?;
                    let map = EnvironmentMap::new(image, rotation);
                    Light::Environment { radiance: Vec3::splat(scale), map: Some(Arc::new(map)) }
                }
                (Some(_), Some(_)) => {
                    return Err(
                        self.err(&path.key("radiance"), "give either `radiance` or a map `file`, not both")
                    )
                }
                (None, None) => {
                    return Err(self.err(path, "an environment light needs `radiance` or a map `file`"))
                }
            },
            LightDesc::Sphere { center, radius, radiance } => Light::Sphere {
                center: v(*center),
                radius: self.positive(&path.key("radius"), *radius)?,
                radiance: self.color(&path.key("radiance"), *radiance)?,
            },
        })
    }
}

/// Record the effects a material asks for, on behalf of object `object`.
/// Whether a texture of the scene reads the uv of a hit: an image texture on a material (diffuse
/// albedo, mirror tint) or on an emitter. Checkers read the position, constants nothing.
fn reads_surface_uv(materials: &[Material], lights: &[Light]) -> bool {
    let material = materials.iter().any(|m| {
        matches!(
            &m.bsdf,
            Bsdf::Diffuse { albedo: Texture::Image(_), .. } | Bsdf::Mirror { color: Texture::Image(_), .. }
        )
    });
    let light = lights.iter().any(|l| matches!(l, Light::Surface { texture: Some(Texture::Image(_)), .. }));
    material || light
}

fn material_effects(effects: &mut Effects, m: &Material, object: usize) {
    let who = format!("objects[{object}] uses material `{}`", m.name);
    let texture = match &m.bsdf {
        Bsdf::Diffuse { albedo: t, .. } | Bsdf::Mirror { color: t, .. } => Some(t),
        Bsdf::Conductor(_)
        | Bsdf::Dielectric { .. }
        | Bsdf::ThinDielectric { .. }
        | Bsdf::Plastic { .. }
        | Bsdf::RoughPlastic { .. } => None,
    };
    match texture {
        Some(Texture::Checker { .. }) => effects.add(Effect::Textures, format!("{who}, a checker texture")),
        Some(Texture::Image(image)) => {
            effects.add(Effect::Textures, format!("{who}, an image texture ({})", image.map.file))
        }
        _ => {}
    }
    match &m.bsdf {
        Bsdf::Diffuse { .. } | Bsdf::ThinDielectric { .. } | Bsdf::Plastic { .. } => {}
        Bsdf::RoughPlastic { alpha, distribution, .. } => {
            let d = distribution.name();
            effects.add(Effect::Glossy, format!("{who}, a rough plastic ({d}, alpha {alpha})"));
        }
        Bsdf::Mirror { roughness, .. } => {
            if *roughness > 0.0 {
                effects.add(Effect::Glossy, format!("{who}, a rough mirror (roughness {roughness})"));
            }
        }
        Bsdf::Conductor(c) => {
            if c.is_rough() {
                let (alpha, d) = (c.alpha, c.distribution.name());
                effects.add(Effect::Glossy, format!("{who}, a rough conductor ({d}, alpha {alpha})"));
            }
        }
        Bsdf::Dielectric { inside, outside, roughness, distribution } => {
            if *roughness > 0.0 {
                let text = match distribution {
                    Distribution::Ggx => format!("roughness {roughness}"),
                    Distribution::Beckmann => format!("beckmann, alpha {}", roughness * roughness),
                };
                effects.add(Effect::Glossy, format!("{who}, rough glass ({text})"));
            }
            if inside.ior.is_dispersive() || outside.ior.is_dispersive() {
                effects.add(Effect::Dispersion, format!("{who}, whose index varies with wavelength"));
            }
            if inside.absorption != Vec3::ZERO || outside.absorption != Vec3::ZERO {
                effects.add(Effect::Absorption, format!("{who}, an absorbing medium"));
            }
        }
    }
}

/// Whether bounds lie within ±[`MAX_EXTENT`] (and so are finite).
fn within_extent(b: Bounds) -> bool {
    b.min.cmpge(Vec3::splat(-MAX_EXTENT)).all() && b.max.cmple(Vec3::splat(MAX_EXTENT)).all()
}

/// The geometry of an emissive object, for the shapes that can emit: `s` placed, and `surfaces`
/// the primitives compiled from it: a mesh's triangles, or the one surface of the other shapes,
/// whose texture frame (turned with a rotated object) the emitter's uv follows.
fn emitter_shape(s: &ShapeDesc, surfaces: &[BodySurface]) -> Option<EmitterShape> {
    let v = Vec3::from_array;
    if let ShapeDesc::Mesh { .. } = s {
        let triangles: Vec<_> = surfaces
            .iter()
            .filter_map(|(s, _)| match s {
                Shape::Triangle(t) => Some(*t),
                _ => None,
            })
            .collect();
        return EmitterMesh::new(&triangles).map(|m| EmitterShape::Mesh(Arc::new(m)));
    }
    match (s, surfaces.first().map(|(s, _)| s)) {
        (ShapeDesc::Sphere { center, radius }, Some(Shape::Sphere(sphere))) => {
            Some(EmitterShape::Sphere { center: v(*center), radius: *radius, frame: sphere.texture_frame() })
        }
        (ShapeDesc::Quad { corner, u, v: ev }, _) => {
            Some(EmitterShape::Quad { corner: v(*corner), u: v(*u), v: v(*ev) })
        }
        (ShapeDesc::Cylinder { .. }, Some(Shape::Cylinder(wall))) => {
            // The caps, if any, are the two disks after the wall (bottom, then top).
            let caps = match surfaces {
                [_, (Shape::Disk(bottom), _), (Shape::Disk(top), _)] => {
                    Some([bottom.texture_frame(), top.texture_frame()])
                }
                _ => None,
            };
            Some(EmitterShape::Cylinder {
                base: wall.base(),
                axis: wall.axis(),
                radius: wall.radius(),
                height: wall.height(),
                frame: wall.texture_frame(),
                caps,
                inward: wall.inward(),
            })
        }
        (ShapeDesc::Disk { center, normal, radius, inner_radius, .. }, Some(Shape::Disk(disk))) => {
            Some(EmitterShape::Disk {
                center: v(*center),
                normal: try_unit(v(*normal))?,
                radius: *radius,
                inner_radius: *inner_radius,
                frame: disk.texture_frame(),
            })
        }
        _ => None,
    }
}

/// The emitter of a round shape `s` (as written, in object space) placed by a general affine
/// map: its [`AffineShape`] surfaces' object-space shapes make the object's emitter, which the
/// map wraps ([`EmitterShape::Affine`]), with the world area of all its surfaces.
fn affine_emitter(s: &ShapeDesc, surfaces: &[BodySurface]) -> Option<EmitterShape> {
    let placed: Vec<&AffineShape> = surfaces
        .iter()
        .filter_map(|(s, _)| match s {
            Shape::Affine(a) => Some(&**a),
            _ => None,
        })
        .collect();
    let first = placed.first()?;
    let object: Vec<BodySurface> =
        surfaces.iter().zip(&placed).map(|((_, interface), a)| (a.object().clone(), *interface)).collect();
    let area = placed.iter().map(|a| f64::from(a.area())).sum::<f64>() as f32;
    let object = emitter_shape(s, &object)?;
    AffineEmitter::new(object, first.linear(), first.translation(), area)
        .map(|a| EmitterShape::Affine(Arc::new(a)))
}

/// Whether a shape is round (a sphere, cylinder or disk, or a body made of them): placed by
/// its defining numbers under a similarity, intersected in object space under any other map.
fn is_round(s: &ShapeDesc) -> bool {
    !matches!(s, ShapeDesc::Quad { .. } | ShapeDesc::Polygon { .. } | ShapeDesc::Mesh { .. })
}

/// Turns the texture frame of every placed surface to its unplaced twin's frame turned by
/// `rotation` (`unplaced` holds the same surfaces, in order, before a similarity placed them).
fn turn_texture_frames(placed: &mut [BodySurface], unplaced: &[BodySurface], rotation: glam::Mat3) {
    debug_assert_eq!(placed.len(), unplaced.len(), "a similarity keeps a body's surfaces");
    for ((shape, _), (twin, _)) in placed.iter_mut().zip(unplaced) {
        shape.turn_texture_frame(twin, rotation);
    }
}

/// The `shape = "..."` name of a shape description.
fn shape_kind(s: &ShapeDesc) -> &'static str {
    match s {
        ShapeDesc::Sphere { .. } => "sphere",
        ShapeDesc::Cylinder { .. } => "cylinder",
        ShapeDesc::Disk { .. } => "disk",
        ShapeDesc::Quad { .. } => "quad",
        ShapeDesc::Polygon { .. } => "polygon",
        ShapeDesc::Mesh { .. } => "mesh",
        ShapeDesc::HollowSphere { .. } => "hollow_sphere",
        ShapeDesc::Bowl { .. } => "bowl",
        ShapeDesc::DrinkingGlass { .. } => "drinking_glass",
    }
}

/// The power of two that maps the scene's extent to about 1000 BVH units.
fn scale_for_extent(extent: f32) -> f32 {
    if !(extent.is_finite() && extent > 0.0) {
        return 1.0;
    }
    2f32.powi((extent / 1000.0).log2().round().clamp(-100.0, 100.0) as i32)
}

/// Build the CwBvh over all primitives (in BVH units) and reorder them to BVH order.
fn build_bvh(
    primitives: Vec<Primitive>,
    shutter: (f32, f32),
) -> (Vec<Primitive>, obvhs::cwbvh::CwBvh, BvhStats) {
    let start = Instant::now();
    let bounds: Vec<_> = primitives.iter().map(|p| p.bounds_over(shutter)).collect();
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for b in &bounds {
        lo = lo.min(b.min);
        hi = hi.max(b.max);
    }
    let scale = scale_for_extent((hi - lo).max_element());
    let inv = 1.0 / scale;
    // Pad every box a little: shapes accept hits a few ulps beyond their exact edges (so seams
    // overlap) and the CwBvh's f32 slab test is not conservative by itself.
    let aabbs: Vec<Aabb> = bounds
        .iter()
        .map(|b| {
            let pad =
                BOX_PADDING * ((b.max - b.min).max_element() + b.min.abs().max(b.max.abs()).max_element());
            Aabb::new(Vec3A::from((b.min - pad) * inv), Vec3A::from((b.max + pad) * inv))
        })
        .collect();
    let mut core = Duration::ZERO;
    let bvh = build_cwbvh(&aabbs, BvhBuildParams::medium_build(), &mut core);
    let mut ordered = primitives;
    permute_in_place(&mut ordered, &bvh.primitive_indices);
    let stats = BvhStats {
        nodes: bvh.nodes.len(),
        primitives: ordered.len(),
        depth: cwbvh_depth(&bvh),
        build_seconds: start.elapsed().as_secs_f64(),
        bounds: if ordered.is_empty() { (Vec3::ZERO, Vec3::ZERO) } else { (lo, hi) },
        scale,
    };
    (ordered, bvh, stats)
}

/// Reorder `items` so that `items[k]` becomes the old `items[order[k]]`, without a copy of the
/// list (a mesh of a million triangles would need another 80 MB): `order` must be a permutation.
fn permute_in_place<T>(items: &mut [T], order: &[u32]) {
    assert_eq!(items.len(), order.len(), "the BVH holds every primitive once");
    let mut placed = vec![false; items.len()];
    for start in 0..items.len() {
        if placed[start] {
            continue;
        }
        // Follow the cycle through `start`: slot k receives the item at order[k].
        let mut k = start;
        loop {
            placed[k] = true;
            let from = order[k] as usize;
            if from == start {
                break;
            }
            items.swap(k, from);
            k = from;
        }
    }
}

/// Depth of a CwBvh's node tree.
fn cwbvh_depth(bvh: &obvhs::cwbvh::CwBvh) -> usize {
    if bvh.nodes.is_empty() {
        return 0;
    }
    let mut depth = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        depth = depth.max(d);
        let node = &bvh.nodes[i];
        let mut child = node.child_base_idx as usize;
        for slot in 0..8 {
            if node.is_child_empty(slot) {
                continue;
            }
            if node.is_leaf(slot) {
                continue;
            }
            stack.push((child, d + 1));
            child += 1;
        }
    }
    depth
}

/// The smooth dielectric objects of a scene, each with the bounding sphere of its smooth
/// dielectric primitives over the shutter interval: where manifold next-event estimation seeds
/// its chains ([`crate::manifold`]). In the order of the objects.
fn casters(
    primitives: &[Primitive],
    materials: &[Material],
    objects: usize,
    shutter: (f32, f32),
) -> Vec<crate::manifold::Caster> {
    let mut bounds: Vec<Option<Bounds>> = vec![None; objects];
    for p in primitives {
        if crate::manifold::is_caster(&materials[p.material as usize].bsdf) {
            let b = p.bounds_over(shutter);
            let slot = &mut bounds[p.object as usize];
            *slot = Some(slot.map_or(b, |s| Bounds { min: s.min.min(b.min), max: s.max.max(b.max) }));
        }
    }
    bounds
        .into_iter()
        .flatten()
        .map(|b| {
            let centre = (b.min + b.max) * 0.5;
            crate::manifold::Caster { centre, radius: (b.max - b.min).length() * 0.5 }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::permute_in_place;

    #[test]
    fn permuting_in_place_matches_gathering() {
        let mut state = 12345u64;
        for n in [0usize, 1, 2, 7, 100, 1000] {
            // A random permutation (Fisher–Yates with a xorshift).
            let mut order: Vec<u32> = (0..n as u32).collect();
            for i in (1..n).rev() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                order.swap(i, (state % (i as u64 + 1)) as usize);
            }
            let items: Vec<String> = (0..n).map(|i| format!("item {i}")).collect();
            let gathered: Vec<String> = order.iter().map(|&i| items[i as usize].clone()).collect();
            let mut permuted = items;
            permute_in_place(&mut permuted, &order);
            assert_eq!(permuted, gathered, "n = {n}");
        }
    }
}
