//! `vitrum export --format mitsuba`: every shipped scene exports to well-formed Mitsuba 3 XML,
//! and the mapping of shapes, interfaces, lights, camera and settings is the documented one
//! (docs/mitsuba-export.md).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn vitrum() -> Command {
    Command::new(env!("CARGO_BIN_EXE_vitrum"))
}

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

// ---------- a small XML reader: elements and attributes, no text content ----------

#[derive(Debug)]
struct Element {
    name: String,
    attrs: Vec<(String, String)>,
    children: Vec<Element>,
}

impl Element {
    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// Direct children with this tag name.
    fn kids<'a>(&'a self, name: &str) -> impl Iterator<Item = &'a Element> + 'a {
        let name = name.to_string();
        self.children.iter().filter(move |c| c.name == name)
    }

    /// All descendants (and self) with this tag name, depth first.
    fn all<'a>(&'a self, name: &str, out: &mut Vec<&'a Element>) {
        if self.name == name {
            out.push(self);
        }
        for c in &self.children {
            c.all(name, out);
        }
    }

    /// The `value` of the child property `<kind name="name" value=.../>`.
    fn param(&self, kind: &str, name: &str) -> Option<&str> {
        self.kids(kind).find(|c| c.attr("name") == Some(name)).and_then(|c| c.attr("value"))
    }
}

fn is_name_char(c: char, first: bool) -> bool {
    c.is_ascii_alphabetic()
        || c == '_'
        || c == ':'
        || (!first && (c.is_ascii_digit() || c == '-' || c == '.'))
}

