//! Method variants in an `-i` list: a method with settings, compared like a method of its own.
//!
//! `-i vcm,vcm[radius=0.002],path[max_depth=8,sampler=independent]` names three columns: `vcm`
//! with its settings, `vcm` with an initial merge radius of 0.002, and `path` cut at depth 8
//! with independent samples. An item is `NAME` or `NAME[KEY=VALUE,…]`; its label (in tables,
//! figures, the report, file names) is the item as written, without spaces. The settings:
//!
//! | key | value | methods |
//! |---|---|---|
//! | `max_depth` | 0 to 256 | every method |
//! | `sampler` | `sobol`, `stratified`, `independent` | every method |
//! | `radius` | the initial merge radius, > 0 (scene units) | `ppm`, `bpm`, `vcm` |
//! | `radius_alpha` | the radius schedule's α, in (0, 1] | `ppm`, `bpm`, `vcm` |
//! | `large_step` | the probability of a large step, in (0, 1] | `pssmlt`, `mmlt` |
//! | `sigma` | the deviation of a small step, in (0, 1] | `pssmlt`, `mmlt` |
//! | `seeding` | `sms` (unbiased) or `straight` (MNEE) | `mnee` |
//! | `max_chain` | the most glass interfaces of a chain, 1 to 16 | `mnee` |
//! | `max_trials` | the cap on SMS's trials, at least 1 | `mnee` |
//!
//! A label may not repeat: `-i vcm,vcm` is refused, `-i vcm,vcm[radius=0.002]` is two columns.

use super::support::{integrator_named, CliError};
use crate::integrators::Integrator;
use crate::params::Seeding;
use crate::render::RenderOptions;
use crate::sampler::SamplerKind;

/// One setting of a variant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Setting {
    /// The maximum path depth.
    MaxDepth(u32),
    /// The sampler.
    Sampler(SamplerKind),
    /// The initial merge radius.
    Radius(f32),
    /// The merge radius schedule's α.
    RadiusAlpha(f32),
    /// The Metropolis methods' probability of a large step.
    LargeStep(f32),
    /// The Metropolis methods' deviation of a small step.
    Sigma(f32),
    /// How manifold next-event estimation seeds its chains.
    Seeding(Seeding),
    /// The most glass interfaces of a manifold chain.
    MaxChain(u32),
    /// The cap on specular manifold sampling's trials.
    MaxTrials(u32),
}

/// A method of an `-i` list with its settings and label.
pub struct MethodSpec {
    /// The method.
    pub integrator: Box<dyn Integrator>,
    /// Its label: the method's name, or the item as written for a variant.
    pub label: String,
    /// The settings that override the sweep's options for this method.
    pub settings: Vec<Setting>,
}

impl MethodSpec {
    /// The method with no settings of its own.
    pub fn plain(integrator: Box<dyn Integrator>) -> MethodSpec {
        MethodSpec { label: integrator.name().to_string(), integrator, settings: Vec::new() }
    }

    /// Applies the settings to `opts` (the sweep's options for the method).
    pub fn apply(&self, opts: &mut RenderOptions) {
        for setting in &self.settings {
            match *setting {
                Setting::MaxDepth(d) => opts.params.max_depth = d,
                Setting::Sampler(k) => opts.sampler = k,
                Setting::Radius(r) => opts.params.merging.radius = Some(r),
                Setting::RadiusAlpha(a) => opts.params.merging.alpha = a,
                Setting::LargeStep(p) => opts.params.metropolis.large_step = p,
                Setting::Sigma(s) => opts.params.metropolis.sigma = s,
                Setting::Seeding(s) => opts.params.manifold.get_or_insert_with(Default::default).seeding = s,
                Setting::MaxChain(n) => {
                    opts.params.manifold.get_or_insert_with(Default::default).max_chain = n
                }
                Setting::MaxTrials(n) => {
                    opts.params.manifold.get_or_insert_with(Default::default).max_trials = n
                }
            }
        }
    }

    /// The label as a file name: letters, digits, `.`, `_` and `-` kept, the rest `-`
    /// (`vcm[radius=0.002]` → `vcm-radius-0.002`).
    pub fn file_stem(&self) -> String {
        let stem: String = self
            .label
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() || "._".contains(c) { c } else { '-' })
            .collect();
        stem.trim_end_matches('-').to_string()
    }
}

