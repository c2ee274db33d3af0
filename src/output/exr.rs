//! OpenEXR output: float32 linear RGB in one scanline layer, with the render's metadata in the header;
//! and input, each file's declared size checked against the image size limit before decoding.

use super::{check_pixel_count, stage_bytes, OutputError, Staged};
use crate::image::limits::check_image_size;
use crate::image::Image;
use crate::stats::RayCounts;
use exr::image::{Encoding, Layer, SpecificChannels};
use exr::math::Vec2;
use exr::meta::attribute::{AttributeValue, ChannelList, Text};
use exr::meta::header::LayerAttributes;
use exr::meta::MetaData;
// The reader/writer builder traits and `read()`.
use exr::prelude::traits::*;
use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::Path;

/// Render metadata stored in the EXR header.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExrMetadata {
    /// The renderer version (`vitrum:version`; the software name is "vitrum {version}").
    pub version: String,
    /// The integrator name (`vitrum:integrator`).
    pub integrator: String,
    /// Samples per pixel (`vitrum:spp`, an int attribute).
    pub spp: u32,
    /// The random seed (`vitrum:seed`, decimal text because an EXR int cannot hold a u64).
    pub seed: u64,
    /// Wall-clock render time (`renderTimeSeconds`, a float attribute).
    pub render_time_seconds: f64,
    /// Rays traced (`vitrum:rays`, text like "primary=640000 reflected=1234 refracted=2345 shadow=99999").
    pub rays: RayCounts,
    /// The scene as "path (content hash)" (`vitrum:scene`).
    pub scene: String,
    /// The effects the scene calls for (`vitrum:effects`).
    pub effects: String,
}

/// The name of the (single) layer the beauty image is written to.
const BEAUTY_LAYER: &str = "beauty";

/// An EXR text attribute holding the UTF-8 bytes of `s` (`Text::from` would panic beyond Latin-1).
fn text(s: &str) -> Text {
    Text::from_slice_unchecked(s.as_bytes())
}

/// A text attribute value.
fn text_value(s: &str) -> AttributeValue {
    AttributeValue::Text(text(s))
}

/// The `vitrum:rays` text for `rays`.
fn rays_text(rays: &RayCounts) -> String {
    format!(
        "primary={} reflected={} refracted={} shadow={}",
        rays.primary, rays.reflected, rays.refracted, rays.shadow
    )
}

/// The ray counts of a `vitrum:rays` text (what [`rays_text`] writes).
pub fn parse_rays(text: &str) -> Option<RayCounts> {
    let mut rays = RayCounts::default();
    for item in text.split_whitespace() {
        let (k, v) = item.split_once('=')?;
        let v: u64 = v.parse().ok()?;
        match k {
            "primary" => rays.primary = v,
            "reflected" => rays.reflected = v,
            "refracted" => rays.refracted = v,
            "shadow" => rays.shadow = v,
            _ => return None,
        }
    }
    Some(rays)
}

/// The custom header attributes for `meta` (see docs/architecture.md, "Contracts").
fn metadata_attributes(
    path: &Path,
    meta: &ExrMetadata,
) -> Result<Vec<(&'static str, AttributeValue)>, OutputError> {
    let spp = i32::try_from(meta.spp).map_err(|_| {
        OutputError::format(path, format!("spp {} does not fit the EXR int attribute", meta.spp))
    })?;
    Ok(vec![
        ("vitrum:version", text_value(&meta.version)),
        ("vitrum:integrator", text_value(&meta.integrator)),
        ("vitrum:spp", AttributeValue::I32(spp)),
        ("vitrum:seed", text_value(&meta.seed.to_string())),
        ("renderTimeSeconds", AttributeValue::F32(meta.render_time_seconds as f32)),
        ("vitrum:rays", text_value(&rays_text(&meta.rays))),
        ("vitrum:scene", text_value(&meta.scene)),
        ("vitrum:effects", text_value(&meta.effects)),
    ])
}

/// Map an EXR library error about `path`: I/O errors keep their kind, the rest become [`OutputError::Exr`].
fn exr_error(path: &Path, error: exr::error::Error) -> OutputError {
    match error {
        exr::error::Error::Io(source) => OutputError::io(path, source),
        other => OutputError::Exr { path: path.to_path_buf(), message: other.to_string() },
    }
}

/// Write `image` as float32 RGB with ZIP-compressed scanlines (`SMALL_LOSSLESS`) in one layer, atomically.
pub fn write_exr(path: &Path, image: &Image, meta: &ExrMetadata) -> Result<(), OutputError> {
    stage_exr(path, image, meta)?.commit()
}

