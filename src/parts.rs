//! One render in parts: split over time (checkpoints and resume) or over processes and machines
//! (shards and merge).
//!
//! A part is a [`Film`] (per pixel the f64 sums of the per-sample estimates and of their squares)
//! with the sample indices it holds, the range it was asked to render, the sample count its
//! sampler planned for, and the [`Identity`] of the render it belongs to: the settings every part
//! of one render shares. The random stream of a sample is a pure function of (seed, pixel, sample
//! index, dimension), so any sample range can be rendered anywhere:
//! - **Resume** continues a part's sums in index order from where they stopped: the finished
//!   film holds the very bits of an uninterrupted render.
//! - **Merge** adds the parts' sums, in the order of their first sample index. A sum of partial
//!   sums rounds differently from one running sum, so a merged image equals the single render
//!   within f64 summation rounding (relative 1e-15 of a sum, far below the f32 of the image:
//!   pixels equal or a few float ulps apart), not bit for bit. Light tracing's splats merge the
//!   same way: every part's estimate is its sum over (its samples · the film area), the merge
//!   divides the summed sums by the summed sample counts.

use crate::render::{Film, Progression, RenderOptions};
use crate::sampler::SamplerKind;
use crate::scene::Scene;
use std::fmt;
use std::ops::Range;

/// A set of sample indices: ascending, disjoint, non-adjacent ranges.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SampleSet(Vec<Range<u32>>);

impl SampleSet {
    /// The indices of `range` (empty when the range is).
    pub fn of(range: Range<u32>) -> SampleSet {
        SampleSet(if range.is_empty() { Vec::new() } else { vec![range] })
    }

    /// The ranges, ascending.
    pub fn ranges(&self) -> &[Range<u32>] {
        &self.0
    }

    /// How many indices the set holds.
    pub fn count(&self) -> u64 {
        self.0.iter().map(|r| (r.end - r.start) as u64).sum()
    }

    /// The set as one range, when it is one (or empty, as `0..0`).
    pub fn as_range(&self) -> Option<Range<u32>> {
        match self.0.as_slice() {
            [] => Some(0..0),
            [r] => Some(r.clone()),
            _ => None,
        }
    }

    /// The union with `other`, or the first range of indices both hold.
    pub fn union(&self, other: &SampleSet) -> Result<SampleSet, Range<u32>> {
        let mut all: Vec<Range<u32>> = self.0.iter().chain(&other.0).cloned().collect();
        all.sort_by_key(|r| r.start);
        let mut out: Vec<Range<u32>> = Vec::with_capacity(all.len());
        for r in all {
            match out.last_mut() {
                Some(last) if r.start < last.end => return Err(r.start..r.end.min(last.end)),
                Some(last) if r.start == last.end => last.end = r.end,
                _ => out.push(r),
            }
        }
        Ok(SampleSet(out))
    }

    /// The indices of `range` that the set does not hold, as ranges.
    pub fn missing_from(&self, range: Range<u32>) -> SampleSet {
        let mut missing = Vec::new();
        let mut at = range.start;
        for r in &self.0 {
            if r.start > at {
                missing.push(at..r.start.min(range.end));
            }
            at = at.max(r.end);
            if at >= range.end {
                break;
            }
        }
        if at < range.end {
            missing.push(at..range.end);
        }
        SampleSet(missing.into_iter().filter(|r| !r.is_empty()).collect())
    }

    /// Parse the form [`Display`](fmt::Display) writes: `A..B` ranges separated by commas.
    pub fn parse(text: &str) -> Result<SampleSet, String> {
        let mut set = SampleSet::default();
        for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            set = set.union(&SampleSet::of(parse_sample_range(item)?)).map_err(|r| {
                format!("`{text}`: the sample indices {}..{} are listed twice", r.start, r.end)
            })?;
        }
        Ok(set)
    }
}

impl fmt::Display for SampleSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ranges: Vec<String> = self.0.iter().map(|r| format!("{}..{}", r.start, r.end)).collect();
        write!(f, "{}", ranges.join(","))
    }
}

