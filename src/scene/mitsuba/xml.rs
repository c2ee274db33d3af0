//! Mitsuba's XML scene format read into a tree of objects with typed properties, as Mitsuba 3
//! reads it: files of a version below 2.0 have their camelCase names upgraded to snake_case,
//! `<default>` and `$name` substitution, `<include>`, `<ref>` to an object defined before,
//! the property types `float`, `integer`, `boolean`, `string`, `rgb`, `spectrum`, `point`,
//! `vector` and `transform` (any composition of `matrix`, `lookat`, `translate`, `rotate` and
//! `scale`, each applied after the ones before it).
//!
//! Every error names the file, line and column of the element it is about. Hostile input is
//! bounded: files of at most [`MAX_SCENE_BYTES`](crate::scene::compile::MAX_SCENE_BYTES), nesting
//! of at most [`MAX_NESTING`] elements, includes at most [`MAX_INCLUDES`] deep and never cyclic,
//! at most [`MAX_OBJECTS`] objects in all.

use glam::{DMat4, DVec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Deepest nesting of elements accepted.
pub const MAX_NESTING: usize = 64;
/// Deepest chain of `<include>`s accepted.
pub const MAX_INCLUDES: usize = 16;
/// Most objects (plugins) a scene may hold, includes counted.
pub const MAX_OBJECTS: usize = 1 << 20;

/// Where something is in a scene file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Position {
    /// The file.
    pub file: Rc<str>,
    /// Line, from 1.
    pub line: u32,
    /// Column, from 1.
    pub column: u32,
}

impl std::fmt::Display for Position {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// An error in a Mitsuba file: where, in which element, and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct XmlError {
    /// Where.
    pub position: Position,
    /// The element, as `<shape type="sphere">`.
    pub element: String,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for XmlError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}: {}", self.position, self.element, self.message)
    }
}

/// A property's value.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// `<float>`.
    Float(f64),
    /// `<integer>`.
    Integer(i64),
    /// `<boolean>`.
    Boolean(bool),
    /// `<string>`.
    String(String),
    /// `<rgb>` (also Mitsuba 0.5's `<srgb>`, converted to linear).
    Rgb([f64; 3]),
    /// `<spectrum>` of one value for every wavelength.
    Constant(f64),
    /// `<spectrum>` as wavelength (nm) : value pairs, by increasing wavelength.
    Sampled(Vec<(f64, f64)>),
    /// `<point>`.
    Point(DVec3),
    /// `<vector>`.
    Vector(DVec3),
    /// `<transform>`: the composed matrix, object to world, and (origin, target, up) when it is
    /// one `lookat` alone (a camera placed by it keeps those exact numbers).
    Transform(DMat4, Option<[DVec3; 3]>),
}

impl Value {
    /// The property type's element name.
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Constant(_) | Value::Sampled(_) => "spectrum",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Transform(..) => "transform",
        }
    }
}

/// A named property of an object.
#[derive(Clone, Debug, PartialEq)]
pub struct Property {
    /// Its name (snake_case).
    pub name: String,
    /// Its value.
    pub value: Value,
    /// Where it is written.
    pub position: Position,
}

/// An object (a plugin instance): `<shape type="sphere">`, `<bsdf>`, `<emitter>`, ….
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// The element's tag: `scene`, `shape`, `bsdf`, `emitter`, `sensor`, `film`, `sampler`,
    /// `rfilter`, `integrator`, `texture`, `medium`, ….
    pub tag: String,
    /// The plugin (`type`); empty for the scene.
    pub plugin: String,
    /// Its `id`, if any.
    pub id: Option<String>,
    /// Its `name` as the child of another object (a texture given for `reflectance`), if any.
    pub name: Option<String>,
    /// Its properties, in file order.
    pub properties: Vec<Property>,
    /// Its nested objects (and objects referenced by `<ref>`), in file order.
    pub children: Vec<Rc<Object>>,
    /// Where it starts.
    pub position: Position,
}