/// Encode the EXR into a temporary file beside `path`, to be published with [`Staged::commit`].
pub fn stage_exr(path: &Path, image: &Image, meta: &ExrMetadata) -> Result<Staged, OutputError> {
    stage_rgb_exr(path, image, meta, &[])
}

/// The beauty layer's attributes: the render metadata and the `notes` (text attributes).
fn layer_attributes(
    path: &Path,
    meta: &ExrMetadata,
    notes: &[(String, String)],
) -> Result<LayerAttributes, OutputError> {
    let mut attributes = LayerAttributes::named(BEAUTY_LAYER);
    attributes.software_name = Some(text(&format!("vitrum {}", meta.version)));
    for (name, value) in metadata_attributes(path, meta)? {
        attributes.other.insert(text(name), value);
    }
    for (name, value) in notes {
        if attributes.other.contains_key(&text(name)) || name.is_empty() {
            return Err(OutputError::format(path, format!("attribute `{name}` is given twice or empty")));
        }
        attributes.other.insert(text(name), text_value(value));
    }
    Ok(attributes)
}

/// [`stage_exr`] with the text attributes `notes`.
fn stage_rgb_exr(
    path: &Path,
    image: &Image,
    meta: &ExrMetadata,
    notes: &[(String, String)],
) -> Result<Staged, OutputError> {
    check_pixel_count(path, image)?;
    let attributes = layer_attributes(path, meta, notes)?;
    let width = image.width;
    let pixels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = image.pixels[p.y() * width + p.x()];
        (c.x, c.y, c.z)
    });
    let layer = Layer::new((image.width, image.height), attributes, Encoding::SMALL_LOSSLESS, pixels);
    let file = exr::image::Image::from_layer(layer);
    encode_and_stage(path, |bytes| file.write().to_buffered(bytes))
}

/// `image` as the bytes of a plain float32 RGB EXR file (ZIP-compressed scanlines, one unnamed
/// layer, no render metadata): textures and environment maps written for other renderers.
pub fn encode_exr_rgb(path: &Path, image: &Image) -> Result<Vec<u8>, OutputError> {
    check_pixel_count(path, image)?;
    let width = image.width;
    let pixels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = image.pixels[p.y() * width + p.x()];
        (c.x, c.y, c.z)
    });
    let layer =
        Layer::new((image.width, image.height), LayerAttributes::default(), Encoding::SMALL_LOSSLESS, pixels);
    let mut bytes = Cursor::new(Vec::new());
    exr::image::Image::from_layer(layer).write().to_buffered(&mut bytes).map_err(|e| exr_error(path, e))?;
    let mut bytes = bytes.into_inner();
    sort_header_attributes(&mut bytes);
    Ok(bytes)
}

/// Encode an EXR file in memory with `encode`, then stage its bytes (see [`stage_bytes`]).
fn encode_and_stage(
    path: &Path,
    encode: impl FnOnce(&mut Cursor<Vec<u8>>) -> Result<(), exr::error::Error>,
) -> Result<Staged, OutputError> {
    let mut bytes = Cursor::new(Vec::new());
    // Errors name the final path: the temporary name means nothing to the user.
    encode(&mut bytes).map_err(|e| exr_error(path, e))?;
    let mut bytes = bytes.into_inner();
    sort_header_attributes(&mut bytes);
    stage_bytes(path, &bytes)
}

/// Puts the attributes of every header of the EXR file `bytes` in the order of their names, so
/// that the same image and metadata give the same bytes: the `exr` crate writes custom attributes
/// in the order of a `HashMap`, which changes from process to process. A header keeps its
/// length, so the offset table after it stays valid. Bytes that are not a well-formed header are
/// left as they are.
fn sort_header_attributes(bytes: &mut [u8]) {
    const MULTIPART: u32 = 0x1000;
    let Some(version) = bytes.get(4..8) else { return };
    let multipart = u32::from_le_bytes(version.try_into().expect("4 bytes")) & MULTIPART != 0;
    let mut at = 8;
    loop {
        let Some(end) = sort_one_header(bytes, at) else { return };
        at = end + 1;
        if !multipart || bytes.get(at).is_none_or(|&b| b == 0) {
            return;
        }
    }
}

