//! The scene file as written by hand: plain serde data, unknown fields rejected.
//!
//! Units: lengths in scene units (metres suggested), angles in degrees, point-light intensity in
//! W/sr, area-light radiance in W/(m²·sr), colours as linear RGB (a single number means grey).
//! `scenes/README.md` documents every field; keep the two in step.

use crate::methods::Method;
use serde::Deserialize;
use std::collections::BTreeMap;

/// A point or vector in scene units.
pub type Vec3Desc = [f32; 3];

/// A linear RGB colour, written either as `[r, g, b]` or as one grey value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rgb {
    /// One value for all three channels.
    Grey(f32),
    /// Red, green, blue.
    Rgb([f32; 3]),
}

impl<'de> Deserialize<'de> for Rgb {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Rgb, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Rgb;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a colour: one number (grey) or [r, g, b]")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Rgb, E> {
                Ok(Rgb::Grey(v as f32))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Rgb, E> {
                Ok(Rgb::Grey(v as f32))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Rgb, E> {
                Ok(Rgb::Grey(v as f32))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Rgb, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, channel) in c.iter_mut().enumerate() {
                    *channel =
                        seq.next_element()?.ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<f32>()?.is_some() {
                    return Err(serde::de::Error::invalid_length(4, &self));
                }
                Ok(Rgb::Rgb(c))
            }
        }
        d.deserialize_any(Visitor)
    }
}

impl Rgb {
    /// The three channels.
    pub fn channels(self) -> [f32; 3] {
        match self {
            Rgb::Grey(g) => [g; 3],
            Rgb::Rgb(c) => c,
        }
    }
}

/// The whole scene file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// The pinhole camera.
    pub camera: CameraDesc,
    /// Render defaults; command-line options override them.
    #[serde(default)]
    pub render: RenderDesc,
    /// Named materials, referenced by objects.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    /// Geometry.
    #[serde(default)]
    pub objects: Vec<ObjectDesc>,
    /// Light sources.
    #[serde(default)]
    pub lights: Vec<LightDesc>,
}

/// Camera placement and image size.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Eye position.
    pub position: Vec3Desc,
    /// The point the camera looks at.
    pub look_at: Vec3Desc,
    /// Which way is up (must not be parallel to the view direction).
    #[serde(default = "default_up")]
    pub up: Vec3Desc,
    /// Vertical field of view in degrees, in (0, 180).
    #[serde(default = "default_fov")]
    pub fov: f32,
    /// Image size `[width, height]` in pixels.
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 2],
    /// Radius of the thin lens in scene units; 0 is a pinhole (no depth of field).
    #[serde(default)]
    pub aperture: f32,
    /// Distance to the plane in focus; default: the distance to `look_at`.
    #[serde(default)]
    pub focus_distance: Option<f32>,
    /// Shutter interval `[open, close]` in the time unit of object velocities.
    #[serde(default = "default_shutter")]
    pub shutter: [f32; 2],
    /// The pixel reconstruction filter: `"box"` (default), `"tent"`, `"gaussian"`, or a table
    /// with its parameters (`{ type = "tent", radius = 1.5 }`, `{ type = "gaussian", stddev = 0.5 }`).
    #[serde(default)]
    pub filter: Option<PixelFilterDesc>,
    /// Distance of the near clip plane along the view axis (scene units, default 0: none).
    #[serde(default)]
    pub near_clip: f32,
    /// The window of the film that is rendered and written (default: the whole film).
    #[serde(default)]
    pub crop: Option<CropDesc>,
}

/// `[camera] crop`: a window of the film, `{ offset = [x, y], size = [width, height] }` in
/// pixels from the top-left corner.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CropDesc {
    /// The window's top-left pixel (default `[0, 0]`).
    #[serde(default)]
    pub offset: [u32; 2],
    /// The window's size in pixels.
    pub size: [u32; 2],
}

/// `[camera] filter`: a filter name, or a table `{ type = NAME, radius = …, stddev = … }`.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelFilterDesc {
    /// `box`, `tent` or `gaussian`.
    pub kind: String,
    /// The tent's radius in pixels.
    pub radius: Option<f32>,
    /// The Gaussian's standard deviation in pixels.
    pub stddev: Option<f32>,
}

impl<'de> Deserialize<'de> for PixelFilterDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<PixelFilterDesc, D::Error> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Table {
            #[serde(rename = "type")]
            kind: String,
            radius: Option<f32>,
            stddev: Option<f32>,
        }
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = PixelFilterDesc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str(
                    "a pixel filter: \"box\", \"tent\", \"gaussian\" or a table { type = \"tent\", radius = 1.0 } / { type = \"gaussian\", stddev = 0.5 }",
                )
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<PixelFilterDesc, E> {
                Ok(PixelFilterDesc { kind: v.to_string(), radius: None, stddev: None })
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<PixelFilterDesc, A::Error> {
                let t = Table::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                Ok(PixelFilterDesc { kind: t.kind, radius: t.radius, stddev: t.stddev })
            }
        }
        d.deserialize_any(Visitor)
    }
}

fn default_shutter() -> [f32; 2] {
    [0.0, 1.0]
}