impl Object {
    /// `<shape type="sphere">` (with its id when it has one), for messages.
    pub fn describe(&self) -> String {
        match (&self.id, self.plugin.is_empty()) {
            (_, true) => format!("<{}>", self.tag),
            (Some(id), false) => format!("<{} type=\"{}\" id=\"{id}\">", self.tag, self.plugin),
            (None, false) => format!("<{} type=\"{}\">", self.tag, self.plugin),
        }
    }

    /// The property called `name`, if given.
    pub fn property(&self, name: &str) -> Option<&Property> {
        self.properties.iter().find(|p| p.name == name)
    }

    /// The nested objects with tag `tag`.
    pub fn children_tagged<'a>(&'a self, tag: &'a str) -> impl Iterator<Item = &'a Rc<Object>> + 'a {
        self.children.iter().filter(move |c| c.tag == tag)
    }
}

/// A whole scene file with its version.
#[derive(Clone, Debug, PartialEq)]
pub struct Document {
    /// The `version` attribute of `<scene>`, (major, minor, patch).
    pub version: (u32, u32, u32),
    /// The `<scene>` object.
    pub scene: Object,
}

/// The tags of objects (plugins), as opposed to properties.
const OBJECT_TAGS: [&str; 12] = [
    "shape",
    "bsdf",
    "emitter",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "integrator",
    "texture",
    "medium",
    "phase",
    "volume",
];

/// Reads the scene file `path` with the `defaults` given from outside (`name → value`, which
/// take precedence over the file's `<default>`s).
pub fn read(path: &Path, defaults: &HashMap<String, String>) -> Result<Document, XmlError> {
    let file: Rc<str> = path.display().to_string().into();
    let text = read_text(path, &file, None)?;
    read_str(&text, &path.display().to_string(), Some(path), defaults)
}

/// Reads scene text named `name` in messages; `path` is its file, if any: `<include>`s are
/// resolved beside it (text without a file may include nothing).
pub fn read_str(
    text: &str,
    name: &str,
    path: Option<&Path>,
    defaults: &HashMap<String, String>,
) -> Result<Document, XmlError> {
    let mut reader =
        Reader { defaults: defaults.clone(), ids: HashMap::new(), objects: 0, includes: Vec::new() };
    let file: Rc<str> = name.into();
    let doc = parse_xml(text, &file)?;
    let root = doc.root_element();
    let at = |node: roxmltree::Node| position(&doc, &file, node);
    if root.tag_name().name() != "scene" {
        return Err(error(
            at(root),
            &format!("<{}>", root.tag_name().name()),
            "the root element must be <scene>",
        ));
    }
    let version_text = root.attribute("version").ok_or_else(|| {
        error(
            at(root),
            "<scene>",
            "has no `version` attribute (e.g. version=\"3.0.0\"), which says how to read the file",
        )
    })?;
    let version = parse_version(version_text).ok_or_else(|| {
        error(at(root), "<scene>", &format!("version `{version_text}` is not MAJOR.MINOR.PATCH"))
    })?;
    if let Some(path) = path {
        reader.includes.push(canonical(path));
    }
    let mut scene = Object {
        tag: "scene".into(),
        plugin: String::new(),
        id: None,
        name: None,
        properties: Vec::new(),
        children: Vec::new(),
        position: at(root),
    };
    let dir = path.map(|p| p.parent().unwrap_or(Path::new(".")));
    let context = Context { file: &file, dir, version, doc: &doc };
    reader.fill(&context, root, &mut scene, 1)?;
    Ok(Document { version, scene })
}

/// Where a file is read from and how.
struct Context<'a, 'input> {
    file: &'a Rc<str>,
    /// The folder includes are read from; `None` for text without a file.
    dir: Option<&'a Path>,
    version: (u32, u32, u32),
    doc: &'a roxmltree::Document<'input>,
}

/// The state of one read: substitutions, objects by id, the include chain and the object count.
struct Reader {
    defaults: HashMap<String, String>,
    ids: HashMap<String, Rc<Object>>,
    objects: usize,
    includes: Vec<PathBuf>,
}