/// Sorts the attributes of the header that starts at `start`; returns the position of its
/// terminating null byte, or `None` (and changes nothing) when the bytes are not a header.
fn sort_one_header(bytes: &mut [u8], start: usize) -> Option<usize> {
    let null_after = |from: usize| bytes.get(from..)?.iter().position(|&b| b == 0).map(|k| from + k);
    let mut records: Vec<(usize, usize, usize)> = Vec::new(); // (start, name end, end)
    let mut at = start;
    loop {
        let name_end = null_after(at)?;
        if name_end == at {
            break;
        }
        let type_end = null_after(name_end + 1)?;
        let size = i32::from_le_bytes(bytes.get(type_end + 1..type_end + 5)?.try_into().ok()?);
        let end = (type_end + 5).checked_add(usize::try_from(size).ok()?)?;
        if end > bytes.len() {
            return None;
        }
        records.push((at, name_end, end));
        at = end;
    }
    let mut sorted = records.clone();
    sorted.sort_by(|a, b| bytes[a.0..a.1].cmp(&bytes[b.0..b.1]));
    let header: Vec<u8> = sorted.iter().flat_map(|&(from, _, to)| bytes[from..to].to_vec()).collect();
    bytes[start..at].copy_from_slice(&header);
    Some(at)
}

/// An extra float32 channel of an EXR file, one value per pixel in row-major order.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraChannel {
    /// Channel name, e.g. `variance.R` (a `layer.` prefix groups channels in viewers).
    pub name: String,
    /// `width * height` values.
    pub values: Vec<f32>,
}

/// The channels of a render's per-pixel variance: `variance.R`, `variance.G`, `variance.B` (the
/// variance of each pixel's estimate, its squared standard error) and `samples` (the samples
/// behind it).
pub fn variance_channels(variance: &Image, samples: &[f32]) -> Vec<ExtraChannel> {
    let channel = |name: &str, f: fn(glam::Vec3) -> f32| ExtraChannel {
        name: name.to_string(),
        values: variance.pixels.iter().map(|&v| f(v)).collect(),
    };
    vec![
        channel("variance.R", |v| v.x),
        channel("variance.G", |v| v.y),
        channel("variance.B", |v| v.z),
        ExtraChannel { name: "samples".into(), values: samples.to_vec() },
    ]
}

/// The per-pixel variance kept in an EXR's [`variance_channels`], `None` when the file has no
/// `variance.R`, `variance.G` and `variance.B` channels.
pub fn read_variance(path: &Path) -> Result<Option<Image>, OutputError> {
    let exr = read_exr_channels(path)?;
    let [Some(r), Some(g), Some(b)] = ["variance.R", "variance.G", "variance.B"].map(|c| exr.channels.get(c))
    else {
        return Ok(None);
    };
    let pixels = r.iter().zip(g).zip(b).map(|((&r, &g), &b)| glam::Vec3::new(r, g, b)).collect();
    Ok(Some(Image { width: exr.width, height: exr.height, pixels }))
}

/// Like [`stage_exr`], with `extra` float32 channels beside R, G, B in the beauty layer.
pub fn stage_exr_with_channels(
    path: &Path,
    image: &Image,
    meta: &ExrMetadata,
    extra: &[ExtraChannel],
) -> Result<Staged, OutputError> {
    stage_exr_with_notes(path, image, meta, extra, &[])
}

/// Like [`stage_exr_with_channels`], with the extra text attributes `notes` (name, value) in the
/// header, such as `vitrum:interrupted`; a name may not repeat one of the render metadata.
pub fn stage_exr_with_notes(
    path: &Path,
    image: &Image,
    meta: &ExrMetadata,
    extra: &[ExtraChannel],
    notes: &[(String, String)],
) -> Result<Staged, OutputError> {
    if extra.is_empty() {
        return stage_rgb_exr(path, image, meta, notes);
    }
    stage_layers(path, image, meta, extra, notes, None)
}

/// A second layer of 32-bit unsigned integer channels (the film state of a render part, see
/// [`crate::output::film`]), one value per pixel each in row-major order.
#[derive(Clone, Debug, PartialEq)]
pub struct U32Layer {
    /// Layer name.
    pub name: String,
    /// Channels (name, `width * height` values).
    pub channels: Vec<(String, Vec<u32>)>,
}

/// Like [`stage_exr_with_notes`], with the layer `second` after the beauty layer (its values
/// move into the encoder: a large film is not copied).
pub fn stage_exr_with_layer(
    path: &Path,
    image: &Image,
    meta: &ExrMetadata,
    extra: &[ExtraChannel],
    notes: &[(String, String)],
    second: U32Layer,
) -> Result<Staged, OutputError> {
    stage_layers(path, image, meta, extra, notes, Some(second))
}