fn default_up() -> Vec3Desc {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f32 {
    40.0
}
fn default_resolution() -> [u32; 2] {
    [800, 800]
}

/// Render defaults stored with the scene, and each method's own parameters in its
/// `[render.METHOD]` table.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    /// Integrator name (`vitrum integrators` lists them).
    #[serde(default = "default_integrator")]
    pub integrator: String,
    /// Samples per pixel.
    #[serde(default = "default_spp")]
    pub spp: u32,
    /// Refused: a depth belongs to one method (`[render.whitted] max_depth = 5`). Read only to
    /// say so at its line ([`MOVED_MAX_DEPTH`]).
    #[serde(default)]
    pub max_depth: Option<serde::de::IgnoredAny>,
    /// Seed of every random stream.
    #[serde(default)]
    pub seed: u64,
    /// Scene-level ambient radiance of the empirical Phong model (raycast, whitted).
    #[serde(default = "default_zero_rgb")]
    pub ambient: Rgb,
    /// Radiance of rays that leave the scene.
    #[serde(default = "default_zero_rgb")]
    pub background: Rgb,
    /// Constant dielectric reflectance instead of exact Fresnel (the thesis used 0.06).
    #[serde(default)]
    pub reflectance: Option<f32>,
    /// Exposure of the PNG preview, in stops.
    #[serde(default)]
    pub exposure: f32,
    /// Spectral rendering: `auto` (when the scene disperses), `on` or `off`.
    #[serde(default = "default_auto")]
    pub spectral: String,
    /// Sample distribution: `sobol`, `stratified` or `independent`.
    #[serde(default = "default_sampler")]
    pub sampler: String,
    /// `[render.raycast]`: ray casting has no parameters of its own.
    #[serde(default)]
    pub raycast: NoParamsDesc,
    /// `[render.whitted]`: Whitted ray tracing.
    #[serde(default)]
    pub whitted: DepthDesc,
    /// `[render.ssaa]`: supersampled antialiasing over Whitted radiance.
    #[serde(default)]
    pub ssaa: SsaaDesc,
    /// `[render.distributed]`: distributed ray tracing.
    #[serde(default)]
    pub distributed: DepthDesc,
    /// `[render.path]`: path tracing.
    #[serde(default)]
    pub path: DepthDesc,
    /// `[render.light]`: light tracing.
    #[serde(default)]
    pub light: DepthDesc,
    /// `[render.bpt]`: bidirectional path tracing.
    #[serde(default)]
    pub bpt: BidirectionalDesc,
    /// `[render.ppm]`: progressive photon mapping.
    #[serde(default)]
    pub ppm: MergeDesc,
    /// `[render.bpm]`: bidirectional photon mapping.
    #[serde(default)]
    pub bpm: MergeDesc,
    /// `[render.vcm]`: vertex connection and merging.
    #[serde(default)]
    pub vcm: MergeDesc,
    /// `[render.pssmlt]`: primary-sample-space Metropolis light transport.
    #[serde(default)]
    pub pssmlt: MetropolisDesc,
    /// `[render.mmlt]`: multiplexed Metropolis light transport.
    #[serde(default)]
    pub mmlt: MetropolisDesc,
    /// `[render.mnee]`: path tracing with manifold next-event estimation.
    #[serde(default)]
    pub mnee: ManifoldDesc,
}

/// The message for a `max_depth` in `[render]`, which no longer applies to every method.
pub const MOVED_MAX_DEPTH: &str = "a depth is set per method, e.g. `[render.whitted] max_depth = 5` \
     (likewise [render.ssaa], [render.distributed], [render.path], [render.light], [render.bpt], \
     [render.ppm], [render.bpm], [render.vcm], [render.pssmlt], [render.mmlt], [render.mnee]); without one each \
     method uses its own default (5; 16 for mmlt; 256 for path, light, pssmlt, mnee and the bidirectional methods)";

/// The methods with a `[render.METHOD]` table, in the order `vitrum integrators` lists them:
/// every method of the table of methods ([`crate::methods::NAMES`]).
pub const METHOD_TABLES: [&str; crate::methods::NAMES.len()] = crate::methods::NAMES;

/// The methods that merge photons and so take `radius` and `radius_alpha`
/// ([`crate::methods::Settings::Merging`]).
pub const MERGING_METHODS: [&str; crate::methods::MERGING_NAMES.len()] = crate::methods::MERGING_NAMES;

/// The methods of the bidirectional engine, which take `max_light_paths`.
pub const BIDIRECTIONAL_METHODS: [&str; 4] = {
    use crate::methods::Method;
    [Method::Bpt.name(), Method::Ppm.name(), Method::Bpm.name(), Method::Vcm.name()]
};

/// Whether the method `name` has a maximum depth (`[render.NAME] max_depth`): every method
/// but `raycast`, which shades the first hit only ([`Method::has_max_depth`]).
pub fn has_max_depth(name: &str) -> bool {
    Method::from_name(name).is_some_and(Method::has_max_depth)
}

/// The table of a method without parameters of its own: it must be empty.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoParamsDesc {}

/// The table of a method whose one parameter is its recursion depth.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepthDesc {
    /// Maximum recursion depth (bounces); default the method's own.
    #[serde(default)]
    pub max_depth: Option<u32>,
}

/// The table of a method that merges photons (`ppm`, `bpm`, `vcm`).
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MergeDesc {
    /// Maximum number of scattering events of a full path; default the method's own.
    #[serde(default)]
    pub max_depth: Option<u32>,
    /// Initial merge radius in scene units; default a fraction of the scene's size.
    #[serde(default)]
    pub radius: Option<f32>,
    /// Knaus–Zwicker α in (0, 1) of the radius schedule; default 0.75.
    #[serde(default)]
    pub radius_alpha: Option<f32>,
    /// The most light sub-paths an iteration traces (at least 1); default 2²⁰.
    #[serde(default)]
    pub max_light_paths: Option<u32>,
}

/// The table of `pssmlt`: its depth and its Metropolis settings
/// ([`crate::params::MetropolisParams`], whose defaults apply where a field is absent).
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetropolisDesc {
    /// Maximum number of scattering events of a path; default the method's own.
    #[serde(default)]
    pub max_depth: Option<u32>,
    /// Probability in (0, 1] that a proposal is a large step; default 0.3.
    #[serde(default)]
    pub large_step: Option<f32>,
    /// Standard deviation of a small step, in (0, 1]; default 0.01.
    #[serde(default)]
    pub sigma: Option<f32>,
    /// Bootstrap samples per sample index (at least 1); default 4096.
    #[serde(default)]
    pub bootstrap: Option<u32>,
    /// Markov chains per sample index (at least 1); default 64.
    #[serde(default)]
    pub chains: Option<u32>,
}

