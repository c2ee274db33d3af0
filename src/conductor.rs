//! Complex refractive indices η + ik of conductors: the named metals' measured spectra, their RGB
//! values as Mitsuba 3's RGB variants compute them, and the index in a path's channels.
//!
//! **Data.** The spectra of `Au`, `Ag`, `Cu`, `Al` and `Cr` are Mitsuba's `data/ior/<name>.eta.spd`
//! and `<name>.k.spd` (mitsuba-renderer/mitsuba, from the luxpop.com database; `Cr` is its
//! concatenation of LLNL CXRO and Palik), copied number for number at their own wavelengths in nm
//! (the files' header says Å, their numbers are nm). Mitsuba 3 names the same files.
//!
//! **RGB.** Mitsuba 3's RGB variants turn a spectrum into a colour with `ior_from_file` →
//! `spectrum_list_to_srgb`: the spectrum (linear between its samples, zero outside them) times
//! the CIE 1931 colour-matching functions summed at 1000 points spread over 360–830 nm, times
//! 470/1000 and `MI_CIE_Y_NORMALIZATION` = 1/106.7502593994140625, to linear sRGB, negatives
//! set to 0. [`Metal::rgb`] does the same sum with vitrum's colour-matching functions (the
//! Wyman–Sloan–Shirley fit of [`crate::spectrum::cie_xyz`], where Mitsuba interpolates the CIE
//! table: gold agrees with Mitsuba's published RGB values within 2%, tested).
//!
//! **Spectral mode.** A named metal is read from its spectrum at each of the path's three
//! wavelengths (linear between samples, as Mitsuba's spectral variants do); an index given as RGB
//! becomes a spectrum by the same linear basis as every colour of the scene
//! ([`crate::spectrum::Channels::colour`]: at each wavelength a convex blend of the three values).

use crate::bsdf::{Beckmann, ConductorFresnel, MicrofacetDistribution, RoughConductor, TrowbridgeReitz};
use crate::spectrum::{cie_xyz, xyz_to_linear_srgb, Channels};
use glam::Vec3;

/// A metal with a measured complex index: (wavelength nm, η, k) in increasing wavelength.
#[derive(Debug, PartialEq)]
pub struct Metal {
    /// Mitsuba's name (`Au`, …).
    pub name: &'static str,
    /// The samples (wavelength in nm, η, k).
    samples: &'static [[f32; 3]],
}

/// Mitsuba's `MI_CIE_Y_NORMALIZATION`: 1 / ∫ ȳ over 360–830 nm of its table.
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;

impl Metal {
    /// The metal called `name` (Mitsuba's spelling, case-sensitive).
    pub fn named(name: &str) -> Option<&'static Metal> {
        METALS.iter().find(|m| m.name == name)
    }

    /// η and k at `lambda` nm, linear between samples and held constant beyond them.
    pub fn at(&self, lambda: f32) -> (f32, f32) {
        let s = self.samples;
        let i = s.partition_point(|p| p[0] <= lambda);
        if i == 0 {
            return (s[0][1], s[0][2]);
        }
        if i == s.len() {
            let last = s[s.len() - 1];
            return (last[1], last[2]);
        }
        let (a, b) = (s[i - 1], s[i]);
        let t = (lambda - a[0]) / (b[0] - a[0]);
        (a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]))
    }

    /// (η, k) as RGB, computed as Mitsuba 3's RGB variants do (module documentation).
    pub fn rgb(&self) -> (Vec3, Vec3) {
        const STEPS: usize = 1000;
        const MIN: f64 = 360.0;
        const MAX: f64 = 830.0;
        let (first, last) = (self.samples[0][0] as f64, self.samples[self.samples.len() - 1][0] as f64);
        let (mut eta, mut k) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for i in 0..STEPS {
            let lambda = MIN + i as f64 / (STEPS - 1) as f64 * (MAX - MIN);
            if lambda < first || lambda > last {
                continue;
            }
            let xyz = cie_xyz(lambda as f32).as_dvec3();
            let (e, kk) = self.at(lambda as f32);
            eta += xyz * e as f64;
            k += xyz * kk as f64;
        }
        let scale = (MAX - MIN) / STEPS as f64 * CIE_Y_NORMALIZATION;
        let to_rgb = |xyz: glam::DVec3| xyz_to_linear_srgb((xyz * scale).as_vec3()).max(Vec3::ZERO);
        (to_rgb(eta), to_rgb(k))
    }
}

