//! A render part in its EXR file ([`crate::parts`]): the beauty layer as in every render, plus
//! the state to resume and merge it, exactly.
//!
//! - A second layer `film` holds per pixel the f64 sums of the per-sample estimates, overall and
//!   per replica, each f64 as two 32-bit unsigned integer channels of its bits (`sum.R.hi`,
//!   `sum.R.lo`, …, `sum.B.lo`, then `replica0.R.hi` … `replicaK.B.lo` for the R replicas): EXR
//!   has no f64 channels, and f32 would lose the bits that make a resumed render equal an
//!   uninterrupted one. Viewers show the beauty layer (the first); the film layer is opaque data.
//!   The replica count is in the identity (`vitrum:settings`), the samples each replica holds
//!   follow from `vitrum:samples`.
//! - Header attributes of the beauty layer: `vitrum:samples` (the sample indices held, as
//!   `A..B` ranges), `vitrum:sample-target` (the range asked for), `vitrum:spp-planned`,
//!   `vitrum:settings` (the [`Identity`]), `vitrum:film-norm`, `vitrum:non-finite`,
//!   `vitrum:scene-file`, `vitrum:render-seconds`, `vitrum:time-budget` (time budgets), and the
//!   usual render metadata (whose `vitrum:spp` is the count of samples held). A merge with
//!   `--allow-gaps` also writes `vitrum:missing-samples`, the indices of its target it lacks.

use super::exr::{
    parse_rays, read_exr_with_layer, stage_exr_with_layer, ExrMetadata, ExtraChannel, U32Layer,
};
use super::replicas::decode_replicas;
use super::{OutputError, Staged};
use crate::image::Image;
use crate::parts::{parse_sample_range, Identity, Part, PartInfo, SampleSet};
use crate::render::{Film, ReplicaMeans};
use crate::sampler::Replicas;
use glam::DVec3;
use std::collections::BTreeMap;
use std::path::Path;

/// The name of the layer that holds the sums.
pub const FILM_LAYER: &str = "film";

/// The film layer's channels for `film`, in a fixed order.
fn film_layer(film: &Film) -> U32Layer {
    let r = film.replicas.count() as usize;
    let mut channels = Vec::with_capacity(6 * (r + 1));
    let replica = |k: usize| film.replica_sums[k..].iter().step_by(r);
    let sums = std::iter::once(("sum".to_string(), film.sum.iter().step_by(1)))
        .chain((0..r).map(|k| (format!("replica{k}"), replica(k))));
    for (name, values) in sums {
        for (axis, pick) in [("R", 0usize), ("G", 1), ("B", 2)] {
            let bits: Vec<u64> = values.clone().map(|v| v.to_array()[pick].to_bits()).collect();
            channels.push((format!("{name}.{axis}.hi"), bits.iter().map(|b| (b >> 32) as u32).collect()));
            channels.push((format!("{name}.{axis}.lo"), bits.iter().map(|&b| b as u32).collect()));
        }
    }
    U32Layer { name: FILM_LAYER.to_string(), channels }
}