fn unescape(s: &str) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        let end = rest[i..].find(';').ok_or_else(|| format!("unterminated entity in {s:?}"))? + i;
        let entity = &rest[i + 1..end];
        out.push(match entity {
            "amp" => '&',
            "lt" => '<',
            "gt" => '>',
            "quot" => '"',
            "apos" => '\'',
            e if e.starts_with('#') => {
                let code = e[1..].parse::<u32>().map_err(|_| format!("bad character reference &{e};"))?;
                char::from_u32(code).ok_or_else(|| format!("bad character reference &{e};"))?
            }
            e => return Err(format!("unknown entity &{e};")),
        });
        rest = &rest[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Parse a document with one root element: balanced tags, quoted and escaped attributes,
/// well-formed comments, no text content.
fn parse_xml(text: &str) -> Result<Element, String> {
    let mut stack: Vec<Element> = Vec::new();
    let mut root = None;
    let mut s = text;
    if let Some(rest) = s.strip_prefix("<?xml") {
        s = &rest[rest.find("?>").ok_or("unterminated XML declaration")? + 2..];
    }
    loop {
        let trimmed = s.trim_start();
        if trimmed.is_empty() {
            break;
        }
        if !trimmed.starts_with('<') {
            return Err(format!("text content outside tags: {:?}", &trimmed[..trimmed.len().min(40)]));
        }
        s = trimmed;
        if let Some(rest) = s.strip_prefix("<!--") {
            let end = rest.find("-->").ok_or("unterminated comment")?;
            let body = &rest[..end];
            if body.contains("--") || body.ends_with('-') {
                return Err(format!("`--` inside a comment: {body:?}"));
            }
            s = &rest[end + 3..];
            continue;
        }
        if let Some(rest) = s.strip_prefix("</") {
            let end = rest.find('>').ok_or("unterminated closing tag")?;
            let name = rest[..end].trim();
            let element =
                stack.pop().ok_or_else(|| format!("closing tag </{name}> without an opening one"))?;
            if element.name != name {
                return Err(format!("<{}> closed by </{name}>", element.name));
            }
            match stack.last_mut() {
                Some(parent) => parent.children.push(element),
                None if root.is_none() => root = Some(element),
                None => return Err("more than one root element".into()),
            }
            s = &rest[end + 1..];
            continue;
        }
        // An opening or empty-element tag.
        let mut chars = s[1..].char_indices();
        let mut name_end = 0;
        for (i, c) in chars.by_ref() {
            if !is_name_char(c, i == 0) {
                name_end = i;
                break;
            }
        }
        let name = s[1..1 + name_end].to_string();
        if name.is_empty() {
            return Err(format!("bad tag: {:?}", &s[..s.len().min(40)]));
        }
        let mut rest = &s[1 + name_end..];
        let mut attrs = Vec::new();
        let empty;
        loop {
            rest = rest.trim_start();
            if let Some(r) = rest.strip_prefix("/>") {
                empty = true;
                rest = r;
                break;
            }
            if let Some(r) = rest.strip_prefix('>') {
                empty = false;
                rest = r;
                break;
            }
            let eq = rest.find('=').ok_or_else(|| format!("attribute without value in <{name}>"))?;
            let key = rest[..eq].trim().to_string();
            if key.is_empty() || !key.chars().enumerate().all(|(i, c)| is_name_char(c, i == 0)) {
                return Err(format!("bad attribute name {key:?} in <{name}>"));
            }
            let after = rest[eq + 1..].trim_start();
            let value =
                after.strip_prefix('"').ok_or_else(|| format!("unquoted attribute {key} in <{name}>"))?;
            let close = value.find('"').ok_or_else(|| format!("unterminated attribute {key} in <{name}>"))?;
            if attrs.iter().any(|(k, _): &(String, String)| *k == key) {
                return Err(format!("duplicate attribute {key} in <{name}>"));
            }
            if value[..close].contains('<') {
                return Err(format!("raw `<` in attribute {key} of <{name}>"));
            }
            attrs.push((key, unescape(&value[..close])?));
            rest = &value[close + 1..];
        }
        let element = Element { name, attrs, children: Vec::new() };
        if empty {
            match stack.last_mut() {
                Some(parent) => parent.children.push(element),
                None if root.is_none() => root = Some(element),
                None => return Err("more than one root element".into()),
            }
        } else {
            stack.push(element);
        }
        s = rest;
    }
    if let Some(open) = stack.last() {
        return Err(format!("<{}> is never closed", open.name));
    }
    root.ok_or_else(|| "no root element".into())
}

#[test]
fn the_reader_rejects_malformed_xml() {
    assert!(parse_xml("<a><b/></a>").is_ok());
    for bad in [
        "<a><b></a>",
        "<a>",
        "<a/><b/>",
        "<a x=1/>",
        "<a x=\"&foo;\"/>",
        "<a>text</a>",
        "<!-- a -- b --><a/>",
    ] {
        assert!(parse_xml(bad).is_err(), "{bad}");
    }
}

// ---------- exporting ----------

/// An exported scene: the parsed XML, its folder and the command's output.
struct Exported {
    root: Element,
    dir: tempfile::TempDir,
    xml: PathBuf,
    output: Output,
}

impl Exported {
    /// `$name` references resolved through the scene's `<default>`s.
    fn resolve<'a>(&'a self, value: &'a str) -> &'a str {
        match value.strip_prefix('$') {
            Some(name) => self
                .root
                .kids("default")
                .find(|d| d.attr("name") == Some(name))
                .and_then(|d| d.attr("value"))
                .unwrap_or_else(|| panic!("no default for {value}")),
            None => value,
        }
    }

    fn by_id(&self, id: &str) -> &Element {
        let mut found = Vec::new();
        for kind in ["bsdf", "medium", "texture"] {
            let mut all = Vec::new();
            self.root.all(kind, &mut all);
            found.extend(all.into_iter().filter(|e| e.attr("id") == Some(id)));
        }
        assert_eq!(found.len(), 1, "id {id} should name exactly one element");
        found[0]
    }

    fn shapes(&self, kind: &str) -> Vec<&Element> {
        self.root.kids("shape").filter(|s| s.attr("type") == Some(kind)).collect()
    }

    /// The BSDF of a shape: inline or referenced.
    fn bsdf_of<'a>(&'a self, shape: &'a Element) -> &'a Element {
        let inline: Vec<_> = shape.kids("bsdf").collect();
        let refs: Vec<_> = shape.kids("ref").filter(|r| r.attr("name").is_none()).collect();
        match (&inline[..], &refs[..]) {
            ([b], []) => b,
            ([], [r]) => self.by_id(r.attr("id").unwrap()),
            _ => panic!("shape {:?} should have exactly one BSDF", shape.attr("type")),
        }
    }

    /// A dielectric shape's (int_ior, ext_ior).
    fn iors(&self, shape: &Element) -> (f32, f32) {
        let b = self.bsdf_of(shape);
        assert_eq!(b.attr("type"), Some("dielectric"));
        let get = |n| b.param("float", n).unwrap().parse::<f32>().unwrap();
        (get("int_ior"), get("ext_ior"))
    }
}

fn export_with(scene_file: &Path, extra: &[&str]) -> Exported {
    let dir = tempfile::tempdir().unwrap();
    let xml = dir.path().join("scene.xml");
    let output = vitrum()
        .arg("export")
        .arg(scene_file)
        .args(["--format", "mitsuba", "-o"])
        .arg(&xml)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "export of {} failed: {}",
        scene_file.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    let text = std::fs::read_to_string(&xml).unwrap();
    let root = parse_xml(&text).unwrap_or_else(|e| panic!("{}: {e}", scene_file.display()));
    Exported { root, dir, xml, output }
}

fn export(name: &str) -> Exported {
    export_with(&scene(name), &[])
}

fn floats(text: &str) -> Vec<f32> {
    text.split([',', ' ']).filter(|s| !s.is_empty()).map(|s| s.parse().unwrap()).collect()
}

#[test]
fn every_shipped_scene_exports_to_well_formed_xml_with_its_meshes() {
    let mut names: Vec<_> = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 10, "{names:?}");
    for path in names {
        let e = export_with(&path, &[]);
        let what = path.display();
        assert_eq!(e.root.name, "scene", "{what}");
        assert_eq!(e.root.attr("version"), Some("3.0.0"), "{what}");
        assert_eq!(e.root.kids("integrator").count(), 1, "{what}");
        assert_eq!(e.root.kids("sensor").count(), 1, "{what}");
        assert!(e.root.kids("shape").count() >= 5, "{what}");
        // every reference resolves, every shape has one BSDF
        let mut refs = Vec::new();
        e.root.all("ref", &mut refs);
        for r in refs {
            e.by_id(r.attr("id").unwrap());
        }
        for shape in e.root.kids("shape") {
            e.bsdf_of(shape);
        }
        // every `$name` has a default
        let mut props = Vec::new();
        for kind in ["integer", "float", "string"] {
            e.root.all(kind, &mut props);
        }
        for p in props {
            e.resolve(p.attr("value").unwrap());
        }
        // mesh files exist beside the XML and are PLY
        for shape in e.shapes("ply") {
            let file = e.xml.parent().unwrap().join(shape.param("string", "filename").unwrap());
            let bytes =
                std::fs::read(&file).unwrap_or_else(|err| panic!("{what}: {}: {err}", file.display()));
            assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0\n"), "{}", file.display());
        }
        // no temporary files are left behind
        for entry in std::fs::read_dir(e.dir.path()).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.starts_with('.'), "{what}: leftover {name}");
        }
    }
}