/// The table of `mnee`: its depth and its manifold settings
/// ([`crate::params::ManifoldParams`], whose defaults apply where a field is absent).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManifoldDesc {
    /// Maximum number of scattering events of a path; default the method's own.
    #[serde(default)]
    pub max_depth: Option<u32>,
    /// `straight` (MNEE, the default) or `sms` (specular manifold sampling).
    #[serde(default)]
    pub seeding: Option<String>,
    /// The most smooth dielectric interfaces of a chain, 1 to 16; default 8.
    #[serde(default)]
    pub max_chain: Option<u32>,
    /// The cap on SMS's trials (at least 1); default 256.
    #[serde(default)]
    pub max_trials: Option<u32>,
}

/// The table of `bpt`: its depth and the cap on light sub-paths per iteration.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BidirectionalDesc {
    /// Maximum number of scattering events of a full path; default the method's own.
    #[serde(default)]
    pub max_depth: Option<u32>,
    /// The most light sub-paths an iteration traces (at least 1); default 2²⁰.
    #[serde(default)]
    pub max_light_paths: Option<u32>,
}

fn default_auto() -> String {
    "auto".into()
}
fn default_sampler() -> String {
    "sobol".into()
}

/// Settings of `ssaa` (supersampled antialiasing over Whitted radiance).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SsaaDesc {
    /// Maximum recursion depth of the Whitted radiance of each sample; default `ssaa`'s own.
    #[serde(default)]
    pub max_depth: Option<u32>,
    /// `adaptive` (thesis: corners, subdivide on contrast) or `grid` (regular n×n).
    #[serde(default = "default_ssaa_mode")]
    pub mode: String,
    /// Samples per side of the regular grid.
    #[serde(default = "default_ssaa_grid")]
    pub grid: u32,
    /// Maximum subdivision level of the adaptive mode (level L spaces samples 3^-L pixels apart).
    #[serde(default = "default_ssaa_levels")]
    pub levels: u32,
    /// Contrast that triggers subdivision: the largest channel difference between corners
    /// relative to their sum, |a − b| / (a + b).
    #[serde(default = "default_ssaa_threshold")]
    pub threshold: f32,
}

impl Default for SsaaDesc {
    fn default() -> Self {
        SsaaDesc {
            max_depth: None,
            mode: default_ssaa_mode(),
            grid: default_ssaa_grid(),
            levels: default_ssaa_levels(),
            threshold: default_ssaa_threshold(),
        }
    }
}

fn default_ssaa_mode() -> String {
    "adaptive".into()
}
fn default_ssaa_grid() -> u32 {
    4
}
fn default_ssaa_levels() -> u32 {
    1
}
fn default_ssaa_threshold() -> f32 {
    0.1
}

impl RenderDesc {
    /// The `[render.NAME]` table of the merging method `name` (`None` for other methods).
    pub fn merge_of(&self, name: &str) -> Option<&MergeDesc> {
        match Method::from_name(name)? {
            Method::Ppm => Some(&self.ppm),
            Method::Bpm => Some(&self.bpm),
            Method::Vcm => Some(&self.vcm),
            _ => None,
        }
    }

    /// The cap on light sub-paths per iteration the scene sets for the bidirectional method
    /// `name` in its `[render.NAME]` table.
    pub fn max_light_paths_of(&self, name: &str) -> Option<u32> {
        match Method::from_name(name)? {
            Method::Bpt => self.bpt.max_light_paths,
            _ => self.merge_of(name).and_then(|m| m.max_light_paths),
        }
    }

    /// The maximum depth the scene sets for the method `name` in its `[render.NAME]` table.
    pub fn max_depth_of(&self, name: &str) -> Option<u32> {
        match Method::from_name(name)? {
            Method::RayCast => None,
            Method::Whitted => self.whitted.max_depth,
            Method::Ssaa => self.ssaa.max_depth,
            Method::Distributed => self.distributed.max_depth,
            Method::Path => self.path.max_depth,
            Method::Light => self.light.max_depth,
            Method::Bpt => self.bpt.max_depth,
            Method::Ppm => self.ppm.max_depth,
            Method::Bpm => self.bpm.max_depth,
            Method::Vcm => self.vcm.max_depth,
            Method::Pssmlt => self.pssmlt.max_depth,
            Method::Mmlt => self.mmlt.max_depth,
            Method::Mnee => self.mnee.max_depth,
        }
    }
}

impl Default for RenderDesc {
    fn default() -> Self {
        RenderDesc {
            integrator: default_integrator(),
            spp: default_spp(),
            max_depth: None,
            seed: 0,
            ambient: default_zero_rgb(),
            background: default_zero_rgb(),
            reflectance: None,
            exposure: 0.0,
            spectral: default_auto(),
            sampler: default_sampler(),
            raycast: NoParamsDesc::default(),
            whitted: DepthDesc::default(),
            ssaa: SsaaDesc::default(),
            distributed: DepthDesc::default(),
            path: DepthDesc::default(),
            light: DepthDesc::default(),
            bpt: BidirectionalDesc::default(),
            ppm: MergeDesc::default(),
            bpm: MergeDesc::default(),
            vcm: MergeDesc::default(),
            pssmlt: MetropolisDesc::default(),
            mmlt: MetropolisDesc::default(),
            mnee: ManifoldDesc::default(),
        }
    }
}

fn default_integrator() -> String {
    "whitted".into()
}
fn default_spp() -> u32 {
    1
}
fn default_zero_rgb() -> Rgb {
    Rgb::Grey(0.0)
}