/// Parse a sample range `A..B` (indices A to B−1, A < B).
pub fn parse_sample_range(text: &str) -> Result<Range<u32>, String> {
    let bad = || format!("`{text}`: expected a sample range A..B with whole numbers A < B, e.g. 0..64");
    let (a, b) = text.trim().split_once("..").ok_or_else(bad)?;
    let (a, b): (u32, u32) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if a >= b {
        return Err(bad());
    }
    Ok(a..b)
}

/// Shard `index` of `count` (0-based, as Slurm array and Kubernetes indices usually are).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, `0..count`.
    pub index: u32,
    /// How many shards.
    pub count: u32,
}

impl Shard {
    /// Parse `I/N` with 0 ≤ I < N.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let bad = || format!("`{text}`: expected I/N with whole numbers 0 ≤ I < N, e.g. 0/8");
        let (i, n) = text.trim().split_once('/').ok_or_else(bad)?;
        let (index, count): (u32, u32) =
            (i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    /// The sample indices of this shard of an `spp`-sample render: `spp·I/N .. spp·(I+1)/N`
    /// (sizes differ by at most one; the shards cover `0..spp` exactly).
    pub fn range(self, spp: u32) -> Range<u32> {
        let at = |i: u32| (spp as u64 * i as u64 / self.count as u64) as u32;
        at(self.index)..at(self.index + 1)
    }
}

/// The settings that every part of one render shares: (field, value) pairs in a fixed order.
/// Parts with different identities are different renders and are never merged or resumed
/// into each other.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Identity(Vec<(String, String)>);

impl Identity {
    /// The identity of a `width × height` render of `scene` by `integrator` with `opts`
    /// (`wavelengths`: whether it traces wavelengths).
    pub fn new(
        scene: &Scene,
        integrator: &str,
        opts: &RenderOptions,
        (width, height): (usize, usize),
        wavelengths: bool,
    ) -> Identity {
        let fields = [
            ("version", crate::VERSION.to_string()),
            ("scene", scene.origin.hash.clone()),
            ("integrator", integrator.to_string()),
            ("seed", opts.seed.to_string()),
            ("resolution", format!("{width}x{height}")),
            ("sampler", opts.sampler.name().to_string()),
            ("replicas", opts.replicas.count().to_string()),
            ("max-depth", opts.params.max_depth.to_string()),
            ("wavelengths", if wavelengths { "yes" } else { "no" }.to_string()),
            ("reflectance", opts.params.reflectance.map_or("fresnel".to_string(), |r| r.to_string())),
        ];
        let mut fields: Vec<(String, String)> = fields.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
        if crate::scene::desc::MERGING_METHODS.contains(&integrator) {
            let merging = &opts.params.merging;
            fields.push((
                "radius".into(),
                crate::integrators::initial_radius(scene, merging, opts.resolution).to_string(),
            ));
            fields.push(("radius-alpha".into(), merging.alpha.to_string()));
        }
        // Written only when it is not the default, so that earlier parts keep their identity.
        let cap = opts.params.merging.max_light_paths;
        if crate::scene::desc::BIDIRECTIONAL_METHODS.contains(&integrator)
            && cap != crate::params::DEFAULT_MAX_LIGHT_PATHS
        {
            fields.push(("max-light-paths".into(), cap.to_string()));
        }
        if let Some(strategy) = opts.params.merging.only {
            fields.push(("strategy".into(), strategy.name().to_string()));
        }
        Identity(fields)
    }

    /// The value of `field`.
    pub fn get(&self, field: &str) -> Option<&str> {
        self.0.iter().find(|(k, _)| k == field).map(|(_, v)| v.as_str())
    }

    /// The fields, in order.
    pub fn fields(&self) -> &[(String, String)] {
        &self.0
    }

    /// The first field (name, this value, the other's value) in which `other` differs.
    pub fn difference(&self, other: &Identity) -> Option<(String, String, String)> {
        let missing = || "(none)".to_string();
        let names = self.0.iter().map(|(k, _)| k).chain(other.0.iter().map(|(k, _)| k));
        for name in names {
            let (a, b) = (self.get(name), other.get(name));
            if a != b {
                let show = |v: Option<&str>| v.map_or_else(missing, str::to_string);
                return Some((name.clone(), show(a), show(b)));
            }
        }
        None
    }