#[test]
fn cornell_glass_maps_shapes_interfaces_light_and_camera() {
    let e = export("cornell-glass.toml");

    let spheres = e.shapes("sphere");
    assert_eq!(spheres.len(), 1);
    assert_eq!(e.iors(spheres[0]), (1.52, 1.0));
    assert_eq!(floats(spheres[0].kids("point").next().unwrap().attr("x").unwrap()), [-0.42]);
    assert_eq!(spheres[0].param("float", "radius"), Some("0.4"));

    // the capped cylinder: an uncapped cylinder plus two disks, all glass, caps facing out
    let cylinders = e.shapes("cylinder");
    assert_eq!(cylinders.len(), 1);
    assert_eq!(e.iors(cylinders[0]), (1.52, 1.0));
    assert_eq!(cylinders[0].param("float", "radius"), Some("0.28"));
    let disks = e.shapes("disk");
    assert_eq!(disks.len(), 2);
    let mut normal_y = Vec::new();
    for d in &disks {
        assert_eq!(e.iors(d), (1.52, 1.0));
        let m =
            floats(d.kids("transform").next().unwrap().kids("matrix").next().unwrap().attr("value").unwrap());
        // the third column is the disk's normal (Mitsuba's +z)
        normal_y.push(m[6]);
        assert!((m[3] - 0.45).abs() < 1e-6 && (m[11] - 0.3).abs() < 1e-6, "{m:?}");
    }
    normal_y.sort_by(f32::total_cmp);
    assert_eq!(normal_y, [-1.0, 1.0]);

    // five walls as rectangles, two-sided diffuse; the floor's checker as a checkerboard
    let rects = e.shapes("rectangle");
    assert_eq!(rects.len(), 5);
    for r in &rects {
        let b = e.bsdf_of(r);
        assert_eq!(b.attr("type"), Some("twosided"));
        assert_eq!(b.kids("bsdf").next().unwrap().attr("type"), Some("diffuse"));
    }
    let mut textures = Vec::new();
    e.root.all("texture", &mut textures);
    assert_eq!(textures.len(), 1);
    assert_eq!(textures[0].attr("type"), Some("checkerboard"));

    // the point light
    let emitters: Vec<_> = e.root.kids("emitter").collect();
    assert_eq!(emitters.len(), 1);
    assert_eq!(emitters[0].attr("type"), Some("point"));
    assert_eq!(floats(emitters[0].param("rgb", "intensity").unwrap()), [5.0, 5.0, 5.0]);
    let pos = emitters[0].kids("point").next().unwrap();
    assert_eq!((pos.attr("x"), pos.attr("y"), pos.attr("z")), (Some("0"), Some("1.8"), Some("0")));

    // the camera
    let sensor = e.root.kids("sensor").next().unwrap();
    assert_eq!(sensor.attr("type"), Some("perspective"));
    assert_eq!(sensor.param("float", "fov"), Some("39"));
    assert_eq!(sensor.param("string", "fov_axis"), Some("y"));
    let lookat = sensor.kids("transform").next().unwrap().kids("lookat").next().unwrap();
    assert_eq!(floats(lookat.attr("origin").unwrap()), [0.0, 1.0, 3.8]);
    assert_eq!(floats(lookat.attr("up").unwrap()), [0.0, 1.0, 0.0]);
    let film = sensor.kids("film").next().unwrap();
    assert_eq!(film.attr("type"), Some("hdrfilm"));
    assert_eq!(e.resolve(film.param("integer", "width").unwrap()), "800");
    assert_eq!(e.resolve(film.param("integer", "height").unwrap()), "800");
    assert_eq!(film.kids("rfilter").next().unwrap().attr("type"), Some("box"));
    let sampler = sensor.kids("sampler").next().unwrap();
    assert_eq!(sampler.attr("type"), Some("independent"));
    assert_eq!(sampler.param("integer", "sample_count"), Some("$spp"));

    // the integrator: path at the depth of vitrum's `path` (the scene's depth 5 is Whitted's,
    // `[render.whitted]`): its 256 bounces are 257 segments
    let integrator = e.root.kids("integrator").next().unwrap();
    assert_eq!(integrator.attr("type"), Some("path"));
    assert_eq!(e.resolve(integrator.param("integer", "max_depth").unwrap()), "257");

    // what does not translate is said, in the file and on stderr
    let stderr = String::from_utf8_lossy(&e.output.stderr);
    assert!(stderr.contains("Phong") && stderr.contains("ambient"), "{stderr}");
    let text = std::fs::read_to_string(&e.xml).unwrap();
    assert!(text.contains("<!-- Not exact: the scene ambient"), "{text}");
}