/// Empirical Phong coefficients used by ray casting and Whitted; absent ones take the
/// material's defaults.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhongDesc {
    /// Ambient weight k_a.
    pub ambient: Option<f32>,
    /// Diffuse (Lambert) weight k_d.
    pub diffuse: Option<f32>,
    /// Specular highlight weight k_s.
    pub specular: Option<f32>,
    /// Highlight exponent h (sharpness).
    pub shininess: Option<f32>,
}

/// A texture for a colour of a material (diffuse albedo, mirror tint).
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum TextureDesc {
    /// A 3-D checkerboard of two colours with cells of side `size`.
    Checker {
        /// First colour.
        color1: Rgb,
        /// Second colour.
        color2: Rgb,
        /// Edge length of one cell in scene units.
        size: f32,
    },
    /// An image file (PNG, JPEG or OpenEXR) addressed by the surface's texture coordinates.
    Image {
        /// Path of the image, relative to the scene file.
        file: String,
        /// Repetitions of the image per unit of uv, along u and v (both greater than 0).
        #[serde(default = "default_uv_scale")]
        scale: [f32; 2],
        /// Shift of the image in image units, added after `scale`.
        #[serde(default)]
        offset: [f32; 2],
        /// What lookups outside the image read.
        #[serde(default)]
        wrap: WrapDesc,
        /// How texels are combined.
        #[serde(default)]
        filter: FilterDesc,
        /// How the file's values encode colour (default: `srgb` for PNG and JPEG, `linear` for EXR).
        colorspace: Option<ColorSpaceDesc>,
    },
}

fn default_uv_scale() -> [f32; 2] {
    [1.0, 1.0]
}

/// `wrap` of an image texture: `repeat` (default) or `clamp`.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WrapDesc {
    /// The image tiles the plane.
    #[default]
    Repeat,
    /// Border texels extend outwards.
    Clamp,
}

/// `filter` of an image texture: `bilinear` (default) or `nearest`.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FilterDesc {
    /// Bilinear interpolation of texel centres.
    #[default]
    Bilinear,
    /// The texel a point falls in.
    Nearest,
}

/// `colorspace` of an image texture: `srgb` or `linear`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ColorSpaceDesc {
    /// The sRGB transfer curve.
    Srgb,
    /// Linear values.
    Linear,
}

/// A named material.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum MaterialDesc {
    /// Lambertian reflector.
    Diffuse {
        /// Albedo (default 0.8 grey); give either this or a texture.
        color: Option<Rgb>,
        /// Optional texture for the albedo.
        texture: Option<TextureDesc>,
        /// Radiance emitted from both sides of the surface, W/(m²·sr) (spheres, quads, disks,
        /// cylinders, meshes); with `emission_texture`, the factor on its colours (default 1).
        emission: Option<Rgb>,
        /// A texture for the emitted radiance (an image or a checker).
        emission_texture: Option<TextureDesc>,
        /// Whether only the side the surface normal points to emits, as Mitsuba's `area`
        /// emitter (black from behind); default false: both sides emit.
        #[serde(default)]
        emission_one_sided: bool,
        /// Whether only the side the surface normal points to reflects, as Mitsuba's `diffuse`
        /// (black from behind, blind to light from behind); default false: both sides reflect.
        #[serde(default)]
        one_sided: bool,
        /// Empirical Phong terms.
        #[serde(default)]
        phong: PhongDesc,
    },
    /// Mirror, perfect or (with roughness) glossy.
    Mirror {
        /// Reflectance per channel (default 1); give either this or a texture.
        color: Option<Rgb>,
        /// Optional texture for the reflectance.
        texture: Option<TextureDesc>,
        /// GGX roughness in [0, 1] (α = roughness²); 0 is a perfect mirror.
        #[serde(default)]
        roughness: f32,
        /// Empirical Phong terms.
        #[serde(default)]
        phong: PhongDesc,
    },
    /// Conductor (Mitsuba's `conductor` and `roughconductor`): Fresnel reflection of a complex
    /// index η + ik, smooth or rough.
    Conductor {
        /// A built-in metal by Mitsuba's name (`Au`, `Ag`, `Cu`, `Al`, `Cr`, or `none` for a
        /// perfect conductor, η = 0 and k = 1); the default when neither this nor `eta`/`k` is
        /// given is `none`.
        metal: Option<String>,
        /// Real part η of the complex index per channel (with `k`, instead of `metal`).
        eta: Option<Rgb>,
        /// Imaginary part k (extinction coefficient) per channel (with `eta`).
        k: Option<Rgb>,
        /// Real index of the medium outside (Mitsuba's `ext_eta`, default 1).
        #[serde(default = "default_one")]
        ior_outside: f32,
        /// Factor on the Fresnel reflectance per channel, in [0, 1] (default 1).
        specular_reflectance: Option<Rgb>,
        /// Width α of the microfacet distribution as Mitsuba defines it, in [0, 1]; 0 (default)
        /// is smooth. For GGX it is vitrum's `roughness`².
        #[serde(default)]
        alpha: f32,
        /// Microfacet distribution: `beckmann` (default, as Mitsuba's) or `ggx`.
        #[serde(default)]
        distribution: DistributionDesc,
        /// Empirical Phong terms.
        #[serde(default)]
        phong: PhongDesc,
    },
    /// Dielectric interface: the media on the inside and the outside, smooth or rough.
    Dielectric {
        /// Index on the side opposite the surface normal (inside a closed body).
        ior: IorDesc,
        /// Index on the side the normal points to.
        #[serde(default = "default_ior_outside")]
        ior_outside: IorDesc,
        /// Beer–Lambert absorption coefficient of the inside medium, per scene unit.
        #[serde(default = "default_zero_rgb")]
        absorption: Rgb,
        /// Absorption coefficient of the outside medium, per scene unit.
        #[serde(default = "default_zero_rgb")]
        absorption_outside: Rgb,
        /// Roughness in [0, 1] (the distribution's α = roughness²); 0 (default) is smooth glass,
        /// more is frosted. Give this or `alpha`.
        roughness: Option<f32>,
        /// Width α of the microfacet distribution as Mitsuba defines it, in [0, 1] (instead of
        /// `roughness`).
        alpha: Option<f32>,
        /// Microfacet distribution: `ggx` (default) or `beckmann` (Mitsuba's default for
        /// `roughdielectric`).
        distribution: Option<DistributionDesc>,
        /// Empirical Phong terms.
        #[serde(default)]
        phong: PhongDesc,
    },
    /// An infinitely thin dielectric slab (Mitsuba's `thindielectric`), such as a window pane.
    ThinDielectric {
        /// The slab's refractive index.
        ior: f32,
        /// The index of the medium around it (default 1).
        #[serde(default = "default_one")]
        ior_outside: f32,
        /// Empirical Phong terms.
        #[serde(default)]
        phong: PhongDesc,
    },
    /// A diffuse base under a smooth dielectric coating (Mitsuba's `plastic`).
    Plastic {
        /// The base's diffuse reflectance in [0, 1] per channel (default 0.5).
        diffuse_reflectance: Option<Rgb>,
        /// Factor on the coating's specular reflection in [0, 1] per channel (default 1).
        specular_reflectance: Option<Rgb>,
        /// The coating's refractive index (default 1.49, polypropylene).
        #[serde(default = "default_plastic_ior")]
        ior: f32,
        /// The index of the medium outside (default 1).
        #[serde(default = "default_one")]
        ior_outside: f32,
        /// Whether the light bouncing inside the coating shifts the colour, ρ/(1 − ρ·F_dr)
        /// instead of ρ/(1 − F_dr) (Mitsuba's `nonlinear`, default false).
        #[serde(default)]
        nonlinear: bool,
        /// Whether the back is the same plastic (Mitsuba's `twosided` wrapper); default false:
        /// black from behind, as Mitsuba's bare `plastic`.
        #[serde(default)]
        two_sided: bool,
        /// Empirical Phong terms.
        #[serde(default)]
        phong: PhongDesc,
    },
    /// A diffuse base under a rough dielectric coating (Mitsuba's `roughplastic`).
    RoughPlastic {
        /// The base's diffuse reflectance in [0, 1] per channel (default 0.5).
        diffuse_reflectance: Option<Rgb>,
        /// Factor on the coating's specular reflection in [0, 1] per channel (default 1).
        specular_reflectance: Option<Rgb>,
        /// The coating's refractive index (default 1.49, polypropylene).
        #[serde(default = "default_plastic_ior")]
        ior: f32,
        /// The index of the medium outside (default 1).
        #[serde(default = "default_one")]
        ior_outside: f32,
        /// Whether the light bouncing inside the coating shifts the colour (Mitsuba's
        /// `nonlinear`, default false).
        #[serde(default)]
        nonlinear: bool,
        /// Whether the back is the same plastic (Mitsuba's `twosided` wrapper); default false:
        /// black from behind, as Mitsuba's bare `roughplastic`.
        #[serde(default)]
        two_sided: bool,
        /// Width α of the coating's microfacet distribution as Mitsuba defines it, in (0, 1]
        /// (default 0.1, Mitsuba's).
        #[serde(default = "default_plastic_alpha")]
        alpha: f32,
        /// Microfacet distribution: `beckmann` (default, as Mitsuba's) or `ggx`.
        #[serde(default)]
        distribution: DistributionDesc,
        /// Empirical Phong terms.
        #[serde(default)]
        phong: PhongDesc,
    },
}