/// The names of the built-in metals, and `none` (a perfect conductor, η = 0 and k = 1).
pub const METAL_NAMES: [&str; 6] = ["Au", "Ag", "Cu", "Al", "Cr", "none"];

/// A conductor's complex index: RGB values, and for a named metal its measured spectrum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ComplexIor {
    /// η per RGB channel (for a named metal, [`Metal::rgb`]).
    pub eta: Vec3,
    /// k per RGB channel.
    pub k: Vec3,
    /// The measured spectrum of a named metal, read in spectral mode.
    pub metal: Option<&'static Metal>,
}

impl ComplexIor {
    /// An index given as RGB values.
    pub fn rgb(eta: Vec3, k: Vec3) -> ComplexIor {
        ComplexIor { eta, k, metal: None }
    }

    /// The index of a name of [`METAL_NAMES`]: a measured metal, or `none`'s η = 0, k = 1.
    pub fn named(name: &str) -> Option<ComplexIor> {
        if name == "none" {
            return Some(ComplexIor::rgb(Vec3::ZERO, Vec3::ONE));
        }
        let metal = Metal::named(name)?;
        let (eta, k) = metal.rgb();
        Some(ComplexIor { eta, k, metal: Some(metal) })
    }

    /// (η, k) in a path's `channels`: the RGB values, or the spectrum at the three wavelengths.
    #[inline]
    pub fn in_channels(&self, channels: &Channels) -> (Vec3, Vec3) {
        match (channels, self.metal) {
            (Channels::Rgb, _) => (self.eta, self.k),
            (Channels::Spectral(w), Some(metal)) => {
                let [a, b, c] = w.lambda.map(|l| metal.at(l));
                (Vec3::new(a.0, b.0, c.0), Vec3::new(a.1, b.1, c.1))
            }
            (Channels::Spectral(_), None) => (channels.colour(self.eta), channels.colour(self.k)),
        }
    }
}

/// Which microfacet distribution a rough conductor's normals follow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    /// Trowbridge–Reitz (GGX).
    Ggx,
    /// Beckmann (Mitsuba's default for `roughconductor`).
    Beckmann,
}

impl Distribution {
    /// This distribution with width `alpha` (Mitsuba's α: GGX's α, Beckmann's √2 × RMS slope).
    pub fn with_alpha(self, alpha: f32) -> MicrofacetDistribution {
        match self {
            Distribution::Ggx => TrowbridgeReitz::new(alpha).into(),
            Distribution::Beckmann => Beckmann::new(alpha).into(),
        }
    }

    /// The name in scene files and Mitsuba's XML (`ggx`, `beckmann`).
    pub fn name(self) -> &'static str {
        match self {
            Distribution::Ggx => "ggx",
            Distribution::Beckmann => "beckmann",
        }
    }
}

/// A conductor (Mitsuba's `conductor` and `roughconductor`): Fresnel reflection of a complex
/// index relative to the outside medium, scaled by a colour, smooth or with microfacets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// The metal's complex index (absolute).
    pub index: ComplexIor,
    /// The real index of the medium outside (Mitsuba's `ext_eta`); η and k are divided by it.
    pub ior_outside: f32,
    /// Factor on the Fresnel reflectance per RGB channel (Mitsuba's `specular_reflectance`).
    pub specular_reflectance: Vec3,
    /// The distribution's width α as Mitsuba defines it (0 is smooth): GGX's α (vitrum's
    /// `roughness`²), Beckmann's √2 × RMS slope.
    pub alpha: f32,
    /// The distribution of microfacet normals.
    pub distribution: Distribution,
}

impl Conductor {
    /// The microfacet distribution (effectively smooth below α = 1e-3).
    pub fn microfacets(&self) -> MicrofacetDistribution {
        self.distribution.with_alpha(self.alpha)
    }

    /// The Fresnel term in a path's `channels`.
    #[inline]
    pub fn fresnel(&self, channels: &Channels) -> ConductorFresnel {
        let (eta, k) = self.index.in_channels(channels);
        ConductorFresnel::Complex {
            eta: eta / self.ior_outside,
            k: k / self.ior_outside,
            scale: channels.colour(self.specular_reflectance),
        }
    }