impl Reader {
    /// Reads the children of `node` into `object` (`depth` the nesting of `node`).
    fn fill(
        &mut self,
        cx: &Context,
        node: roxmltree::Node,
        object: &mut Object,
        depth: usize,
    ) -> Result<(), XmlError> {
        for child in node.children().filter(roxmltree::Node::is_element) {
            let at = position(cx.doc, cx.file, child);
            let tag = child.tag_name().name();
            let describe = describe_element(child);
            if depth >= MAX_NESTING {
                return Err(error(at, &describe, &format!("elements nest deeper than {MAX_NESTING}")));
            }
            match tag {
                "default" => {
                    let name = self.attribute(cx, child, "name")?;
                    let value = self.attribute(cx, child, "value")?;
                    self.defaults.entry(name).or_insert(value);
                }
                "include" => self.include(cx, child, object, depth)?,
                "ref" => {
                    let id = self.attribute(cx, child, "id")?;
                    let target = self.ids.get(&id).cloned().ok_or_else(|| {
                        error(
                            at.clone(),
                            &describe,
                            &format!("no object with id `{id}` is defined before it"),
                        )
                    })?;
                    match child.attribute("name") {
                        Some(name) => {
                            let mut named = (*target).clone();
                            named.name = Some(upgrade_name(name, cx.version));
                            object.children.push(Rc::new(named));
                        }
                        None => object.children.push(target),
                    }
                }
                tag if OBJECT_TAGS.contains(&tag) => {
                    self.objects += 1;
                    if self.objects > MAX_OBJECTS {
                        return Err(error(at, &describe, &format!("more than {MAX_OBJECTS} objects")));
                    }
                    let plugin = self.attribute(cx, child, "type")?;
                    let id = child.attribute("id").map(|v| self.substitute(cx, child, v)).transpose()?;
                    let name = child.attribute("name").map(|n| upgrade_name(n, cx.version));
                    let mut nested = Object {
                        tag: tag.to_string(),
                        plugin,
                        id: id.clone(),
                        name,
                        properties: Vec::new(),
                        children: Vec::new(),
                        position: at.clone(),
                    };
                    self.fill(cx, child, &mut nested, depth + 1)?;
                    let nested = Rc::new(nested);
                    if let Some(id) = id {
                        if self.ids.insert(id.clone(), nested.clone()).is_some() {
                            return Err(error(at, &describe, &format!("the id `{id}` is defined twice")));
                        }
                    }
                    object.children.push(nested);
                }
                _ => {
                    let property = self.property(cx, child, depth)?;
                    if object.properties.iter().any(|p| p.name == property.name) {
                        return Err(error(at, &describe, &format!("`{}` is given twice", property.name)));
                    }
                    object.properties.push(property);
                }
            }
        }
        Ok(())
    }

    /// Reads the file of an `<include filename="…"/>` and adds its objects and properties.
    fn include(
        &mut self,
        cx: &Context,
        node: roxmltree::Node,
        object: &mut Object,
        depth: usize,
    ) -> Result<(), XmlError> {
        let at = position(cx.doc, cx.file, node);
        let describe = describe_element(node);
        let name = self.attribute(cx, node, "filename")?;
        let Some(dir) = cx.dir else {
            return Err(error(at, &describe, "scene text without a file includes nothing"));
        };
        let path = dir.join(&name);
        let key = canonical(&path);
        if self.includes.contains(&key) {
            return Err(error(at, &describe, &format!("`{name}` includes itself (a cycle of includes)")));
        }
        if self.includes.len() >= MAX_INCLUDES {
            return Err(error(at, &describe, &format!("includes nest deeper than {MAX_INCLUDES}")));
        }
        let file: Rc<str> = path.display().to_string().into();
        let text = read_text(&path, &file, Some((&at, &describe)))?;
        let doc = parse_xml(&text, &file)?;
        let root = doc.root_element();
        if root.tag_name().name() != "scene" {
            let at = position(&doc, &file, root);
            return Err(error(
                at,
                &describe_element(root),
                "an included file's root element must be <scene>",
            ));
        }
        let version = root.attribute("version").and_then(parse_version).unwrap_or(cx.version);
        let inner =
            Context { file: &file, dir: Some(path.parent().unwrap_or(Path::new("."))), version, doc: &doc };
        self.includes.push(key);
        let result = self.fill(&inner, root, object, depth + 1);
        self.includes.pop();
        result
    }

