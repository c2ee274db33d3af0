//! High-sample reference renders for sweeps, cached on disk by method, scene content, settings
//! and version.
//!
//! A reference is rendered by the method a short pilot render of each fit candidate finds the
//! most efficient ([`choose_by_pilot`]: the lowest relative variance × seconds among `path`,
//! `bpt` and `vcm`, those that simulate every effect of the scene and, where a point (delta)
//! light meets a specular surface, `vcm` alone, since path tracing misses those caustics:
//! [`choose_method`]). It is stored in the cache folder as an EXR file named after
//! its method, resolution, sample count and a digest of its key, with a JSON sidecar holding the
//! whole key: the method, the scene's content hash, the resolution, spp, seed, maximum depth, the
//! other render settings that change the image (Fresnel override, spectral mode, sampler, the
//! merge radius and its α for a merging method) and the crate version. A later request with the same key reads the file back instead of rendering; a key
//! that differs in anything, a missing or unreadable file, or one of another size is rendered
//! anew and replaces it. Both files are written atomically, the EXR before its sidecar, so a
//! reader never trusts a half-written reference. The content hash covers the scene file's text,
//! not the mesh files it loads: after editing a mesh, clear the cache.
//!
//! The reference's random streams use [`reference_seed`] of the given seed, never the seed
//! itself: a render judged against it with the same seed would otherwise share its first samples
//! with the reference (with the independent sampler, exactly), and its error would look smaller
//! than it is.

use crate::image::Image;
use crate::integrators::Integrator;
use crate::light::Light;
use crate::methods::Method;
use crate::output::exr::{stage_exr_with_notes, ExrMetadata};
use crate::output::film::{read_render, RenderRead};
use crate::output::replicas::render_channels;
use crate::output::{write_atomically, OutputError};
use crate::render::{camera_for, Budget, RenderOptions, ReplicaMeans};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The cache folder used when none is given: `.vitrum-cache` in the working directory.
pub const DEFAULT_CACHE_DIR: &str = ".vitrum-cache";

/// A reference image and where it came from.
#[derive(Clone, Debug)]
pub struct Reference {
    /// The image.
    pub image: Image,
    /// The cached EXR file.
    pub path: PathBuf,
    /// Samples per pixel of the reference.
    pub spp: u32,
    /// Whether it was read from the cache (false: rendered now).
    pub cached: bool,
    /// The variance of each pixel's estimate (kept in the EXR's variance channels), so that
    /// the reference's own noise can be told from a method's bias ([`crate::metrics::split`]).
    pub variance: Option<Image>,
    /// The means of its replicas (kept in the EXR's replica channels): the standard errors of
    /// every judgement against it include the reference's own noise.
    pub replicas: Option<ReplicaMeans>,
}

/// Everything a cached reference depends on (the sidecar's contents).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceKey {
    /// The integrator that renders it (`path` or `vcm`, or the one `--reference-method` names).
    pub integrator: String,
    /// Content hash of the scene text.
    pub scene_hash: String,
    /// The scene's display name (informative; not part of the identity).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scene: Option<String>,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// The seed of the sweep (the reference itself uses [`reference_seed`] of it).
    pub seed: u64,
    /// Maximum depth.
    pub max_depth: u32,
    /// Constant dielectric reflectance, when set.
    pub reflectance: Option<f32>,
    /// Spectral mode (`Debug` form).
    pub spectral: String,
    /// Sampler name.
    pub sampler: String,
    /// The replica count (absent in keys of older versions, which the version tells apart).
    #[serde(default)]
    pub replicas: u32,
    /// The initial merge radius and its α, for a merging method (absent for the others, so
    /// that the keys of `path` references stay as they were).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub merging: Option<[f32; 2]>,
    /// The crate version that rendered it.
    pub version: String,
}