#[test]
fn hollow_spheres_inner_surfaces_swap_the_indices() {
    let e = export("hollow-spheres.toml");
    let spheres = e.shapes("sphere");
    assert_eq!(spheres.len(), 4);
    let mut by_radius: Vec<(f32, (f32, f32))> =
        spheres.iter().map(|s| (s.param("float", "radius").unwrap().parse().unwrap(), e.iors(s))).collect();
    by_radius.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(
        by_radius,
        [(0.2, (1.0, 1.52)), (0.34, (1.0, 1.52)), (0.38, (1.52, 1.0)), (0.38, (1.52, 1.0))],
        "inner spheres: air inside (opposite the outward normal), glass outside"
    );
}

#[test]
fn options_set_samples_depth_resolution_and_integrator() {
    let e = export_with(
        &scene("soft-shadows.toml"),
        &["--spp", "7", "--max-depth", "9", "--resolution", "320x200", "--integrator", "ptracer"],
    );
    assert_eq!(e.resolve("$spp"), "7");
    let integrator = e.root.kids("integrator").next().unwrap();
    assert_eq!(integrator.attr("type"), Some("ptracer"));
    assert_eq!(e.resolve(integrator.param("integer", "max_depth").unwrap()), "10");
    let film = e.root.kids("sensor").next().unwrap().kids("film").next().unwrap();
    assert_eq!(e.resolve(film.param("integer", "width").unwrap()), "320");
    assert_eq!(e.resolve(film.param("integer", "height").unwrap()), "200");
    // the quad light: a rectangle with a one-sided area emitter and a black BSDF
    let lights: Vec<_> =
        e.shapes("rectangle").into_iter().filter(|s| s.kids("emitter").count() == 1).collect();
    assert_eq!(lights.len(), 1);
    let emitter = lights[0].kids("emitter").next().unwrap();
    assert_eq!(emitter.attr("type"), Some("area"));
    assert_eq!(floats(emitter.param("rgb", "radiance").unwrap()), [31.25, 31.25, 31.25]);
    let black = e.bsdf_of(lights[0]).kids("bsdf").next().unwrap();
    assert_eq!(floats(black.param("rgb", "reflectance").unwrap()), [0.0, 0.0, 0.0]);
    // it faces down (u × v = −y): the third column of to_world
    let m = floats(
        lights[0].kids("transform").next().unwrap().kids("matrix").next().unwrap().attr("value").unwrap(),
    );
    assert_eq!((m[2], m[6], m[10]), (0.0, -1.0, 0.0));
}

#[test]
fn absorbing_glass_becomes_media_with_volpath() {
    let e = export("coloured-glass.toml");
    assert_eq!(e.root.kids("integrator").next().unwrap().attr("type"), Some("volpath"));
    let media: Vec<_> = e.root.kids("medium").collect();
    assert_eq!(media.len(), 3);
    // the hollow sphere: its glass is the interior of the outer surface and the exterior of
    // the inner one, the same medium
    let spheres = e.shapes("sphere");
    let medium_of = |s: &Element, side: &str| {
        s.kids("ref").find(|r| r.attr("name") == Some(side)).map(|r| r.attr("id").unwrap().to_string())
    };
    let radius = |s: &Element| s.param("float", "radius").unwrap().to_string();
    let outer = spheres.iter().find(|s| radius(s) == "0.22").unwrap();
    let inner = spheres.iter().find(|s| radius(s) == "0.19").unwrap();
    assert!(medium_of(outer, "interior").is_some() && medium_of(outer, "exterior").is_none());
    assert_eq!(medium_of(inner, "exterior"), medium_of(outer, "interior"));
    assert!(medium_of(inner, "interior").is_none());
    let blue = e.by_id(&medium_of(outer, "interior").unwrap());
    let scale: f32 = blue.param("float", "scale").unwrap().parse().unwrap();
    let sigma: Vec<f32> = floats(blue.param("rgb", "sigma_t").unwrap()).iter().map(|s| s * scale).collect();
    assert_eq!(sigma, [30.0, 12.0, 1.0]);
}