/// The text attributes that describe a part with `film` and `info`.
fn part_notes(film: &Film, info: &PartInfo) -> Vec<(String, String)> {
    let target = format!("{}..{}", info.target.start, info.target.end);
    [
        ("vitrum:samples", info.samples.to_string()),
        ("vitrum:sample-target", target),
        ("vitrum:spp-planned", info.planned.to_string()),
        ("vitrum:settings", info.identity.to_string()),
        // Rust prints the shortest text that reads back as the same f64.
        ("vitrum:film-norm", film.norm.to_string()),
        ("vitrum:non-finite", film.non_finite.to_string()),
        ("vitrum:scene-file", info.scene_file.clone()),
        // The render seconds exactly (`renderTimeSeconds` is an f32), for time budgets.
        ("vitrum:render-seconds", film.seconds.to_string()),
        ("vitrum:time-budget", info.time_budget.map_or(String::new(), |t| t.to_string())),
    ]
    .into_iter()
    .filter(|(_, v)| !v.is_empty())
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// Stage the part with `film` and `info` as the EXR `path` (published with
/// [`Staged::commit`]): its image, the `extra` float channels and `notes` in the beauty layer,
/// its sums in the film layer.
pub fn stage_part(
    path: &Path,
    film: &Film,
    info: &PartInfo,
    meta: &ExrMetadata,
    extra: &[ExtraChannel],
    notes: &[(String, String)],
) -> Result<Staged, OutputError> {
    let mut all = part_notes(film, info);
    all.extend_from_slice(notes);
    stage_exr_with_layer(path, &film.image(), meta, extra, &all, film_layer(film))
}

/// A part read back from its EXR file, with all the file's header attributes.
pub struct PartFile {
    /// The part.
    pub part: Part,
    /// Every header attribute of the beauty layer, as text.
    pub attributes: BTreeMap<String, String>,
}

/// An EXR render read back in one go: its beauty image and header attributes, and its part
/// when it is one (it has the film layer).
pub struct RenderRead {
    /// The beauty layer's R, G, B.
    pub image: Image,
    /// Every header attribute of the beauty layer, as text.
    pub attributes: BTreeMap<String, String>,
    /// The part, for a file written by [`stage_part`].
    pub part: Option<Part>,
    /// The render's replicas: the part's, or those its channels keep
    /// ([`super::replicas`]); `None` for a render that keeps none.
    pub replicas: Option<ReplicaMeans>,
    /// The file's `variance.R/G/B` channels, when it has them.
    pub variance_channels: Option<Image>,
}

impl RenderRead {
    /// The variance of each pixel's mean: from the replicas, else from the file's
    /// `variance.R/G/B` channels (a file of another tool or version); `None` without either.
    pub fn variance(&self) -> Option<Image> {
        self.replicas.as_ref().map(ReplicaMeans::variance).or_else(|| self.variance_channels.clone())
    }
}

/// The error for a file at `path` that is not a render part, and why.
fn not_a_part(path: &Path, what: &str) -> OutputError {
    OutputError::format(
        path,
        format!(
            "not a render part ({what}): render it with --samples, --shard or --checkpoint, which keep the \
             sums needed to resume and merge"
        ),
    )
}

/// Read a render (a part or a plain one) from `path` with one read of the file: a checkpoint
/// replaced meanwhile cannot mix two versions. A film layer with missing or malformed
/// attributes is an error, not a plain render.
pub fn read_render(path: &Path) -> Result<RenderRead, OutputError> {
    let read = read_exr_with_layer(path, FILM_LAYER)?;
    let (image, attributes) = (read.image, read.attributes);
    let part = match read.layer {
        Some(layer) => Some(decode_part(path, &image, &attributes, &layer)?),
        None => None,
    };
    let replicas = match &part {
        Some(part) => part.film.replica_means(),
        None => decode_replicas(path, (image.width, image.height), &read.channels, &attributes)?,
    };
    let variance_channels = match ["variance.R", "variance.G", "variance.B"].map(|c| read.channels.get(c)) {
        [Some(r), Some(g), Some(b)] => Some(Image {
            width: image.width,
            height: image.height,
            pixels: r.iter().zip(g).zip(b).map(|((&r, &g), &b)| glam::Vec3::new(r, g, b)).collect(),
        }),
        _ => None,
    };
    Ok(RenderRead { image, attributes, part, replicas, variance_channels })
}

/// Read the part written by [`stage_part`] from `path`; an EXR without the film layer or its
/// attributes (a plain render) is refused with a message that says how to make one.
pub fn read_part(path: &Path) -> Result<PartFile, OutputError> {
    let read = read_render(path)?;
    match read.part {
        Some(part) => Ok(PartFile { part, attributes: read.attributes }),
        None => Err(not_a_part(path, "it has no `film` layer")),
    }
}

/// The part in `image`, `attributes` and the film `layer` of the file `path`.
fn decode_part(
    path: &Path,
    image: &Image,
    attributes: &BTreeMap<String, String>,
    layer: &U32Layer,
) -> Result<Part, OutputError> {
    let not_a_part = |what: &str| not_a_part(path, what);
    let attr =
        |name: &str| attributes.get(name).ok_or_else(|| not_a_part(&format!("it has no {name} attribute")));
    let bad = |name: &str, e: String| OutputError::format(path, format!("attribute {name}: {e}"));
    let samples = SampleSet::parse(attr("vitrum:samples")?).map_err(|e| bad("vitrum:samples", e))?;
    let target =
        parse_sample_range(attr("vitrum:sample-target")?).map_err(|e| bad("vitrum:sample-target", e))?;
    let number = |name: &str| -> Result<u64, OutputError> {
        attr(name)?.parse().map_err(|_| bad(name, "not a whole number".into()))
    };
    let planned = u32::try_from(number("vitrum:spp-planned")?)
        .map_err(|_| bad("vitrum:spp-planned", "too big".into()))?;
    let non_finite = number("vitrum:non-finite")?;
    let identity = Identity::parse(attr("vitrum:settings")?).map_err(|e| bad("vitrum:settings", e))?;
    let norm: f64 =
        attr("vitrum:film-norm")?.parse().map_err(|_| bad("vitrum:film-norm", "not a number".into()))?;
    let rays = parse_rays(attr("vitrum:rays")?).ok_or_else(|| bad("vitrum:rays", "not ray counts".into()))?;
    let seconds: f64 = attr("vitrum:render-seconds")?
        .parse()
        .map_err(|_| bad("vitrum:render-seconds", "not a number of seconds".into()))?;
    let time_budget = match attributes.get("vitrum:time-budget") {
        Some(t) => Some(t.parse().map_err(|_| bad("vitrum:time-budget", "not a number of seconds".into()))?),
        None => None,
    };
    let scene_file = attr("vitrum:scene-file")?.clone();
    let count = u32::try_from(samples.count()).map_err(|_| bad("vitrum:samples", "too many".into()))?;

    let (w, h) = (image.width, image.height);
    let channel = |name: &str| -> Result<&Vec<u32>, OutputError> {
        layer
            .channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
            .filter(|v| v.len() == w * h)
            .ok_or_else(|| not_a_part(&format!("its film layer has no full-size {name} channel")))
    };
    let replicas = identity
        .get("replicas")
        .and_then(|r| r.parse().ok())
        .and_then(Replicas::new)
        .ok_or_else(|| bad("vitrum:settings", "no replica count from 1 to 64".into()))?;
    let mut film = Film::new(w, h, norm, identity.get("wavelengths") == Some("yes"), replicas);
    let r = replicas.count() as usize;
    let mut replica_sums = vec![vec![DVec3::ZERO; w * h]; r];
    let sums = std::iter::once(("sum".to_string(), &mut film.sum))
        .chain(replica_sums.iter_mut().enumerate().map(|(k, v)| (format!("replica{k}"), v)));
    for (name, values) in sums {
        for (axis, pick) in [("R", 0usize), ("G", 1), ("B", 2)] {
            let (hi, lo) = (channel(&format!("{name}.{axis}.hi"))?, channel(&format!("{name}.{axis}.lo"))?);
            for (v, (&hi, &lo)) in values.iter_mut().zip(hi.iter().zip(lo)) {
                let mut a = v.to_array();
                a[pick] = f64::from_bits((hi as u64) << 32 | lo as u64);
                *v = DVec3::from_array(a);
            }
        }
    }
    for (k, sums) in replica_sums.iter().enumerate() {
        for (p, v) in sums.iter().enumerate() {
            film.replica_sums[p * r + k] = *v;
        }
    }
    for (k, held) in film.replica_samples.iter_mut().enumerate() {
        *held = samples.ranges().iter().map(|range| replicas.samples_in_range(k as u32, range.clone())).sum();
    }
    film.first = samples.ranges().first().map_or(target.start, |r| r.start);
    film.samples = count;
    film.rays = rays;
    film.non_finite = non_finite;
    film.seconds = seconds;
    let info = PartInfo { identity, samples, target, planned, time_budget, scene_file };
    Ok(Part { film, info })
}

#[cfg(test)]
mod tests {
    use super::super::exr::read_exr;
    use super::*;
    use crate::stats::RayCounts;

    #[test]
    fn a_part_round_trips_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("part.exr");
        let replicas = Replicas::new(3).unwrap();
        let mut film = Film::new(5, 3, 0.37, true, replicas);
        for (i, s) in film.sum.iter_mut().enumerate() {
            *s = DVec3::new(i as f64 * 0.1 + 1e-17, -(i as f64).sqrt() / 3.0, f64::MIN_POSITIVE);
        }
        for (i, q) in film.replica_sums.iter_mut().enumerate() {
            *q = DVec3::new(f64::NAN, f64::INFINITY, 1.0 / (i as f64 + 7.0));
        }
        film.first = 16;
        film.advance(8);
        film.rays = RayCounts { primary: 120, reflected: 3, refracted: 4, shadow: 5 };
        film.non_finite = 2;
        film.seconds = 1.234_567_890_123;
        let identity =
            Identity::parse("version=0.1.0; seed=7; sampler=sobol; replicas=3; wavelengths=yes").unwrap();
        let (samples, target, scene_file) = (SampleSet::of(16..24), 16..32, "/s/ü.toml".to_string());
        let info = PartInfo { identity, samples, target, planned: 64, time_budget: Some(2.5), scene_file };
        let part = Part { film, info };
        let meta =
            ExrMetadata { spp: 8, rays: part.film.rays, render_time_seconds: 1.5, ..Default::default() };
        stage_part(&path, &part.film, &part.info, &meta, &[], &[]).unwrap().commit().unwrap();

        let back = read_part(&path).unwrap().part;
        let bits = |v: &[DVec3]| v.iter().flat_map(|d| d.to_array().map(f64::to_bits)).collect::<Vec<u64>>();
        assert_eq!(bits(&back.film.sum), bits(&part.film.sum));
        assert_eq!(bits(&back.film.replica_sums), bits(&part.film.replica_sums));
        // Samples 16..24 of 3 replicas: 16, 19, 22 in replica 1; 17, 20, 23 in 2; 18, 21 in 0.
        assert_eq!(back.film.replica_samples, [2, 3, 3]);
        assert_eq!(back.film.replica_samples, part.film.replica_samples);
        assert_eq!((back.film.first, back.film.samples, back.film.norm), (16, 8, 0.37));
        assert_eq!((back.film.rays, back.film.non_finite, back.film.spectral), (part.film.rays, 2, true));
        assert_eq!(back.info, part.info);
        assert_eq!(back.film.seconds, 1.234_567_890_123, "render seconds exactly");
        // The beauty layer is the image, as in any render.
        let (image, _) = read_exr(&path).unwrap();
        assert_eq!(image.pixels, part.film.image().pixels);
    }

    #[test]
    fn a_plain_render_is_not_a_part() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plain.exr");
        super::super::exr::write_exr(&path, &crate::image::Image::new(2, 2), &ExrMetadata::default())
            .unwrap();
        let err = read_part(&path).err().unwrap().to_string();
        assert!(err.contains("not a render part") && err.contains("--shard"), "{err}");
        assert!(read_render(&path).unwrap().part.is_none(), "a plain render reads as one");
    }

    #[test]
    fn a_film_layer_without_its_attributes_is_an_error_not_a_plain_render() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("odd.exr");
        let film = Film::new(2, 2, 1.0, false, Replicas::DEFAULT);
        let image = film.image();
        super::super::exr::stage_exr_with_layer(
            &path,
            &image,
            &ExrMetadata::default(),
            &[],
            &[],
            film_layer(&film),
        )
        .unwrap()
        .commit()
        .unwrap();
        let err = read_render(&path).err().expect("refused").to_string();
        assert!(err.contains("no vitrum:samples attribute"), "{err}");
    }
}