    /// The BSDF in a path's `channels`.
    #[inline]
    pub fn scattering(&self, channels: &Channels) -> RoughConductor {
        RoughConductor::with_fresnel(self.fresnel(channels), self.microfacets())
    }

    /// The reflectance at normal incidence in RGB (for the Phong terms and `vitrum info`).
    pub fn normal_reflectance(&self) -> Vec3 {
        self.fresnel(&Channels::Rgb).at(1.0)
    }

    /// Whether the surface is rough (α > 0).
    pub fn is_rough(&self) -> bool {
        self.alpha > 0.0
    }
}

/// The built-in metals (see the module documentation for the source).
static METALS: [Metal; 5] = [
    Metal { name: "Au", samples: &AU },
    Metal { name: "Ag", samples: &AG },
    Metal { name: "Cu", samples: &CU },
    Metal { name: "Al", samples: &AL },
    Metal { name: "Cr", samples: &CR },
];

/// Gold: Mitsuba's `data/ior/Au.eta.spd`, `Au.k.spd`.
#[rustfmt::skip]
#[allow(clippy::excessive_precision, clippy::approx_constant)] // the files' digits, as written
const AU: [[f32; 3]; 56] = [
    [298.757050, 1.795000, 1.920375], [302.400421, 1.812000, 1.920000], [306.133759, 1.822625, 1.918875],
    [309.960449, 1.830000, 1.916000], [313.884003, 1.837125, 1.911375], [317.908142, 1.840000, 1.904000],
    [322.036835, 1.834250, 1.891375], [326.274139, 1.824000, 1.878000], [330.624481, 1.812000, 1.868250],
    [335.092377, 1.798000, 1.860000], [339.682678, 1.782000, 1.851750], [344.400482, 1.766000, 1.846000],
    [349.251221, 1.752500, 1.845250], [354.240509, 1.740000, 1.848000], [359.374420, 1.727625, 1.852375],
    [364.659332, 1.716000, 1.862000], [370.102020, 1.705875, 1.883000], [375.709625, 1.696000, 1.906000],
    [381.489777, 1.684750, 1.922500], [387.450562, 1.674000, 1.936000], [393.600555, 1.666000, 1.947750],
    [399.948975, 1.658000, 1.956000], [406.505493, 1.647250, 1.959375], [413.280579, 1.636000, 1.958000],
    [420.285339, 1.628000, 1.951375], [427.531647, 1.616000, 1.940000], [435.032196, 1.596250, 1.924500],
    [442.800629, 1.562000, 1.904000], [450.851562, 1.502125, 1.875875], [459.200653, 1.426000, 1.846000],
    [467.864838, 1.345875, 1.814625], [476.862213, 1.242000, 1.796000], [486.212463, 1.086750, 1.797375],
    [495.936707, 0.916000, 1.840000], [506.057861, 0.754500, 1.956500], [516.600769, 0.608000, 2.120000],
    [527.592224, 0.491750, 2.326250], [539.061646, 0.402000, 2.540000], [551.040771, 0.345500, 2.730625],
    [563.564453, 0.306000, 2.880000], [576.670593, 0.267625, 2.940625], [590.400818, 0.236000, 2.970000],
    [604.800842, 0.212375, 3.015000], [619.920898, 0.194000, 3.060000], [635.816284, 0.177750, 3.070000],
    [652.548279, 0.166000, 3.150000], [670.184753, 0.161000, 3.445812], [688.800964, 0.160000, 3.800000],
    [708.481018, 0.160875, 4.087687], [729.318665, 0.164000, 4.357000], [751.419250, 0.169500, 4.610188],
    [774.901123, 0.176000, 4.860000], [799.897949, 0.181375, 5.125813], [826.561157, 0.188000, 5.390000],
    [855.063293, 0.198125, 5.631250], [885.601257, 0.210000, 5.880000],
];