#[test]
fn clipped_spheres_annuli_polygons_and_meshes_become_ply_files() {
    let e = export("shapes-gallery.toml");
    let meshes = e.shapes("ply");
    // drinking-glass rim, bowl (2 hemispheres + rim), icosahedron, hexagon, annulus
    assert_eq!(meshes.len(), 7);
    let smooth = meshes.iter().filter(|m| m.param("boolean", "face_normals") == Some("false")).count();
    assert_eq!(smooth, 2, "the bowl's hemispheres have smooth normals, the flat meshes face normals");
    // the air bubble: an interface with air inside and glass outside, as written
    let bubble = e.shapes("sphere").into_iter().find(|s| s.param("float", "radius") == Some("0.09")).unwrap();
    assert_eq!(e.iors(bubble), (1.0, 1.52));
    // the glossy mirror of frosted-glass and the frosted materials
    let f = export("frosted-glass.toml");
    let mut bsdfs = Vec::new();
    f.root.all("bsdf", &mut bsdfs);
    let kinds: Vec<_> = bsdfs.iter().filter_map(|b| b.attr("type")).collect();
    assert!(kinds.contains(&"roughconductor") && kinds.contains(&"roughdielectric"), "{kinds:?}");
    let frosted = bsdfs.iter().find(|b| b.attr("id").is_some_and(|id| id.contains("frosted"))).unwrap();
    assert_eq!(frosted.param("string", "distribution"), Some("ggx"));
    let alpha: f32 = frosted.param("float", "alpha").unwrap().parse().unwrap();
    assert!((alpha - 0.09).abs() < 1e-6, "alpha = roughness²: {alpha}");
}

#[test]
fn conductors_export_as_mitsubas_conductors() {
    // metals.toml: rough Beckmann gold by name, GGX aluminium by name, smooth copper by η and k.
    let e = export("metals.toml");
    let mut bsdfs = Vec::new();
    e.root.all("bsdf", &mut bsdfs);
    let inner = |id: &str| {
        let outer = bsdfs.iter().find(|b| b.attr("id").is_some_and(|i| i.contains(id))).unwrap();
        assert_eq!(outer.attr("type"), Some("twosided"), "{id}: vitrum's conductors have two sides");
        outer.kids("bsdf").next().unwrap()
    };
    let gold = inner("rough-gold");
    assert_eq!(gold.attr("type"), Some("roughconductor"));
    // The index as vitrum's RGB values, which an RGB variant of Mitsuba then uses exactly.
    let (eta, k) = vitrum::conductor::Metal::named("Au").unwrap().rgb();
    assert_eq!(floats(gold.param("rgb", "eta").unwrap()), eta.to_array());
    assert_eq!(floats(gold.param("rgb", "k").unwrap()), k.to_array());
    assert_eq!(gold.param("string", "distribution"), Some("beckmann"));
    assert_eq!(gold.param("float", "alpha").map(|a| a.parse::<f32>().unwrap()), Some(0.2));
    let aluminium = inner("aluminium");
    assert_eq!(aluminium.param("string", "distribution"), Some("ggx"));
    assert_eq!(floats(aluminium.param("rgb", "specular_reflectance").unwrap()), [0.8, 0.8, 0.8]);
    let copper = inner("copper");
    assert_eq!(copper.attr("type"), Some("conductor"));
    assert_eq!(floats(copper.param("rgb", "eta").unwrap()), [0.203, 0.923, 1.102]);
    assert_eq!(floats(copper.param("rgb", "k").unwrap()), [3.881, 2.467, 2.14]);
}

