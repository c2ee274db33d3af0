//! A Mitsuba scene ([`super::xml::Document`]) in vitrum's own TOML format.
//!
//! Every plugin and parameter is either translated exactly, translated with a stated difference
//! (a warning, and a comment in the TOML), ignored with a warning (the parameters only Mitsuba
//! 0.5/0.6 knew, [`LEGACY_PARAMETERS`]), or refused: an unknown parameter or a plugin vitrum
//! lacks is an error at its position listing what is supported, or with `lenient` a warning
//! saying what was dropped or approximated. The supported subset is documented in
//! docs/other-renderers.md ("What is translated").

use super::toml_writer::{number, vector, TomlWriter};
use super::xml::{Document, Object, Position, Property, Value, XmlError};
use crate::methods::Method;
use glam::{DMat3, DMat4, DQuat, DVec3};
use std::cell::RefCell;
use std::collections::{HashMap, HashSet};
use std::rc::Rc;

/// Parameters of Mitsuba 0.5/0.6 that Mitsuba 3 refuses and vitrum accepts with a warning
/// naming each: (plugin tag, parameter, why it is ignored).
pub const LEGACY_PARAMETERS: [(&str, &str, &str); 5] = [
    ("integrator", "strict_normals", "vitrum always uses the geometric normal for the side of a surface"),
    ("film", "gamma", "vitrum's films are linear (the PNG preview applies the sRGB curve)"),
    ("film", "banner", "vitrum writes no banner"),
    ("film", "file_format", "vitrum writes OpenEXR (and a PNG preview with --png)"),
    ("film", "pixel_format", "vitrum renders RGB"),
];

/// Mitsuba's named refractive indices (its `dielectric` plugin's table).
pub const NAMED_IORS: [(&str, f64); 23] = [
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// The plugins translated, by tag, for the error listing what is supported.
pub const SUPPORTED: [(&str, &str); 9] = [
    ("sensor", "perspective, thinlens"),
    ("film", "hdrfilm, ldrfilm"),
    ("rfilter", "box, tent (radius), gaussian (stddev)"),
    ("sampler", "independent, stratified, multijitter, ldsampler, orthogonal (their sample_count and seed)"),
    ("integrator", "path, volpath (as path), bdpt (as bpt), ptracer (as light)"),
    ("shape", "rectangle, cube, sphere, disk, cylinder (any affine to_world), obj, ply"),
    (
        "bsdf",
        "diffuse, twosided, dielectric, roughdielectric (beckmann, ggx), thindielectric, conductor, roughconductor (beckmann, ggx), plastic, roughplastic (beckmann, ggx)",
    ),
    (
        "emitter",
        "area (on rectangles, spheres, disks and cylinders; on cubes and meshes as two-sided emission), point, spot, directional, constant, envmap",
    ),
    ("texture", "bitmap (a diffuse reflectance; a to_uv that scales and moves)"),
];

/// What the import takes from a `<film>`.
struct Film {
    width: u32,
    height: u32,
    /// vitrum's `[camera] filter` value.
    filter: String,
    /// The crop window `[x, y, width, height]`, if not the whole film.
    crop: Option<[u32; 4]>,
}

impl Default for Film {
    /// Mitsuba's film when a sensor has none: 768×576, Gaussian filter.
    fn default() -> Film {
        Film { width: 768, height: 576, filter: "{ type = \"gaussian\", stddev = 0.5 }".into(), crop: None }
    }
}

/// An imported scene: its TOML (with the element of every line) and the warnings.
pub struct Translation {
    /// The TOML.
    pub toml: TomlWriter,
    /// What was ignored, approximated or dropped, one sentence each.
    pub warnings: Vec<String>,
}

/// Translates `doc`; with `options.lenient` what vitrum lacks is dropped or approximated with a
/// warning instead of refused, with `options.two_sided` a one-sided diffuse is read two-sided.
/// `file` writes a file name of the XML (relative to its folder) as the TOML must name it.
pub fn translate(
    doc: &Document,
    options: super::ImportOptions,
    file: &dyn Fn(&str) -> String,
) -> Result<Translation, XmlError> {
    let mut t = Translator {
        lenient: options.lenient,
        two_sided: options.two_sided,
        warnings: Vec::new(),
        materials: HashMap::new(),
        uv_layout: UvLayout::Flipped,
        names: HashSet::new(),
        file,
    };
    let scene = &doc.scene;
    let mut head = TomlWriter::default();
    let (mut camera, mut render) = (TomlWriter::default(), TomlWriter::default());
    let (mut materials, mut objects, mut lights) =
        (TomlWriter::default(), TomlWriter::default(), TomlWriter::default());
    let sensor = scene
        .children_tagged("sensor")
        .next()
        .ok_or_else(|| error(&scene.position, "<scene>", "has no <sensor>: vitrum needs a camera"))?;
    render.from(&scene.position, "<scene>");
    render.table("render");
    t.sensor(sensor, &mut camera, &mut render)?;
    let integrator = scene.children_tagged("integrator").next();
    t.integrator(integrator.map(Rc::as_ref), &mut render)?;
    for (i, shape) in scene.children_tagged("shape").enumerate() {
        t.shape(shape, i, &mut materials, &mut objects, &mut lights)?;
    }
    for emitter in scene.children_tagged("emitter") {
        t.emitter(emitter, &mut lights)?;
    }
    for child in &scene.children {
        if !["sensor", "integrator", "shape", "emitter", "bsdf", "texture"].contains(&child.tag.as_str()) {
            t.lacks(child, &format!("<{}> objects", child.tag))?;
        }
    }
    head.comment(&format!(
        "Imported by vitrum {} from {} (Mitsuba scene version {}.{}.{}).",
        crate::VERSION,
        scene.position.file,
        doc.version.0,
        doc.version.1,
        doc.version.2
    ));
    for w in &t.warnings {
        head.comment(&format!("Not exact: {w}"));
    }
    let mut toml = head;
    for part in [camera, render, materials, objects, lights] {
        toml.append(part);
    }
    Ok(Translation { toml, warnings: t.warnings })
}

/// The state of a translation.
struct Translator<'f> {
    /// How a file name of the XML is written in the TOML.
    file: &'f dyn Fn(&str) -> String,
    lenient: bool,
    /// Whether one-sided diffuse BSDFs are read as two-sided (`--two-sided`).
    two_sided: bool,
    warnings: Vec<String>,
    /// The material key of every BSDF object already written (by address).
    materials: HashMap<(*const Object, UvLayout), String>,
    /// How the uv of the shape whose material is being written relates to vitrum's.
    uv_layout: UvLayout,
    /// Material keys taken.
    names: HashSet<String>,
}

/// The properties of one object, remembering which were read.
struct Props<'a> {
    object: &'a Object,
    used: RefCell<HashSet<String>>,
}

impl<'a> Props<'a> {
    fn of(object: &'a Object) -> Props<'a> {
        Props { object, used: RefCell::new(HashSet::new()) }
    }

    fn get(&self, name: &str) -> Option<&'a Property> {
        self.used.borrow_mut().insert(name.to_string());
        self.object.property(name)
    }

    fn wrong(&self, p: &Property, wanted: &str) -> XmlError {
        error(
            &p.position,
            &self.object.describe(),
            &format!("`{}` must be {wanted}, not {}", p.name, p.value.kind()),
        )
    }

    fn float(&self, name: &str) -> Result<Option<f64>, XmlError> {
        match self.get(name) {
            None => Ok(None),
            Some(Property { value: Value::Float(v), .. }) => Ok(Some(*v)),
            Some(Property { value: Value::Integer(v), .. }) => Ok(Some(*v as f64)),
            Some(p) => Err(self.wrong(p, "a <float>")),
        }
    }

    fn integer(&self, name: &str) -> Result<Option<i64>, XmlError> {
        match self.get(name) {
            None => Ok(None),
            Some(Property { value: Value::Integer(v), .. }) => Ok(Some(*v)),
            Some(p) => Err(self.wrong(p, "an <integer>")),
        }
    }

    fn boolean(&self, name: &str) -> Result<Option<bool>, XmlError> {
        match self.get(name) {
            None => Ok(None),
            Some(Property { value: Value::Boolean(v), .. }) => Ok(Some(*v)),
            Some(p) => Err(self.wrong(p, "a <boolean>")),
        }
    }

    fn string(&self, name: &str) -> Result<Option<String>, XmlError> {
        match self.get(name) {
            None => Ok(None),
            Some(Property { value: Value::String(v), .. }) => Ok(Some(v.clone())),
            Some(p) => Err(self.wrong(p, "a <string>")),
        }
    }

    fn point(&self, name: &str) -> Result<Option<DVec3>, XmlError> {
        match self.get(name) {
            None => Ok(None),
            Some(Property { value: Value::Point(v) | Value::Vector(v), .. }) => Ok(Some(*v)),
            Some(p) => Err(self.wrong(p, "a <point>")),
        }
    }