/// Splits `list` at the commas outside brackets.
fn items(list: &str) -> Vec<&str> {
    let (mut out, mut depth, mut start) = (Vec::new(), 0i32, 0);
    for (i, c) in list.char_indices() {
        match c {
            '[' => depth += 1,
            ']' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&list[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push(&list[start..]);
    out.into_iter().map(str::trim).filter(|s| !s.is_empty()).collect()
}

/// The setting `key=value` of `method` (named in errors as `item`).
fn setting(item: &str, method: &dyn Integrator, key: &str, value: &str) -> Result<Setting, CliError> {
    let bad = |what: String| CliError::BadInput(format!("-i {item}: {what}"));
    let merging = crate::scene::desc::MERGING_METHODS.contains(&method.name());
    let number = |what: &str| -> Result<f32, CliError> {
        value
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(format!("{key}={value}: {what}")))
    };
    match key {
        "max_depth" => value
            .parse::<u32>()
            .ok()
            .filter(|d| *d <= crate::scene::compile::MAX_DEPTH)
            .map(Setting::MaxDepth)
            .ok_or_else(|| {
                bad(format!(
                    "max_depth={value}: a whole number from 0 to {}",
                    crate::scene::compile::MAX_DEPTH
                ))
            }),
        "sampler" => SamplerKind::from_name(value)
            .map(Setting::Sampler)
            .ok_or_else(|| bad(format!("sampler={value}: one of sobol, stratified, independent"))),
        "radius" | "radius_alpha" if !merging => {
            Err(bad(format!("{key}: only the merging methods (ppm, bpm, vcm) have a merge radius")))
        }
        "radius" => {
            let r = number("a positive number of scene units")?;
            if r > 0.0 {
                Ok(Setting::Radius(r))
            } else {
                Err(bad(format!("radius={value}: a positive number of scene units")))
            }
        }
        "radius_alpha" => {
            let a = number("a number in (0, 1]")?;
            if a > 0.0 && a <= 1.0 {
                Ok(Setting::RadiusAlpha(a))
            } else {
                Err(bad(format!("radius_alpha={value}: a number in (0, 1]")))
            }
        }
        "large_step" | "sigma"
            if !matches!(method.method(), crate::methods::Method::Pssmlt | crate::methods::Method::Mmlt) =>
        {
            Err(bad(format!("{key}: only the Metropolis methods (pssmlt, mmlt) have large and small steps")))
        }
        "large_step" | "sigma" => {
            let v = number("a number in (0, 1]")?;
            match (v > 0.0 && v <= 1.0, key) {
                (true, "large_step") => Ok(Setting::LargeStep(v)),
                (true, _) => Ok(Setting::Sigma(v)),
                (false, _) => Err(bad(format!("{key}={value}: a number in (0, 1]"))),
            }
        }
        "seeding" | "max_chain" | "max_trials" if method.method() != crate::methods::Method::Mnee => {
            Err(bad(format!("{key}: only manifold next-event estimation (mnee) solves chains through glass")))
        }
        "seeding" => Seeding::from_name(value)
            .map(Setting::Seeding)
            .ok_or_else(|| bad(format!("seeding={value}: one of sms, straight"))),
        "max_chain" => value
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=crate::manifold::MAX_CHAIN as u32).contains(n))
            .map(Setting::MaxChain)
            .ok_or_else(|| {
                bad(format!("max_chain={value}: a whole number from 1 to {}", crate::manifold::MAX_CHAIN))
            }),
        "max_trials" => value
            .parse::<u32>()
            .ok()
            .filter(|n| *n >= 1)
            .map(Setting::MaxTrials)
            .ok_or_else(|| bad(format!("max_trials={value}: a whole number, at least 1"))),
        _ => Err(bad(format!(
            "unknown setting `{key}`; known: max_depth, sampler, radius, radius_alpha, large_step, sigma, \
             seeding, max_chain, max_trials"
        ))),
    }
}