    /// The attribute `name` of `node`, substituted; an error when it is missing.
    fn attribute(&self, cx: &Context, node: roxmltree::Node, name: &str) -> Result<String, XmlError> {
        let value = node.attribute(name).ok_or_else(|| {
            error(
                position(cx.doc, cx.file, node),
                &describe_element(node),
                &format!("has no `{name}` attribute"),
            )
        })?;
        self.substitute(cx, node, value)
    }

    /// `text` with every `$name` replaced by its default (longest names first).
    fn substitute(&self, cx: &Context, node: roxmltree::Node, text: &str) -> Result<String, XmlError> {
        if !text.contains('$') {
            return Ok(text.to_string());
        }
        let mut names: Vec<&String> = self.defaults.keys().collect();
        names.sort_by_key(|n| std::cmp::Reverse(n.len()));
        let mut out = text.to_string();
        for name in names {
            out = out.replace(&format!("${name}"), &self.defaults[name]);
        }
        if let Some(i) = out.find('$') {
            let rest: String =
                out[i + 1..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            return Err(error(
                position(cx.doc, cx.file, node),
                &describe_element(node),
                &format!("`${rest}` has no value: give it a <default name=\"{rest}\" value=\"…\"/>"),
            ));
        }
        Ok(out)
    }

    /// A property element.
    fn property(&self, cx: &Context, node: roxmltree::Node, depth: usize) -> Result<Property, XmlError> {
        let at = position(cx.doc, cx.file, node);
        let describe = describe_element(node);
        let fail = |m: String| error(at.clone(), &describe, &m);
        let tag = node.tag_name().name();
        let name = upgrade_name(&self.attribute(cx, node, "name")?, cx.version);
        let value_of = |n: roxmltree::Node| self.attribute(cx, n, "value");
        let value = match tag {
            "float" => Value::Float(number(&value_of(node)?).map_err(fail)?),
            "integer" => {
                let text = value_of(node)?;
                Value::Integer(
                    text.trim().parse().map_err(|_| fail(format!("`{text}` is not a whole number")))?,
                )
            }
            "boolean" => match value_of(node)?.trim() {
                "true" => Value::Boolean(true),
                "false" => Value::Boolean(false),
                other => return Err(fail(format!("`{other}` is not `true` or `false`"))),
            },
            "string" => Value::String(value_of(node)?),
            "rgb" | "color" => Value::Rgb(triple(&value_of(node)?).map_err(fail)?),
            "srgb" => Value::Rgb(srgb(&value_of(node)?).map_err(fail)?),
            "spectrum" => spectrum(&value_of(node)?).map_err(fail)?,
            "point" | "vector" => {
                let v = match node.attribute("value") {
                    Some(_) => triple(&value_of(node)?).map_err(fail)?,
                    None => xyz(self, cx, node, 0.0)?,
                };
                let v = DVec3::from_array(v);
                if tag == "point" {
                    Value::Point(v)
                } else {
                    Value::Vector(v)
                }
            }
            "transform" => {
                let matrix = self.transform(cx, node, depth)?;
                let ops: Vec<roxmltree::Node> = node.children().filter(roxmltree::Node::is_element).collect();
                let look_at = match ops[..] {
                    [op] if op.tag_name().name().eq_ignore_ascii_case("lookat") => {
                        let get = |k: &str| self.attribute(cx, op, k).ok().and_then(|t| triple(&t).ok());
                        let up = if op.attribute("up").is_some() { get("up") } else { Some([0.0, 1.0, 0.0]) };
                        match (get("origin"), get("target"), up) {
                            (Some(o), Some(t), Some(u)) => {
                                Some([DVec3::from_array(o), DVec3::from_array(t), DVec3::from_array(u)])
                            }
                            _ => None,
                        }
                    }
                    _ => None,
                };
                Value::Transform(matrix, look_at)
            }
            other => {
                return Err(fail(format!(
                    "unknown element <{other}>; known: the objects {}, the properties float, integer, \
                     boolean, string, rgb, spectrum, point, vector, transform, and default, include, ref",
                    OBJECT_TAGS.join(", ")
                )))
            }
        };
        Ok(Property { name, value, position: at })
    }

    /// The matrix of a `<transform>`: its operations composed in order (each applied after the
    /// ones before it).
    fn transform(&self, cx: &Context, node: roxmltree::Node, depth: usize) -> Result<DMat4, XmlError> {
        let mut matrix = DMat4::IDENTITY;
        if depth + 1 >= MAX_NESTING {
            let at = position(cx.doc, cx.file, node);
            return Err(error(
                at,
                &describe_element(node),
                &format!("elements nest deeper than {MAX_NESTING}"),
            ));
        }
        for op in node.children().filter(roxmltree::Node::is_element) {
            let at = position(cx.doc, cx.file, op);
            let describe = describe_element(op);
            let fail = |m: String| error(at.clone(), &describe, &m);
            let step = match op.tag_name().name() {
                "translate" => DMat4::from_translation(DVec3::from_array(self.vector_of(cx, op, 0.0)?)),
                "scale" => {
                    let s = match op.attribute("value") {
                        Some(_) => {
                            let text = self.attribute(cx, op, "value")?;
                            match number(&text) {
                                Ok(v) => [v; 3],
                                Err(_) => triple(&text).map_err(fail)?,
                            }
                        }
                        None => xyz(self, cx, op, 1.0)?,
                    };
                    DMat4::from_scale(DVec3::from_array(s))
                }
                "rotate" => {
                    let axis = DVec3::from_array(match op.attribute("axis") {
                        Some(_) => triple(&self.attribute(cx, op, "axis")?).map_err(fail)?,
                        None => self.vector_of(cx, op, 0.0)?,
                    });
                    let angle = number(&self.attribute(cx, op, "angle")?).map_err(fail)?;
                    if axis.length() <= 0.0 {
                        return Err(fail("the rotation axis is zero".into()));
                    }
                    // Mitsuba 3 (Dr.Jit's `rotate`) does not normalise the axis: a unit axis turns,
                    // another also stretches along itself (checked against its render,
                    // tests/data/mitsuba3/transforms.xml). Entries within 1e-15 of zero are zero:
                    // a turn by a multiple of 90° is exact.
                    let turn = rotation(axis, angle.to_radians()).to_cols_array();
                    DMat4::from_cols_array(&turn.map(|e| if e.abs() < 1e-15 { 0.0 } else { e }))
                }
                "matrix" => {
                    let values = numbers(&self.attribute(cx, op, "value")?).map_err(fail)?;
                    match values.len() {
                        16 => DMat4::from_cols_array(&values.try_into().expect("16")).transpose(),
                        9 => {
                            let v = values;
                            DMat4::from_cols_array(&[
                                v[0], v[3], v[6], 0.0, v[1], v[4], v[7], 0.0, v[2], v[5], v[8], 0.0, 0.0,
                                0.0, 0.0, 1.0,
                            ])
                        }
                        n => {
                            return Err(fail(format!(
                                "has {n} numbers; a matrix has 16 (4×4) or 9 (3×3), row by row"
                            )))
                        }
                    }
                }
                "lookat" | "lookAt" => {
                    let origin = DVec3::from_array(triple(&self.attribute(cx, op, "origin")?).map_err(fail)?);
                    let target = DVec3::from_array(triple(&self.attribute(cx, op, "target")?).map_err(fail)?);
                    let up = match op.attribute("up") {
                        Some(_) => DVec3::from_array(triple(&self.attribute(cx, op, "up")?).map_err(fail)?),
                        None => DVec3::Y,
                    };
                    look_at(origin, target, up).ok_or_else(|| {
                        fail("origin and target coincide, or up is parallel to the view direction".into())
                    })?
                }
                other => {
                    return Err(fail(format!(
                    "unknown transform operation <{other}>; known: translate, rotate, scale, matrix, lookat"
                )))
                }
            };
            matrix = step * matrix;
        }
        if !matrix.is_finite() {
            let at = position(cx.doc, cx.file, node);
            return Err(error(at, &describe_element(node), "the transform is not finite"));
        }
        Ok(matrix)
    }

    /// `x`, `y`, `z` attributes (each `missing` when absent) or a `value` triple.
    fn vector_of(&self, cx: &Context, node: roxmltree::Node, missing: f64) -> Result<[f64; 3], XmlError> {
        match node.attribute("value") {
            Some(_) => {
                let at = position(cx.doc, cx.file, node);
                triple(&self.attribute(cx, node, "value")?)
                    .map_err(|m| error(at, &describe_element(node), &m))
            }
            None => xyz(self, cx, node, missing),
        }
    }
}

/// The `x`, `y` and `z` attributes of `node` (each `missing` when absent).
fn xyz(reader: &Reader, cx: &Context, node: roxmltree::Node, missing: f64) -> Result<[f64; 3], XmlError> {
    let mut v = [missing; 3];
    for (slot, axis) in v.iter_mut().zip(["x", "y", "z"]) {
        if let Some(text) = node.attribute(axis) {
            let text = reader.substitute(cx, node, text)?;
            *slot = number(&text)
                .map_err(|m| error(position(cx.doc, cx.file, node), &describe_element(node), &m))?;
        }
    }
    Ok(v)
}

/// Mitsuba's `lookat`: the camera (or object) at `origin` looking at `target`, its +z the view
/// direction, +y towards `up` and +x to the left (x = up × z).
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).try_normalize()?;
    let left = up.normalize_or_zero().cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0)))
}

