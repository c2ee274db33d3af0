//! Filled vessels (`fill` and `liquid` of `drinking_glass` and `bowl`): the one-object glass of
//! water compiles into the surfaces and media of the hand-written `glass-of-water.toml`, renders
//! the same image within noise, stays at 1 in the white furnace, and bad fills are refused.

mod common;

use common::{block_chi2, image_mean_and_error, render_with_variance};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use vitrum::geometry::Shape;
use vitrum::material::{Bsdf, Medium};
use vitrum::scene::{self, Scene};

fn hard(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hard").join(name)
}

fn text(name: &str) -> String {
    std::fs::read_to_string(hard(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn load_text(text: &str, name: &str) -> Scene {
    scene::load_str(text, name, Some(&hard(""))).unwrap_or_else(|e| panic!("{e}"))
}

/// The scene `name` with its TOML edited by `edit`.
fn variant(name: &str, edit: impl FnOnce(&mut toml::Table)) -> Scene {
    let mut t: toml::Table = text(name).parse().unwrap();
    edit(&mut t);
    load_text(&toml::to_string(&t).unwrap(), name)
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 1e-6
}

/// Whether two analytic shapes are the same surface (within rounding of the heights).
fn same_shape(a: &Shape, b: &Shape) -> bool {
    let near = |x: f32, y: f32| (x - y).abs() <= 1e-6;
    match (a, b) {
        (Shape::Cylinder(a), Shape::Cylinder(b)) => {
            close(a.base(), b.base())
                && close(a.axis(), b.axis())
                && near(a.radius(), b.radius())
                && near(a.height(), b.height())
        }
        (Shape::Disk(a), Shape::Disk(b)) => {
            close(a.center(), b.center())
                && close(a.normal(), b.normal())
                && near(a.radius(), b.radius())
                && near(a.inner_radius(), b.inner_radius())
        }
        (Shape::Sphere(a), Shape::Sphere(b)) => {
            close(a.center(), b.center())
                && near(a.radius(), b.radius())
                && a.min_height() == b.min_height()
                && a.max_height() == b.max_height()
        }
        _ => false,
    }
}

/// Every primitive of a scene as (shape, inside medium, outside medium); `None` media for
/// surfaces that are not interfaces (the furnace).
fn surfaces(scene: &Scene) -> Vec<(Shape, Option<(Medium, Medium)>)> {
    (0..scene.primitives.len() as u32)
        .map(|i| {
            let media = match scene.material_of(i).bsdf {
                Bsdf::Dielectric { inside, outside, .. } => Some((inside, outside)),
                _ => None,
            };
            (scene.primitives[i as usize].shape.clone(), media)
        })
        .collect()
}

#[test]
fn the_one_object_glass_of_water_has_the_hand_written_surfaces_and_media() {
    let one = surfaces(&scene::load(&hard("glass-of-water-filled.toml")).unwrap());
    let hand = surfaces(&scene::load(&hard("glass-of-water.toml")).unwrap());
    assert_eq!(one.len(), 8, "seven surfaces of the glass and the furnace");
    assert_eq!(one.len(), hand.len());
    // A one-to-one matching: each surface of the one-object form is exactly one hand-written
    // surface with the same media on the same sides.
    let mut used = vec![false; hand.len()];
    for (shape, media) in &one {
        let found = hand
            .iter()
            .enumerate()
            .find(|(k, (s, m))| !used[*k] && same_shape(shape, s) && m == media)
            .map(|(k, _)| k);
        let k =
            found.unwrap_or_else(|| panic!("no hand-written surface like {shape:?} with media {media:?}"));
        used[k] = true;
    }
    assert!(used.iter().all(|&u| u));
}

#[test]
fn the_one_object_bowl_splits_its_inner_sphere_at_the_liquid_level() {
    let s = scene::load(&hard("bowl-of-liquid-filled.toml")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let inner: Vec<_> = surfaces(&s)
        .into_iter()
        .filter_map(|(shape, media)| match shape {
            Shape::Sphere(sp) if (sp.radius() - 0.46).abs() < 1e-6 => {
                let (i, o) = media.unwrap();
                Some((sp.min_height(), sp.max_height(), i.ior.nominal(), o.ior.nominal()))
            }
            _ => None,
        })
        .collect();
    assert_eq!(inner.len(), 2, "{inner:?}");
    assert!(inner.contains(&(f32::NEG_INFINITY, -0.15, 1.36, 1.52)), "liquid below the level: {inner:?}");
    assert!(inner.contains(&(-0.15, 0.0, 1.0, 1.52)), "air above it: {inner:?}");
}

/// The glass of water with absorbing glass and water, in either form: the image then depends on
/// the lengths travelled in each medium, so that a wrong surface or medium shows.
fn absorbing(one_object: bool) -> Scene {
    let glass = toml::Value::try_from([0.4f32, 0.1, 0.2]).unwrap();
    let water = toml::Value::try_from([1.5f32, 0.5, 0.1]).unwrap();
    if one_object {
        variant("glass-of-water-filled.toml", |t| {
            let m = t["materials"].as_table_mut().unwrap();
            m["glass"].as_table_mut().unwrap().insert("absorption".into(), glass);
            let o = t["objects"].as_array_mut().unwrap()[0].as_table_mut().unwrap();
            let mut liquid = toml::Table::new();
            liquid.insert("ior".into(), toml::Value::Float(1.33));
            liquid.insert("absorption".into(), water);
            o.insert("liquid".into(), liquid.into());
        })
    } else {
        variant("glass-of-water.toml", |t| {
            let m = t["materials"].as_table_mut().unwrap();
            let mut set = |name: &str, key: &str, v: &toml::Value| {
                m[name].as_table_mut().unwrap().insert(key.into(), v.clone());
            };
            // `absorption` is the medium opposite the normal, `absorption_outside` the other.
            set("glass_air", "absorption", &glass);
            set("glass_water", "absorption", &glass);
            set("glass_water", "absorption_outside", &water);
            set("water_glass", "absorption", &water);
            set("water_glass", "absorption_outside", &glass);
            set("air_glass", "absorption_outside", &glass);
            set("water_air", "absorption", &water);
        })
    }
}

#[test]
fn the_one_object_and_hand_written_glasses_of_water_render_alike() {
    // `path` at 32×32, 64 samples per pixel, independent seeds: the χ² of the 8×8 block means in
    // their standard errors stays below 39.1, the 99.99% quantile of χ² with 12 degrees of freedom
    // (of the 16 blocks, the four corners see only the furnace, exactly 1, and have no variance);
    // the absorption makes the glass a few tenths darker than the furnace, so a wrong
    // surface or medium moves blocks by many standard errors.
    let one = render_with_variance(&absorbing(true), "path", 32, 64, 1);
    let hand = render_with_variance(&absorbing(false), "path", 32, 64, 2);
    let (chi2, blocks) = block_chi2(&one, &hand);
    let darkest = one.0.pixels.iter().map(|p| p.min_element()).fold(1.0, f32::min);
    println!("one object vs hand-written: χ² {chi2:.1} over {blocks} blocks; darkest pixel {darkest:.3}");
    assert_eq!(blocks, 12);
    assert!(darkest < 0.8, "the absorption must show (darkest pixel {darkest})");
    assert!(chi2 < 39.1, "block χ² {chi2} over {blocks} blocks");
    // The check has teeth: without the water's absorption the one-object form differs.
    let clear = variant("glass-of-water-filled.toml", |t| {
        let m = t["materials"].as_table_mut().unwrap();
        let glass = toml::Value::try_from([0.4f32, 0.1, 0.2]).unwrap();
        m["glass"].as_table_mut().unwrap().insert("absorption".into(), glass);
    });
    let clear = render_with_variance(&clear, "path", 32, 64, 3);
    let (chi2, _) = block_chi2(&clear, &hand);
    println!("clear water vs absorbing water: χ² {chi2:.1}");
    assert!(chi2 > 39.1, "clear water passed for absorbing water (χ² {chi2})");
}

/// The scene `name` with its closed emitter (the last object) replaced by a white environment,
/// at 24×24 pixels.
fn in_white_environment(name: &str) -> Scene {
    variant(name, |t| {
        let objects = t["objects"].as_array_mut().unwrap();
        let furnace = objects.pop().unwrap();
        assert_eq!(furnace["material"].as_str(), Some("furnace"));
        let mut env = toml::Table::new();
        env.insert("type".into(), "environment".into());
        env.insert("radiance".into(), toml::Value::Float(1.0));
        t.insert("lights".into(), toml::Value::Array(vec![env.into()]));
        t["materials"].as_table_mut().unwrap().remove("furnace");
        let size = toml::Value::try_from([24, 24]).unwrap();
        t["camera"].as_table_mut().unwrap().insert("resolution".into(), size);
    })
}

#[test]
fn filled_vessels_vanish_in_the_white_furnace() {
    // Clear glass and liquid with consistent interfaces neither add nor remove light: the mean
    // over the image of `path` (16 renders of 24×24 at 4 samples per pixel) is never above 1 by
    // more than 4 standard errors of the render-to-render spread (plus 1e-4 for the float sums),
    // and below 1 by no more than 4 standard errors plus 1e-3: light that total internal
    // reflection traps in the glass's wall is cut at 256 bounces. Measured for the glass of
    // water, the deficit shrinks with the depth: 4.8e-3 at 16 bounces, 2.1e-3 at 64, 4.9e-4 at
    // 256 (0.999512 ± 0.000118), the same figures to the last digit as the hand-written scene.
    for name in ["glass-of-water-filled.toml", "bowl-of-liquid-filled.toml"] {
        let scene = in_white_environment(name);
        let (mean, error) = image_mean_and_error(&scene, "path", 4, 16);
        println!("{name} in a white environment: path mean {mean:.6} ± {error:.6}");
        assert!(mean <= 1.0 + 4.0 * error + 1e-4, "{name}: gains light: mean {mean} ± {error}");
        assert!(mean >= 1.0 - 4.0 * error - 1e-3, "{name}: loses light: mean {mean} ± {error}");
    }
}

/// `vitrum info` on the scene `file` with its `fill` line set to `fill`.
fn info_with(file: &str, fill: &str) -> std::process::Output {
    let dir = tempfile::tempdir().unwrap();
    let edited: String = text(file)
        .lines()
        .map(|l| if l.starts_with("fill =") { format!("fill = {fill}") } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n");
    let path = dir.path().join(file);
    std::fs::write(&path, edited).unwrap();
    Command::new(env!("CARGO_BIN_EXE_vitrum")).arg("info").arg(&path).output().unwrap()
}

#[test]
fn a_fill_out_of_range_is_refused_naming_the_field_and_the_range() {
    let line = |file: &str| text(file).lines().position(|l| l.starts_with("fill =")).unwrap() + 1;
    let cases = [
        ("glass-of-water-filled.toml", "-0.1", "(0, 0.84]"),
        ("glass-of-water-filled.toml", "0.85", "(0, 0.84]"),
        ("glass-of-water-filled.toml", "0.0", "(0, 0.84]"),
        ("bowl-of-liquid-filled.toml", "-0.01", "[0, 0.46)"),
        ("bowl-of-liquid-filled.toml", "0.46", "[0, 0.46)"),
    ];
    for (file, fill, range) in cases {
        let out = info_with(file, fill);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{file} fill = {fill}: {err}");
        assert!(err.contains("objects[0].fill"), "{file} fill = {fill}: {err}");
        assert!(err.contains(range), "{file} fill = {fill}: {err}");
        assert!(err.contains(&format!(":{}:", line(file))), "{file} fill = {fill}: no line: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    // The edges of the ranges are allowed: full to the rim.
    for (file, fill) in [("glass-of-water-filled.toml", "0.84"), ("bowl-of-liquid-filled.toml", "0.0")] {
        let out = info_with(file, fill);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{file} fill = {fill}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

#[test]
fn liquids_by_name_and_bad_liquids() {
    let with = |liquid: &str| {
        let t = text("glass-of-water-filled.toml").replace("liquid = { ior = 1.33 }", liquid);
        scene::load_str(&t, "glass.toml", None).map_err(|e| e.to_string())
    };
    let indices = |s: &Scene| -> Vec<f32> {
        s.materials
            .iter()
            .filter_map(|m| match m.bsdf {
                Bsdf::Dielectric { inside, .. } if m.name.ends_with("surface)") => Some(inside.ior.nominal()),
                _ => None,
            })
            .collect()
    };
    assert_eq!(indices(&with("liquid = \"water\"").unwrap()), [1.333]);
    assert_eq!(indices(&with("liquid = \"olive_oil\"").unwrap()), [1.47]);
    assert_eq!(indices(&with("").unwrap()), [1.333], "water by default");
    let s = with("liquid = { ior = 1.4, absorption = [0.1, 0.2, 0.3] }").unwrap();
    assert!(s.effects.has(vitrum::scene::Effect::Absorption), "an absorbing liquid is an effect");
    let err = with("liquid = \"mercury\"").err().unwrap();
    assert!(err.contains("objects[0].liquid") && err.contains("water, ethanol, olive_oil"), "{err}");
    let err = with("liquid = { ior = 1.4, colour = 1 }").err().unwrap();
    assert!(err.contains("colour"), "{err}");
    let err = with("liquid = { ior = -1.0 }").err().unwrap();
    assert!(err.contains("objects[0].liquid.ior"), "{err}");
    // A liquid without a fill level, and a filled vessel that is not glass.
    let t = text("glass-of-water-filled.toml").replace("fill = 0.54", "");
    let err = scene::load_str(&t, "glass.toml", None).err().unwrap().to_string();
    assert!(err.contains("objects[0].liquid") && err.contains("fill"), "{err}");
    let t = text("glass-of-water-filled.toml").replace("material = \"glass\"", "material = \"furnace\"");
    let err = scene::load_str(&t, "glass.toml", None).err().unwrap().to_string();
    assert!(err.contains("objects[0].material") && err.contains("dielectric"), "{err}");
}

/// The three meshes of `scenes/hard/meshes/make_bowl.py` (glass/air, glass/liquid, liquid/air:
/// rim centre at the origin, outer radius 0.5, wall 0.04, the liquid 0.15 below the rim) with
/// `lon` segments around the axis and `lat` rings on the outer wall (the script's 48 and 12; its
/// inner wall has 10 rings below the liquid and 3 above, scaled here by `lat / 12`), written to
/// `dir` as `glass-air.obj`, `glass-liquid.obj` and `liquid-air.obj`.
fn write_bowl_meshes(dir: &std::path::Path, lon: usize, lat: usize) {
    use std::f64::consts::PI;
    use std::fmt::Write;
    let (r_out, r_in, depth) = (0.5f64, 0.46f64, 0.15f64);
    // A ring of the sphere of `radius` at polar angle `polar` from the bottom pole, rounded as the
    // script prints it (so that the meshes share their seams exactly).
    let ring = |radius: f64, polar: f64| -> Vec<[f64; 3]> {
        let (y, rho) = (-radius * polar.cos(), radius * polar.sin());
        (0..lon)
            .map(|k| {
                let a = 2.0 * PI * k as f64 / lon as f64;
                [rho * a.cos(), y, rho * a.sin()].map(|x| format!("{x:.7}").parse().unwrap())
            })
            .collect()
    };
    struct Mesh {
        v: Vec<[f64; 3]>,
        f: Vec<[usize; 3]>,
    }
    impl Mesh {
        fn add(&mut self, points: &[[f64; 3]]) -> Vec<usize> {
            let start = self.v.len();
            self.v.extend_from_slice(points);
            (start..start + points.len()).collect()
        }
        fn tri(&mut self, a: usize, b: usize, c: usize, outward: [f64; 3]) {
            let (pa, pb, pc) = (self.v[a], self.v[b], self.v[c]);
            let e1 = [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]];
            let e2 = [pc[0] - pa[0], pc[1] - pa[1], pc[2] - pa[2]];
            let n =
                [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            let (b, c) =
                if n[0] * outward[0] + n[1] * outward[1] + n[2] * outward[2] < 0.0 { (c, b) } else { (b, c) };
            self.f.push([a, b, c]);
        }
        fn band(&mut self, r0: &[usize], r1: &[usize], outward: impl Fn([f64; 3]) -> [f64; 3]) {
            let n = r0.len();
            for k in 0..n {
                let (a, b, c, d) = (r0[k], r0[(k + 1) % n], r1[k], r1[(k + 1) % n]);
                let centre =
                    [0, 1, 2].map(|j| (self.v[a][j] + self.v[b][j] + self.v[c][j] + self.v[d][j]) / 4.0);
                self.tri(a, b, d, outward(centre));
                self.tri(a, d, c, outward(centre));
            }
        }
        fn fan(&mut self, centre: usize, r: &[usize], outward: impl Fn([f64; 3]) -> [f64; 3]) {
            let n = r.len();
            for k in 0..n {
                self.tri(centre, r[k], r[(k + 1) % n], outward(self.v[centre]));
            }
        }
        fn write(&self, path: std::path::PathBuf) {
            let mut text = String::new();
            for p in &self.v {
                writeln!(text, "v {} {} {}", p[0], p[1], p[2]).unwrap();
            }
            for t in &self.f {
                writeln!(text, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1).unwrap();
            }
            std::fs::write(path, text).unwrap();
        }
    }
    let away = |p: [f64; 3]| p;
    let towards = |p: [f64; 3]| p.map(|x| -x);
    let up = |_: [f64; 3]| [0.0, 1.0, 0.0];
    let (below, above) = ((10 * lat).div_ceil(12), (3 * lat).div_ceil(12));
    let level = (depth / r_in).acos();
    let outer: Vec<_> = (1..=lat).map(|i| ring(r_out, PI / 2.0 * i as f64 / lat as f64)).collect();
    let inner_lo: Vec<_> = (1..=below).map(|i| ring(r_in, level * i as f64 / below as f64)).collect();
    let inner_hi: Vec<_> =
        (1..=above).map(|i| ring(r_in, level + (PI / 2.0 - level) * i as f64 / above as f64)).collect();
    let level_ring = inner_lo.last().unwrap().clone();

    let mut g = Mesh { v: vec![], f: vec![] };
    let pole = g.add(&[[0.0, -r_out, 0.0]])[0];
    let rings: Vec<_> = outer.iter().map(|r| g.add(r)).collect();
    g.fan(pole, &rings[0], away);
    for w in rings.windows(2) {
        g.band(&w[0], &w[1], away);
    }
    let rim_inner = g.add(inner_hi.last().unwrap());
    g.band(rings.last().unwrap(), &rim_inner, up);
    let mut hi = vec![g.add(&level_ring)];
    hi.extend(inner_hi[..inner_hi.len() - 1].iter().map(|r| g.add(r)));
    hi.push(rim_inner);
    for w in hi.windows(2) {
        g.band(&w[0], &w[1], towards);
    }
    g.write(dir.join("glass-air.obj"));

    let mut w = Mesh { v: vec![], f: vec![] };
    let pole = w.add(&[[0.0, -r_in, 0.0]])[0];
    let rings: Vec<_> = inner_lo.iter().map(|r| w.add(r)).collect();
    w.fan(pole, &rings[0], towards);
    for p in rings.windows(2) {
        w.band(&p[0], &p[1], towards);
    }
    w.write(dir.join("glass-liquid.obj"));

    let mut s = Mesh { v: vec![], f: vec![] };
    let centre = s.add(&[[0.0, level_ring[0][1], 0.0]])[0];
    let r = s.add(&level_ring);
    s.fan(centre, &r, up);
    s.write(dir.join("liquid-air.obj"));
}

/// `bowl-of-liquid-filled.toml` (the analytic one-object bowl), or `bowl-of-liquid.toml` (three
/// hand-written triangle meshes) with its meshes replaced by those of `mesh_dir` when given; both
/// with absorbing glass and liquid.
fn absorbing_bowl(one_object: bool, mesh_dir: Option<&std::path::Path>) -> Scene {
    let glass = toml::Value::try_from([0.6f32, 0.2, 0.3]).unwrap();
    let liquid = toml::Value::try_from([2.0f32, 0.6, 0.1]).unwrap();
    if one_object {
        return variant("bowl-of-liquid-filled.toml", |t| {
            let m = t["materials"].as_table_mut().unwrap();
            m["glass"].as_table_mut().unwrap().insert("absorption".into(), glass);
            let o = t["objects"].as_array_mut().unwrap()[0].as_table_mut().unwrap();
            let mut l = toml::Table::new();
            l.insert("ior".into(), toml::Value::Float(1.36));
            l.insert("absorption".into(), liquid);
            o.insert("liquid".into(), l.into());
        });
    }
    variant("bowl-of-liquid.toml", |t| {
        let m = t["materials"].as_table_mut().unwrap();
        let mut set = |name: &str, key: &str, v: &toml::Value| {
            m[name].as_table_mut().unwrap().insert(key.into(), v.clone());
        };
        // Each mesh's normals point out of the medium named first.
        set("glass_air", "absorption", &glass);
        set("glass_liquid", "absorption", &glass);
        set("glass_liquid", "absorption_outside", &liquid);
        set("liquid_air", "absorption", &liquid);
        if let Some(dir) = mesh_dir {
            for (o, file) in t["objects"].as_array_mut().unwrap().iter_mut().zip([
                "glass-air",
                "glass-liquid",
                "liquid-air",
            ]) {
                let path = dir.join(format!("{file}.obj")).display().to_string();
                o.as_table_mut().unwrap().insert("file".into(), path.into());
            }
        }
    })
}

#[test]
fn the_one_object_bowl_of_liquid_is_what_the_hand_written_meshes_converge_to() {
    // The hand-written bowl is a tessellation of the one-object bowl's interfaces: `path` at
    // 32×32, 64 samples per pixel, with absorbing glass and liquid (so that path lengths show),
    // block χ² of the 8×8 block means in their standard errors. The shipped meshes (48 segments,
    // 12 rings) differ by their facets; regenerated 8× finer around and 4× along, the difference
    // is at the noise floor: below the 99.99% quantile of χ² for the blocks with variance.
    let one = render_with_variance(&absorbing_bowl(true, None), "path", 32, 64, 1);
    let darkest = one.0.pixels.iter().map(|p| p.min_element()).fold(1.0, f32::min);
    assert!(darkest < 0.8, "the absorption must show (darkest pixel {darkest})");
    let shipped = render_with_variance(&absorbing_bowl(false, None), "path", 32, 64, 2);
    let (coarse, blocks) = block_chi2(&one, &shipped);
    let dir = tempfile::tempdir().unwrap();
    write_bowl_meshes(dir.path(), 384, 48);
    let fine = render_with_variance(&absorbing_bowl(false, Some(dir.path())), "path", 32, 64, 3);
    let (fine_chi2, fine_blocks) = block_chi2(&one, &fine);
    println!(
        "bowl, one object vs hand-written meshes: χ² {coarse:.1} over {blocks} blocks (shipped 48 x 12), \
         {fine_chi2:.1} over {fine_blocks} (384 x 48)"
    );
    // 99.99% quantiles of χ² by degrees of freedom.
    let bound =
        |n: usize| [(8, 31.8), (12, 39.1), (16, 45.9)].iter().find(|q| q.0 == n).map(|q| q.1).unwrap();
    assert!(
        fine_chi2 < bound(fine_blocks),
        "fine tessellation: block χ² {fine_chi2} over {fine_blocks} blocks"
    );
    assert!(fine_chi2 < coarse, "the difference shrinks with the tessellation ({coarse} → {fine_chi2})");
}