/// Silver: Mitsuba's `data/ior/Ag.eta.spd`, `Ag.k.spd`.
#[rustfmt::skip]
#[allow(clippy::excessive_precision, clippy::approx_constant)] // the files' digits, as written
const AG: [[f32; 3]; 56] = [
    [298.757050, 1.519000, 1.080000], [302.400421, 1.496000, 0.882000], [306.133759, 1.432500, 0.761063],
    [309.960449, 1.323000, 0.647000], [313.884003, 1.142062, 0.550875], [317.908142, 0.932000, 0.504000],
    [322.036835, 0.719062, 0.554375], [326.274139, 0.526000, 0.663000], [330.624481, 0.388125, 0.818563],
    [335.092377, 0.294000, 0.986000], [339.682678, 0.253313, 1.120687], [344.400482, 0.238000, 1.240000],
    [349.251221, 0.221438, 1.345250], [354.240509, 0.209000, 1.440000], [359.374420, 0.194813, 1.533750],
    [364.659332, 0.186000, 1.610000], [370.102020, 0.192063, 1.641875], [375.709625, 0.200000, 1.670000],
    [381.489777, 0.198063, 1.735000], [387.450562, 0.192000, 1.810000], [393.600555, 0.182000, 1.878750],
    [399.948975, 0.173000, 1.950000], [406.505493, 0.172625, 2.029375], [413.280579, 0.173000, 2.110000],
    [420.285339, 0.166688, 2.186250], [427.531647, 0.160000, 2.260000], [435.032196, 0.158500, 2.329375],
    [442.800629, 0.157000, 2.400000], [450.851562, 0.151063, 2.478750], [459.200653, 0.144000, 2.560000],
    [467.864838, 0.137313, 2.640000], [476.862213, 0.132000, 2.720000], [486.212463, 0.130250, 2.798125],
    [495.936707, 0.130000, 2.880000], [506.057861, 0.129938, 2.973750], [516.600769, 0.130000, 3.070000],
    [527.592224, 0.130063, 3.159375], [539.061646, 0.129000, 3.250000], [551.040771, 0.124375, 3.348125],
    [563.564453, 0.120000, 3.450000], [576.670593, 0.119313, 3.553750], [590.400818, 0.121000, 3.660000],
    [604.800842, 0.125500, 3.766250], [619.920898, 0.131000, 3.880000], [635.816284, 0.136125, 4.010625],
    [652.548279, 0.140000, 4.150000], [670.184753, 0.140063, 4.293125], [688.800964, 0.140000, 4.440000],
    [708.481018, 0.144313, 4.586250], [729.318665, 0.148000, 4.740000], [751.419250, 0.145875, 4.908125],
    [774.901123, 0.143000, 5.090000], [799.897949, 0.142563, 5.288750], [826.561157, 0.145000, 5.500000],
    [855.063293, 0.151938, 5.720624], [885.601257, 0.163000, 5.950000],
];

/// Copper: Mitsuba's `data/ior/Cu.eta.spd`, `Cu.k.spd`.
#[rustfmt::skip]
#[allow(clippy::excessive_precision, clippy::approx_constant)] // the files' digits, as written
const CU: [[f32; 3]; 55] = [
    [302.400421, 1.380000, 1.687000], [306.133759, 1.358438, 1.703313], [309.960449, 1.340000, 1.720000],
    [313.884003, 1.329063, 1.744563], [317.908142, 1.325000, 1.770000], [322.036835, 1.332500, 1.791625],
    [326.274139, 1.340000, 1.810000], [330.624481, 1.334375, 1.822125], [335.092377, 1.325000, 1.834000],
    [339.682678, 1.317812, 1.851750], [344.400482, 1.310000, 1.872000], [349.251221, 1.300313, 1.894250],
    [354.240509, 1.290000, 1.916000], [359.374420, 1.281563, 1.931688], [364.659332, 1.270000, 1.950000],
    [370.102020, 1.249062, 1.972438], [375.709625, 1.225000, 2.015000], [381.489777, 1.200000, 2.121562],
    [387.450562, 1.180000, 2.210000], [393.600555, 1.174375, 2.177188], [399.948975, 1.175000, 2.130000],
    [406.505493, 1.177500, 2.160063], [413.280579, 1.180000, 2.210000], [420.285339, 1.178125, 2.249938],
    [427.531647, 1.175000, 2.289000], [435.032196, 1.172812, 2.326000], [442.800629, 1.170000, 2.362000],
    [450.851562, 1.165312, 2.397625], [459.200653, 1.160000, 2.433000], [467.864838, 1.155312, 2.469187],
    [476.862213, 1.150000, 2.504000], [486.212463, 1.142812, 2.535875], [495.936707, 1.135000, 2.564000],
    [506.057861, 1.131562, 2.589625], [516.600769, 1.120000, 2.605000], [527.592224, 1.092437, 2.595562],
    [539.061646, 1.040000, 2.583000], [551.040771, 0.950375, 2.576500], [563.564453, 0.826000, 2.599000],
    [576.670593, 0.645875, 2.678062], [590.400818, 0.468000, 2.809000], [604.800842, 0.351250, 3.010750],
    [619.920898, 0.272000, 3.240000], [635.816284, 0.230813, 3.458187], [652.548279, 0.214000, 3.670000],
    [670.184753, 0.209250, 3.863125], [688.800964, 0.213000, 4.050000], [708.481018, 0.216250, 4.239563],
    [729.318665, 0.223000, 4.430000], [751.419250, 0.236500, 4.619563], [774.901123, 0.250000, 4.817000],
    [799.897949, 0.254188, 5.034125], [826.561157, 0.260000, 5.260000], [855.063293, 0.280000, 5.485625],
    [885.601257, 0.300000, 5.717000],
];