/// Mitsuba 3's rotation by `angle` radians about `axis`: cos·I + (1 − cos)·a aᵀ + sin·[a]×,
/// with `axis` as given (a unit axis gives the rotation itself, bit for bit as glam's).
fn rotation(axis: DVec3, angle: f64) -> DMat4 {
    if axis.length_squared() == 1.0 {
        return DMat4::from_axis_angle(axis, angle);
    }
    let (s, c) = angle.sin_cos();
    let a = axis;
    let m = glam::DMat3::from_cols(
        DVec3::new(
            c + (1.0 - c) * a.x * a.x,
            (1.0 - c) * a.x * a.y + s * a.z,
            (1.0 - c) * a.x * a.z - s * a.y,
        ),
        DVec3::new(
            (1.0 - c) * a.x * a.y - s * a.z,
            c + (1.0 - c) * a.y * a.y,
            (1.0 - c) * a.y * a.z + s * a.x,
        ),
        DVec3::new(
            (1.0 - c) * a.x * a.z + s * a.y,
            (1.0 - c) * a.y * a.z - s * a.x,
            c + (1.0 - c) * a.z * a.z,
        ),
    );
    DMat4::from_mat3(m)
}

/// A camelCase name of a file before version 2.0 in snake_case, as Mitsuba 3 upgrades it
/// (`toWorld` → `to_world`, `intIOR` → `int_ior`); newer names as they are.
pub fn upgrade_name(name: &str, version: (u32, u32, u32)) -> String {
    if version.0 >= 2 {
        return name.to_string();
    }
    let mut out = String::with_capacity(name.len() + 4);
    let mut previous_lower = false;
    for c in name.chars() {
        if c.is_uppercase() && previous_lower {
            out.push('_');
        }
        previous_lower = c.is_lowercase() || c.is_ascii_digit();
        out.extend(c.to_lowercase());
    }
    out
}

