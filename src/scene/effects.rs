//! The effects a scene calls for, each with the object or setting that asks for it.
//!
//! Integrators declare what they do with each effect ([`Support`]); the renderer warns before
//! rendering when a scene asks for something the chosen method does not simulate.

use std::fmt;

/// A rendering effect that costs something to simulate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Effect {
    /// A refractive index that varies with wavelength: spectral rendering.
    Dispersion,
    /// Absorbing media (coloured glass): Beer–Lambert attenuation.
    Absorption,
    /// Objects moving while the shutter is open: a time sample per camera ray.
    MotionBlur,
    /// A thin lens with an aperture: a lens sample per camera ray.
    DepthOfField,
    /// Area lights: penumbrae need samples over the light.
    SoftShadows,
    /// An environment light (constant or a map): light from every direction that leaves the scene.
    Environment,
    /// Rough mirrors, conductors (GGX or Beckmann) or dielectrics: glossy reflection and refraction.
    Glossy,
    /// Spatially varying colour.
    Textures,
    /// Triangle meshes.
    Meshes,
}

impl Effect {
    /// Every effect, in the order `vitrum info` lists them.
    pub const ALL: [Effect; 9] = [
        Effect::Dispersion,
        Effect::Absorption,
        Effect::MotionBlur,
        Effect::DepthOfField,
        Effect::SoftShadows,
        Effect::Environment,
        Effect::Glossy,
        Effect::Textures,
        Effect::Meshes,
    ];

    /// Name used in output and metadata.
    pub fn name(self) -> &'static str {
        match self {
            Effect::Dispersion => "dispersion",
            Effect::Absorption => "absorption",
            Effect::MotionBlur => "motion-blur",
            Effect::DepthOfField => "depth-of-field",
            Effect::SoftShadows => "soft-shadows",
            Effect::Environment => "environment",
            Effect::Glossy => "glossy",
            Effect::Textures => "textures",
            Effect::Meshes => "meshes",
        }
    }
}

impl fmt::Display for Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One effect present in a scene and why.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectUse {
    /// The effect.
    pub effect: Effect,
    /// Which object or setting asks for it.
    pub reason: String,
}

/// What an integrator does with an effect.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Support {
    /// Simulated correctly.
    Simulates,
    /// Approximated; the text says how.
    Approximates(&'static str),
    /// Ignored; the text says what is lost.
    Ignores(&'static str),
}

/// The set of effects a scene calls for.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Effects(pub Vec<EffectUse>);

impl Effects {
    /// Record that `effect` is needed because of `reason` (the first reason per effect is kept).
    pub fn add(&mut self, effect: Effect, reason: impl Into<String>) {
        if !self.has(effect) {
            self.0.push(EffectUse { effect, reason: reason.into() });
            self.0.sort_by_key(|u| u.effect);
        }
    }

    /// Whether the scene calls for `effect`.
    pub fn has(&self, effect: Effect) -> bool {
        self.0.iter().any(|u| u.effect == effect)
    }

    /// Comma-separated effect names in canonical order (`none` when empty), as stored in
    /// output metadata.
    pub fn names(&self) -> String {
        let names: Vec<&str> = Effect::ALL.iter().filter(|e| self.has(**e)).map(|e| e.name()).collect();
        if names.is_empty() {
            return "none".into();
        }
        names.join(",")
    }
}