    /// A colour: `<rgb>`, a `<spectrum>` (constant or `wavelength:value` pairs, read as Mitsuba
    /// 3's RGB variants read it inside an emitter or elsewhere: [`super::spectra`]) or a `<float>`.
    fn color(&self, name: &str) -> Result<Option<[f64; 3]>, XmlError> {
        let emitter = self.object.tag == "emitter";
        match self.get(name) {
            None => Ok(None),
            Some(Property { value: Value::Rgb(c), .. }) => Ok(Some(*c)),
            Some(Property { value: Value::Constant(v), .. }) => {
                Ok(Some(super::spectra::constant(*v, emitter)))
            }
            Some(Property { value: Value::Float(v), .. }) => Ok(Some([*v; 3])),
            Some(Property { value: Value::Sampled(pairs), .. }) => {
                Ok(Some(super::spectra::sampled(pairs, emitter).0))
            }
            Some(p) => Err(self.wrong(p, "an <rgb>, <spectrum> or <float>")),
        }
    }

    fn transform(&self, name: &str) -> Result<Option<DMat4>, XmlError> {
        match self.get(name) {
            None => Ok(None),
            Some(Property { value: Value::Transform(m, _), .. }) => Ok(Some(*m)),
            Some(p) => Err(self.wrong(p, "a <transform>")),
        }
    }

    /// Every property not read: the legacy ones a warning each, the others an error (a warning
    /// when lenient).
    fn finish(self, t: &mut Translator<'_>) -> Result<(), XmlError> {
        let used = self.used.into_inner();
        for p in self.object.properties.iter().filter(|p| !used.contains(&p.name)) {
            let legacy =
                LEGACY_PARAMETERS.iter().find(|(tag, name, _)| *tag == self.object.tag && *name == p.name);
            match legacy {
                Some((_, _, why)) => {
                    t.warn(&p.position, &format!("`{}` of {} ignored: {why}", p.name, self.object.describe()))
                }
                None => {
                    let message = format!("unknown parameter `{}` of {}", p.name, self.object.describe());
                    if t.lenient {
                        t.warn(&p.position, &format!("{message}: dropped (--lenient)"));
                    } else {
                        return Err(error(&p.position, &self.object.describe(), &format!(
                            "unknown parameter `{}` (or one vitrum does not support yet); --lenient drops it with a warning",
                            p.name
                        )));
                    }
                }
            }
        }
        Ok(())
    }
}