impl ReferenceKey {
    /// The key of the reference of `scene` by the method `method` at `spp` with the options `opts`.
    pub fn new(scene: &Scene, method: &str, opts: &RenderOptions, spp: u32) -> ReferenceKey {
        let camera = camera_for(scene, opts.resolution);
        let merging = crate::scene::desc::MERGING_METHODS.contains(&method).then(|| {
            [
                crate::integrators::initial_radius(scene, &opts.params.merging, opts.resolution),
                opts.params.merging.alpha,
            ]
        });
        ReferenceKey {
            integrator: method.into(),
            merging,
            scene_hash: scene.origin.hash.clone(),
            scene: Some(scene.origin.name.clone()),
            // The image's size: the crop window's.
            width: camera.crop.width,
            height: camera.crop.height,
            spp,
            seed: opts.seed,
            max_depth: opts.params.max_depth,
            reflectance: opts.params.reflectance,
            spectral: format!("{:?}", opts.spectral),
            sampler: opts.sampler.name().into(),
            replicas: opts.replicas.count(),
            version: crate::VERSION.into(),
        }
    }

    /// Whether two keys name the same reference (the display name may differ).
    fn same(&self, other: &ReferenceKey) -> bool {
        ReferenceKey { scene: None, ..self.clone() } == ReferenceKey { scene: None, ..other.clone() }
    }

    /// The file name without extension: readable settings and a digest of the whole key.
    pub fn file_stem(&self) -> String {
        let identity = ReferenceKey { scene: None, ..self.clone() };
        let text = serde_json::to_string(&identity).expect("a key serialises");
        format!(
            "{}-{}x{}-{}spp-{:016x}",
            self.integrator,
            self.width,
            self.height,
            self.spp,
            fnv1a(text.as_bytes())
        )
    }
}

/// The seed of a reference's random streams for the sweep seed `seed` (see the module documentation).
pub fn reference_seed(seed: u64) -> u64 {
    seed ^ 0x7265_6665_7265_6e63 // "referenc"
}

/// 64-bit FNV-1a: a stable digest (unlike `std`'s hasher, the same in every Rust version).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

/// The cached reference for `key` in `cache_dir`, with its variance and replicas, when a valid
/// one is there (one of two samples or more cached without replicas is not).
fn read_cached(exr: &Path, sidecar: &Path, key: &ReferenceKey) -> Option<(Image, RenderRead)> {
    let stored: ReferenceKey = serde_json::from_str(&std::fs::read_to_string(sidecar).ok()?).ok()?;
    if !stored.same(key) {
        return None;
    }
    let read = read_render(exr).ok()?;
    let size = (key.width as usize, key.height as usize);
    let replicas_fit = match &read.replicas {
        Some(r) => (r.width(), r.height()) == size,
        None => key.spp < 2 || key.replicas < 2,
    };
    ((read.image.width, read.image.height) == size && replicas_fit).then(|| (read.image.clone(), read))
}

/// The method that renders a correct reference of a scene, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReferenceChoice {
    /// The integrator's name.
    pub method: &'static str,
    /// Why it is the right one for the scene, in a sentence.
    pub why: String,
}

/// The reference method of `scene`: `vcm` where a delta light (point, spot, directional) meets a
/// specular surface (a smooth mirror or dielectric), since `path` misses the caustics a delta
/// light casts through or off such a surface; `path` (unbiased, and the cheapest per sample)
/// otherwise.
pub fn choose_method(scene: &Scene) -> ReferenceChoice {
    let point = scene.lights.iter().position(Light::is_delta);
    let specular =
        (0..scene.primitives.len() as u32).map(|i| scene.material_of(i)).find(|m| m.bsdf.is_specular());
    match (point, specular) {
        (Some(light), Some(material)) => {
            let kind = match scene.lights[light] {
                Light::Spot { .. } => "spot light",
                Light::Directional { .. } => "directional light",
                _ => "point light",
            };
            ReferenceChoice {
                method: Method::Vcm.name(),
                why: format!(
                    "{kind} {} meets the specular material `{}`: path tracing misses the caustics \
                     (a {kind} is reached only by shadow rays, which cannot bend through glass or off \
                     a mirror), vertex connection and merging finds them",
                    light + 1,
                    material.name
                ),
            }
        }
        (Some(_), None) => ReferenceChoice {
            method: Method::Path.name(),
            why: "no specular surface: path tracing is unbiased for the point light".into(),
        },
        (None, _) => ReferenceChoice {
            method: Method::Path.name(),
            why: "no point light: path tracing reaches every light and is unbiased".into(),
        },
    }
}

