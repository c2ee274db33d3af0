//! Every command: `render` (and its parts: shards, checkpoints, resume), `info`, `export`, and the
//! research commands `diff` (error metrics), `converge` (error against samples and seconds),
//! `compare` (equal-time figures and tables), `report` (every scene × method in one page) and `merge` (render parts into one image). Each
//! lives in its own module with its clap arguments and a `run` function; [`crate::cli`]
//! dispatches to them, and what they share is in [`support`]. Nothing here imports the CLI.

pub mod compare;
pub mod converge;
pub mod diff;
pub mod export;
pub mod import;
pub mod info;
pub mod merge;
pub mod parts;
pub mod render;
pub mod report;
pub mod support;
pub mod variants;

use crate::integrators::{self, Integrator, RenderParams};
use crate::metrics::Split;
use crate::output::exr::parse_rays;
use crate::output::film::read_render;
use crate::render::{Budget, RenderOptions, RenderOutput};
use crate::sampler::Replicas;
use crate::scene::compile::{MAX_DEPTH, MAX_PIXELS};
use crate::scene::Scene;
use std::path::PathBuf;
use support::{integrator_named, CliError};

/// Render options shared by the sweeps (`converge`, `compare`); the scene file gives the rest.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SweepArgs {
    /// Image size, e.g. 400x300 (default from the scene file).
    #[arg(long, value_parser = support::parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// Seed of the random streams (default from the scene file).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Maximum depth for every method, the reference included (default: the scene's
    /// `[render.METHOD] max_depth`, else each method's own; references: the method's own).
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=MAX_DEPTH as i64))]
    pub max_depth: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long, allow_negative_numbers = true)]
    pub threads: Option<usize>,
    /// Sampler of the methods' renders: sobol, stratified or independent (default from the scene
    /// file; the reference keeps the scene's).
    #[arg(long, value_parser = ["sobol", "stratified", "independent"])]
    pub sampler: Option<String>,
    /// Independent randomisations every render (the reference's too) splits its samples into,
    /// 1 to 64 (default 8): their spread gives the variances and standard errors.
    #[arg(long, value_name = "R", value_parser = render::parse_replicas)]
    pub replicas: Option<Replicas>,
}

impl SweepArgs {
    /// The options for rendering `scene` with `integrator` under `budget`: the depth from
    /// `--max-depth`, else the scene's `[render.METHOD] max_depth`, else the method's default.
    pub fn options(&self, scene: &Scene, integrator: &dyn Integrator, budget: Budget) -> RenderOptions {
        let mut opts = self.options_with(scene, scene.settings.params(integrator, self.max_depth), budget);
        if let Some(kind) = self.sampler.as_deref().and_then(crate::sampler::SamplerKind::from_name) {
            opts.sampler = kind;
        }
        opts
    }

    /// The options for rendering the reference of `scene` with the method `reference` under
    /// `budget`: as [`SweepArgs::options`], but at the method's full default depth unless
    /// `--max-depth` is given. A scene's depth for a method (`[render.path] max_depth = 8`) is
    /// a setting of that method's render, which the reference judges: it does not cut the
    /// reference.
    pub fn reference_options(
        &self,
        scene: &Scene,
        reference: &dyn Integrator,
        budget: Budget,
    ) -> RenderOptions {
        let max_depth = self.max_depth.unwrap_or_else(|| reference.default_max_depth());
        let params = RenderParams { max_depth, ..scene.settings.params(reference, None) };
        self.options_with(scene, params, budget)
    }

    /// The options for `scene` with the integrator parameters `params` under `budget`.
    fn options_with(&self, scene: &Scene, params: RenderParams, budget: Budget) -> RenderOptions {
        let s = &scene.settings;
        RenderOptions {
            budget,
            resolution: self.resolution,
            seed: self.seed.unwrap_or(s.seed),
            params,
            spectral: s.spectral,
            sampler: s.sampler,
            planned_spp: None,
            replicas: self.replicas.unwrap_or_default(),
        }
    }

    /// A worker pool with the requested number of threads.
    pub fn pool(&self) -> Result<rayon::ThreadPool, CliError> {
        support::thread_pool(self.threads)
    }
}

/// The reference a sweep measures against: its image, with its variance and replicas when they
/// are known.
#[derive(Clone, Debug)]
pub(crate) struct SweepReference {
    /// The image.
    pub image: crate::image::Image,
    /// The variance of each pixel's mean.
    pub variance: Option<crate::image::Image>,
    /// Its replicas' means.
    pub replicas: Option<crate::render::ReplicaMeans>,
}