impl Translator<'_> {
    fn warn(&mut self, at: &Position, message: &str) {
        let warning = format!("{at}: {message}");
        if !self.warnings.contains(&warning) {
            self.warnings.push(warning);
        }
    }

    /// A plugin or feature vitrum lacks: an error, or with `lenient` a warning (Ok, dropped).
    fn lacks(&mut self, object: &Object, what: &str) -> Result<(), XmlError> {
        let supported = SUPPORTED
            .iter()
            .find(|(tag, _)| *tag == object.tag)
            .map_or("none".to_string(), |(_, list)| list.to_string());
        if self.lenient {
            self.warn(
                &object.position,
                &format!("{} ({what}): not supported, dropped (--lenient)", object.describe()),
            );
            Ok(())
        } else {
            Err(error(
                &object.position,
                &object.describe(),
                &format!("{what} not supported by vitrum; supported <{}> plugins: {supported}; --lenient drops it with a warning", object.tag),
            ))
        }
    }

    /// `flip_normals` on `shape`, a sphere (`what`), which vitrum cannot turn over (its normals
    /// face outwards): accepted where it changes nothing, a shape without an
    /// emitter (`emits`) whose BSDF looks the same from both sides (a `twosided` one, a
    /// `thindielectric`, a diffuse read as two-sided with `--two-sided`); otherwise refused (or
    /// with `--lenient` ignored with a warning), since it would move the side a one-sided BSDF
    /// reflects on, a dielectric's inside or an emitter's emitting side.
    fn unflippable(&mut self, shape: &Object, emits: bool, what: &str) -> Result<(), XmlError> {
        let bsdf = shape.children_tagged("bsdf").next();
        let sides_alike = match bsdf.map(|b| b.plugin.as_str()) {
            Some("twosided" | "thindielectric") => true,
            None | Some("diffuse") => self.two_sided,
            Some(_) => false,
        };
        if !emits && sides_alike {
            return Ok(());
        }
        let why = if emits { "an area emitter (emitting inwards)" } else { "a one-sided BSDF" };
        let message = format!("flip_normals on {what} with {why}: vitrum's face outwards");
        if self.lenient {
            self.warn(&shape.position, &format!("{message}; ignored (--lenient)"));
            Ok(())
        } else {
            Err(error(
                &shape.position,
                &shape.describe(),
                &format!("{message}; --lenient ignores it with a warning"),
            ))
        }
    }

    /// The camera and film (and the sampler inside the sensor).
    fn sensor(
        &mut self,
        sensor: &Object,
        camera: &mut TomlWriter,
        render: &mut TomlWriter,
    ) -> Result<(), XmlError> {
        camera.from(&sensor.position, &sensor.describe());
        let p = Props::of(sensor);
        let thin = match sensor.plugin.as_str() {
            "perspective" => false,
            "thinlens" => true,
            _ => {
                self.lacks(sensor, &format!("the sensor `{}`", sensor.plugin))?;
                false
            }
        };
        let film = sensor.children_tagged("film").next();
        let film = match film {
            Some(film) => self.film(film)?,
            None => Film::default(),
        };
        let (w, h) = (film.width, film.height);
        let m = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let origin = m.transform_point3(DVec3::ZERO);
        let dir = m.transform_vector3(DVec3::Z).normalize_or_zero();
        let up = m.transform_vector3(DVec3::Y).normalize_or_zero();
        let left = m.transform_vector3(DVec3::X).normalize_or_zero();
        if left.dot(up.cross(dir)) < 0.0 {
            let message = "the camera's to_world mirrors the image (its x axis is not up × view direction)";
            if !self.lenient {
                return Err(error(
                    &sensor.position,
                    &sensor.describe(),
                    &format!("{message}; vitrum's cameras cannot mirror; --lenient renders it unmirrored"),
                ));
            }
            self.warn(&sensor.position, &format!("{message}: rendered unmirrored (--lenient)"));
        }
        let fov = p.float("fov")?.unwrap_or(39.3077);
        let axis = p.string("fov_axis")?.unwrap_or_else(|| "x".into());
        let tan_half = (fov.to_radians() / 2.0).tan();
        let (wf, hf) = (f64::from(w), f64::from(h));
        let vertical = match axis.as_str() {
            "x" => tan_half * hf / wf,
            "y" => tan_half,
            "diagonal" => tan_half * hf / (wf * wf + hf * hf).sqrt(),
            "smaller" if w < h => tan_half * hf / wf,
            "smaller" => tan_half,
            "larger" if w > h => tan_half * hf / wf,
            "larger" => tan_half,
            other => {
                return Err(error(
                    &sensor.position,
                    &sensor.describe(),
                    &format!("fov_axis `{other}`: one of x, y, diagonal, smaller, larger"),
                ))
            }
        };
        // Mitsuba's near clip plane (default 0.01, along the view axis) is vitrum's; far_clip
        // (default 10⁴) is not: nothing is clipped beyond.
        let near_clip = p.float("near_clip")?.unwrap_or(0.01);
        if near_clip.is_nan() || near_clip <= 0.0 {
            return Err(error(&sensor.position, &sensor.describe(), "`near_clip` must be greater than zero"));
        }
        if let Some(far) = p.float("far_clip")? {
            if far <= near_clip {
                return Err(error(
                    &sensor.position,
                    &sensor.describe(),
                    "`far_clip` must be greater than `near_clip`",
                ));
            }
            self.warn(
                &sensor.position,
                &format!("far_clip {far} ignored: vitrum's camera sees out to any distance"),
            );
        }
        camera.table("camera");
        camera.comment(&format!("Mitsuba's fov {fov}° along `{axis}` at {w}x{h}: vitrum's fov is vertical"));
        // A lone lookat keeps its own numbers: vitrum's camera orthonormalises them as Mitsuba does.
        let exact = match p.get("to_world") {
            Some(Property { value: Value::Transform(_, Some(look_at)), .. }) => Some(*look_at),
            _ => None,
        };
        let [origin, target, up] = exact.unwrap_or([origin, origin + dir, up]);
        camera.vector("position", origin.to_array());
        camera.vector("look_at", target.to_array());
        camera.vector("up", up.to_array());
        camera.number("fov", 2.0 * vertical.atan().to_degrees());
        camera.raw("resolution", &format!("[{w}, {h}]"));
        camera.number("near_clip", near_clip);
        camera.raw("filter", &film.filter);
        if let Some([x, y, cw, ch]) = film.crop {
            camera.raw("crop", &format!("{{ offset = [{x}, {y}], size = [{cw}, {ch}] }}"));
        }
        if thin {
            let aperture = p.float("aperture_radius")?.unwrap_or(0.03);
            camera.number("aperture", aperture);
            if let Some(d) = p.float("focus_distance")? {
                camera.number("focus_distance", d);
            }
        }
        if let Some(sampler) = sensor.children_tagged("sampler").next() {
            self.sampler(sampler, render)?;
        }
        p.finish(self)?;
        for child in &sensor.children {
            if !["film", "sampler"].contains(&child.tag.as_str()) {
                self.lacks(child, &format!("<{}> inside a sensor", child.tag))?;
            }
        }
        Ok(())
    }

    /// The film's size, its reconstruction filter and its crop window.
    fn film(&mut self, film: &Object) -> Result<Film, XmlError> {
        if !["hdrfilm", "ldrfilm"].contains(&film.plugin.as_str()) {
            self.lacks(film, &format!("the film `{}`", film.plugin))?;
        }
        let p = Props::of(film);
        let size = |name: &str, default: i64| -> Result<u32, XmlError> {
            let v = p.integer(name)?.unwrap_or(default);
            u32::try_from(v).ok().filter(|&v| v > 0).ok_or_else(|| {
                error(
                    &film.position,
                    &film.describe(),
                    &format!("`{name}` {v}: must be a positive number of pixels"),
                )
            })
        };
        let (w, h) = (size("width", 768)?, size("height", 576)?);
        let crop = self.crop_window(film, &p, w, h)?;
        // Mitsuba cuts a pixel's filter footprint at the film's edge unless `sample_border` is
        // set, as vitrum always does.
        let border = p.boolean("sample_border")?.unwrap_or(false);
        for name in
            ["filename", "component_format", "rfilter", "high_quality_edges", "tonemap_method", "exposure"]
        {
            p.get(name);
        }
        p.finish(self)?;
        // Mitsuba's default filter is the Gaussian of standard deviation 0.5.
        let mut filter = "{ type = \"gaussian\", stddev = 0.5 }".to_string();
        for child in &film.children {
            if child.tag == "rfilter" {
                filter = self.rfilter(child)?;
            } else {
                self.lacks(child, &format!("<{}> inside a film", child.tag))?;
            }
        }
        if border && filter != "\"box\"" {
            let what = "`sample_border` = true (vitrum cuts every filter footprint at the film's edge)";
            self.lacks(film, what)?;
        }
        Ok(Film { width: w, height: h, filter, crop })
    }

    /// Mitsuba's crop window (`crop_offset_x/y`, default 0; `crop_width/height`, default the
    /// film's size), which must lie on the film; `None` for the whole film.
    fn crop_window(
        &mut self,
        film: &Object,
        p: &Props,
        w: u32,
        h: u32,
    ) -> Result<Option<[u32; 4]>, XmlError> {
        let read = |name: &str, default: u32, least: u32| -> Result<u32, XmlError> {
            let v = p.integer(name)?.unwrap_or(default as i64);
            u32::try_from(v).ok().filter(|&v| v >= least).ok_or_else(|| {
                error(&film.position, &film.describe(), &format!("`{name}` {v}: must be at least {least}"))
            })
        };
        let (x, y) = (read("crop_offset_x", 0, 0)?, read("crop_offset_y", 0, 0)?);
        let (cw, ch) = (read("crop_width", w, 1)?, read("crop_height", h, 1)?);
        if x as u64 + cw as u64 > w as u64 || y as u64 + ch as u64 > h as u64 {
            return Err(error(
                &film.position,
                &film.describe(),
                &format!("the crop window {cw}×{ch} at ({x}, {y}) reaches past the {w}×{h} film"),
            ));
        }
        Ok(([x, y, cw, ch] != [0, 0, w, h]).then_some([x, y, cw, ch]))
    }

    /// A reconstruction filter as vitrum's `[camera] filter` value (`box`; `tent` with its
    /// `radius`, default 1; `gaussian` with its `stddev`, default 0.5).
    fn rfilter(&mut self, child: &Object) -> Result<String, XmlError> {
        let p = Props::of(child);
        let positive = |name: &str, default: f64| -> Result<f64, XmlError> {
            let v = p.float(name)?.unwrap_or(default);
            if v.is_nan() || v <= 0.0 {
                return Err(error(
                    &child.position,
                    &child.describe(),
                    &format!("`{name}` {v}: must be positive"),
                ));
            }
            Ok(v)
        };
        let filter = match child.plugin.as_str() {
            "box" => "\"box\"".to_string(),
            "tent" => format!("{{ type = \"tent\", radius = {} }}", number(positive("radius", 1.0)?)),
            "gaussian" => format!("{{ type = \"gaussian\", stddev = {} }}", number(positive("stddev", 0.5)?)),
            other => {
                self.lacks(child, &format!("the reconstruction filter `{other}`"))?;
                "\"box\"".to_string()
            }
        };
        p.finish(self)?;
        Ok(filter)
    }

    fn sampler(&mut self, sampler: &Object, render: &mut TomlWriter) -> Result<(), XmlError> {
        render.from(&sampler.position, &sampler.describe());
        let p = Props::of(sampler);
        let count = p.integer("sample_count")?.unwrap_or(4);
        let count = u32::try_from(count).ok().filter(|&c| c > 0).ok_or_else(|| {
            error(&sampler.position, &sampler.describe(), &format!("sample_count {count}: must be positive"))
        })?;
        render.raw("spp", &count.to_string());
        if let Some(seed) = p.integer("seed")? {
            render.raw("seed", &seed.max(0).to_string());
        }
        let kind = match sampler.plugin.as_str() {
            "independent" => "independent",
            "stratified" => "stratified",
            "multijitter" | "ldsampler" | "orthogonal" | "sobol" => "sobol",
            other => {
                self.lacks(sampler, &format!("the sampler `{other}`"))?;
                "sobol"
            }
        };
        render.string("sampler", kind);
        for name in ["jitter", "scramble_seed", "dimension"] {
            p.get(name);
        }
        p.finish(self)
    }

    fn integrator(&mut self, integrator: Option<&Object>, render: &mut TomlWriter) -> Result<(), XmlError> {
        let Some(integrator) = integrator else {
            return Ok(());
        };
        render.from(&integrator.position, &integrator.describe());
        let p = Props::of(integrator);
        let method = match integrator.plugin.as_str() {
            "path" => Method::Path,
            "volpath" => {
                self.warn(&integrator.position, "volpath rendered as vitrum's path (no participating media)");
                Method::Path
            }
            "bdpt" => Method::Bpt,
            "ptracer" => Method::Light,
            other => {
                self.lacks(integrator, &format!("the integrator `{other}`"))?;
                Method::Path
            }
        }
        .name();
        let depth = p.integer("max_depth")?.unwrap_or(-1);
        if p.get("rr_depth").is_some() {
            self.warn(
                &integrator.position,
                "rr_depth ignored: vitrum's Russian roulette starts at its own depth",
            );
        }
        p.get("hide_emitters");
        p.get("strict_normals");
        let max = i64::from(crate::scene::compile::MAX_DEPTH);
        // Mitsuba counts path segments (1: emitters seen directly); vitrum's path-like methods
        // count scattering events (0: the same), Whitted's family also gathers light at its last hit.
        let (bounces, whitted) = match depth {
            -1 => (max, max),
            d if d >= 1 => ((d - 1).min(max), (d - 2).clamp(0, max)),
            d => {
                return Err(error(
                    &integrator.position,
                    &integrator.describe(),
                    &format!("max_depth {d}: −1 (unlimited) or at least 1"),
                ))
            }
        };
        render.line(&format!("integrator = \"{method}\""));
        render.comment(&format!(
            "Mitsuba's max_depth {depth} counts path segments; vitrum's depth counts bounces: {bounces} (Whitted's family {whitted})"
        ));
        // Every method with a depth, the path-like ones first (the order of the tables written).
        let with_depth = Method::ALL.into_iter().filter(|m| m.has_max_depth());
        for m in with_depth.clone().filter(|m| !m.recursive()).chain(with_depth.filter(|m| m.recursive())) {
            render.table(&format!("render.{}", m.name()));
            let depth = if m.recursive() { whitted } else { bounces };
            render.raw("max_depth", &depth.to_string());
        }
        p.finish(self)
    }

    /// One `<shape>`: its objects (or light) and its material.
    fn shape(
        &mut self,
        shape: &Object,
        index: usize,
        materials: &mut TomlWriter,
        objects: &mut TomlWriter,
        lights: &mut TomlWriter,
    ) -> Result<(), XmlError> {
        let p = Props::of(shape);
        let m = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let flip = p.boolean("flip_normals")?.unwrap_or(false);
        let name = shape.id.clone().unwrap_or_else(|| format!("shape{index}-{}", shape.plugin));
        let emitter = shape.children_tagged("emitter").next();
        let radiance = match emitter {
            Some(e) if e.plugin == "area" => {
                let ep = Props::of(e);
                let r = ep.color("radiance")?.unwrap_or([1.0; 3]);
                ep.finish(self)?;
                Some(r)
            }
            Some(e) => {
                self.lacks(e, &format!("the emitter `{}` on a shape", e.plugin))?;
                None
            }
            None => None,
        };
        for child in &shape.children {
            if !["bsdf", "emitter"].contains(&child.tag.as_str()) {
                self.lacks(child, &format!("<{}> inside a shape", child.tag))?;
            }
        }
        let at = (&shape.position, shape.describe());
        let fail = |m: &str| error(at.0, &at.1, m);
        let mut geometry: Vec<(String, Vec<(&str, String)>)> = Vec::new();
        let mut quad_light = None;
        // How Mitsuba's uv on this shape relates to vitrum's on what the import writes.
        let mut layout = UvLayout::of(&shape.plugin);
        let mut sphere_light: Option<(DVec3, f64)> = None;
        match shape.plugin.as_str() {
            "rectangle" => {
                // Mitsuba's rectangle has uv (0, 0) at its corner (−1, −1), u along x, v along y.
                let square = (DVec3::new(-1.0, -1.0, 0.0), DVec3::X * 2.0, DVec3::Y * 2.0);
                let ((corner, u, v), uv) = mitsuba_face(&m, square, false, flip);
                layout = uv;
                // An emitting rectangle that reflects nothing is a quad light; one that reflects
                // a quad whose material emits.
                if radiance.is_some() && reflects_nothing(shape.children_tagged("bsdf").next()) {
                    quad_light = Some((corner, u, v));
                } else {
                    geometry.push((name.clone(), quad(corner, u, v)));
                }
            }
            "cube" => {
                for (k, face) in cube_faces().into_iter().enumerate() {
                    let ((corner, u, v), uv) = mitsuba_face(&m, face, true, flip);
                    layout = uv;
                    geometry.push((format!("{name}.face{k}"), quad(corner, u, v)));
                }
            }
            "sphere" => {
                let center = p.point("center")?.unwrap_or(DVec3::ZERO);
                let radius = p.float("radius")?.unwrap_or(1.0);
                if flip {
                    self.unflippable(shape, radiance.is_some(), "a sphere")?;
                }
                // Mitsuba 3 keeps a sphere round: under a map that is not a similarity it
                // warns and takes the radius from the polar decomposition (checked against its
                // render: tests/data/mitsuba3/transforms.xml).
                let (c, r) = (m.transform_point3(center), radius * sphere_scale(&m));
                if similarity(&m).is_none() {
                    self.warn(
                        &shape.position,
                        &format!("to_world of a sphere with a non-uniform scale or a shear: a sphere of radius {} as Mitsuba 3 renders it (not an ellipsoid)", number(r)),
                    );
                }
                if radiance.is_some() {
                    sphere_light = Some((c, r));
                } else {
                    // Mitsuba's sphere has its uv pole (v = 0, the image's top row) on its local
                    // +z and u from local +x towards +y, turned by the rotation of to_world;
                    // vitrum's has the pole (v = 1) on +Y and u from +X towards −Z: turned by
                    // 90° about +X, then by Mitsuba's rotation, it is Mitsuba's. The sphere is
                    // written at the origin and moved to its centre, so that the turn leaves
                    // the centre and radius exact.
                    let turn = sphere_rotation(&m) * DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2);
                    let (axis, angle) = DQuat::from_mat3(&turn).to_axis_angle();
                    let mut fields = sphere(DVec3::ZERO, r);
                    fields.push((
                        "transform",
                        format!(
                            "{{ rotate = {{ axis = {}, angle = {} }}, translate = {} }}",
                            vector(axis.to_array()),
                            number(angle.to_degrees()),
                            vector(c.to_array())
                        ),
                    ));
                    geometry.push((name.clone(), fields));
                }
            }
            "disk" => {
                let disk = |c: DVec3, n: DVec3, r: f64| {
                    vec![
                        ("shape", "\"disk\"".into()),
                        ("center", vector(c.to_array())),
                        ("normal", vector(n.to_array())),
                        ("radius", number(r)),
                    ]
                };
                // Mitsuba's disk uv is (radius fraction, angle from the local x towards y / 2π),
                // vitrum's (radius fraction, angle about its normal from its seam).
                match round_in_plane(&m) {
                    Some(scale) => {
                        let c = m.transform_point3(DVec3::ZERO);
                        let n = normal_of(&m, flip);
                        let mut fields = disk(c, n, scale);
                        let l = DMat3::from_mat4(m);
                        let (seam, uv) = seam_of(n, l.x_axis, l.y_axis);
                        fields.extend(seam);
                        layout = uv;
                        geometry.push((name.clone(), fields));
                    }
                    None => {
                        // An elliptic disk: the unit disk under the whole map.
                        let n = if flip { -DVec3::Z } else { DVec3::Z };
                        let mut fields = disk(DVec3::ZERO, n, 1.0);
                        let (seam, uv) = seam_of(n, DVec3::X, DVec3::Y);
                        fields.extend(seam);
                        layout = uv;
                        fields.push(("transform", matrix(&m)));
                        geometry.push((name.clone(), fields));
                    }
                }
            }
            "cylinder" => {
                let p0 = p.point("p0")?.unwrap_or(DVec3::ZERO);
                let p1 = p.point("p1")?.unwrap_or(DVec3::Z);
                let radius = p.float("radius")?.unwrap_or(1.0);
                let (a, b) = (m.transform_point3(p0), m.transform_point3(p1));
                let axis = b - a;
                let upright = |l: DMat3| {
                    let tol = 1e-5 * l.x_axis.length() * axis.length();
                    axis.dot(l.x_axis).abs() <= tol && axis.dot(l.y_axis).abs() <= tol
                };
                // Along object z, any frame that keeps the xy circle round and the axis upright
                // (the exporter's); along another axis, a similarity.
                let along_z = (p1 - p0).truncate().length() <= 1e-12 * (p1 - p0).length();
                let scale = if along_z {
                    round_in_plane(&m).filter(|_| upright(DMat3::from_mat4(m)))
                } else {
                    similarity(&m).map(|(s, _)| s)
                };
                // By its end points, as Mitsuba places them (and as the exporter writes them
                // back: a round trip reads the same numbers).
                let cylinder = |base: DVec3, top: DVec3, r: f64| {
                    let mut fields = vec![
                        ("shape", "\"cylinder\"".into()),
                        ("base", vector(base.to_array())),
                        ("top", vector(top.to_array())),
                        ("radius", number(r)),
                        ("caps", "false".into()),
                    ];
                    if flip {
                        // Mitsuba flips the geometric and shading normals: towards the axis.
                        fields.push(("flip_normals", "true".into()));
                    }
                    fields
                };
                // Mitsuba's cylinder uv is (angle from its local x towards y / 2π, height
                // fraction), its local frame being to_world times Duff et al.'s frame of p1 − p0
                // (the one vitrum's texture_frame gives); vitrum's wall measures the angle from
                // its seam.
                let (tx, ty) = (p1 - p0).normalize_or_zero().any_orthonormal_pair();
                match scale {
                    Some(scale) => {
                        let mut fields = cylinder(a, b, radius * scale);
                        let l = DMat3::from_mat4(m);
                        let (seam, uv) = seam_of(axis.normalize_or_zero(), l * tx, l * ty);
                        if uv == UvLayout::Same {
                            fields.extend(seam);
                            layout = uv;
                        }
                        geometry.push((name.clone(), fields));
                    }
                    None => {
                        // An elliptic or oblique cylinder: Mitsuba's own object space, the unit
                        // cylinder along z under to_world times [r·tx, r·ty, p1 − p0, p0] (the
                        // form the exporter writes, so that a round trip reads the same numbers;
                        // an emitter's sampling is parametrised by it).
                        layout = UvLayout::Same;
                        let mut fields = cylinder(DVec3::ZERO, DVec3::Z, 1.0);
                        let frame = glam::DMat4::from_cols(
                            (tx * radius).extend(0.0),
                            (ty * radius).extend(0.0),
                            (p1 - p0).extend(0.0),
                            p0.extend(1.0),
                        );
                        fields.push(("transform", matrix(&(m * frame))));
                        geometry.push((name.clone(), fields));
                    }
                }
            }
            "obj" | "ply" => {
                let file = p.string("filename")?.ok_or_else(|| fail("has no `filename`"))?;
                let face_normals = p.boolean("face_normals")?.unwrap_or(false);
                let mut fields = vec![
                    ("shape", "\"mesh\"".into()),
                    ("file", toml::Value::String((self.file)(&file)).to_string()),
                ];
                if flip {
                    // Mitsuba flips the geometric and shading normals: vitrum turns the mesh over.
                    fields.push(("flip_normals", "true".into()));
                }
                if face_normals {
                    // Mitsuba shades with the face normals: the file's vertex normals are ignored.
                    fields.push(("face_normals", "true".into()));
                } else {
                    // Mitsuba computes smooth vertex normals for a file that has none.
                    fields.push(("smooth_normals", "\"missing\"".into()));
                }
                fields.extend(placement(&m).ok_or_else(|| {
                    fail("to_world has a shear or a mirror, which a mesh's transform cannot hold yet")
                })?);
                geometry.push((name.clone(), fields));
            }
            other => return self.lacks(shape, &format!("the shape `{other}`")),
        }
        p.finish(self)?;
        let bsdf = shape.children_tagged("bsdf").next();
        if let (Some((corner, u, v)), Some(r)) = (quad_light, radiance) {
            lights.from(&shape.position, &shape.describe());
            lights.array_table("lights");
            lights
                .comment(&format!("{name}: a rectangle with an area emitter (one-sided, along its normal)"));
            lights.string("type", "quad");
            lights.vector("corner", corner.to_array());
            lights.vector("u", u.to_array());
            lights.vector("v", v.to_array());
            lights.vector("radiance", r);
            return Ok(());
        }
        if let (Some((c, r)), Some(radiance)) = (sphere_light, radiance) {
            lights.from(&shape.position, &shape.describe());
            lights.array_table("lights");
            lights.comment(&format!("{name}: a sphere with an area emitter (outwards)"));
            lights.string("type", "sphere");
            lights.vector("center", c.to_array());
            lights.number("radius", r);
            lights.vector("radiance", radiance);
            if let Some(b) = bsdf {
                self.warn(&b.position, &format!("{name}: the bsdf of an emitting sphere is dropped (vitrum's sphere lights reflect nothing)"));
            }
            return Ok(());
        }
        self.uv_layout = layout;
        // Mitsuba's area emitter emits on the side the normal faces: so does a vitrum emission
        // with `emission_one_sided` (disks, cylinders, the cube's quads, meshes).
        let material = self.material(bsdf.map(Rc::as_ref), radiance, &shape.position, materials);
        self.uv_layout = UvLayout::Flipped;
        let material = material?;
        for (object, fields) in geometry {
            objects.from(&shape.position, &shape.describe());
            objects.array_table("objects");
            objects.string("name", &object);
            objects.string("material", &material);
            for (key, value) in fields {
                objects.raw(key, &value);
            }
        }
        Ok(())
    }

    /// The key of the material for `bsdf` (written once per BSDF object), with `emission`: the
    /// radiance emitted on the side the normal faces (Mitsuba's `area` emitter).
    fn material(
        &mut self,
        bsdf: Option<&Object>,
        emission: Option<[f64; 3]>,
        at: &Position,
        out: &mut TomlWriter,
    ) -> Result<String, XmlError> {
        let key_of = bsdf.map(|b| (b as *const Object, self.uv_layout));
        if emission.is_none() {
            if let Some(key) = key_of.and_then(|k| self.materials.get(&k)) {
                return Ok(key.clone());
            }
        }
        let base = bsdf.and_then(|b| b.id.clone()).unwrap_or_else(|| "material".into());
        let mut key: String = base
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
            .collect();
        let stem = key.clone();
        let mut n = 2;
        while self.names.contains(&key) {
            key = format!("{stem}-{n}");
            n += 1;
        }
        self.names.insert(key.clone());
        match bsdf {
            Some(b) => out.from(&b.position, &b.describe()),
            None => out.from(at, "<shape> without a <bsdf>"),
        }
        out.table(&format!("materials.{key}"));
        match bsdf {
            None if emission.is_some() => {
                out.comment("Mitsuba's default for an emitter: a black diffuse BSDF (it reflects nothing)");
                out.string("type", "diffuse");
                out.vector("color", [0.0; 3]);
            }
            None => {
                out.comment("Mitsuba's default: a (one-sided) diffuse BSDF of reflectance 0.5");
                out.string("type", "diffuse");
                out.vector("color", [0.5; 3]);
                self.diffuse_sides(at, "a shape without a bsdf", out);
            }
            Some(b) => self.bsdf(b, out, false)?,
        }
        if let Some(r) = emission {
            out.vector("emission", r);
            out.comment("Mitsuba's area emitter emits on the side the normal faces");
            out.raw("emission_one_sided", "true");
        }
        if emission.is_none() {
            if let Some(k) = key_of {
                self.materials.insert(k, key.clone());
            }
        }
        Ok(key)
    }

    /// The microfacet roughness of a `roughdielectric`, `roughconductor` or `roughplastic` `b`:
    /// Mitsuba's `alpha` (default 0.1) and `distribution` (beckmann, the default, or ggx);
    /// `Ok(false)` when an anisotropic roughness was dropped (lenient) and the material ends there.
    fn roughness(&mut self, b: &Object, p: &Props<'_>, out: &mut TomlWriter) -> Result<bool, XmlError> {
        let alpha = if p.get("alpha_u").is_some() || p.get("alpha_v").is_some() {
            // Mitsuba asks for both, without `alpha`; equal, they are the isotropic roughness.
            // An anisotropic one needs the shapes' dp/du tangent frames, which vitrum's BSDF
            // frames (built from the normal alone) do not follow.
            if p.get("alpha").is_some() {
                return Err(error(
                    &b.position,
                    &b.describe(),
                    "`alpha` together with `alpha_u`/`alpha_v`: give one or the other",
                ));
            }
            match (p.float("alpha_u")?, p.float("alpha_v")?) {
                (Some(u), Some(v)) if u == v => u,
                (Some(_), Some(_)) => {
                    self.lacks(b, "an anisotropic roughness (alpha_u ≠ alpha_v)")?;
                    return Ok(false);
                }
                _ => {
                    return Err(error(
                        &b.position,
                        &b.describe(),
                        "`alpha_u` and `alpha_v` go together: give both",
                    ))
                }
            }
        } else {
            p.float("alpha")?.unwrap_or(0.1)
        };
        out.number("alpha", alpha);
        match p.string("distribution")?.as_deref() {
            None | Some("beckmann") => out.string("distribution", "beckmann"),
            Some("ggx") => out.string("distribution", "ggx"),
            Some(other) => {
                return Err(error(
                    &b.position,
                    &b.describe(),
                    &format!("distribution `{other}`: beckmann or ggx"),
                ))
            }
        }
        p.get("sample_visible");
        Ok(true)
    }

    /// The fields of a material from `bsdf` (`two_sided` when inside a `twosided`).
    fn bsdf(&mut self, b: &Object, out: &mut TomlWriter, two_sided: bool) -> Result<(), XmlError> {
        let p = Props::of(b);
        match b.plugin.as_str() {
            "twosided" => {
                let inner: Vec<&Rc<Object>> = b.children_tagged("bsdf").collect();
                match inner[..] {
                    [one] => self.bsdf(one, out, true)?,
                    _ => return Err(error(
                        &b.position,
                        &b.describe(),
                        "a twosided BSDF wraps exactly one <bsdf> (two different sides are not supported)",
                    )),
                }
            }
            "diffuse" => {
                out.string("type", "diffuse");
                let texture = b
                    .children
                    .iter()
                    .find(|c| c.tag == "texture" && c.name.as_deref() == Some("reflectance"));
                match texture {
                    Some(t) => self.texture(t, out)?,
                    None => out.vector("color", p.color("reflectance")?.unwrap_or([0.5; 3])),
                }
                if !two_sided {
                    self.diffuse_sides(&b.position, &b.describe(), out);
                }
            }
            "dielectric" | "roughdielectric" => {
                out.string("type", "dielectric");
                out.comment("int_ior: the side opposite the normal (inside); ext_ior: the side it points to");
                out.number("ior", mitsuba_ior(&p, b, "int_ior", "bk7")?);
                out.number("ior_outside", mitsuba_ior(&p, b, "ext_ior", "air")?);
                if b.plugin == "roughdielectric" && !self.roughness(b, &p, out)? {
                    return Ok(());
                }
                for name in ["specular_reflectance", "specular_transmittance"] {
                    if let Some(c) = p.color(name)? {
                        if c != [1.0; 3] {
                            return self.lacks(b, &format!("`{name}` other than 1"));
                        }
                    }
                }
            }
            "thindielectric" => {
                out.string("type", "thin_dielectric");
                for (name, key, default) in [("int_ior", "ior", "bk7"), ("ext_ior", "ior_outside", "air")] {
                    let value = mitsuba_ior(&p, b, name, default)?;
                    out.number(key, value);
                }
                for name in ["specular_reflectance", "specular_transmittance"] {
                    if let Some(c) = p.color(name)? {
                        if c != [1.0; 3] {
                            return self.lacks(b, &format!("`{name}` other than 1"));
                        }
                    }
                }
            }
            "plastic" | "roughplastic" => {
                let rough = b.plugin == "roughplastic";
                out.string("type", if rough { "rough_plastic" } else { "plastic" });
                for name in ["diffuse_reflectance", "specular_reflectance"] {
                    if b.children.iter().any(|c| c.tag == "texture" && c.name.as_deref() == Some(name)) {
                        return self.lacks(b, &format!("a texture for `{name}`"));
                    }
                }
                out.vector("diffuse_reflectance", p.color("diffuse_reflectance")?.unwrap_or([0.5; 3]));
                if let Some(c) = p.color("specular_reflectance")? {
                    out.vector("specular_reflectance", c);
                }
                out.comment("int_ior: the coating; ext_ior: the medium outside");
                out.number("ior", mitsuba_ior(&p, b, "int_ior", "polypropylene")?);
                out.number("ior_outside", mitsuba_ior(&p, b, "ext_ior", "air")?);
                if p.boolean("nonlinear")? == Some(true) {
                    out.raw("nonlinear", "true");
                }
                if rough && !self.roughness(b, &p, out)? {
                    return Ok(());
                }
                if two_sided {
                    out.raw("two_sided", "true");
                } else {
                    out.comment(&format!("Mitsuba's {} is one-sided: black from behind", b.plugin));
                }
            }
            "conductor" | "roughconductor" => {
                out.string("type", "conductor");
                let eta = p.color("eta")?;
                let k = p.color("k")?;
                match (p.string("material")?, eta, k) {
                    (_, Some(eta), Some(k)) => {
                        out.vector("eta", eta);
                        out.vector("k", k);
                    }
                    (Some(metal), None, None) => {
                        const METALS: [&str; 6] = ["Au", "Ag", "Cu", "Al", "Cr", "none"];
                        if !METALS.contains(&metal.as_str()) {
                            return self.lacks(
                                b,
                                &format!(
                                    "the conductor material `{metal}` (vitrum has {})",
                                    METALS.join(", ")
                                ),
                            );
                        }
                        out.string("metal", &metal);
                    }
                    (None, None, None) => out.string("metal", "none"),
                    _ => {
                        return Err(error(
                            &b.position,
                            &b.describe(),
                            "give both `eta` and `k`, or a `material`",
                        ))
                    }
                }
                if let Some(outside) = p.float("ext_eta")? {
                    out.number("ior_outside", outside);
                }
                if let Some(c) = p.color("specular_reflectance")? {
                    out.vector("specular_reflectance", c);
                }
                if b.plugin == "roughconductor" && !self.roughness(b, &p, out)? {
                    return Ok(());
                }
                if !two_sided {
                    out.comment("Mitsuba's conductor reflects on its front only; vitrum's on both sides");
                    self.warn(
                        &b.position,
                        &format!("{}: one-sided in Mitsuba, two-sided in vitrum", b.describe()),
                    );
                }
            }
            other => {
                self.lacks(b, &format!("the BSDF `{other}`"))?;
                out.comment(&format!(
                    "Mitsuba's `{other}` is not supported: dropped, written as black diffuse (--lenient)"
                ));
                out.string("type", "diffuse");
                out.vector("color", [0.0; 3]);
                return Ok(());
            }
        }
        p.finish(self)
    }

    /// The sides of a Mitsuba `diffuse` outside a `twosided` (`what` at `at`): one-sided, or
    /// two-sided with a warning when `--two-sided` asks for that reading.
    fn diffuse_sides(&mut self, at: &Position, what: &str, out: &mut TomlWriter) {
        if self.two_sided {
            out.comment(
                "Mitsuba's diffuse is one-sided (black from behind); read as two-sided (--two-sided)",
            );
            self.warn(at, &format!("{what}: one-sided in Mitsuba, read as two-sided (--two-sided)"));
        } else {
            out.comment("Mitsuba's diffuse is one-sided: black from behind");
            out.raw("one_sided", "true");
        }
    }

    /// An image texture (`bitmap`) for a diffuse colour.
    fn texture(&mut self, t: &Object, out: &mut TomlWriter) -> Result<(), XmlError> {
        if t.plugin != "bitmap" {
            return self.lacks(t, &format!("the texture `{}`", t.plugin));
        }
        let p = Props::of(t);
        let file =
            p.string("filename")?.ok_or_else(|| error(&t.position, &t.describe(), "has no `filename`"))?;
        let mut fields =
            vec![format!("type = \"image\""), format!("file = {}", toml::Value::String((self.file)(&file)))];
        match p.string("filter_type")?.as_deref() {
            None | Some("bilinear") => {}
            Some("nearest") => fields.push("filter = \"nearest\"".into()),
            Some(other) => {
                return Err(error(
                    &t.position,
                    &t.describe(),
                    &format!("filter_type `{other}`: bilinear or nearest"),
                ))
            }
        }
        match p.string("wrap_mode")?.as_deref() {
            None | Some("repeat") => {}
            Some("clamp") => fields.push("wrap = \"clamp\"".into()),
            Some(other) => {
                return Err(error(
                    &t.position,
                    &t.describe(),
                    &format!("wrap_mode `{other}`: repeat or clamp (mirror is not supported yet)"),
                ))
            }
        }
        if p.boolean("raw")?.unwrap_or(false) {
            fields.push("colorspace = \"linear\"".into());
        }
        // Mitsuba reads the bitmap at (x, y) = to_uv·(u, v) of the shape's uv, y down from the
        // top row (its 2-D map: rows and columns 0, 1 and 3 of the 4×4); vitrum at
        // st = uv·scale + offset, t up from the bottom row. Where Mitsuba's v is vitrum's
        // (a rectangle, a cylinder, a disk) the image is mirrored in v; elsewhere (an OBJ, whose
        // v Mitsuba's loader flips, a sphere, a cube's faces) Mitsuba's v is 1 − vitrum's (see
        // UvLayout). Only a diagonal map has a counterpart.
        let m = p.transform("to_uv")?.unwrap_or(DMat4::IDENTITY);
        let (a, d, b, e) = (m.x_axis.x, m.x_axis.y, m.y_axis.x, m.y_axis.y);
        let (c, f) = (m.w_axis.x, m.w_axis.y);
        if b != 0.0 || d != 0.0 {
            return Err(error(
                &t.position,
                &t.describe(),
                "to_uv turns or shears the texture coordinates: vitrum's textures take a scale and an offset only",
            ));
        }
        let (scale, offset) = match self.uv_layout {
            UvLayout::Same => {
                // Mitsuba's rectangle has uv (0, 0) at its corner (−1, −1) and reads a
                // bitmap's top row at v = 0; vitrum's quad reads the bottom row there. A PLY's
                // uv is the file's in both.
                out.comment("Mitsuba reads the image with v from its top row: mirrored in v");
                ([a, -e], [c, 1.0 - f])
            }
            UvLayout::Flipped => ([a, e], [c, 1.0 - e - f]),
            UvLayout::Unmatched => {
                return self.lacks(
                    t,
                    "a bitmap on a cylinder whose to_world mirrors it (its uv would turn the other way)",
                )
            }
        };
        if scale != [1.0, 1.0] || offset != [0.0, 0.0] {
            fields.push(format!("scale = {}", vector(scale)));
            fields.push(format!("offset = {}", vector(offset)));
        }
        out.raw("texture", &format!("{{ {} }}", fields.join(", ")));
        p.finish(self)
    }

    /// A light without a shape of its own.
    fn emitter(&mut self, e: &Object, lights: &mut TomlWriter) -> Result<(), XmlError> {
        lights.from(&e.position, &e.describe());
        let p = Props::of(e);
        // A nested object (a texture as the radiance, a spot's projected image) has no vitrum
        // counterpart in these lights.
        for child in &e.children {
            self.lacks(child, &format!("a <{}> nested in {}", child.tag, e.describe()))?;
        }
        match e.plugin.as_str() {
            "point" => {
                let m = p.transform("to_world")?;
                let position = p
                    .point("position")?
                    .or(m.map(|m| m.transform_point3(DVec3::ZERO)))
                    .unwrap_or(DVec3::ZERO);
                lights.array_table("lights");
                lights.string("type", "point");
                lights.vector("position", position.to_array());
                lights.vector("intensity", p.color("intensity")?.unwrap_or([1.0; 3]));
            }
            "spot" => {
                // Mitsuba's spot sits at the origin of its to_world and shines along its +z.
                let m = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
                let axes = DMat3::from_mat4(m);
                let gram = axes.transpose() * axes;
                let scale2 = gram.x_axis.x;
                let similar = (gram - DMat3::from_diagonal(DVec3::splat(scale2)))
                    .to_cols_array()
                    .iter()
                    .all(|v| v.abs() <= 1e-6 * scale2);
                if !(scale2 > 0.0 && similar) {
                    return Err(error(
                        &e.position,
                        &e.describe(),
                        "to_world must be a rotation, translation and uniform scale (a sheared or stretched \
                         spot has an elliptic beam, which vitrum lacks)",
                    ));
                }
                lights.array_table("lights");
                lights.string("type", "spot");
                lights.vector("position", m.transform_point3(DVec3::ZERO).to_array());
                lights.vector("direction", m.transform_vector3(DVec3::Z).normalize().to_array());
                lights.vector("intensity", p.color("intensity")?.unwrap_or([1.0; 3]));
                // The defaults (20°, three quarters of the cutoff) are Mitsuba's and vitrum's.
                for angle in ["cutoff_angle", "beam_width"] {
                    if let Some(degrees) = p.float(angle)? {
                        lights.number(angle, degrees);
                    }
                }
            }
            "directional" => {
                // The light travels along `direction`, or along the +z of its to_world.
                let direction = match (p.point("direction")?, p.transform("to_world")?) {
                    (Some(_), Some(_)) => {
                        return Err(error(
                            &e.position,
                            &e.describe(),
                            "give `direction` or `to_world`, not both",
                        ))
                    }
                    (Some(d), None) => d,
                    (None, m) => m.unwrap_or(DMat4::IDENTITY).transform_vector3(DVec3::Z),
                };
                if !(direction.length().is_finite() && direction.length() > 0.0) {
                    return Err(error(&e.position, &e.describe(), "the direction must be a non-zero vector"));
                }
                lights.array_table("lights");
                lights.string("type", "directional");
                lights.vector("direction", direction.normalize().to_array());
                lights.vector("irradiance", p.color("irradiance")?.unwrap_or([1.0; 3]));
            }
            "constant" => {
                lights.array_table("lights");
                lights.string("type", "environment");
                lights.vector("radiance", p.color("radiance")?.unwrap_or([1.0; 3]));
            }
            "envmap" => {
                let file = p
                    .string("filename")?
                    .ok_or_else(|| error(&e.position, &e.describe(), "has no `filename`"))?;
                let scale = p.float("scale")?.unwrap_or(1.0);
                let m = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
                let angle = y_rotation(&m).ok_or_else(|| {
                    error(
                        &e.position,
                        &e.describe(),
                        "to_world must be a rotation about +Y (vitrum turns environment maps about +Y only)",
                    )
                })?;
                lights.array_table("lights");
                lights.string("type", "environment");
                lights.string("file", &(self.file)(&file));
                lights.number("scale", scale);
                lights.number("rotation", angle);
            }
            "area" => {
                return Err(error(&e.position, &e.describe(), "an area emitter belongs inside a <shape>"))
            }
            other => return self.lacks(e, &format!("the emitter `{other}`")),
        }
        p.finish(self)
    }
}