/// The methods that may render a reference, in the order a tie goes.
pub const CANDIDATES: [&str; 3] = [Method::Path.name(), Method::Bpt.name(), Method::Vcm.name()];

/// Why `method` cannot render a correct reference of `scene`: an effect of the scene it does not
/// simulate, or caustics of a point light through a specular surface that `path` and `bpt`
/// cannot find ([`choose_method`]); `None` when it can. The merging methods' shared wavelengths
/// and shutter time per iteration count as simulated: their iterations sample them, so the
/// image converges to the right one.
pub fn unfit_for_reference(scene: &Scene, method: &dyn Integrator) -> Option<String> {
    use crate::scene::effects::Effect;
    let merging = crate::scene::desc::MERGING_METHODS.contains(&method.name());
    for effect in scene.effects.0.iter().map(|u| u.effect) {
        let shared = merging && matches!(effect, Effect::Dispersion | Effect::MotionBlur);
        if method.support(effect) != crate::scene::effects::Support::Simulates && !shared {
            return Some(format!("does not simulate {}", effect.name()));
        }
    }
    let rule = choose_method(scene);
    (rule.method == Method::Vcm.name() && method.method() != Method::Vcm)
        .then(|| "cannot find the caustics of a point light through a specular surface".to_string())
}

/// A candidate's pilot render: how noisy it is for the time it took.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pilot {
    /// The method.
    pub method: String,
    /// Samples per pixel it took.
    pub spp: u32,
    /// Seconds it took.
    pub seconds: f64,
    /// The mean over pixels and channels of the relative variance of its pixels' means,
    /// v/(x̄² + 0.01) (from its replicas; relative as the verdicts and the relMSE are: an
    /// absolute variance would favour a method whose error sits in dark pixels); infinite
    /// without an estimate.
    pub variance: f64,
}

impl Pilot {
    /// Relative variance × seconds: what the method would reach in one second (lower is better).
    pub fn cost(&self) -> f64 {
        self.variance * self.seconds
    }
}

/// The mean over pixels and channels of v/(x̄² + 0.01) of a render's mean x̄ and its variance v;
/// infinite without a variance or where it is not finite.
fn relative_variance(out: &crate::render::RenderOutput) -> f64 {
    let Some(v) = &out.variance else { return f64::INFINITY };
    let mut sum = 0.0f64;
    for (x, v) in out.image.pixels.iter().zip(&v.pixels) {
        let (x, v) = (x.as_dvec3(), v.as_dvec3());
        sum += (v / (x * x + crate::metrics::REL_EPSILON)).element_sum() / 3.0;
    }
    let mean = sum / out.image.pixels.len().max(1) as f64;
    if mean.is_finite() {
        mean
    } else {
        f64::INFINITY
    }
}

/// The seconds each candidate's pilot renders for by default.
pub const PILOT_SECONDS: f64 = 0.5;