#[test]
fn polygon_vertices_are_recovered_from_the_edges() {
    use glam::Vec3;
    use vitrum::geometry::Polygon;
    let hexagon = vec![
        Vec3::new(-0.99, 1.4, -0.2),
        Vec3::new(-0.99, 1.275, 0.0165),
        Vec3::new(-0.99, 1.025, 0.0165),
        Vec3::new(-0.99, 0.9, -0.2),
        Vec3::new(-0.99, 1.025, -0.4165),
        Vec3::new(-0.99, 1.275, -0.4165),
    ];
    let got = Polygon::new(hexagon.clone()).unwrap().vertices();
    assert_eq!(got.len(), 6);
    for (a, b) in got.iter().zip(&hexagon) {
        assert!((*a - *b).length() < 1e-5, "{a} vs {b}");
    }
    // a vertex on a straight edge (a 180° corner) is left out: the same square
    let square = vec![Vec3::ZERO, Vec3::new(0.5, 0.0, 0.0), Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
    let got = Polygon::new(square).unwrap().vertices();
    assert_eq!(got.len(), 4, "{got:?}");
}

#[test]
fn bad_input_exits_with_code_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.xml");
    let run = |args: &[&str], output: &Path| {
        let o = vitrum().arg("export").args(args).arg("-o").arg(output).output().unwrap();
        (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let cornell = scene("cornell-glass.toml");
    let cornell = cornell.to_str().unwrap();

    let (code, err) = run(&[cornell, "--format", "pbrt"], &out);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("pbrt") && err.contains("mitsuba"), "{err}");

    let (code, err) = run(&[cornell], &dir.path().join("no-such-folder").join("x.xml"));
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("no-such-folder"), "{err}");

    let (code, err) = run(&[cornell], &dir.path().join("x.exr"));
    assert_eq!(code, Some(2), "{err}");

    let (code, err) = run(&[cornell, "--spp", "0"], &out);
    assert_eq!(code, Some(2), "{err}");

    let (code, err) = run(&[cornell, "--integrator", "bdpt"], &out);
    assert_eq!(code, Some(2), "{err}");

    let missing = dir.path().join("missing.toml");
    let (code, err) = run(&[missing.to_str().unwrap()], &out);
    assert_eq!(code, Some(2), "{err}");

    let entries: HashMap<_, _> =
        std::fs::read_dir(dir.path()).unwrap().map(|e| (e.unwrap().file_name(), ())).collect();
    assert!(entries.is_empty(), "{entries:?}");
}

/// The texels of an image file written by the export (beside the XML) or read by a scene.
fn decode(path: &Path) -> vitrum::texture::ImageMap {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    vitrum::texture::ImageMap::decode(path, &bytes, None).unwrap()
}

/// The 16 numbers of a `<transform name=...><matrix value=.../></transform>` child.
fn matrix(e: &Element, name: &str) -> Vec<f32> {
    let t = e.kids("transform").find(|t| t.attr("name") == Some(name)).unwrap_or_else(|| panic!("no {name}"));
    floats(t.kids("matrix").next().unwrap().attr("value").unwrap())
}