fn default_plastic_alpha() -> f32 {
    0.1
}

fn default_plastic_ior() -> f32 {
    1.49
}

fn default_one() -> f32 {
    1.0
}

/// `distribution` of a conductor: `beckmann` (default) or `ggx`.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum DistributionDesc {
    /// Beckmann, Mitsuba's default.
    #[default]
    Beckmann,
    /// Trowbridge–Reitz (GGX).
    Ggx,
}

fn default_ior_outside() -> IorDesc {
    IorDesc::Constant(1.0)
}

/// The error for an index table without exactly one of `cauchy` and `abbe`.
pub const IOR_TABLE_ERROR: &str = "give exactly one of `cauchy = [A, B]` or `abbe = [n_d, V_d]`";

/// A refractive index: a number, a named glass (`"bk7"`), `{ cauchy = [A, B_nm²] }` or
/// `{ abbe = [n_d, V_d] }`.
#[derive(Clone, Debug, PartialEq)]
pub enum IorDesc {
    /// The same index at every wavelength.
    Constant(f32),
    /// A glass from the built-in list.
    Named(String),
    /// Cauchy's n(λ) = A + B/λ², λ in nm.
    Cauchy([f32; 2]),
    /// Index n_d at 587.6 nm and Abbe number V_d.
    Abbe([f32; 2]),
}