impl SweepReference {
    /// The reference as the split judges it.
    pub fn estimate(&self) -> crate::metrics::Estimate<'_> {
        crate::metrics::Estimate {
            image: &self.image,
            replicas: self.replicas.as_ref(),
            variance: self.variance.as_ref(),
        }
    }
}

impl From<crate::reference::Reference> for SweepReference {
    fn from(r: crate::reference::Reference) -> SweepReference {
        SweepReference { image: r.image, variance: r.variance, replicas: r.replicas }
    }
}

impl From<ChosenReference> for SweepReference {
    fn from(r: ChosenReference) -> SweepReference {
        SweepReference::from(r.reference)
    }
}

impl From<diff::Judged> for SweepReference {
    fn from(j: diff::Judged) -> SweepReference {
        SweepReference { image: j.image, variance: j.variance, replicas: j.replicas }
    }
}

/// The warning for a reference too noisy to judge some of `splits` (method, split), with the
/// samples per pixel a reference would need (from `spp`, its own, when it was rendered by the
/// sweep): its variance part falls as 1/spp, and must fall to a tenth of the rest of the relative error E.
pub fn reference_noise_warning(splits: &[(&str, Option<&Split>)], spp: Option<u32>) -> Option<String> {
    let noisy: Vec<(&str, &Split)> =
        splits.iter().filter_map(|(m, s)| s.filter(|s| s.reference_too_noisy()).map(|s| (*m, s))).collect();
    if noisy.is_empty() {
        return None;
    }
    let list = noisy
        .iter()
        .map(|(m, s)| format!("{m} ({:.0}% of its error)", 100.0 * s.reference_share()))
        .collect::<Vec<_>>()
        .join(", ");
    let limit = crate::metrics::REFERENCE_SHARE_LIMIT;
    let advice = match spp {
        Some(spp) => {
            // V_r·spp/n ≤ limit·(MSE − V_r + V_r·spp/n) ⇔ n ≥ spp·V_r·(1 − limit)/(limit·(MSE − V_r)).
            let factor = noisy
                .iter()
                .map(|(_, s)| {
                    s.reference_variance * (1.0 - limit) / (limit * (s.error - s.reference_variance))
                })
                .fold(1.0f64, f64::max);
            let needed = (spp as f64 * factor).ceil().min(u32::MAX as f64) as u32;
            format!(
                "; render a longer reference: about --reference-spp {}",
                needed.next_power_of_two().max(spp)
            )
        }
        None => "; give a reference of more samples".to_string(),
    };
    Some(format!(
        "vitrum: warning: the reference is too noisy to judge the bias of {list}: its variance must be at most \
         {:.0}% of the relative error{advice}",
        100.0 * limit
    ))
}

/// A reference the sweep renders itself (or reads from its cache): the method named by
/// `--reference-method`, or the one a pilot render of each fit candidate finds the most efficient
/// ([`crate::reference::choose_by_pilot`]); its samples per pixel and the cache folder.
pub struct CachedReference {
    /// The method named by `--reference-method`, if any.
    pub named: Option<Box<dyn Integrator>>,
    /// Samples per pixel.
    pub spp: u32,
    /// The cache folder.
    pub cache: PathBuf,
    /// How long each candidate's pilot renders.
    pub pilot: std::time::Duration,
}

/// A sweep's reference with the method that rendered it and why that one.
pub struct ChosenReference {
    /// The reference.
    pub reference: crate::reference::Reference,
    /// The method that rendered it.
    pub method: &'static str,
    /// Why that method (named, the only fit one, or the pilots' numbers).
    pub why: String,
}

impl CachedReference {
    /// The reference of `scene` by `method` (`--reference-method`, else chosen by pilots when
    /// rendered) at `spp` samples, cached in `cache` (default `.vitrum-cache`).
    pub fn plan(
        _scene: &Scene,
        method: Option<&str>,
        spp: u32,
        cache: Option<PathBuf>,
    ) -> Result<CachedReference, CliError> {
        let bad = |m: String| CliError::BadInput(m);
        if spp == 0 {
            return Err(bad("--reference-spp 0: at least one sample per pixel".into()));
        }
        let cache = cache.unwrap_or_else(|| PathBuf::from(crate::reference::DEFAULT_CACHE_DIR));
        if cache.exists() && !cache.is_dir() {
            return Err(bad(format!("--cache {}: is not a folder", cache.display())));
        }
        let named = match method {
            Some(name) => Some(integrators::create(name).ok_or_else(|| {
                bad(format!(
                    "--reference-method {name}: unknown integrator; known: {}",
                    integrators::names().join(", ")
                ))
            })?),
            None => None,
        };
        if let Some(method) = &named {
            if let crate::render::Progression::Fixed(image) = method.progression() {
                let (name, why) = (method.name(), image.why());
                return Err(bad(format!(
                    "--reference-method {name}: its samples are not a sample count ({why})"
                )));
            }
        }
        let pilot = std::time::Duration::from_secs_f64(crate::reference::PILOT_SECONDS);
        Ok(CachedReference { named, spp, cache, pilot })
    }