    /// Parse the form [`Display`](fmt::Display) writes: `field=value` pairs separated by `; `.
    pub fn parse(text: &str) -> Result<Identity, String> {
        let fields = text
            .split("; ")
            .filter(|s| !s.is_empty())
            .map(|kv| {
                let (k, v) = kv.split_once('=').ok_or_else(|| format!("`{kv}` is not field=value"))?;
                Ok((k.to_string(), v.to_string()))
            })
            .collect::<Result<Vec<_>, String>>()?;
        Ok(Identity(fields))
    }
}

impl fmt::Display for Identity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let fields: Vec<String> = self.0.iter().map(|(k, v)| format!("{k}={v}")).collect();
        write!(f, "{}", fields.join("; "))
    }
}

/// A part of a render: its running sums and what they hold.
#[derive(Clone, Debug)]
pub struct Part {
    /// The sums (for a part whose samples are one range, `film.sample_range()` is that range).
    pub film: Film,
    /// What the sums hold.
    pub info: PartInfo,
}

/// What a part's sums hold, and of which render.
#[derive(Clone, Debug, PartialEq)]
pub struct PartInfo {
    /// The render it belongs to.
    pub identity: Identity,
    /// The sample indices the sums hold.
    pub samples: SampleSet,
    /// The sample indices the part was asked to render (a resume renders the rest of them).
    pub target: Range<u32>,
    /// The sample count its sampler planned for (sample `s` was drawn as sample `s` of this; 0:
    /// no plan, a time budget).
    pub planned: u32,
    /// For a time budget, the render seconds it was given in all (a resume renders the rest).
    pub time_budget: Option<f64>,
    /// The scene file it was rendered from, absolute (or the embedded default scene's name):
    /// where `--resume` reads the scene.
    pub scene_file: String,
}

impl PartInfo {
    /// The sample indices of the target that the part does not hold (after a merge with
    /// `--allow-gaps`, or of an unfinished part).
    pub fn missing(&self) -> SampleSet {
        self.samples.missing_from(self.target.clone())
    }

    /// Whether the sample count planned for changes the samples drawn: for the camera pass
    /// with the stratified sampler (strata of the planned count) and a plan of one sample (the
    /// pixel centre); light tracing's paths never depend on it.
    pub fn plan_matters(&self) -> bool {
        let camera_pass = self
            .identity
            .get("integrator")
            .and_then(crate::integrators::create)
            .is_some_and(|i| matches!(i.progression(), Progression::Camera(_)));
        camera_pass
            && (self.identity.get("sampler") == Some(SamplerKind::Stratified.name()) || self.planned == 1)
    }
}

/// Merge `parts` (named for the error messages) into one: refused, with a message naming the two
/// parts and what differs, when their identities, planned sample counts (where the plan matters),
/// image sizes or film normalisations differ, or when two parts hold the same sample index.
///
/// The merged part's target is the whole render, `0..N` with N the largest planned sample count
/// (for time budgets, which plan none, the last sample held). Unless `allow_gaps`, parts that
/// leave indices of it unheld (shards 0, 1 and 3 of 4) are refused, naming the missing ranges;
/// with it, the merged part holds what the parts hold ([`PartInfo::missing`] names the rest) and
/// its estimate is the mean over the samples held.
pub fn merge(parts: &[(String, Part)], allow_gaps: bool) -> Result<Part, String> {
    let Some((first_name, first)) = parts.first() else {
        return Err("no parts to merge".into());
    };
    for (name, part) in &parts[1..] {
        if let Some((field, a, b)) = first.info.identity.difference(&part.info.identity) {
            return Err(format!(
                "{name} is not a part of the same render as {first_name}: its {field} is {b}, not {a}"
            ));
        }
        if (first.info.plan_matters() || part.info.plan_matters()) && first.info.planned != part.info.planned
        {
            return Err(format!(
                "{name} was drawn from a {}-sample plan, {first_name} from a {}-sample one ({} sampler): \
                 render every shard with the same --spp",
                part.info.planned,
                first.info.planned,
                first.info.identity.get("sampler").unwrap_or("?")
            ));
        }
        let (a, b) = (&first.film, &part.film);
        if (a.width, a.height, a.norm.to_bits()) != (b.width, b.height, b.norm.to_bits()) {
            return Err(format!("{name} and {first_name} have different film sizes or normalisations"));
        }
    }
    let mut order: Vec<&(String, Part)> = parts.iter().collect();
    order.sort_by_key(|(_, p)| p.info.samples.ranges().first().map_or(0, |r| r.start));
    let mut film = order[0].1.film.clone();
    let mut samples = order[0].1.info.samples.clone();
    for (name, part) in &order[1..] {
        samples = samples.union(&part.info.samples).map_err(|r| {
            format!("{name} holds the sample indices {}..{} that another part holds too", r.start, r.end)
        })?;
        add_film(&mut film, &part.film);
    }
    let count = u32::try_from(samples.count()).map_err(|_| "more than 2³² samples per pixel".to_string())?;
    let hull = match (samples.ranges().first(), samples.ranges().last()) {
        (Some(a), Some(b)) => a.start..b.end,
        _ => 0..0,
    };
    film.first = hull.start;
    film.samples = count;
    let planned = order.iter().map(|(_, p)| p.info.planned).max().unwrap_or(0);
    let target = 0..planned.max(hull.end);
    let missing = samples.missing_from(target.clone());
    if !allow_gaps && missing.count() > 0 {
        return Err(format!(
            "the parts leave gaps: the samples {missing} of {}..{} are in none of them ({} of {} held); \
             render the missing parts, or give --allow-gaps to merge what is there",
            target.start,
            target.end,
            count,
            target.end - target.start
        ));
    }
    let info = PartInfo {
        identity: first.info.identity.clone(),
        samples,
        target,
        planned,
        time_budget: None,
        scene_file: first.info.scene_file.clone(),
    };
    Ok(Part { film, info })
}