/// `MAJOR.MINOR.PATCH` (or `MAJOR.MINOR`).
fn parse_version(text: &str) -> Option<(u32, u32, u32)> {
    let parts: Vec<u32> = text.trim().split('.').map(|p| p.parse().ok()).collect::<Option<_>>()?;
    match parts[..] {
        [a, b] => Some((a, b, 0)),
        [a, b, c] => Some((a, b, c)),
        _ => None,
    }
}

/// A finite number.
fn number(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("`{}` is not a finite number", text.trim())),
    }
}

/// Numbers separated by commas and/or white space.
fn numbers(text: &str) -> Result<Vec<f64>, String> {
    text.split(|c: char| c == ',' || c.is_whitespace()).filter(|s| !s.is_empty()).map(number).collect()
}

/// Three numbers, or one for all three.
fn triple(text: &str) -> Result<[f64; 3], String> {
    match numbers(text)?[..] {
        [v] => Ok([v; 3]),
        [a, b, c] => Ok([a, b, c]),
        _ => Err(format!("`{}` is not one or three numbers", text.trim())),
    }
}

/// Mitsuba 0.5's `<srgb>`: three numbers or `#rrggbb`, sRGB-encoded, returned linear.
fn srgb(text: &str) -> Result<[f64; 3], String> {
    let t = text.trim();
    let encoded = match t.strip_prefix('#') {
        Some(hex) if hex.len() == 6 => {
            let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).map(|b| f64::from(b) / 255.0);
            [byte(0), byte(2), byte(4)].map(|b| b.map_err(|_| format!("`{t}` is not #rrggbb")))
        }
        Some(_) => return Err(format!("`{t}` is not #rrggbb")),
        None => triple(t)?.map(Ok),
    };
    let linear = |c: f64| if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    let [r, g, b] = encoded;
    Ok([linear(r?), linear(g?), linear(b?)])
}