/// The beauty layer (R, G, B and the `extra` channels, float32) and an optional second layer.
fn stage_layers(
    path: &Path,
    image: &Image,
    meta: &ExrMetadata,
    extra: &[ExtraChannel],
    notes: &[(String, String)],
    second: Option<U32Layer>,
) -> Result<Staged, OutputError> {
    use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, SmallVec};
    check_pixel_count(path, image)?;
    for c in extra {
        if c.values.len() != image.pixels.len() {
            return Err(OutputError::format(
                path,
                format!("channel {} has {} values for {} pixels", c.name, c.values.len(), image.pixels.len()),
            ));
        }
        if ["R", "G", "B"].contains(&c.name.as_str()) || extra.iter().filter(|o| o.name == c.name).count() > 1
        {
            return Err(OutputError::format(path, format!("channel {} is given twice", c.name)));
        }
    }
    let attributes = layer_attributes(path, meta, notes)?;
    let rgb = |f: fn(&glam::Vec3) -> f32| image.pixels.iter().map(f).collect::<Vec<f32>>();
    let mut list = vec![
        AnyChannel::new("R", FlatSamples::F32(rgb(|p| p.x))),
        AnyChannel::new("G", FlatSamples::F32(rgb(|p| p.y))),
        AnyChannel::new("B", FlatSamples::F32(rgb(|p| p.z))),
    ];
    for c in extra {
        list.push(AnyChannel::new(text(&c.name), FlatSamples::F32(c.values.clone())));
    }
    let size = (image.width, image.height);
    let beauty =
        Layer::new(size, attributes, Encoding::SMALL_LOSSLESS, AnyChannels::sort(SmallVec::from_vec(list)));
    let Some(second) = second else {
        let file = exr::image::Image::from_layer(beauty);
        return encode_and_stage(path, |bytes| file.write().to_buffered(bytes));
    };
    if second.channels.iter().any(|(_, v)| v.len() != image.pixels.len()) {
        return Err(OutputError::format(
            path,
            format!("layer {} does not match the image size", second.name),
        ));
    }
    let list = second
        .channels
        .into_iter()
        .map(|(name, values)| AnyChannel::new(text(&name), FlatSamples::U32(values)))
        .collect();
    let layer = Layer::new(
        size,
        LayerAttributes::named(text(&second.name)),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(list)),
    );
    let file = exr::image::Image::from_layers(
        exr::meta::header::ImageAttributes::with_size(size),
        vec![beauty, layer],
    );
    encode_and_stage(path, |bytes| file.write().to_buffered(bytes))
}

/// An EXR image of every layer and channel, full resolution, any sample type.
type FlatImage = exr::image::Image<exr::image::Layers<exr::image::AnyChannels<exr::image::FlatSamples>>>;

/// Refuses the EXR file contents `bytes` read from `path` when a layer's data window holds more
/// than [`MAX_IMAGE_PIXELS`](crate::image::limits::MAX_IMAGE_PIXELS): read from the headers
/// alone, before any pixel is allocated.
fn check_declared_size(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let meta = MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| exr_error(path, e))?;
    for size in meta.headers.iter().map(|h| h.layer_size) {
        check_image_size(size.width() as u64, size.height() as u64)
            .map_err(|e| OutputError::format(path, e.to_string()))?;
    }
    Ok(())
}

/// Every layer and channel (any sample type) of the EXR file `bytes` read from `path`.
fn decode_all_layers(path: &Path, bytes: &[u8]) -> Result<FlatImage, OutputError> {
    check_declared_size(path, bytes)?;
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| exr_error(path, e))
}

/// One layer of a [`FlatImage`].
type FlatLayer = exr::image::Layer<exr::image::AnyChannels<exr::image::FlatSamples>>;

/// The values of decoded `samples` as f32: moved when they are f32 already, never copied.
fn into_f32(samples: exr::prelude::FlatSamples) -> Vec<f32> {
    match samples {
        exr::prelude::FlatSamples::F32(values) => values,
        other => other.values_as_f32().collect(),
    }
}