/// Add `other`'s sums and counters to `film` (same size).
fn add_film(film: &mut Film, other: &Film) {
    for (a, b) in film.sum.iter_mut().zip(&other.sum) {
        *a += *b;
    }
    for (a, b) in film.replica_sums.iter_mut().zip(&other.replica_sums) {
        *a += *b;
    }
    for (a, b) in film.replica_samples.iter_mut().zip(&other.replica_samples) {
        *a += *b;
    }
    film.rays += other.rays;
    film.non_finite += other.non_finite;
    film.seconds += other.seconds;
    for (a, b) in film.requests.0.iter_mut().zip(other.requests.0) {
        *a += b;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_sets_parse_print_and_refuse_overlaps() {
        let set = SampleSet::parse("8..12, 0..4,4..6").unwrap();
        assert_eq!(set.ranges(), [0..6, 8..12]);
        assert_eq!(set.to_string(), "0..6,8..12");
        assert_eq!(set.count(), 10);
        assert_eq!(set.as_range(), None);
        assert_eq!(SampleSet::parse(&set.to_string()).unwrap(), set);
        assert_eq!(set.union(&SampleSet::of(6..8)).unwrap().as_range(), Some(0..12));
        assert_eq!(set.union(&SampleSet::of(5..9)), Err(5..6));
        assert!(SampleSet::parse("0..4,3..5").is_err());
        for bad in ["4..4", "5..2", "a..3", "3", "-1..2"] {
            assert!(parse_sample_range(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn missing_ranges_are_the_target_less_the_set() {
        let set = SampleSet::parse("2..4,6..8").unwrap();
        assert_eq!(set.missing_from(0..10).to_string(), "0..2,4..6,8..10");
        assert_eq!(set.missing_from(2..8).to_string(), "4..6");
        assert_eq!(set.missing_from(3..4).count(), 0);
        assert_eq!(SampleSet::default().missing_from(0..5).to_string(), "0..5");
        assert_eq!(SampleSet::of(0..16).missing_from(0..12).count(), 0);
    }

    #[test]
    fn gaps_are_refused_unless_allowed_and_then_the_mean_is_over_the_samples_held() {
        // Shards 0, 1 and 3 of a 16-sample render (4 samples each, planned 16).
        let shard = |r: Range<u32>, v: f64| {
            let (name, mut p) = part(r, "0", v);
            p.info.planned = 16;
            (name, p)
        };
        let parts = [shard(0..4, 4.0), shard(4..8, 4.0), shard(12..16, 8.0)];
        let err = merge(&parts, false).unwrap_err();
        assert!(err.contains("the samples 8..12 of 0..16") && err.contains("--allow-gaps"), "{err}");
        let merged = merge(&parts, true).unwrap();
        assert_eq!(merged.info.samples.to_string(), "0..8,12..16");
        assert_eq!(merged.info.target, 0..16);
        assert_eq!(merged.info.missing().to_string(), "8..12");
        assert_eq!(merged.film.samples, 12, "the samples actually held");
        assert_eq!(merged.film.image().pixels[0].x, (16.0 / (12.0 * 3.0)) as f32);
        // A missing tail is a gap too; the full set is none.
        let err = merge(&parts[..2], false).unwrap_err();
        assert!(err.contains("the samples 8..16 of 0..16"), "{err}");
        let full = [shard(0..8, 8.0), shard(8..12, 4.0), shard(12..16, 4.0)];
        assert_eq!(merge(&full, false).unwrap().info.missing().count(), 0);
    }

    #[test]
    fn shards_cover_the_samples_exactly_once() {
        for (spp, n) in [(12, 5), (64, 8), (7, 7), (1000, 3), (u32::MAX, 6)] {
            let ranges: Vec<Range<u32>> = (0..n).map(|i| Shard { index: i, count: n }.range(spp)).collect();
            assert_eq!(ranges[0].start, 0);
            assert_eq!(ranges.last().unwrap().end, spp);
            assert!(ranges.windows(2).all(|w| w[0].end == w[1].start), "{ranges:?}");
            let sizes: Vec<u32> = ranges.iter().map(|r| r.end - r.start).collect();
            assert!(sizes.iter().max().unwrap() - sizes.iter().min().unwrap() <= 1, "{sizes:?}");
        }
        assert_eq!(Shard::parse("2/8").unwrap(), Shard { index: 2, count: 8 });
        for bad in ["8/8", "1/0", "x/2", "3"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
    }

    fn part(samples: Range<u32>, seed: &str, values: f64) -> (String, Part) {
        let mut film = Film::new(2, 1, 3.0, false, crate::sampler::Replicas::DEFAULT);
        film.first = samples.start;
        for s in samples.clone() {
            for pixel in 0..2 {
                film.add(pixel, s, glam::DVec3::splat(values / (samples.end - samples.start) as f64));
            }
        }
        film.advance(samples.end - samples.start);
        let fields = [("seed", seed), ("sampler", "sobol"), ("integrator", "path")];
        let identity = Identity(fields.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect());
        let name = format!("part {}..{}", samples.start, samples.end);
        let (set, scene_file) = (SampleSet::of(samples.clone()), "s.toml".to_string());
        let info =
            PartInfo { identity, samples: set, target: samples, planned: 12, time_budget: None, scene_file };
        (name, Part { film, info })
    }

    #[test]
    fn merge_adds_sums_and_counts_and_refuses_other_renders() {
        let merged = merge(&[part(4..12, "0", 8.0), part(0..4, "0", 4.0)], false).unwrap();
        assert_eq!(merged.info.samples.as_range(), Some(0..12));
        assert_eq!((merged.film.first, merged.film.samples), (0, 12));
        assert_eq!(merged.film.sum[0].x, 12.0);
        // Replica r holds the indices ≡ r mod 8 of both parts.
        assert_eq!(merged.film.replica_samples, [2, 2, 2, 2, 1, 1, 1, 1]);
        // The estimate is the summed sums over the summed counts and the film normalisation.
        assert_eq!(merged.film.image().pixels[0].x, (12.0 / (12.0 * 3.0)) as f32);

        let err = merge(&[part(0..4, "0", 1.0), part(4..8, "1", 1.0)], false).unwrap_err();
        assert!(err.contains("seed is 1, not 0"), "{err}");
        let err = merge(&[part(0..4, "0", 1.0), part(2..8, "0", 1.0)], false).unwrap_err();
        assert!(err.contains("2..4"), "{err}");
        let (name, mut stratified) = part(4..8, "0", 1.0);
        stratified.info.identity.0[1].1 = "stratified".into();
        let (other_name, mut other) = part(0..4, "0", 1.0);
        other.info.identity = stratified.info.identity.clone();
        other.info.planned = 16;
        let err = merge(&[(name, stratified), (other_name, other)], false).unwrap_err();
        assert!(err.contains("plan"), "{err}");
    }
}