/// Aluminium: Mitsuba's `data/ior/Al.eta.spd`, `Al.k.spd`.
#[rustfmt::skip]
#[allow(clippy::excessive_precision, clippy::approx_constant)] // the files' digits, as written
const AL: [[f32; 3]; 56] = [
    [298.757050, 0.273375, 3.593750], [302.400421, 0.280000, 3.640000], [306.133759, 0.286813, 3.689375],
    [309.960449, 0.294000, 3.740000], [313.884003, 0.301875, 3.789375], [317.908142, 0.310000, 3.840000],
    [322.036835, 0.317875, 3.894375], [326.274139, 0.326000, 3.950000], [330.624481, 0.334750, 4.005000],
    [335.092377, 0.344000, 4.060000], [339.682678, 0.353813, 4.113750], [344.400482, 0.364000, 4.170000],
    [349.251221, 0.374375, 4.233750], [354.240509, 0.385000, 4.300000], [359.374420, 0.395750, 4.365000],
    [364.659332, 0.407000, 4.430000], [370.102020, 0.419125, 4.493750], [375.709625, 0.432000, 4.560000],
    [381.489777, 0.445688, 4.633750], [387.450562, 0.460000, 4.710000], [393.600555, 0.474688, 4.784375],
    [399.948975, 0.490000, 4.860000], [406.505493, 0.506188, 4.938125], [413.280579, 0.523000, 5.020000],
    [420.285339, 0.540063, 5.108750], [427.531647, 0.558000, 5.200000], [435.032196, 0.577313, 5.290000],
    [442.800629, 0.598000, 5.380000], [450.851562, 0.620313, 5.480000], [459.200653, 0.644000, 5.580000],
    [467.864838, 0.668625, 5.690000], [476.862213, 0.695000, 5.800000], [486.212463, 0.723750, 5.915000],
    [495.936707, 0.755000, 6.030000], [506.057861, 0.789000, 6.150000], [516.600769, 0.826000, 6.280000],
    [527.592224, 0.867000, 6.420000], [539.061646, 0.912000, 6.550000], [551.040771, 0.963000, 6.700000],
    [563.564453, 1.020000, 6.850000], [576.670593, 1.080000, 7.000000], [590.400818, 1.150000, 7.150000],
    [604.800842, 1.220000, 7.310000], [619.920898, 1.300000, 7.480000], [635.816284, 1.390000, 7.650000],
    [652.548279, 1.490000, 7.820000], [670.184753, 1.600000, 8.010000], [688.800964, 1.740000, 8.210000],
    [708.481018, 1.910000, 8.390000], [729.318665, 2.140000, 8.570000], [751.419250, 2.410000, 8.620000],
    [774.901123, 2.630000, 8.600000], [799.897949, 2.800000, 8.450000], [826.561157, 2.740000, 8.310000],
    [855.063293, 2.580000, 8.210000], [885.601257, 2.240000, 8.210000],
];

