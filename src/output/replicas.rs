//! A render's replicas in its EXR file, so that any vitrum render can be judged later (`vitrum
//! diff`, `compare --renders`) with the variance and the standard errors its replicas give
//! ([`crate::render::ReplicaMeans`]).
//!
//! - Channels `replica.K.R`, `replica.K.G`, `replica.K.B` (float32) of the beauty layer: the
//!   mean of replica `K`, for each replica that holds samples (K counts those from 0).
//! - The attribute `vitrum:replica-samples`: the samples each of those replicas holds, as
//!   `n0,n1,…`.
//! - Beside them, as before, `variance.R`, `variance.G`, `variance.B` (the variance of each
//!   pixel's mean, from the replicas) and `samples` (the samples behind each pixel), which
//!   viewers and other tools can read without knowing about replicas.
//!
//! The replicas cost 12·R bytes per pixel uncompressed (96 at the default R = 8), eight times
//! the beauty's 12.

use super::exr::{variance_channels, ExtraChannel};
use super::OutputError;
use crate::image::Image;
use crate::render::{RenderOutput, ReplicaMeans};
use glam::Vec3;
use std::collections::BTreeMap;
use std::path::Path;

/// The attribute with the samples each stored replica holds.
pub const REPLICA_SAMPLES: &str = "vitrum:replica-samples";

/// The name of replica `k`'s channel `axis` (`R`, `G` or `B`).
fn channel_name(k: usize, axis: &str) -> String {
    format!("replica.{k}.{axis}")
}

/// The channels and attributes that keep `out`'s variance and replicas in its EXR file (none
/// for a render without replicas).
pub fn render_channels(out: &RenderOutput) -> (Vec<ExtraChannel>, Vec<(String, String)>) {
    let (Some(variance), Some(replicas)) = (&out.variance, &out.replicas) else {
        return (Vec::new(), Vec::new());
    };
    let counts = out.samples_per_pixel.clone().unwrap_or_else(|| vec![out.spp as f32; variance.pixels.len()]);
    let mut channels = variance_channels(variance, &counts);
    for (k, mean) in replicas.means.iter().enumerate() {
        for (axis, pick) in [("R", 0usize), ("G", 1), ("B", 2)] {
            let values = mean.pixels.iter().map(|p| p.to_array()[pick]).collect();
            channels.push(ExtraChannel { name: channel_name(k, axis), values });
        }
    }
    let samples = replicas.samples.iter().map(u32::to_string).collect::<Vec<_>>().join(",");
    (channels, vec![(REPLICA_SAMPLES.to_string(), samples)])
}

/// The replicas kept in a file's `channels` and `attributes` (of an image `width × height`,
/// read from `path`): `None` when it keeps none, an error when they are malformed.
pub fn decode_replicas(
    path: &Path,
    (width, height): (usize, usize),
    channels: &BTreeMap<String, Vec<f32>>,
    attributes: &BTreeMap<String, String>,
) -> Result<Option<ReplicaMeans>, OutputError> {
    let Some(text) = attributes.get(REPLICA_SAMPLES) else {
        return Ok(None);
    };
    let bad = |what: String| OutputError::format(path, format!("attribute {REPLICA_SAMPLES}: {what}"));
    let samples: Vec<u32> = text
        .split(',')
        .map(|n| n.trim().parse().map_err(|_| bad(format!("{n:?} is not a sample count"))))
        .collect::<Result<_, _>>()?;
    if samples.len() < 2 || samples.contains(&0) {
        return Err(bad(format!("{text:?}: needs two or more replicas that hold samples")));
    }
    let mut means = Vec::with_capacity(samples.len());
    for k in 0..samples.len() {
        let channel = |axis: &str| {
            channels.get(&channel_name(k, axis)).filter(|v| v.len() == width * height).ok_or_else(|| {
                OutputError::format(
                    path,
                    format!("no full-size channel {} for {text:?}", channel_name(k, axis)),
                )
            })
        };
        let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
        let pixels = (0..width * height).map(|p| Vec3::new(r[p], g[p], b[p])).collect();
        means.push(Image { width, height, pixels });
    }
    Ok(Some(ReplicaMeans { means, samples }))
}