/// The decoded `layer` called `name` with its channels moved out; an error unless all its
/// channels are 32-bit unsigned integers of the layer's full size.
fn into_u32_layer(path: &Path, layer: FlatLayer, name: &str) -> Result<U32Layer, OutputError> {
    use exr::prelude::FlatSamples;
    let pixels = layer.size.area();
    let mut channels = Vec::new();
    for c in layer.channel_data.list {
        let channel = utf8(c.name.as_slice());
        let FlatSamples::U32(values) = c.sample_data else {
            let what = format!("channel {channel} of layer {name} is not a 32-bit unsigned integer");
            return Err(OutputError::format(path, what));
        };
        if values.len() != pixels {
            return Err(OutputError::format(path, format!("layer {name} is subsampled")));
        }
        channels.push((channel, values));
    }
    Ok(U32Layer { name: name.to_string(), channels })
}

/// Every channel of an EXR file's first layer.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrChannels {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The values of each channel as f32, row-major, by channel name.
    pub channels: BTreeMap<String, Vec<f32>>,
}

/// Every channel of the first layer as f32 values, by name, with the layer's width and height.
pub fn read_exr_channels(path: &Path) -> Result<ExrChannels, OutputError> {
    let bytes = std::fs::read(path).map_err(|e| OutputError::io(path, e))?;
    check_declared_size(path, &bytes)?;
    let file = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(&bytes))
        .map_err(|e| exr_error(path, e))?;
    let layer = file.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channels = layer
        .channel_data
        .list
        .into_iter()
        .map(|c| (utf8(c.name.as_slice()), into_f32(c.sample_data)))
        .collect();
    Ok(ExrChannels { width, height, channels })
}

/// Read the first layer's R, G, B channels as f32 plus all header attributes (image- and layer-level) as strings.
pub fn read_exr(path: &Path) -> Result<(Image, BTreeMap<String, String>), OutputError> {
    // Read once and decode twice (pixels, then the raw headers), so both come from the same file version.
    let bytes = std::fs::read(path).map_err(|e| OutputError::io(path, e))?;
    let file = decode_all_layers(path, &bytes)?;
    decode_rgb(path, &bytes, &file)
}

/// What [`read_exr_with_layer`] reads of a file.
pub struct ExrRead {
    /// The first layer's R, G, B.
    pub image: Image,
    /// Every header attribute of the first layer, as text.
    pub attributes: BTreeMap<String, String>,
    /// The first layer's other full-size channels, as f32, by name.
    pub channels: BTreeMap<String, Vec<f32>>,
    /// The layer asked for, when the file has one.
    pub layer: Option<U32Layer>,
}

/// [`read_exr`], the first layer's other channels and the first of the later layers called
/// `layer` ([`U32Layer`]: all its channels 32-bit unsigned integers of full size), when the file
/// has one, from one read of the file: all come from the same version of a file that is being
/// replaced (a live checkpoint). The decoded channels move into the result, never copied.
pub fn read_exr_with_layer(path: &Path, layer: &str) -> Result<ExrRead, OutputError> {
    let bytes = std::fs::read(path).map_err(|e| OutputError::io(path, e))?;
    let file = decode_all_layers(path, &bytes)?;
    let (image, attributes) = decode_rgb(path, &bytes, &file)?;
    let mut layers = file.layer_data.into_iter();
    let first = layers.next().map_or_else(Vec::new, |l| l.channel_data.list.into_vec());
    let channels = first
        .into_iter()
        .filter(|c| {
            !["R", "G", "B"].iter().any(|n| c.name.eq(n)) && c.sample_data.len() == image.pixels.len()
        })
        .map(|c| (utf8(c.name.as_slice()), into_f32(c.sample_data)))
        .collect();
    let named = layers.find(|l| l.attributes.layer_name.as_ref().is_some_and(|n| n.eq(layer)));
    let layer = named.map(|l| into_u32_layer(path, l, layer)).transpose()?;
    Ok(ExrRead { image, attributes, channels, layer })
}

/// The first layer's R, G, B channels of EXR file contents `bytes` read from `path` (named in
/// errors): image textures and environment maps.
pub fn decode_exr_rgb(path: &Path, bytes: &[u8]) -> Result<Image, OutputError> {
    let file = decode_all_layers(path, bytes)?;
    Ok(decode_rgb(path, bytes, &file)?.0)
}