/// How a Mitsuba shape's uv (u_m, v_m) relates to the uv (u, v) vitrum gives the shape the
/// import writes, for a bitmap on it (Mitsuba reads the image with v down from its top row,
/// vitrum with v up from its bottom row).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum UvLayout {
    /// (u_m, v_m) = (u, v): a `rectangle`, a `ply` mesh (its file's uv), a `cylinder` and a
    /// `disk` (written with Mitsuba's seam).
    Same,
    /// (u_m, v_m) = (u, 1 − v): an `obj` mesh (Mitsuba's OBJ loader flips v), a `sphere`
    /// (written with Mitsuba's pole and seam), a `cube`'s faces (each written from its corner
    /// at Mitsuba's uv (0, 1)), a flipped `rectangle` or `disk` (the angle the other way round).
    Flipped,
    /// Not related by the import: a `cylinder` whose to_world mirrors its angle.
    Unmatched,
}

impl UvLayout {
    fn of(plugin: &str) -> UvLayout {
        match plugin {
            "rectangle" | "ply" => UvLayout::Same,
            "obj" | "sphere" => UvLayout::Flipped,
            _ => UvLayout::Unmatched,
        }
    }
}

/// The `seam` field (none where vitrum's default frame, Duff et al.'s t₁ of `n`, is it) that
/// makes a disk's or cylinder's texture angle about the unit `n` start along `x` and grow towards
/// `y` (Mitsuba's local x and y axes in the world), and the layout that relates the two uv:
/// `Same` when vitrum's frame (seam, n × seam) turns the way x, y do, else `Flipped` (the angle
/// runs the other way: Mitsuba's second coordinate is 1 − vitrum's, true of a disk's).
fn seam_of(n: DVec3, x: DVec3, y: DVec3) -> (Option<(&'static str, String)>, UvLayout) {
    // Taken as it is when it already lies across `n` (to single precision): the direction an
    // export wrote reads back unchanged.
    let unit = x.normalize_or_zero();
    let seam = if unit.dot(n).abs() <= 1e-7 { unit } else { (x - x.dot(n) * n).normalize_or_zero() };
    let default = n.any_orthonormal_pair().0;
    let field = ((seam - default).length() > 1e-6).then(|| ("seam", vector(seam.to_array())));
    let layout = if n.cross(seam).dot(y) > 0.0 { UvLayout::Same } else { UvLayout::Flipped };
    (field, layout)
}

/// The `key = value` fields of a sphere.
fn sphere(center: DVec3, radius: f64) -> Vec<(&'static str, String)> {
    vec![("shape", "\"sphere\"".into()), ("center", vector(center.to_array())), ("radius", number(radius))]
}

/// `{ matrix = [16 numbers, row by row] }`: a general affine `transform` (the last row 0 0 0 1).
fn matrix(m: &DMat4) -> String {
    let rows = m.transpose().to_cols_array();
    let numbers: Vec<String> = rows.iter().map(|&v| number(v)).collect();
    format!("{{ matrix = [{}] }}", numbers.join(", "))
}

/// The `key = value` fields of a quad.
fn quad(corner: DVec3, u: DVec3, v: DVec3) -> Vec<(&'static str, String)> {
    vec![
        ("shape", "\"quad\"".into()),
        ("corner", vector(corner.to_array())),
        ("u", vector(u.to_array())),
        ("v", vector(v.to_array())),
    ]
}

/// A face of a Mitsuba shape whose uv is (a, b) at `origin + a·du + b·dv` (object space), placed
/// by `m` as a vitrum quad (corner, u, v) with the same uv for an image, and how the two uv relate.
/// The quad's normal u × v is du × dv's, or its opposite when exactly one of `inward` (du × dv
/// points into the shape), `flip` (flip_normals) and a mirroring `m` holds: then the quad runs
/// from `origin + dv` along du and −dv, Mitsuba's v being 1 − vitrum's.
fn mitsuba_face(
    m: &DMat4,
    (origin, du, dv): (DVec3, DVec3, DVec3),
    inward: bool,
    flip: bool,
) -> ((DVec3, DVec3, DVec3), UvLayout) {
    let mirrored = DMat3::from_mat4(*m).determinant() < 0.0;
    let (wu, wv) = (m.transform_vector3(du), m.transform_vector3(dv));
    if mirrored ^ flip ^ inward {
        ((m.transform_point3(origin + dv), wu, -wv), UvLayout::Flipped)
    } else {
        ((m.transform_point3(origin), wu, wv), UvLayout::Same)
    }
}

/// Whether `bsdf`, an emitting shape's, reflects nothing: absent (Mitsuba 3 gives a shape with
/// an emitter a black diffuse by default, a shape without one a diffuse 0.5) or a black
/// `diffuse`, bare or in a `twosided`.
fn reflects_nothing(bsdf: Option<&Rc<Object>>) -> bool {
    let Some(b) = bsdf else { return true };
    match b.plugin.as_str() {
        "twosided" => reflects_nothing(b.children_tagged("bsdf").next()),
        "diffuse" => {
            b.children.is_empty()
                && match b.property("reflectance").map(|p| &p.value) {
                    Some(Value::Rgb(c)) => *c == [0.0; 3],
                    Some(Value::Float(v) | Value::Constant(v)) => *v == 0.0,
                    _ => false,
                }
        }
        _ => false,
    }
}

/// The six faces of Mitsuba's cube [−1, 1]³ as (origin, du, dv): each face's uv (a, b) is at
/// `origin + a·du + b·dv`, as Mitsuba 3's cube mesh gives its corners' texture coordinates
/// (`src/shapes/cube.cpp`); du × dv points into the cube on every face.
fn cube_faces() -> [(DVec3, DVec3, DVec3); 6] {
    let (x, y, z) = (DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z * 2.0);
    let c = |a: f64, b: f64, c: f64| DVec3::new(a, b, c);
    [
        (c(-1.0, -1.0, -1.0), z, x), // −y
        (c(1.0, 1.0, 1.0), -x, -z),  // +y
        (c(1.0, -1.0, 1.0), y, -z),  // +x
        (c(-1.0, -1.0, 1.0), y, x),  // +z
        (c(-1.0, -1.0, -1.0), y, z), // −x
        (c(-1.0, 1.0, -1.0), -y, x), // −z
    ]
}

/// The world normal of the object's +z under `m` (inverse transpose), flipped with `flip`.
/// When the z column is perpendicular to the x and y columns (within 1e-6 radians) it has that
/// direction: it is taken, normalised unless it is a unit vector to single precision already
/// (the exporter writes a disk's normal there, which a round trip then reads back unchanged).
fn normal_of(m: &DMat4, flip: bool) -> DVec3 {
    let l = DMat3::from_mat4(*m);
    let z = l.z_axis;
    let perpendicular = |c: DVec3| c.dot(z).abs() <= 1e-6 * c.length() * z.length();
    let n = if z.length_squared() > 0.0 && perpendicular(l.x_axis) && perpendicular(l.y_axis) {
        if (z.length_squared() - 1.0).abs() <= 2.0 * f64::from(f32::EPSILON) {
            z
        } else {
            z.normalize()
        }
    } else {
        (l.inverse().transpose() * DVec3::Z).normalize_or_zero()
    };
    if flip {
        -n
    } else {
        n
    }
}

/// The uniform scale and rotation of `m`'s linear part when it is a similarity (orthogonal
/// columns of equal length, no mirror), within a relative 1e-5.
fn similarity(m: &DMat4) -> Option<(f64, DMat3)> {
    let l = DMat3::from_mat4(*m);
    let s = l.x_axis.length();
    let tol = 1e-5 * s;
    let equal = (l.y_axis.length() - s).abs() <= tol && (l.z_axis.length() - s).abs() <= tol;
    let orthogonal = l.x_axis.dot(l.y_axis).abs() <= tol * s
        && l.y_axis.dot(l.z_axis).abs() <= tol * s
        && l.x_axis.dot(l.z_axis).abs() <= tol * s;
    (s > 0.0 && equal && orthogonal && l.determinant() > 0.0).then(|| (s, l * (1.0 / s)))
}

/// Q of Mitsuba 3's `transform_decompose` of `m`'s linear part L = Q·S (Q orthogonal, S
/// symmetric), by its 25 steps of the polar iteration Q ← (Q + Q⁻ᵀ)/2; `None` for a singular L.
fn polar_rotation(m: &DMat4) -> Option<DMat3> {
    let l = DMat3::from_mat4(*m);
    if l.determinant() == 0.0 {
        return None;
    }
    let mut q = l;
    for _ in 0..25 {
        q = (q + q.inverse().transpose()) * 0.5;
    }
    Some(q)
}

/// The radius factor Mitsuba 3 gives a sphere under `m`: S's first diagonal element of
/// [`polar_rotation`]'s L = Q·S. For a similarity it is the scale.
fn sphere_scale(m: &DMat4) -> f64 {
    polar_rotation(m).map_or(0.0, |q| q.x_axis.dot(DMat3::from_mat4(*m).x_axis))
}

/// The rotation that turns Mitsuba 3's sphere (and its uv frame) under `m`: Q of
/// [`polar_rotation`], a mirror's Q negated (vitrum's texture frames turn, never mirror).
fn sphere_rotation(m: &DMat4) -> DMat3 {
    match polar_rotation(m) {
        Some(q) if q.determinant() < 0.0 => -q,
        Some(q) => q,
        None => DMat3::IDENTITY,
    }
}

/// The scale of `m` in its object's xy plane when it keeps circles round there (the x and y
/// columns orthogonal and of equal length; the z column may be anything): disks and cylinders.
fn round_in_plane(m: &DMat4) -> Option<f64> {
    let l = DMat3::from_mat4(*m);
    let s = l.x_axis.length();
    let tol = 1e-5 * s;
    let round = (l.y_axis.length() - s).abs() <= tol && l.x_axis.dot(l.y_axis).abs() <= tol * s;
    (s > 0.0 && round && l.determinant() != 0.0).then_some(s)
}

/// A mesh's `transform = { scale, rotate, translate }` fields for `m` = translate · rotate ·
/// scale (per axis), none for the identity (without a transform, vertex normals that are unit
/// already are kept as they are: an exported mesh's read back to the same bits); `None` when
/// `m` has a shear or a mirror.
fn placement(m: &DMat4) -> Option<Vec<(&'static str, String)>> {
    if *m == DMat4::IDENTITY {
        return Some(Vec::new());
    }
    let l = DMat3::from_mat4(*m);
    let s = DVec3::new(l.x_axis.length(), l.y_axis.length(), l.z_axis.length());
    if s.min_element() <= 0.0 {
        return None;
    }
    let r = DMat3::from_cols(l.x_axis / s.x, l.y_axis / s.y, l.z_axis / s.z);
    let tol = 1e-5;
    let orthonormal = (r.transpose() * r - DMat3::IDENTITY).to_cols_array().iter().all(|e| e.abs() <= tol);
    if !orthonormal || r.determinant() < 0.0 {
        return None;
    }
    let (axis, angle) = DQuat::from_mat3(&r).to_axis_angle();
    let t = m.w_axis.truncate();
    let mut parts = vec![format!("scale = {}", vector(s.to_array()))];
    if angle.abs() > 1e-12 {
        parts.push(format!(
            "rotate = {{ axis = {}, angle = {} }}",
            vector(axis.to_array()),
            number(angle.to_degrees())
        ));
    }
    parts.push(format!("translate = {}", vector(t.to_array())));
    Some(vec![("transform", format!("{{ {} }}", parts.join(", ")))])
}

/// The angle in degrees of `m` as a rotation about +Y in vitrum's sense (the exporter writes
/// vitrum's turn θ as Mitsuba's to_world with columns (cos θ, 0, −sin θ), +Y, (sin θ, 0, cos θ));
/// `None` for any other transform.
fn y_rotation(m: &DMat4) -> Option<f64> {
    let l = DMat3::from_mat4(*m);
    let (c, s) = (l.x_axis.x, l.z_axis.x);
    let expected = DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c));
    let close = (l - expected).to_cols_array().iter().all(|e| e.abs() <= 1e-6)
        && ((c * c + s * s) - 1.0).abs() <= 1e-6;
    (close && m.w_axis.truncate().length() <= 1e-9).then(|| s.atan2(c).to_degrees())
}