impl<'de> Deserialize<'de> for IorDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<IorDesc, D::Error> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Table {
            cauchy: Option<[f32; 2]>,
            abbe: Option<[f32; 2]>,
        }
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = IorDesc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a refractive index: a number, a glass name, { cauchy = [A, B] } or { abbe = [n_d, V_d] }")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<IorDesc, E> {
                Ok(IorDesc::Constant(v as f32))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<IorDesc, E> {
                Ok(IorDesc::Constant(v as f32))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<IorDesc, E> {
                Ok(IorDesc::Constant(v as f32))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<IorDesc, E> {
                Ok(IorDesc::Named(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<IorDesc, A::Error> {
                let t = Table::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                match (t.cauchy, t.abbe) {
                    (Some(c), None) => Ok(IorDesc::Cauchy(c)),
                    (None, Some(a)) => Ok(IorDesc::Abbe(a)),
                    _ => Err(serde::de::Error::custom(IOR_TABLE_ERROR)),
                }
            }
        }
        d.deserialize_any(Visitor)
    }
}
/// The liquid in a filled vessel: a name from [`LIQUIDS`] (`"water"`) or a table
/// `{ ior = 1.333, absorption = [r, g, b] }` (absorption per scene unit, default 0).
#[derive(Clone, Debug, PartialEq)]
pub enum LiquidDesc {
    /// A liquid from [`LIQUIDS`].
    Named(String),
    /// A liquid given by its medium.
    Medium {
        /// Refractive index (any form `ior` takes in a material).
        ior: IorDesc,
        /// Beer–Lambert absorption coefficient per scene unit.
        absorption: Rgb,
    },
}

/// The named liquids and their (constant) refractive indices at 589 nm.
pub const LIQUIDS: [(&str, f32); 3] = [("water", 1.333), ("ethanol", 1.361), ("olive_oil", 1.47)];

impl<'de> Deserialize<'de> for LiquidDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<LiquidDesc, D::Error> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Table {
            ior: IorDesc,
            #[serde(default = "default_zero_rgb")]
            absorption: Rgb,
        }
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = LiquidDesc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a liquid: a name (\"water\") or { ior = 1.333, absorption = [r, g, b] }")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<LiquidDesc, E> {
                Ok(LiquidDesc::Named(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<LiquidDesc, A::Error> {
                let t = Table::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                Ok(LiquidDesc::Medium { ior: t.ior, absorption: t.absorption })
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// The axis of a cylinder, bowl or drinking glass that names none: +Y.
pub(super) fn default_axis() -> Vec3Desc {
    [0.0, 1.0, 0.0]
}
fn default_true() -> bool {
    true
}

/// One object: a shape or a composite body, with a material.
#[derive(Clone, Debug, Deserialize)]
pub struct ObjectDesc {
    /// Optional name shown by `vitrum info`.
    #[serde(default)]
    pub name: Option<String>,
    /// Material name (a key of `[materials]`).
    pub material: String,
    /// Linear motion in scene units per unit of shutter time (motion blur), in world space.
    #[serde(default)]
    pub velocity: Option<Vec3Desc>,
    /// Placement of the shape: scale, then rotate, then translate.
    #[serde(default)]
    pub transform: Option<TransformDesc>,
    /// The geometry.
    #[serde(flatten)]
    pub shape: ShapeDesc,
}

/// `transform = { scale = s | [sx, sy, sz], rotate = { axis = [x, y, z], angle = DEG }, translate
/// = [x, y, z] }`: applied in the order scale, rotate, translate; every part optional. Or
/// `transform = { matrix = [16 numbers] }`: a 4×4 affine matrix written row by row (last row
/// `[0, 0, 0, 1]`, positive determinant), alone.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    /// A 4×4 affine matrix, row-major: `p ↦ M·p + t` with `M` the upper-left 3×3 block and `t`
    /// the last column (instead of `scale`, `rotate` and `translate`).
    #[serde(default)]
    pub matrix: Option<[f32; 16]>,
    /// Scale factor, one for all axes or one per axis (all > 0), applied first.
    #[serde(default)]
    pub scale: Option<ScaleDesc>,
    /// Rotation about an axis through the origin, applied after scaling.
    #[serde(default)]
    pub rotate: Option<RotateDesc>,
    /// Translation, applied last.
    #[serde(default)]
    pub translate: Option<Vec3Desc>,
}

/// A rotation by `angle` degrees about `axis` (right-handed).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotateDesc {
    /// The axis direction (non-zero; normalised).
    pub axis: Vec3Desc,
    /// The angle in degrees, counter-clockwise seen from the tip of the axis.
    pub angle: f32,
}

/// A scale written as one number (uniform) or as `[sx, sy, sz]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScaleDesc {
    /// The same factor on every axis.
    Uniform(f32),
    /// One factor per axis.
    Axes([f32; 3]),
}

impl ScaleDesc {
    /// The factor per axis.
    pub fn axes(self) -> [f32; 3] {
        match self {
            ScaleDesc::Uniform(s) => [s; 3],
            ScaleDesc::Axes(a) => a,
        }
    }
}

impl<'de> Deserialize<'de> for ScaleDesc {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<ScaleDesc, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = ScaleDesc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a scale: one number (uniform) or [sx, sy, sz]")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<ScaleDesc, E> {
                Ok(ScaleDesc::Uniform(v as f32))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<ScaleDesc, E> {
                Ok(ScaleDesc::Uniform(v as f32))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<ScaleDesc, E> {
                Ok(ScaleDesc::Uniform(v as f32))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<ScaleDesc, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, axis) in c.iter_mut().enumerate() {
                    *axis = seq.next_element()?.ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<f32>()?.is_some() {
                    return Err(serde::de::Error::invalid_length(4, &self));
                }
                Ok(ScaleDesc::Axes(c))
            }
        }
        d.deserialize_any(Visitor)
    }
}

/// The geometry of an object, chosen by `shape = "..."`.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeDesc {
    /// A full sphere.
    Sphere {
        /// Centre.
        center: Vec3Desc,
        /// Radius.
        radius: f32,
    },
    /// A finite cylinder, capped by default: from `base` along `axis` for `height`, or from
    /// `base` to `top`.
    Cylinder {
        /// Centre of the bottom cap.
        base: Vec3Desc,
        /// Centre of the top cap, instead of `axis` and `height`.
        #[serde(default)]
        top: Option<Vec3Desc>,
        /// Direction from bottom to top (normalised; default +Y).
        #[serde(default)]
        axis: Option<Vec3Desc>,
        /// Radius.
        radius: f32,
        /// Length along the axis.
        #[serde(default)]
        height: Option<f32>,
        /// Close both ends with disks.
        #[serde(default = "default_true")]
        caps: bool,
        /// Turn the normals towards the axis (Mitsuba's `flip_normals`): the inside becomes the
        /// front a one-sided material reflects on and a one-sided emission leaves from, and a
        /// dielectric's outside.
        #[serde(default)]
        flip_normals: bool,
        /// Direction from the axis in which the wall's u is 0 (its texture seam), projected onto
        /// the cross-section; default t₁ of the axis (`scenes/README.md`, Texture coordinates).
        #[serde(default)]
        seam: Option<Vec3Desc>,
    },
    /// A disk, or an annulus when `inner_radius > 0`.
    Disk {
        /// Centre.
        center: Vec3Desc,
        /// Normal (the side called outside).
        normal: Vec3Desc,
        /// Outer radius.
        radius: f32,
        /// Radius of the hole.
        #[serde(default)]
        inner_radius: f32,
        /// Direction from the centre in which v is 0 (the texture seam), projected onto the
        /// disk's plane; default t₁ of the normal (`scenes/README.md`, Texture coordinates).
        #[serde(default)]
        seam: Option<Vec3Desc>,
    },
    /// A parallelogram `corner + a·u + b·v`, a, b in [0, 1]; normal `u × v`.
    Quad {
        /// One corner.
        corner: Vec3Desc,
        /// First edge.
        u: Vec3Desc,
        /// Second edge.
        v: Vec3Desc,
    },
    /// A planar convex polygon, vertices counter-clockwise seen from the normal side.
    Polygon {
        /// At least three vertices.
        vertices: Vec<Vec3Desc>,
    },
    /// A triangle mesh from a Wavefront OBJ file (path relative to the scene file).
    Mesh {
        /// The OBJ file.
        file: String,
        /// Uniform scale applied first.
        #[serde(default = "default_scale")]
        scale: f32,
        /// Translation applied after scaling.
        #[serde(default)]
        translate: Vec3Desc,
        /// Shade with the triangles' own (flat) normals and ignore the file's vertex normals
        /// (Mitsuba's `faceNormals`).
        #[serde(default)]
        face_normals: bool,
        /// Whether and where smooth vertex normals are recomputed from the triangles
        /// ([`SmoothNormals`]).
        #[serde(default)]
        smooth_normals: SmoothNormals,
        /// Turn the surface over (Mitsuba's `flip_normals`): every triangle's winding reversed
        /// and its vertex normals negated, which moves the front (the side a one-sided material
        /// reflects and a one-sided emission leaves from) and the inside of a dielectric.
        #[serde(default)]
        flip_normals: bool,
    },
    /// A hollow sphere: a shell between `inner_radius` and `radius`.
    HollowSphere {
        /// Centre.
        center: Vec3Desc,
        /// Outer radius.
        radius: f32,
        /// Inner radius.
        inner_radius: f32,
    },
    /// A spherical bowl: a hemispherical shell opening along `axis`, closed by a flat rim ring.
    Bowl {
        /// Centre of the spheres (the middle of the rim).
        center: Vec3Desc,
        /// Direction the bowl opens to.
        #[serde(default = "default_axis")]
        axis: Vec3Desc,
        /// Outer radius.
        radius: f32,
        /// Wall thickness.
        thickness: f32,
        /// Fill with a liquid up to this depth *below the rim plane*, in [0, radius − thickness):
        /// 0 is full to the rim. Absent: empty.
        #[serde(default)]
        fill: Option<f32>,
        /// The liquid (default `"water"` when `fill` is given).
        #[serde(default)]
        liquid: Option<LiquidDesc>,
    },
    /// A cylindrical drinking glass, open at the top.
    DrinkingGlass {
        /// Centre of the bottom.
        base: Vec3Desc,
        /// Direction from bottom to rim.
        #[serde(default = "default_axis")]
        axis: Vec3Desc,
        /// Outer radius.
        radius: f32,
        /// Outer height.
        height: f32,
        /// Wall thickness.
        wall: f32,
        /// Thickness of the solid base.
        bottom: f32,
        /// Fill with a liquid up to this height *above the cavity floor*, in (0, height − bottom]:
        /// `height − bottom` is full to the rim. Absent: empty.
        #[serde(default)]
        fill: Option<f32>,
        /// The liquid (default `"water"` when `fill` is given).
        #[serde(default)]
        liquid: Option<LiquidDesc>,
    },
}

/// A mesh's `smooth_normals`: `false`, `true` or `"missing"`. Recomputed normals are each
/// vertex's average of its faces' normals weighted by the faces' angles there (Thürmer and
/// Wüthrich's weights, which do not depend on how a surface is split into triangles).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SmoothNormals {
    /// `false`: the file's vertex normals, or the faces' own where it has none.
    #[default]
    Off,
    /// `true`: recomputed over corners at the same position, replacing the file's (Tungsten's
    /// `recompute_normals`, for files whose vertex normals are placeholders).
    Replace,
    /// `"missing"`: Mitsuba 3's rule for OBJ and PLY files: a file with vertex normals keeps
    /// them; one without gets them recomputed, over corners at the same position with the same
    /// texture coordinates (Mitsuba's vertices: a uv seam stays a crease).
    WhereMissing,
}