/// Chromium: Mitsuba's `data/ior/Cr.eta.spd`, `Cr.k.spd` (LLNL CXRO + Palik).
#[rustfmt::skip]
#[allow(clippy::excessive_precision, clippy::approx_constant)] // the files' digits, as written
const CR: [[f32; 3]; 28] = [
    [300.194000, 0.980000, 2.670000], [307.643005, 1.020000, 2.760000], [316.276001, 1.060000, 2.850000],
    [323.708008, 1.120000, 2.950000], [333.279999, 1.180000, 3.040000], [341.542999, 1.260000, 3.120000],
    [351.217987, 1.330000, 3.180000], [362.514984, 1.390000, 3.240000], [372.312012, 1.430000, 3.310000],
    [385.031006, 1.440000, 3.400000], [396.102020, 1.480000, 3.540000], [409.175018, 1.540000, 3.710000],
    [424.589020, 1.650000, 3.890000], [438.092010, 1.800000, 4.060000], [455.808990, 1.990000, 4.220000],
    [471.406982, 2.220000, 4.360000], [490.040009, 2.490000, 4.440000], [512.314026, 2.750000, 4.460000],
    [532.102966, 2.980000, 4.450000], [558.468018, 3.180000, 4.410000], [582.066040, 3.340000, 4.380000],
    [610.739014, 3.480000, 4.360000], [700.452026, 3.840000, 4.370000], [815.658020, 4.230000, 4.340000],
    [826.533020, 4.270000, 4.330000], [849.178040, 4.310000, 4.320000], [860.971985, 4.330000, 4.310000],
    [885.570984, 4.380000, 4.310000],
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_are_increasing_and_interpolate_their_samples() {
        for m in &METALS {
            assert!(m.samples.windows(2).all(|w| w[0][0] < w[1][0]), "{}", m.name);
            for s in m.samples {
                assert_eq!(m.at(s[0]), (s[1], s[2]), "{}", m.name);
            }
            assert_eq!(m.at(100.0), (m.samples[0][1], m.samples[0][2]));
        }
        let gold = Metal::named("Au").unwrap();
        let (eta, _) = gold.at(0.5 * (gold.samples[0][0] + gold.samples[1][0]));
        assert!((eta - 0.5 * (1.795 + 1.812)).abs() < 1e-6);
        assert!(Metal::named("Gold").is_none() && ComplexIor::named("none").unwrap().k == Vec3::ONE);
    }

    #[test]
    fn rgb_values_match_mitsubas_published_gold_and_look_like_their_metals() {
        // Mitsuba's RGB gold, η = (0.1431, 0.3750, 1.4425), k = (3.9832, 2.3857, 1.6032), as
        // Tungsten (`ComplexIorData.hpp`) copies it from Mitsuba: the same sum within ~2%.
        let (eta, k) = Metal::named("Au").unwrap().rgb();
        let (eta_m, k_m) = (Vec3::new(0.1431, 0.3750, 1.4425), Vec3::new(3.9832, 2.3857, 1.6032));
        let close = |a: Vec3, b: Vec3| ((a - b).abs() / b).max_element() < 0.03;
        println!("Au: η {eta}, k {k}");
        assert!(close(eta, eta_m) && close(k, k_m), "η {eta} vs {eta_m}, k {k} vs {k_m}");
        // Gold and copper reflect red best; silver and aluminium are nearly neutral.
        for name in ["Au", "Ag", "Cu", "Al", "Cr"] {
            let c = ComplexIor::named(name).unwrap();
            let f0 = crate::optics::fresnel_conductor(1.0, c.eta, c.k);
            println!("{name}: η {}, k {}, F0 {f0}", c.eta, c.k);
            assert!(f0.cmpgt(Vec3::splat(0.3)).all() && f0.cmplt(Vec3::ONE).all(), "{name}: {f0}");
            match name {
                "Au" | "Cu" => assert!(f0.x > f0.y && f0.y > f0.z, "{name}: {f0}"),
                _ => assert!(f0.max_element() - f0.min_element() < 0.1, "{name}: {f0}"),
            }
        }
    }

    #[test]
    fn spectral_channels_read_the_table_or_blend_the_rgb() {
        let gold = ComplexIor::named("Au").unwrap();
        let w = crate::spectrum::Wavelengths::sample(0.3);
        let (eta, k) = gold.in_channels(&Channels::Spectral(w));
        let metal = gold.metal.unwrap();
        assert_eq!((eta.x, k.x), metal.at(w.lambda[0]));
        assert_eq!((eta.z, k.z), metal.at(w.lambda[2]));
        assert_eq!(gold.in_channels(&Channels::Rgb), (gold.eta, gold.k));
        let grey = ComplexIor::rgb(Vec3::splat(0.5), Vec3::splat(3.0));
        let (eta, k) = grey.in_channels(&Channels::Spectral(w));
        assert!(eta.abs_diff_eq(Vec3::splat(0.5), 1e-5) && k.abs_diff_eq(Vec3::splat(3.0), 1e-5));
    }
}