#[test]
fn textured_box_writes_image_textures_as_bitmaps_with_their_texels() {
    let e = export("textured-box.toml");
    let dir = e.xml.parent().unwrap().to_path_buf();
    let mut bitmaps = Vec::new();
    e.root.all("texture", &mut bitmaps);
    // floor, three plaster walls, poster
    assert_eq!(bitmaps.len(), 5);
    let mut files = std::collections::BTreeSet::new();
    for b in &bitmaps {
        assert_eq!(b.attr("type"), Some("bitmap"));
        assert_eq!(b.attr("name"), Some("reflectance"));
        assert_eq!(b.param("boolean", "raw"), Some("true"));
        assert_eq!(b.param("string", "filter_type"), Some("bilinear"));
        let file = b.param("string", "filename").unwrap();
        assert!(file.starts_with("scene-textures/") && file.ends_with(".exr"), "{file}");
        files.insert(file.to_string());
    }
    // each image once: tiles, plaster, poster
    assert_eq!(files.len(), 3, "{files:?}");
    let by_name =
        |part: &str| bitmaps.iter().find(|b| b.param("string", "filename").unwrap().contains(part)).unwrap();
    // the floor: tiles at scale 2 × 2; Mitsuba's rectangle uv is vitrum's (a, b), its bitmap's
    // y runs down from the top row: (x, y) = (2a, 1 − 2b)
    let floor = by_name("tiles");
    assert_eq!(floor.param("string", "wrap_mode"), Some("repeat"));
    assert_eq!(
        matrix(floor, "to_uv"),
        [2.0, 0.0, 0.0, 0.0, 0.0, -2.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    );
    let plaster = by_name("plaster");
    assert_eq!(matrix(plaster, "to_uv")[..8], [2.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0]);
    let poster = by_name("poster");
    assert_eq!(poster.param("string", "wrap_mode"), Some("clamp"));
    assert_eq!(matrix(poster, "to_uv")[..8], [1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0]);
    // the files decode to the scene's own (linear) texels
    for name in ["tiles", "plaster", "poster"] {
        let written = decode(&dir.join(by_name(name).param("string", "filename").unwrap()));
        let original = decode(&scene("textures").join(format!("{name}.png")));
        assert_eq!((written.width, written.height), (original.width, original.height), "{name}");
        assert!(written.texels == original.texels, "{name}: the texels differ");
    }
    // exact: no note about textures
    let stderr = String::from_utf8_lossy(&e.output.stderr);
    assert!(!stderr.lines().any(|l| l.contains("note:") && l.contains("texture")), "{stderr}");
}

#[test]
fn glass_in_sky_writes_the_environment_map_as_an_envmap() {
    let e = export("glass-in-sky.toml");
    let emitters: Vec<_> = e.root.kids("emitter").collect();
    assert_eq!(emitters.len(), 1, "the envmap alone, no constant background");
    let env = emitters[0];
    assert_eq!(env.attr("type"), Some("envmap"));
    assert_eq!(env.param("float", "scale"), Some("1"));
    assert_eq!(
        matrix(env, "to_world"),
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    );
    let file = e.xml.parent().unwrap().join(env.param("string", "filename").unwrap());
    let written = decode(&file);
    let sky = decode(&scene("textures").join("sky.exr"));
    // as it is: Mitsuba's envmap reads a map as vitrum does (bilinear, the same grid)
    assert_eq!((written.width, written.height), (sky.width, sky.height));
    assert!(written.texels == sky.texels, "the texels differ");
    let stderr = String::from_utf8_lossy(&e.output.stderr);
    assert!(!stderr.lines().any(|l| l.contains("note:") && l.contains("environment")), "{stderr}");
}

#[test]
fn textures_on_other_shapes_rotated_maps_and_what_cannot_be_mapped() {
    let dir = tempfile::tempdir().unwrap();
    let textures = dir.path().join("textures");
    std::fs::create_dir(&textures).unwrap();
    let image = vitrum::image::Image {
        width: 3,
        height: 1,
        pixels: vec![
            glam::Vec3::new(0.1, 0.2, 0.3),
            glam::Vec3::new(0.5, 0.5, 0.5),
            glam::Vec3::new(0.9, 0.0, 0.3),
        ],
    };
    let path = textures.join("strip.exr");
    std::fs::write(&path, vitrum::output::exr::encode_exr_rgb(&path, &image).unwrap()).unwrap();
    let sky = vitrum::image::Image { width: 4, height: 2, pixels: vec![glam::Vec3::splat(2.0); 8] };
    let sky_path = textures.join("sky.exr");
    std::fs::write(&sky_path, vitrum::output::exr::encode_exr_rgb(&sky_path, &sky).unwrap()).unwrap();
    let scene_file = dir.path().join("shapes.toml");
    std::fs::write(
        &scene_file,
        r#"
[camera]
position = [0.0, 1.0, 4.0]
look_at = [0.0, 0.5, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
resolution = [64, 48]

[materials.strip]
type = "diffuse"
texture = { type = "image", file = "textures/strip.exr", filter = "nearest" }

[materials.tinted]
type = "mirror"
texture = { type = "image", file = "textures/strip.exr", scale = [2.0, 1.0] }

[[objects]]
name = "ball"
shape = "sphere"
center = [0.0, 0.5, 0.0]
radius = 0.5
material = "strip"

[[objects]]
name = "can"
shape = "cylinder"
base = [1.0, 0.0, 0.0]
axis = [0.0, 1.0, 0.0]
radius = 0.3
height = 0.6
material = "strip"

[[objects]]
name = "bowl"
shape = "bowl"
center = [-1.2, 0.5, 0.0]
axis = [0.0, 1.0, 0.0]
radius = 0.4
thickness = 0.05
material = "strip"

[[objects]]
name = "mirror"
shape = "quad"
corner = [-1.0, 0.0, -1.0]
u = [2.0, 0.0, 0.0]
v = [0.0, 1.5, 0.0]
material = "tinted"

[[lights]]
type = "environment"
file = "textures/sky.exr"
rotation = 90.0
scale = 0.5
"#,
    )
    .unwrap();
    let e = export_with(&scene_file, &[]);
    // the sphere is placed by its texture frame (t1, t2, axis) = (+X, −Z, +Y), scaled by r
    let sphere = e.shapes("sphere").into_iter().next().unwrap();
    assert_eq!(
        matrix(sphere, "to_world")[..12],
        [0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0, -0.5, 0.0, 0.0]
    );
    let bitmap = |s: &Element| -> Vec<f32> {
        let b = e.bsdf_of(s);
        let mut t = Vec::new();
        b.all("texture", &mut t);
        assert_eq!(t.len(), 1);
        matrix(t[0], "to_uv")
    };
    // sphere: vitrum (u, v) = (x, 1 − y) of Mitsuba's; the bitmap y = 1 − v = Mitsuba's y
    assert_eq!(bitmap(sphere)[..8], [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
    let can = e.shapes("cylinder").into_iter().next().unwrap();
    assert_eq!(matrix(can, "to_world")[..12], [0.3, 0.0, 0.0, 1.0, 0.0, 0.0, 0.6, 0.0, 0.0, -0.3, 0.0, 0.0]);
    assert_eq!(bitmap(can)[..8], [1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0]);
    // the mirror's tint is a bitmap in its conductor
    let mirror = e.shapes("rectangle").into_iter().next().unwrap();
    let conductor = e.bsdf_of(mirror).kids("bsdf").next().unwrap();
    assert_eq!(conductor.attr("type"), Some("conductor"));
    let tint = conductor.kids("texture").next().unwrap();
    assert_eq!(tint.attr("name"), Some("specular_reflectance"));
    assert_eq!(matrix(tint, "to_uv")[..8], [2.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0]);
    // the 3×1 image is written 3×2 (Mitsuba up-samples images below 2×2), its row repeated
    let file = e.xml.parent().unwrap().join(tint.param("string", "filename").unwrap());
    let written = decode(&file);
    assert_eq!((written.width, written.height), (3, 2));
    assert_eq!(written.texels[..3], written.texels[3..]);
    assert_eq!(written.texels[..3], image.pixels[..]);
    // the bowl's tessellated hemispheres carry no uv: the mean colour, with a note
    let stderr = String::from_utf8_lossy(&e.output.stderr);
    assert!(stderr.contains("bowl") && stderr.contains("mean colour"), "{stderr}");
    let bowl = e.shapes("ply").into_iter().find(|s| e.bsdf_of(s).attr("type") == Some("twosided")).unwrap();
    let mean = floats(e.bsdf_of(bowl).kids("bsdf").next().unwrap().param("rgb", "reflectance").unwrap());
    assert!((mean[0] - 0.5).abs() < 1e-6 && (mean[1] - 0.7 / 3.0).abs() < 1e-6, "{mean:?}");
    // the map: rotated 90° about +Y (+Z to +X), with its scale
    let env = e.root.kids("emitter").next().unwrap();
    assert_eq!(env.attr("type"), Some("envmap"));
    assert_eq!(env.param("float", "scale"), Some("0.5"));
    let m = matrix(env, "to_world");
    let close = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert!(close(&m[..12], &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0]), "{m:?}");
    let map = decode(&e.xml.parent().unwrap().join(env.param("string", "filename").unwrap()));
    assert!(map.texels.iter().all(|t| *t == glam::Vec3::splat(2.0)));
}

#[test]
fn ellipsoids_export_as_meshes_since_mitsuba_keeps_spheres_round() {
    // A sphere of radius 0.5 at (0.25, 0, 0) under a shear and a per-axis scale. Mitsuba 3
    // would render a `sphere` under that to_world round, so it is written as a closed mesh whose
    // vertices lie on the ellipsoid {M·(c + 0.5·d) + t : |d| = 1} and whose normals are M⁻ᵀ of
    // the sphere's.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("ellipsoid.toml");
    std::fs::write(
        &file,
        r#"
[camera]
position = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
resolution = [16, 16]
[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
material = "glass"
shape = "sphere"
center = [0.25, 0.0, 0.0]
radius = 0.5
transform = { matrix = [2.0, 1.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.25, 0.0, 0.0, 0.5, -1.0, 0.0, 0.0, 0.0, 1.0] }
[[lights]]
type = "environment"
radiance = 1.0
"#,
    )
    .unwrap();
    let e = export_with(&file, &[]);
    assert!(e.shapes("sphere").is_empty(), "no analytic sphere");
    let meshes = e.shapes("ply");
    assert_eq!(meshes.len(), 1);
    assert_eq!(meshes[0].param("boolean", "face_normals"), Some("false"), "smooth normals");
    let file = e.xml.parent().unwrap().join(meshes[0].param("string", "filename").unwrap());
    let ply = vitrum::scene::mesh::load_ply(&file, &vitrum::scene::mesh::MeshPlacement::IDENTITY).unwrap();
    assert_eq!(ply.degenerate, 0, "no degenerate triangles at the poles");
    let m = glam::DMat3::from_cols_array(&[2.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.5]);
    let t = glam::DVec3::new(0.5, 0.25, -1.0);
    let c = glam::DVec3::new(0.25, 0.0, 0.0);
    let inverse = m.inverse();
    let key = |p: glam::Vec3| p.to_array().map(f32::to_bits);
    let mut edges = std::collections::HashMap::new();
    let mut volume = 0.0;
    for (tri, attributes) in ply.triangles.iter().zip(&ply.attributes) {
        let corners = tri.vertices();
        for (p, n) in corners.iter().zip(attributes.normals.expect("vertex normals")) {
            // Back in the sphere's space the vertex is on the sphere, its normal the radius'.
            let d = (inverse * (p.as_dvec3() - t) - c) / 0.5;
            assert!((d.length() - 1.0).abs() < 1e-5, "{p} is off the ellipsoid ({})", d.length());
            let expected = (inverse.transpose() * d).normalize();
            assert!(n.as_dvec3().dot(expected) > 1.0 - 1e-5, "normal {n} vs {expected}");
        }
        for k in 0..3 {
            *edges.entry((key(corners[k]), key(corners[(k + 1) % 3]))).or_insert(0) += 1;
        }
        let [a, b, cc] = corners.map(|v| v.as_dvec3());
        volume += a.dot(b.cross(cc)) / 6.0;
    }
    // Closed: every edge is shared by exactly two faces, in opposite directions.
    assert!(edges.iter().all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1)), "not closed");
    // Outward: the mesh's volume is positive and the ellipsoid's, det(M)·(4/3)π·0.5³, up to chords.
    let exact = m.determinant() * 4.0 / 3.0 * std::f64::consts::PI * 0.125;
    assert!((volume / exact - 1.0).abs() < 1e-3 && volume > 0.0, "volume {volume} vs {exact}");
}