    /// Choose the method (unless named), then render the reference (or read it from the cache)
    /// with the sweep's options `sweep`, reporting `progress`.
    pub fn get(
        &self,
        scene: &Scene,
        sweep: &SweepArgs,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<ChosenReference, CliError> {
        let failure = |e: crate::output::OutputError| CliError::Failure(e.to_string());
        let (method, why) = match &self.named {
            Some(m) => {
                (integrators::create(m.name()).expect("known"), "named by --reference-method".to_string())
            }
            None => {
                let probe = integrators::create("path").expect("known");
                let opts = sweep.reference_options(scene, probe.as_ref(), Budget::Samples(self.spp));
                let (choice, _) =
                    crate::reference::choose_by_pilot(scene, &opts, self.pilot, &self.cache, progress)
                        .map_err(failure)?;
                (integrators::create(choice.method).expect("a registered method"), choice.why)
            }
        };
        let opts = sweep.reference_options(scene, method.as_ref(), Budget::Samples(self.spp));
        let reference = crate::reference::render_reference(
            scene,
            method.as_ref(),
            &opts,
            self.spp,
            &self.cache,
            progress,
        )
        .map_err(failure)?;
        Ok(ChosenReference { reference, method: method.name(), why })
    }
}

impl ChosenReference {
    /// The line that says where the reference came from and why its method.
    pub fn describe(&self) -> String {
        let r = &self.reference;
        let how = if r.cached { "read from the cache" } else { "rendered and cached" };
        format!("reference: {}, {} spp, {how}: {} ({})", self.method, r.spp, r.path.display(), self.why)
    }
}

/// The integrators named in a comma-separated list, or every one for `all`.
pub fn parse_integrators(list: &str) -> Result<Vec<Box<dyn Integrator>>, CliError> {
    if list.trim() == "all" {
        return Ok(integrators::all());
    }
    let names: Vec<&str> = list.split(',').map(str::trim).filter(|n| !n.is_empty()).collect();
    if names.is_empty() {
        return Err(CliError::BadInput(format!(
            "-i `{list}`: name at least one integrator ({}), or `all`",
            integrators::names().join(", ")
        )));
    }
    names.into_iter().map(integrator_named).collect()
}

/// A render read back from its EXR file: a result computed elsewhere (merged shards of a
/// cluster job, say) for `converge --renders` and `compare --renders`.
pub struct RenderFile {
    /// The file.
    pub path: PathBuf,
    /// The integrator that rendered it (`vitrum:integrator`).
    pub method: Box<dyn Integrator>,
    /// Its seed (`vitrum:seed`).
    pub seed: u64,
    /// The render: image, samples (`vitrum:spp`), seconds (`renderTimeSeconds`: for merged
    /// parts the sum of the parts' render times) and rays; with the replicas and the per-pixel
    /// variance when the file keeps them (replica channels, or a render part's sums).
    pub out: RenderOutput,
}

/// Read the renders `files` of `scene`, with their size: each must be a vitrum EXR of that scene
/// (the content hash in `vitrum:scene`), of `size` (default: the first file's), by a known
/// integrator. Each file is read once.
pub fn read_renders(
    files: &[PathBuf],
    scene: &Scene,
    size: Option<(usize, usize)>,
) -> Result<(Vec<RenderFile>, (usize, usize)), CliError> {
    let mut renders = Vec::with_capacity(files.len());
    let mut size = size;
    for path in files {
        let bad = |what: String| CliError::BadInput(format!("--renders {}: {what}", path.display()));
        let read = read_render(path).map_err(|e| CliError::BadInput(format!("--renders: {e}")))?;
        let attribute = |name: &str| {
            read.attributes.get(name).ok_or_else(|| bad(format!("no {name} attribute: not a vitrum render")))
        };
        let hash = attribute("vitrum:scene")?.rsplit_once(" (").map(|(_, h)| h.trim_end_matches(')'));
        if hash != Some(scene.origin.hash.as_str()) {
            return Err(bad(format!(
                "rendered from another scene ({}), not {} ({})",
                attribute("vitrum:scene")?,
                scene.origin.name,
                scene.origin.hash
            )));
        }
        let (w, h) = *size.get_or_insert((read.image.width, read.image.height));
        if (read.image.width, read.image.height) != (w, h) {
            return Err(bad(format!(
                "{}x{}, not the {w}x{h} of the reference and the other renders",
                read.image.width, read.image.height
            )));
        }
        let name = attribute("vitrum:integrator")?;
        let method = integrators::create(name).ok_or_else(|| bad(format!("unknown integrator `{name}`")))?;
        let seed =
            attribute("vitrum:seed")?.parse().map_err(|_| bad("vitrum:seed is not a number".into()))?;
        let out = match &read.part {
            Some(part) => part.film.output(),
            None => RenderOutput {
                image: read.image.clone(),
                spp: attribute("vitrum:spp")?
                    .parse()
                    .map_err(|_| bad("vitrum:spp is not a number".into()))?,
                seconds: attribute("renderTimeSeconds")?.parse().unwrap_or(0.0),
                rays: parse_rays(attribute("vitrum:rays")?)
                    .ok_or_else(|| bad("vitrum:rays: not ray counts".into()))?,
                non_finite_samples: 0,
                spectral: false,
                samples_per_pixel: None,
                variance: read.variance(),
                replicas: read.replicas.clone(),
            },
        };
        renders.push(RenderFile { path: path.clone(), method, seed, out });
    }
    Ok((renders, size.unwrap_or((0, 0))))
}

/// A crop rectangle `X,Y,W,H` in pixels from the top-left corner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CropArg {
    /// Left edge.
    pub x: usize,
    /// Top edge.
    pub y: usize,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
}