/// The first layer's R, G, B channels of the decoded `file` and the header attributes of its
/// `bytes`.
fn decode_rgb(
    path: &Path,
    bytes: &[u8],
    file: &FlatImage,
) -> Result<(Image, BTreeMap<String, String>), OutputError> {
    let meta = MetaData::read_from_buffered(Cursor::new(&bytes), false).map_err(|e| exr_error(path, e))?;
    let (Some(layer), Some(header)) = (file.layer_data.first(), meta.headers.first()) else {
        return Err(OutputError::format(path, "the EXR file has no layers"));
    };

    let channels = &layer.channel_data.list;
    let channel = |name: &str| {
        channels.iter().find(|c| c.name.eq(name)).ok_or_else(|| {
            let found: Vec<String> = channels.iter().map(|c| utf8(c.name.as_slice())).collect();
            OutputError::format(
                path,
                format!(
                    "not an RGB EXR: the first layer has no {name} channel (it has: {})",
                    found.join(", ")
                ),
            )
        })
    };
    let rgb = [channel("R")?, channel("G")?, channel("B")?];
    let mut image = Image::new(layer.size.width(), layer.size.height());
    if rgb.iter().any(|c| c.sample_data.len() != image.pixels.len()) {
        return Err(OutputError::format(path, "subsampled R, G, B channels are not supported"));
    }
    let [r, g, b] = rgb.map(|c| c.sample_data.values_as_f32());
    for (pixel, ((r, g), b)) in image.pixels.iter_mut().zip(r.zip(g).zip(b)) {
        *pixel = glam::Vec3::new(r, g, b);
    }

    let attributes =
        header.all_named_attributes().map(|(name, value)| (utf8(name), attribute_string(&value))).collect();
    Ok((image, attributes))
}