impl<'de> Deserialize<'de> for SmoothNormals {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<SmoothNormals, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = SmoothNormals;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("true, false or \"missing\"")
            }
            fn visit_bool<E: serde::de::Error>(self, v: bool) -> Result<SmoothNormals, E> {
                Ok(if v { SmoothNormals::Replace } else { SmoothNormals::Off })
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<SmoothNormals, E> {
                match v {
                    "missing" => Ok(SmoothNormals::WhereMissing),
                    _ => Err(E::invalid_value(serde::de::Unexpected::Str(v), &self)),
                }
            }
        }
        d.deserialize_any(Visitor)
    }
}

fn default_scale() -> f32 {
    1.0
}

fn default_cutoff_angle() -> f32 {
    crate::light::SpotBeam::DEFAULT_CUTOFF_DEGREES
}

/// A light source, chosen by `type = "..."`.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum LightDesc {
    /// An isotropic point light.
    Point {
        /// Position.
        position: Vec3Desc,
        /// Radiant intensity in W/sr.
        intensity: Rgb,
    },
    /// A spot light (Mitsuba 3's `spot`): a point light shining into a cone about `direction`
    /// (or towards `look_at`), full intensity within `beam_width` of the axis, falling off
    /// linearly in the angle to 0 at `cutoff_angle`.
    Spot {
        /// Position.
        position: Vec3Desc,
        /// Direction of the beam's axis (give this or `look_at`).
        direction: Option<Vec3Desc>,
        /// A point on the beam's axis (give this or `direction`).
        look_at: Option<Vec3Desc>,
        /// Radiant intensity on the axis in W/sr.
        intensity: Rgb,
        /// Half-angle of the cone in degrees, in (0, 180]; default 20.
        #[serde(default = "default_cutoff_angle")]
        cutoff_angle: f32,
        /// Half-angle of the full-intensity core in degrees, in [0, `cutoff_angle`]; default
        /// three quarters of `cutoff_angle`.
        beam_width: Option<f32>,
    },
    /// Parallel light from infinitely far away (Mitsuba 3's `directional`), e.g. the sun.
    Directional {
        /// The direction the light travels in.
        direction: Vec3Desc,
        /// Irradiance on a surface facing the light in W/m².
        irradiance: Rgb,
    },
    /// A one-sided parallelogram emitter `corner + a·u + b·v`, emitting along `u × v`.
    Quad {
        /// One corner.
        corner: Vec3Desc,
        /// First edge.
        u: Vec3Desc,
        /// Second edge.
        v: Vec3Desc,
        /// Emitted radiance in W/(m²·sr).
        radiance: Rgb,
    },
    /// Radiance from every direction that leaves the scene (also the background): constant, or
    /// an equirectangular HDR map (importance-sampled).
    Environment {
        /// Constant radiance in W/(m²·sr) (without `file`).
        radiance: Option<Rgb>,
        /// An equirectangular image (linear OpenEXR, or PNG/JPEG decoded from sRGB), relative to
        /// the scene file.
        file: Option<String>,
        /// Turn of the map about the up axis (+Y) in degrees, right-handed.
        #[serde(default)]
        rotation: f32,
        /// Factor on the map's texels (greater than 0).
        #[serde(default = "default_scale")]
        scale: f32,
    },
    /// A spherical emitter, radiating outwards from its whole surface.
    Sphere {
        /// Centre.
        center: Vec3Desc,
        /// Radius.
        radius: f32,
        /// Emitted radiance in W/(m²·sr).
        radiance: Rgb,
    },
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::METHODS;

    #[test]
    fn the_moved_depth_message_names_every_method_with_a_depth_and_the_defaults_of_the_table() {
        let depths: Vec<_> = METHODS.iter().filter(|m| m.method.has_max_depth()).collect();
        for m in &depths {
            assert!(MOVED_MAX_DEPTH.contains(&format!("[render.{}]", m.name)), "{}", m.name);
        }
        assert!(!MOVED_MAX_DEPTH.contains("[render.raycast]"), "raycast has no depth");
        // "(5; 256 for path, light, pssmlt and the bidirectional methods)": the two defaults of the
        // table.
        let mut defaults: Vec<u32> =
            depths.iter().filter(|m| m.name != "mmlt").map(|m| m.default_max_depth).collect();
        defaults.dedup();
        assert_eq!(defaults.len(), 2, "{defaults:?}");
        let (low, high) = (defaults[0], defaults[1]);
        let mmlt = crate::methods::DEFAULT_MMLT_DEPTH;
        assert!(MOVED_MAX_DEPTH.contains(&format!(
            "({low}; {mmlt} for mmlt; {high} for path, light, pssmlt, mnee and the bidirectional methods)"
        )));
        for m in &depths {
            let bidirectional = matches!(m.settings, crate::methods::Settings::Merging) || m.name == "bpt";
            let path_like = ["path", "light", "pssmlt", "mnee"].contains(&m.name);
            let expected = if m.name == "mmlt" {
                mmlt
            } else if path_like || bidirectional {
                high
            } else {
                low
            };
            assert_eq!(m.default_max_depth, expected, "{}", m.name);
        }
    }

    #[test]
    fn every_method_of_the_table_with_a_depth_reads_its_own_table() {
        let mut render: RenderDesc = toml::from_str(
            "[whitted]\nmax_depth = 1\n[ssaa]\nmax_depth = 2\n[distributed]\nmax_depth = 3\n[path]\nmax_depth = 4\n\
             [light]\nmax_depth = 5\n[bpt]\nmax_depth = 6\n[ppm]\nmax_depth = 7\n[bpm]\nmax_depth = 8\n\
             [vcm]\nmax_depth = 9\n[pssmlt]\nmax_depth = 10\n[mmlt]\nmax_depth = 11\n[mnee]\nmax_depth = 12\n",
        )
        .unwrap();
        let read: Vec<Option<u32>> = METHODS.iter().map(|m| render.max_depth_of(m.name)).collect();
        assert_eq!(
            read,
            [
                None,
                Some(1),
                Some(2),
                Some(3),
                Some(4),
                Some(5),
                Some(6),
                Some(7),
                Some(8),
                Some(9),
                Some(10),
                Some(11),
                Some(12)
            ]
        );
        render.vcm.radius = Some(0.5);
        for m in METHODS {
            assert_eq!(render.merge_of(m.name).is_some(), m.method.merges(), "{}", m.name);
        }
        assert_eq!(render.merge_of("vcm").unwrap().radius, Some(0.5));
    }
}