/// `text` as a CSV field: quoted (its quotes doubled) when it holds a comma or a quote, as a
/// variant's label does (`path[max_depth=8,sampler=independent]`).
pub(crate) fn csv_field(text: &str) -> String {
    if text.contains([',', '"']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// A named rectangle of the image that metrics are also reported for (`--region NAME=X,Y,W,H`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RegionArg {
    /// Its name in the tables.
    pub name: String,
    /// The rectangle.
    pub rect: CropArg,
}

/// Parses `NAME=X,Y,W,H` (a name of letters, digits, `-` and `_`) or `X,Y,W,H` (named by its
/// numbers).
pub fn parse_region(s: &str) -> Result<RegionArg, String> {
    let (name, rect) = match s.split_once('=') {
        Some((name, rect)) => (name.trim().to_string(), rect),
        None => (s.trim().replace(',', "-"), s),
    };
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(format!("`{s}`: the region's name must be letters, digits, `-` or `_` (NAME=X,Y,W,H)"));
    }
    Ok(RegionArg { name, rect: parse_crop(rect)? })
}

/// A `--mask`: the PNG file whose white pixels are measured, and its name in the tables.
#[derive(Clone, Debug)]
pub struct MaskArg {
    /// Its name in the tables.
    pub name: String,
    /// The PNG file.
    pub path: PathBuf,
}

/// Parses `NAME=FILE.png`, or `FILE.png` (named by its file stem).
pub fn parse_mask(s: &str) -> Result<MaskArg, String> {
    let (name, path) = match s.split_once('=') {
        Some((name, path)) => (name.trim().to_string(), PathBuf::from(path)),
        None => {
            let path = PathBuf::from(s);
            let stem = path.file_stem().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let stem =
                stem.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
            (stem, path)
        }
    };
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
        return Err(format!("`{s}`: the mask's name must be letters, digits, `-` or `_` (NAME=FILE.png)"));
    }
    Ok(MaskArg { name, path })
}

/// The smallest grey level (0–255) of a mask pixel that selects it, and the smallest alpha.
pub const MASK_THRESHOLD: u8 = 128;