/// The methods and variants of an `-i` list (`all`: every method), their labels unique.
pub fn parse_methods(list: &str) -> Result<Vec<MethodSpec>, CliError> {
    let specs: Vec<MethodSpec> = if list.trim() == "all" {
        crate::integrators::all().into_iter().map(MethodSpec::plain).collect()
    } else {
        let mut specs = Vec::new();
        for item in items(list) {
            let label: String = item.chars().filter(|c| !c.is_whitespace()).collect();
            let Some((name, rest)) = label.split_once('[') else {
                specs.push(MethodSpec::plain(integrator_named(&label)?));
                continue;
            };
            let Some(inner) = rest.strip_suffix(']') else {
                return Err(CliError::BadInput(format!("-i {item}: a variant is NAME[KEY=VALUE,…]")));
            };
            let integrator = integrator_named(name)?;
            let mut settings = Vec::new();
            for pair in inner.split(',').filter(|p| !p.is_empty()) {
                let Some((key, value)) = pair.split_once('=') else {
                    return Err(CliError::BadInput(format!("-i {item}: `{pair}` is not KEY=VALUE")));
                };
                settings.push(setting(item, integrator.as_ref(), key, value)?);
            }
            if settings.is_empty() {
                return Err(CliError::BadInput(format!(
                    "-i {item}: a variant needs a setting (or write `{name}`)"
                )));
            }
            specs.push(MethodSpec { integrator, label, settings });
        }
        specs
    };
    if specs.is_empty() {
        return Err(CliError::BadInput(format!(
            "-i `{list}`: name at least one integrator ({}), or `all`",
            crate::integrators::names().join(", ")
        )));
    }
    for (i, s) in specs.iter().enumerate() {
        if specs[..i].iter().any(|o| o.label == s.label || o.file_stem() == s.file_stem()) {
            return Err(CliError::BadInput(format!(
                "-i {list}: `{}` is named twice; a second column of a method needs settings of its own, e.g. \
                 vcm[radius=0.002]",
                s.label
            )));
        }
    }
    Ok(specs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variants_parse_with_their_settings_and_labels() {
        let specs = parse_methods("vcm, vcm[radius=0.002], path[max_depth=8,sampler=independent]").unwrap();
        let labels: Vec<&str> = specs.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(labels, ["vcm", "vcm[radius=0.002]", "path[max_depth=8,sampler=independent]"]);
        assert_eq!(specs[1].settings, [Setting::Radius(0.002)]);
        assert_eq!(specs[2].settings, [Setting::MaxDepth(8), Setting::Sampler(SamplerKind::Independent)]);
        assert_eq!(specs[1].file_stem(), "vcm-radius-0.002");
        let scene = crate::scene::load_default();
        let mut opts = RenderOptions::for_method(&scene, specs[2].integrator.as_ref(), 4);
        specs[2].apply(&mut opts);
        assert_eq!((opts.params.max_depth, opts.sampler), (8, SamplerKind::Independent));
        let mlt = parse_methods("pssmlt[large_step=0.5,sigma=0.02]").unwrap();
        assert_eq!(mlt[0].settings, [Setting::LargeStep(0.5), Setting::Sigma(0.02)]);
        let mut opts = RenderOptions::for_method(&scene, mlt[0].integrator.as_ref(), 4);
        mlt[0].apply(&mut opts);
        assert_eq!((opts.params.metropolis.large_step, opts.params.metropolis.sigma), (0.5, 0.02));
        let mmlt = parse_methods("mmlt[large_step=0.4,sigma=0.03]").unwrap();
        let mut opts = RenderOptions::from_scene(&crate::scene::load_default(), 1);
        mmlt[0].apply(&mut opts);
        assert_eq!((opts.params.metropolis.large_step, opts.params.metropolis.sigma), (0.4, 0.03));
    }

    #[test]
    fn bad_variants_are_refused() {
        for (list, needle) in [
            ("vcm,vcm", "named twice"),
            ("path[radius=0.1]", "only the merging methods"),
            ("vcm[radius=-1]", "positive"),
            ("vcm[radius_alpha=1.5]", "(0, 1]"),
            ("path[large_step=0.5]", "only the Metropolis methods"),
            ("mmlt[sigma=2]", "(0, 1]"),
            ("pssmlt[large_step=0]", "(0, 1]"),
            ("pssmlt[sigma=-0.1]", "(0, 1]"),
            ("path[max_depth=9999]", "0 to"),
            ("path[sampler=halton]", "sobol"),
            ("path[speed=2]", "unknown setting"),
            ("path[]", "needs a setting"),
            ("path[max_depth=8", "NAME[KEY=VALUE"),
            ("nope[max_depth=8]", "unknown integrator"),
        ] {
            let err = match parse_methods(list) {
                Err(CliError::BadInput(m)) => m,
                other => panic!("{list}: {:?}", other.map(|v| v.len())),
            };
            assert!(err.contains(needle), "{list}: {err}");
        }
    }
}