/// The method that renders the reference of `scene` with the sweep's options `opts`: the fit
/// candidate ([`unfit_for_reference`]) with the lowest variance × time in a short pilot render of
/// each (`pilot` long, at the sweep's resolution), with the pilots. A single fit candidate needs
/// no pilot. The choice is measured once and kept in `cache_dir` (`pilot-….json`, keyed like a
/// reference), so later sweeps of the same scene and settings agree with it.
pub fn choose_by_pilot(
    scene: &Scene,
    opts: &RenderOptions,
    pilot: std::time::Duration,
    cache_dir: &Path,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<(ReferenceChoice, Vec<Pilot>), OutputError> {
    let all: Vec<Box<dyn Integrator>> =
        CANDIDATES.iter().map(|n| crate::integrators::create(n).expect("a registered method")).collect();
    let unfit: Vec<(&'static str, String)> = all
        .iter()
        .filter_map(|m| unfit_for_reference(scene, m.as_ref()).map(|why| (m.name(), why)))
        .collect();
    let fit: Vec<&dyn Integrator> =
        all.iter().map(|m| m.as_ref()).filter(|m| !unfit.iter().any(|(n, _)| *n == m.name())).collect();
    // "path and bpt cannot …": the methods that share a reason, named together.
    let mut reasons: Vec<(Vec<&str>, &str)> = Vec::new();
    for (name, why) in &unfit {
        match reasons.iter_mut().find(|(_, w)| *w == why.as_str()) {
            Some((names, _)) => names.push(name),
            None => reasons.push((vec![name], why)),
        }
    }
    let excluded = reasons
        .iter()
        .map(|(names, why)| format!("{} {why}", names.join(" and ")))
        .collect::<Vec<_>>()
        .join("; ");
    match fit.as_slice() {
        [] => return Ok((choose_method(scene), Vec::new())),
        [only] => {
            let why = format!("the only method fit for a reference ({excluded})");
            return Ok((ReferenceChoice { method: only.name(), why }, Vec::new()));
        }
        _ => {}
    }
    let mut key = ReferenceKey::new(scene, "pilot", opts, 0);
    key.integrator = format!(
        "pilot-relative-{}-{}s",
        fit.iter().map(|m| m.name()).collect::<Vec<_>>().join("+"),
        pilot.as_secs_f64()
    );
    let sidecar = cache_dir.join(format!("{}.json", key.file_stem()));
    let stored = std::fs::read_to_string(&sidecar)
        .ok()
        .and_then(|t| serde_json::from_str::<(ReferenceKey, Vec<Pilot>)>(&t).ok());
    let pilots = match stored {
        Some((k, pilots)) if k.same(&key) && pilots.len() == fit.len() => pilots,
        _ => {
            let mut pilots = Vec::with_capacity(fit.len());
            for (i, method) in fit.iter().enumerate() {
                let opts = RenderOptions {
                    budget: Budget::Time(pilot),
                    seed: reference_seed(opts.seed) ^ 0x9e37,
                    ..opts.clone()
                };
                let n = fit.len() as u64;
                let out = crate::render::render(scene, *method, &opts, &|done, total| {
                    progress(i as u64 * 1000 + 1000 * done / total.max(1), n * 1000)
                });
                let variance = relative_variance(&out);
                pilots.push(Pilot {
                    method: method.name().into(),
                    spp: out.spp,
                    seconds: out.seconds,
                    variance,
                });
            }
            std::fs::create_dir_all(cache_dir).map_err(|e| OutputError::io(cache_dir, e))?;
            let text = serde_json::to_string_pretty(&(&key, &pilots)).expect("pilots serialise") + "\n";
            write_atomically(&sidecar, |tmp| {
                std::fs::write(tmp, text.as_bytes()).map_err(|e| OutputError::io(tmp, e))
            })?;
            pilots
        }
    };
    let best =
        pilots.iter().enumerate().min_by(|a, b| a.1.cost().total_cmp(&b.1.cost())).map_or(0, |(i, _)| i);
    let method = fit[best].name();
    let costs = pilots
        .iter()
        .map(|p| format!("{} {:.3e} ({} spp in {:.2} s)", p.method, p.cost(), p.spp, p.seconds))
        .collect::<Vec<_>>()
        .join(", ");
    let mut why =
        format!("the lowest relative variance × seconds in {:.2} s pilots: {costs}", pilot.as_secs_f64());
    if !excluded.is_empty() {
        why += &format!("; not fit: {excluded}");
    }
    Ok((ReferenceChoice { method, why }, pilots))
}

/// The reference of `scene` by `method` at `spp` samples with the resolution, seed and depth of
/// `opts`, read from `cache_dir` when an identical one was made before, otherwise rendered and
/// stored there.
pub fn render_reference(
    scene: &Scene,
    method: &dyn Integrator,
    opts: &RenderOptions,
    spp: u32,
    cache_dir: &Path,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Reference, OutputError> {
    let key = ReferenceKey::new(scene, method.name(), opts, spp);
    let stem = key.file_stem();
    let exr = cache_dir.join(format!("{stem}.exr"));
    let sidecar = cache_dir.join(format!("{stem}.json"));
    if let Some((image, read)) = read_cached(&exr, &sidecar, &key) {
        let variance = read.variance();
        return Ok(Reference { image, path: exr, spp, cached: true, variance, replicas: read.replicas });
    }

    std::fs::create_dir_all(cache_dir).map_err(|e| OutputError::io(cache_dir, e))?;
    let opts =
        RenderOptions { budget: Budget::Samples(spp), seed: reference_seed(opts.seed), ..opts.clone() };
    let out = crate::render::render(scene, method, &opts, progress);
    let meta = ExrMetadata {
        version: crate::VERSION.to_string(),
        integrator: method.name().into(),
        spp: out.spp,
        seed: opts.seed,
        render_time_seconds: out.seconds,
        rays: out.rays,
        scene: format!("{} ({})", scene.origin.name, scene.origin.hash),
        effects: scene.effects.names(),
    };
    let (channels, notes) = render_channels(&out);
    stage_exr_with_notes(&exr, &out.image, &meta, &channels, &notes)?.commit()?;
    let text = serde_json::to_string_pretty(&key).expect("a key serialises") + "\n";
    write_atomically(&sidecar, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| OutputError::io(tmp, e))
    })?;
    Ok(Reference {
        image: out.image,
        path: exr,
        spp,
        cached: false,
        variance: out.variance,
        replicas: out.replicas,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load_str;

    const SCENE: &str = r#"
[camera]
position = [0.0, 0.0, 3.0]
look_at = [0.0, 0.0, 0.0]
fov = 40.0
resolution = [8, 6]
[render]
integrator = "path"
[materials.white]
type = "diffuse"
color = 0.5
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "white"
[[lights]]
type = "environment"
radiance = 1.0
"#;

    /// The `path` reference (as the sweeps make it for this scene).
    fn path_reference(
        scene: &Scene,
        opts: &RenderOptions,
        spp: u32,
        dir: &Path,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<Reference, OutputError> {
        let path = crate::integrators::create("path").unwrap();
        render_reference(scene, path.as_ref(), opts, spp, dir, progress)
    }

    fn bits(image: &Image) -> Vec<[u32; 3]> {
        image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    }

    #[test]
    fn the_second_call_reads_the_cache_and_another_key_renders_again() {
        let scene = load_str(SCENE, "ball", None).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let opts = RenderOptions::from_scene(&scene, 1);
        let first = path_reference(&scene, &opts, 4, dir.path(), &|_, _| {}).unwrap();
        assert!(!first.cached);
        assert_eq!((first.image.width, first.image.height, first.spp), (8, 6, 4));
        let again = path_reference(&scene, &opts, 4, dir.path(), &|_, _| {}).unwrap();
        assert!(again.cached);
        assert_eq!(again.path, first.path);
        assert_eq!(bits(&again.image), bits(&first.image));
        // The variance is kept in the cache, for the split of bias and variance.
        let variance = |r: &Reference| bits(r.variance.as_ref().expect("a 4-spp reference has a variance"));
        assert_eq!(variance(&again), variance(&first));

        // Another seed, sample count, depth or resolution is another reference.
        let changes: [&dyn Fn(&mut RenderOptions); 3] =
            [&|o| o.seed += 1, &|o| o.params.max_depth = 2, &|o| o.resolution = Some((4, 4))];
        for change in changes {
            let mut other = opts.clone();
            change(&mut other);
            assert!(!path_reference(&scene, &other, 4, dir.path(), &|_, _| {}).unwrap().cached);
        }
        assert!(!path_reference(&scene, &opts, 8, dir.path(), &|_, _| {}).unwrap().cached);
        // Another scene text (same name) is another reference.
        let edited = load_str(&SCENE.replace("color = 0.5", "color = 0.6"), "ball", None).unwrap();
        assert!(!path_reference(&edited, &opts, 4, dir.path(), &|_, _| {}).unwrap().cached);
        // And the first key is still there.
        assert!(path_reference(&scene, &opts, 4, dir.path(), &|_, _| {}).unwrap().cached);
    }

    #[test]
    fn a_damaged_cache_entry_is_rendered_again() {
        let scene = load_str(SCENE, "ball", None).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let opts = RenderOptions::from_scene(&scene, 1);
        let first = path_reference(&scene, &opts, 2, dir.path(), &|_, _| {}).unwrap();
        std::fs::write(&first.path, "not an EXR").unwrap();
        let again = path_reference(&scene, &opts, 2, dir.path(), &|_, _| {}).unwrap();
        assert!(!again.cached);
        assert_eq!(bits(&again.image), bits(&first.image), "the same render again");
        assert!(path_reference(&scene, &opts, 2, dir.path(), &|_, _| {}).unwrap().cached);
    }

    #[test]
    fn the_reference_method_follows_the_scene() {
        // The thesis scene: a point light and smooth glass.
        let cornell = crate::scene::load_default();
        let choice = choose_method(&cornell);
        assert_eq!(choice.method, "vcm");
        assert!(choice.why.contains("`glass`"), "{}", choice.why);
        // No point light (an environment): path.
        assert_eq!(choose_method(&load_str(SCENE, "ball", None).unwrap()).method, "path");
        // A point light over diffuse or rough surfaces only: path is unbiased.
        let point = SCENE.replace(
            "type = \"environment\"\nradiance = 1.0",
            "type = \"point\"\nposition = [0.0, 3.0, 0.0]\nintensity = 5.0",
        );
        assert_eq!(choose_method(&load_str(&point, "ball", None).unwrap()).method, "path");
        let glass = |roughness: f32| {
            point.replace(
                "type = \"diffuse\"\ncolor = 0.5",
                &format!("type = \"dielectric\"\nior = 1.5\nroughness = {roughness}"),
            )
        };
        assert_eq!(choose_method(&load_str(&glass(0.3), "ball", None).unwrap()).method, "path");
        assert_eq!(choose_method(&load_str(&glass(0.0), "ball", None).unwrap()).method, "vcm");
        // An unused glass material does not count.
        let unused = format!("{point}[materials.spare]\ntype = \"dielectric\"\nior = 1.5\n");
        assert_eq!(choose_method(&load_str(&unused, "ball", None).unwrap()).method, "path");
    }

    #[test]
    fn the_method_and_its_merge_radius_are_part_of_the_key() {
        let scene = load_str(SCENE, "ball", None).unwrap();
        let mut opts = RenderOptions::from_scene(&scene, 1);
        let path = ReferenceKey::new(&scene, "path", &opts, 64);
        let vcm = ReferenceKey::new(&scene, "vcm", &opts, 64);
        assert!(vcm.file_stem().starts_with("vcm-8x6-64spp-"), "{}", vcm.file_stem());
        assert_ne!(path.file_stem()[5..], vcm.file_stem()[4..], "another digest too");
        assert_eq!(path.merging, None);
        opts.params.merging.radius = Some(0.5);
        assert_ne!(ReferenceKey::new(&scene, "vcm", &opts, 64).file_stem(), vcm.file_stem());
        assert_eq!(ReferenceKey::new(&scene, "path", &opts, 64).file_stem(), path.file_stem());
    }

    #[test]
    fn file_names_show_the_settings_and_differ_by_key() {
        let scene = load_str(SCENE, "ball", None).unwrap();
        let opts = RenderOptions::from_scene(&scene, 1);
        let key = ReferenceKey::new(&scene, "path", &opts, 64);
        assert!(key.file_stem().starts_with("path-8x6-64spp-"), "{}", key.file_stem());
        let other = ReferenceKey { seed: key.seed + 1, ..key.clone() };
        assert_ne!(key.file_stem(), other.file_stem());
        let renamed = ReferenceKey { scene: Some("elsewhere.toml".into()), ..key.clone() };
        assert_eq!(key.file_stem(), renamed.file_stem());
    }
}