/// The refractive index `name` of the dielectric, thin dielectric or plastic `b`: a `<float>` or
/// one of Mitsuba's named materials ([`NAMED_IORS`]), `default` when absent.
fn mitsuba_ior(p: &Props, b: &Object, name: &str, default: &str) -> Result<f64, XmlError> {
    match p.get(name) {
        None => Ok(named_ior(default).expect("a default in the table")),
        Some(Property { value: Value::Float(v), .. }) => Ok(*v),
        Some(prop @ Property { value: Value::String(s), .. }) => named_ior(s).ok_or_else(|| {
            error(
                &prop.position,
                &b.describe(),
                &format!(
                    "`{name}` `{s}` is not one of Mitsuba's named indices: {}",
                    NAMED_IORS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                ),
            )
        }),
        Some(prop) => Err(p.wrong(prop, "a <float> or a <string> naming a material")),
    }
}

/// Mitsuba's index for a material name.
fn named_ior(name: &str) -> Option<f64> {
    NAMED_IORS.iter().find(|(n, _)| n.eq_ignore_ascii_case(name.trim())).map(|(_, v)| *v)
}

/// An error at `position` about `element`.
fn error(position: &Position, element: &str, message: &str) -> XmlError {
    XmlError { position: position.clone(), element: element.to_string(), message: message.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_point_outwards_and_cover_the_cube() {
        let mut normals = Vec::new();
        for face in cube_faces() {
            let ((corner, u, v), layout) = mitsuba_face(&DMat4::IDENTITY, face, true, false);
            assert_eq!(layout, UvLayout::Flipped);
            let centre = corner + 0.5 * (u + v);
            let n = u.cross(v).normalize();
            assert!((n.dot(centre) - 1.0).abs() < 1e-12, "{corner} {u} {v}");
            assert_eq!(centre.abs().max_element(), 1.0);
            normals.push(n);
        }
        // Six different faces, and Mitsuba's uv (0, 0) of the −y face (its vertex 3) where the
        // quad's v is 1.
        normals.dedup_by(|a, b| (*a - *b).length() < 1e-9);
        assert_eq!(normals.len(), 6);
        let ((corner, _, v), _) = mitsuba_face(&DMat4::IDENTITY, cube_faces()[0], true, false);
        assert_eq!(corner + v, DVec3::new(-1.0, -1.0, -1.0));
    }

    #[test]
    fn similarities_and_placements_are_recognised() {
        let m = DMat4::from_scale_rotation_translation(
            DVec3::splat(2.0),
            DQuat::from_rotation_y(0.3),
            DVec3::ONE,
        );
        let (s, _) = similarity(&m).unwrap();
        assert!((s - 2.0).abs() < 1e-12);
        let stretched = DMat4::from_scale(DVec3::new(1.0, 2.0, 1.0));
        assert!(similarity(&stretched).is_none());
        assert!(placement(&stretched).is_some());
        let sheared = DMat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ]);
        assert!(placement(&sheared).is_none());
        assert!(similarity(&DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))).is_none());
    }

    #[test]
    fn a_sphere_takes_mitsubas_radius_from_the_polar_decomposition() {
        // Scale, then rotate: S = diag(scale), the radius factor its x entry.
        let m = DMat4::from_scale_rotation_translation(
            DVec3::new(0.6, 0.3, 0.4),
            DQuat::from_rotation_z(0.5),
            DVec3::ONE,
        );
        assert!((sphere_scale(&m) - 0.6).abs() < 1e-12);
        let uniform = DMat4::from_scale_rotation_translation(
            DVec3::splat(2.0),
            DQuat::from_rotation_y(1.0),
            DVec3::ZERO,
        );
        assert!((sphere_scale(&uniform) - 2.0).abs() < 1e-12);
        // A shear: S = √(LᵀL), whose first entry is not the first column's length.
        let sheared = DMat4::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ]);
        let l = DMat3::from_mat4(sheared);
        let s00 = sphere_scale(&sheared);
        // S² = LᵀL: check (S·S)[0][0] with S = Qᵀ L.
        let mut q = l;
        for _ in 0..25 {
            q = (q + q.inverse().transpose()) * 0.5;
        }
        let s = q.transpose() * l;
        assert!(((s * s).x_axis.x - (l.transpose() * l).x_axis.x).abs() < 1e-9);
        assert!((s00 - s.x_axis.x).abs() < 1e-12 && s00 > 0.0 && s00 < 1.0, "{s00}");
    }

    #[test]
    fn a_mirroring_transform_keeps_the_normal_of_the_inverse_transpose() {
        let m = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        let square = (DVec3::new(-1.0, -1.0, 0.0), DVec3::X * 2.0, DVec3::Y * 2.0);
        let ((_, u, v), _) = mitsuba_face(&m, square, false, false);
        assert!(u.cross(v).normalize().dot(normal_of(&m, false)) > 0.999);
    }

    #[test]
    fn a_disks_normal_is_its_z_column_read_back_unchanged_when_unit() {
        let frame = |z: DVec3, x: DVec3| {
            let y = z.normalize().cross(x);
            DMat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), DVec3::ONE.extend(1.0))
        };
        // A unit normal in single precision (as the exporter writes it), under tangents scaled
        // by the radius: taken as written, not normalised again.
        let n = DVec3::new(0.0, 0.86602545, 0.49999994);
        let t = DVec3::new(0.35, 0.0, 0.0);
        assert_eq!(normal_of(&frame(n, t), false), n);
        assert_eq!(normal_of(&frame(n, t), true), -n);
        // A scaled one is normalised: Mitsuba's inverse transpose has its direction.
        let scaled = normal_of(&frame(n * 0.35, t), false);
        assert!((scaled.length() - 1.0).abs() < 1e-15 && scaled.dot(n) > 1.0 - 1e-12);
        // A z column that leans off the plane's normal: the inverse transpose (x × y).
        let m = frame(n + DVec3::new(0.3, 0.0, 0.0), t);
        let l = DMat3::from_mat4(m);
        let expected = l.x_axis.cross(l.y_axis).normalize();
        assert!(normal_of(&m, false).dot(expected) > 1.0 - 1e-12);
    }

    #[test]
    fn rotations_about_y_round_trip_the_exporters_convention() {
        for deg in [0.0f64, 30.0, -120.0, 180.0] {
            let (s, c) = deg.to_radians().sin_cos();
            let m = DMat4::from_cols(
                DVec3::new(c, 0.0, -s).extend(0.0),
                DVec3::Y.extend(0.0),
                DVec3::new(s, 0.0, c).extend(0.0),
                DVec3::ZERO.extend(1.0),
            );
            let back = y_rotation(&m).unwrap();
            assert!(((back - deg + 540.0) % 360.0 - 180.0).abs() < 1e-9, "{deg} → {back}");
        }
        assert!(y_rotation(&DMat4::from_rotation_x(0.5)).is_none());
    }
}