/// A `<spectrum>` value: one number, or `wavelength:value` pairs by increasing wavelength.
fn spectrum(text: &str) -> Result<Value, String> {
    if !text.contains(':') {
        return Ok(Value::Constant(number(text)?));
    }
    let mut pairs = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (w, v) = item.split_once(':').ok_or_else(|| format!("`{item}` is not wavelength:value"))?;
        let (w, v) = (number(w)?, number(v)?);
        if pairs.last().is_some_and(|&(last, _): &(f64, f64)| w <= last) {
            return Err(format!("the wavelengths must increase (`{item}`)"));
        }
        pairs.push((w, v));
    }
    if pairs.is_empty() {
        return Err("the spectrum has no values".into());
    }
    Ok(Value::Sampled(pairs))
}

/// The file's text, with the size limit of scene files; `from` is the `<include>` asking for it.
fn read_text(path: &Path, file: &Rc<str>, from: Option<(&Position, &str)>) -> Result<String, XmlError> {
    use std::io::Read;
    let limit = crate::scene::compile::MAX_SCENE_BYTES;
    let fail = |m: String| match from {
        Some((at, element)) => error(at.clone(), element, &m),
        None => error(Position { file: file.clone(), line: 1, column: 1 }, "the file", &m),
    };
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut bytes))
        .map_err(|e| fail(format!("cannot read {}: {e}", path.display())))?;
    if bytes.len() as u64 > limit {
        return Err(fail(format!("{} is larger than {} MiB", path.display(), limit >> 20)));
    }
    String::from_utf8(bytes).map_err(|_| fail(format!("{} is not UTF-8 text", path.display())))
}

/// Parses XML text, located errors naming the file.
fn parse_xml<'a>(text: &'a str, file: &Rc<str>) -> Result<roxmltree::Document<'a>, XmlError> {
    let options = roxmltree::ParsingOptions { allow_dtd: false, nodes_limit: u32::MAX };
    roxmltree::Document::parse_with_options(text, options).map_err(|e| {
        let pos = e.pos();
        error(
            Position { file: file.clone(), line: pos.row, column: pos.col },
            "the XML",
            &format!("not well-formed XML: {e}"),
        )
    })
}

/// The position of `node` in its file.
fn position(doc: &roxmltree::Document, file: &Rc<str>, node: roxmltree::Node) -> Position {
    let pos = doc.text_pos_at(node.range().start);
    Position { file: file.clone(), line: pos.row, column: pos.col }
}

/// `<float name="fov">` for messages.
fn describe_element(node: roxmltree::Node) -> String {
    let mut s = format!("<{}", node.tag_name().name());
    for key in ["type", "name", "id"] {
        if let Some(v) = node.attribute(key) {
            s.push_str(&format!(" {key}=\"{v}\""));
        }
    }
    s.push('>');
    s
}

/// An error at `position` about `element`.
fn error(position: Position, element: &str, message: &str) -> XmlError {
    XmlError { position, element: element.to_string(), message: message.to_string() }
}

/// A path's canonical form where it exists (for include cycles), else the path itself.
fn canonical(path: &Path) -> PathBuf {
    path.canonicalize().unwrap_or_else(|_| path.to_path_buf())
}