/// EXR text bytes as a string (we write UTF-8; anything else is decoded lossily).
fn utf8(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A header attribute value as a string: text as-is, numbers in decimal, vectors as "(x, y)",
/// windows as "(min)-(max)", the rest in debug form.
fn attribute_string(value: &AttributeValue) -> String {
    match value {
        AttributeValue::Text(t) => utf8(t.as_slice()),
        AttributeValue::TextVector(ts) => {
            ts.iter().map(|t| utf8(t.as_slice())).collect::<Vec<_>>().join(", ")
        }
        AttributeValue::I32(v) => v.to_string(),
        AttributeValue::F32(v) => v.to_string(),
        AttributeValue::F64(v) => v.to_string(),
        AttributeValue::ChannelList(ChannelList { list, .. }) => list
            .iter()
            .map(|c| format!("{}:{:?}", utf8(c.name.as_slice()), c.sample_type))
            .collect::<Vec<_>>()
            .join(", "),
        AttributeValue::Compression(c) => format!("{c:?}"),
        AttributeValue::LineOrder(l) => format!("{l:?}"),
        AttributeValue::BlockType(b) => format!("{b:?}"),
        // The OpenEXR convention: inclusive min and max corners.
        AttributeValue::IntegerBounds(b) => {
            let (min, max) = (b.position, b.max());
            format!("({}, {})-({}, {})", min.x(), min.y(), max.x(), max.y())
        }
        AttributeValue::IntVec2(v) => format!("({}, {})", v.x(), v.y()),
        AttributeValue::FloatVec2(v) => format!("({}, {})", v.x(), v.y()),
        other => format!("{other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::tests::dir_entries;
    use glam::Vec3;

    /// A 7x5 image with distinct values in every channel, negative zero, NaN and infinities.
    fn test_image() -> Image {
        let mut image = Image::new(7, 5);
        for (i, p) in image.pixels.iter_mut().enumerate() {
            let i = i as f32;
            *p = Vec3::new(i * 0.37, 1.0 / (i + 1.0), 1000.0 + i * 1e-3);
        }
        image.pixels[3] = Vec3::new(f32::NAN, 0.5, -0.0);
        image.pixels[12] = Vec3::new(f32::INFINITY, f32::NEG_INFINITY, 2.0);
        image.pixels[34] = Vec3::new(1e-40, f32::MAX, -3.5); // a denormal and the largest float
        image
    }

    fn test_metadata() -> ExrMetadata {
        ExrMetadata {
            version: "0.1.0".into(),
            integrator: "path".into(),
            spp: 64,
            seed: u64::MAX - 6, // beyond i32 and f64 precision
            render_time_seconds: 12.5,
            rays: RayCounts { primary: 640_000, reflected: 1234, refracted: 2345, shadow: 99_999 },
            scene: "scenes/cornell ü.toml (blake3:0123abcd)".into(),
            effects: "dispersion, soft shadows".into(),
        }
    }

    fn bits(image: &Image) -> Vec<[u32; 3]> {
        image.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    }

    /// The attribute names of the (single-part) header of the EXR file `bytes`, in file order.
    fn attribute_names(bytes: &[u8]) -> Vec<String> {
        let mut names = Vec::new();
        let mut at = 8;
        while bytes[at] != 0 {
            let name_end = at + bytes[at..].iter().position(|&b| b == 0).unwrap();
            let type_end = name_end + 1 + bytes[name_end + 1..].iter().position(|&b| b == 0).unwrap();
            let size = i32::from_le_bytes(bytes[type_end + 1..type_end + 5].try_into().unwrap()) as usize;
            names.push(String::from_utf8(bytes[at..name_end].to_vec()).unwrap());
            at = type_end + 5 + size;
        }
        names
    }

    #[test]
    fn the_same_render_gives_the_same_bytes_with_sorted_attributes() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
        // Each write builds its own attribute map, whose order is random.
        let mut files = Vec::new();
        for _ in 0..4 {
            write_exr(&a, &test_image(), &test_metadata()).unwrap();
            files.push(std::fs::read(&a).unwrap());
        }
        assert!(files.windows(2).all(|w| w[0] == w[1]), "the bytes changed between writes");
        let names = attribute_names(&files[0]);
        assert!(names.len() > 10 && names.contains(&"vitrum:integrator".to_string()), "{names:?}");
        assert!(names.windows(2).all(|w| w[0] < w[1]), "not in name order: {names:?}");
        // The sorted file reads back whole.
        std::fs::write(&b, &files[0]).unwrap();
        let (image, attributes) = read_exr(&b).unwrap();
        assert_eq!(bits(&image), bits(&test_image()));
        assert_eq!(attributes.get("vitrum:spp").map(String::as_str), Some("64"));
        // Bytes that are not a header are left alone.
        let mut junk = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, b'x', 0];
        sort_header_attributes(&mut junk);
        assert_eq!(junk, [0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0, b'x', 0]);
    }

    #[test]
    fn round_trip_is_bit_exact_with_metadata() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("render.exr");
        let image = test_image();
        write_exr(&path, &image, &test_metadata()).unwrap();
        assert_eq!(dir_entries(dir.path()), ["render.exr"]);
        assert_eq!(&std::fs::read(&path).unwrap()[..4], &[0x76, 0x2f, 0x31, 0x01], "EXR magic number");

        let (back, attrs) = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (7, 5));
        assert_eq!(bits(&back), bits(&image));
        assert_eq!(back.non_finite_count(), 2);

        let expected = [
            ("vitrum:version", "0.1.0"),
            ("vitrum:integrator", "path"),
            ("vitrum:spp", "64"),
            ("vitrum:seed", "18446744073709551609"),
            ("renderTimeSeconds", "12.5"),
            ("vitrum:rays", "primary=640000 reflected=1234 refracted=2345 shadow=99999"),
            ("vitrum:scene", "scenes/cornell ü.toml (blake3:0123abcd)"),
            ("vitrum:effects", "dispersion, soft shadows"),
            ("software", "vitrum 0.1.0"),
            ("name", "beauty"),
            ("channels", "B:F32, G:F32, R:F32"),
            ("compression", "ZIP16"),
            ("lineOrder", "Increasing"),
            ("dataWindow", "(0, 0)-(6, 4)"),
            ("displayWindow", "(0, 0)-(6, 4)"),
            ("screenWindowCenter", "(0, 0)"),
        ];
        for (name, value) in expected {
            assert_eq!(attrs.get(name).map(String::as_str), Some(value), "attribute {name} in {attrs:?}");
        }
    }

    #[test]
    fn file_is_a_single_part_scanline_zip_rgb_exr() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("render.exr");
        write_exr(&path, &test_image(), &ExrMetadata::default()).unwrap();
        let meta = MetaData::read_from_file(&path, true).unwrap();
        assert_eq!(meta.headers.len(), 1);
        let header = &meta.headers[0];
        assert_eq!(header.compression, exr::meta::attribute::Compression::ZIP16);
        assert_eq!(header.blocks, exr::meta::BlockDescription::ScanLines);
        assert_eq!(header.channels.uniform_sample_type, Some(exr::meta::attribute::SampleType::F32));
        assert_eq!(header.channels.list.len(), 3);
    }

    #[test]
    fn write_replaces_an_existing_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("render.exr");
        std::fs::write(&path, "old").unwrap();
        write_exr(&path, &test_image(), &ExrMetadata::default()).unwrap();
        assert_eq!(bits(&read_exr(&path).unwrap().0), bits(&test_image()));
        assert_eq!(dir_entries(dir.path()), ["render.exr"]);
    }

    #[test]
    fn failed_write_leaves_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("render.exr");
        let meta = ExrMetadata { spp: u32::MAX, ..ExrMetadata::default() };
        let err = write_exr(&path, &test_image(), &meta).unwrap_err();
        assert!(err.to_string().contains("render.exr"), "{err}");
        let mut short = test_image();
        short.pixels.pop();
        assert!(write_exr(&path, &short, &ExrMetadata::default()).is_err());
        assert!(dir_entries(dir.path()).is_empty());
    }

    #[test]
    fn missing_file_is_an_io_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing.exr");
        let err = read_exr(&path).unwrap_err();
        assert!(
            matches!(&err, OutputError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound)
        );
        assert!(err.to_string().contains("missing.exr"), "{err}");
    }

    #[test]
    fn non_exr_files_are_errors_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let text = dir.path().join("notes.exr");
        std::fs::write(&text, "this is not an EXR file\n").unwrap();
        let empty = dir.path().join("empty.exr");
        std::fs::write(&empty, "").unwrap();
        let truncated = dir.path().join("truncated.exr");
        write_exr(&truncated, &test_image(), &test_metadata()).unwrap();
        let bytes = std::fs::read(&truncated).unwrap();
        std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();

        for path in [text, empty, truncated] {
            let err = read_exr(&path).unwrap_err();
            let name = path.file_name().unwrap().to_str().unwrap();
            assert!(err.to_string().contains(name), "{err}");
        }
    }

    #[test]
    fn variance_channels_round_trip_beside_rgb() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("variance.exr");
        let image = test_image();
        let mut variance = Image::new(7, 5);
        for (i, v) in variance.pixels.iter_mut().enumerate() {
            *v = Vec3::new(i as f32, 2.0 * i as f32, 0.5);
        }
        let extra = variance_channels(&variance, &[16.0; 35]);
        stage_exr_with_channels(&path, &image, &test_metadata(), &extra).unwrap().commit().unwrap();
        let (back, attrs) = read_exr(&path).unwrap();
        assert_eq!(bits(&back), bits(&image));
        assert_eq!(bits(&read_variance(&path).unwrap().unwrap()), bits(&variance));
        assert_eq!(attrs["vitrum:spp"], "64");
        assert_eq!(
            attrs["channels"],
            "B:F32, G:F32, R:F32, samples:F32, variance.B:F32, variance.G:F32, variance.R:F32"
        );
        let ExrChannels { width, height, channels } = read_exr_channels(&path).unwrap();
        assert_eq!((width, height), (7, 5));
        assert_eq!(channels["variance.G"][3], 6.0);
        assert_eq!(channels["variance.B"], vec![0.5; 35]);
        assert_eq!(channels["samples"], vec![16.0; 35]);
        let short = [ExtraChannel { name: "x".into(), values: vec![1.0; 3] }];
        assert!(stage_exr_with_channels(&path, &image, &test_metadata(), &short).is_err());
    }

    #[test]
    fn notes_are_text_attributes_with_or_without_extra_channels() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notes.exr");
        let image = test_image();
        let notes = [("vitrum:interrupted".to_string(), "SIGINT after 3 of 64 samples".to_string())];
        let extra = [ExtraChannel { name: "samples".into(), values: vec![3.0; 35] }];
        for extra in [&extra[..], &[]] {
            stage_exr_with_notes(&path, &image, &test_metadata(), extra, &notes).unwrap().commit().unwrap();
            let (back, attrs) = read_exr(&path).unwrap();
            assert_eq!(bits(&back), bits(&image));
            assert_eq!(attrs["vitrum:interrupted"], "SIGINT after 3 of 64 samples");
            assert_eq!(attrs["vitrum:spp"], "64");
        }
        let clash = [("vitrum:spp".to_string(), "3".to_string())];
        assert!(stage_exr_with_notes(&path, &image, &test_metadata(), &[], &clash).is_err());
        assert_eq!(dir_entries(dir.path()), ["notes.exr"]);
    }

    #[test]
    fn exr_without_rgb_is_a_format_error() {
        use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, SmallVec};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("depth.exr");
        let channels =
            AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("Z", FlatSamples::F32(vec![1.0; 6]))]));
        let layer = Layer::new((3, 2), LayerAttributes::default(), Encoding::UNCOMPRESSED, channels);
        exr::image::Image::from_layer(layer).write().to_file(&path).unwrap();

        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, OutputError::Format { .. }), "{err:?}");
        let message = err.to_string();
        assert!(message.contains("depth.exr") && message.contains("not an RGB EXR"), "{message}");
    }
}