/// The regions of `regions` and `masks` for renders of `size` (width, height), named, in the
/// order given (rectangles first): every rectangle inside the image, every mask a readable
/// image of that size selecting at least one pixel (grey level and alpha both at least
/// [`MASK_THRESHOLD`]), no name twice.
pub fn plan_regions(
    regions: &[RegionArg],
    masks: &[MaskArg],
    size: (usize, usize),
) -> Result<Vec<(String, crate::metrics::Region)>, CliError> {
    use crate::metrics::{Crop, Region};
    let bad = |m: String| CliError::BadInput(m);
    let mut planned: Vec<(String, Region)> = Vec::new();
    let mut add = |name: &str, region: Region, what: String| {
        if planned.iter().any(|(n, _)| n == name) {
            return Err(bad(format!("{what}: the name `{name}` is given twice")));
        }
        planned.push((name.to_string(), region));
        Ok(())
    };
    for r in regions {
        let c = Crop { x: r.rect.x, y: r.rect.y, width: r.rect.width, height: r.rect.height };
        let what = format!("--region {}={},{},{},{}", r.name, c.x, c.y, c.width, c.height);
        if c.x + c.width > size.0 || c.y + c.height > size.1 {
            return Err(bad(format!("{what} does not fit inside the {}x{} image", size.0, size.1)));
        }
        add(&r.name, Region::rect(c), what)?;
    }
    for m in masks {
        let what = format!("--mask {}={}", m.name, m.path.display());
        let image = crate::image::limits::read_raster(&m.path)
            .map_err(|e| bad(format!("{what}: cannot read the image: {e}")))?;
        let image = image.into_luma_alpha8();
        let (w, h) = (image.width() as usize, image.height() as usize);
        if (w, h) != size {
            return Err(bad(format!(
                "{what}: the mask is {w}x{h} but the renders are {}x{}",
                size.0, size.1
            )));
        }
        let selected = image.pixels().map(|p| p[0] >= MASK_THRESHOLD && p[1] >= MASK_THRESHOLD).collect();
        let region = Region::masked(w, selected).ok_or_else(|| {
            bad(format!(
                "{what}: selects no pixel (white, grey level ≥ {MASK_THRESHOLD}, selects; black leaves out)"
            ))
        })?;
        add(&m.name, region, what)?;
    }
    Ok(planned)
}

/// Parses `X,Y,W,H` (whole pixels, W and H at least 1).
pub fn parse_crop(s: &str) -> Result<CropArg, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 4 {
        return Err(format!("`{s}` is not X,Y,W,H, e.g. 100,120,64,64"));
    }
    let mut v = [0usize; 4];
    for (slot, p) in v.iter_mut().zip(&parts) {
        *slot = p.parse().map_err(|_| format!("`{p}` in `{s}` is not a whole number of pixels"))?;
    }
    if v[2] == 0 || v[3] == 0 || (v[2] as u64) * (v[3] as u64) > MAX_PIXELS {
        return Err(format!("`{s}`: width and height must be at least 1 and the area at most {MAX_PIXELS}"));
    }
    Ok(CropArg { x: v[0], y: v[1], width: v[2], height: v[3] })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crops_parse_and_bad_ones_are_refused() {
        assert_eq!(parse_crop("1, 2,3,4"), Ok(CropArg { x: 1, y: 2, width: 3, height: 4 }));
        for bad in ["1,2,3", "1,2,0,4", "a,2,3,4", "-1,2,3,4", "1,2,3,4,5"] {
            assert!(parse_crop(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn references_trace_to_the_full_depth_unless_the_command_line_sets_one() {
        let path = integrators::create("path").unwrap();
        let whitted = integrators::create("whitted").unwrap();
        let depth = |args: &SweepArgs, scene: &Scene, reference: bool, method: &dyn Integrator| {
            let budget = Budget::Samples(4);
            let opts = if reference {
                args.reference_options(scene, method, budget)
            } else {
                args.options(scene, method, budget)
            };
            opts.params.max_depth
        };
        // cornell-glass sets the Whitted depth 5: a `path` reference of it (`--reference-method path`)
        // is not cut by it.
        let cornell = crate::scene::load_default();
        let args = SweepArgs::default();
        assert_eq!(depth(&args, &cornell, false, whitted.as_ref()), 5);
        assert_eq!(depth(&args, &cornell, false, path.as_ref()), 256);
        assert_eq!(depth(&args, &cornell, true, path.as_ref()), 256);
        // A scene's `path` depth is the compared `path`'s setting, not the reference's.
        let text = crate::scene::DEFAULT_SCENE
            .replace("[render.whitted]", "[render.path]\nmax_depth = 8\n[render.whitted]");
        let cut = crate::scene::load_str(&text, "cut.toml", None).unwrap();
        assert_eq!(depth(&args, &cut, false, path.as_ref()), 8);
        assert_eq!(depth(&args, &cut, true, path.as_ref()), 256);
        // --max-depth sets every method, the reference included.
        let args = SweepArgs { max_depth: Some(3), ..SweepArgs::default() };
        for reference in [false, true] {
            assert_eq!(depth(&args, &cut, reference, path.as_ref()), 3);
        }
        assert_eq!(depth(&args, &cut, false, whitted.as_ref()), 3);
    }

    #[test]
    fn integrator_lists() {
        assert_eq!(parse_integrators("all").unwrap().len(), integrators::all().len());
        let two = parse_integrators("path, light").unwrap();
        assert_eq!(two.iter().map(|i| i.name()).collect::<Vec<_>>(), ["path", "light"]);
        assert!(parse_integrators("path,nope").is_err());
        assert!(parse_integrators(" , ").is_err());
    }
}
