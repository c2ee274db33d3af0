//! The effects a scene calls for, each with the object or setting that asks for it.
//!
//! Integrators declare what they do with each effect ([`Support`]); the renderer warns before
//! rendering when a scene asks for something the chosen method does not simulate.

use std::fmt;

/// A rendering effect that costs something to simulate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Effect {
    /// Area lights: penumbrae need samples over the light.
    SoftShadows,
    /// Spatially varying colour.
    Textures,
    /// Triangle meshes.
    Meshes,
}

impl Effect {
    /// Name used in output and metadata.
    pub fn name(self) -> &'static str {
        match self {
            Effect::SoftShadows => "soft-shadows",
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
    /// Record that `effect` is needed because of `reason` (first reason per effect kept, others
    /// counted).
    pub fn add(&mut self, effect: Effect, reason: impl Into<String>) {
        if !self.has(effect) {
            self.0.push(EffectUse { effect, reason: reason.into() });
        }
    }

    /// Whether the scene calls for `effect`.
    pub fn has(&self, effect: Effect) -> bool {
        self.0.iter().any(|u| u.effect == effect)
    }

    /// Comma-separated effect names (`none` when empty), as stored in output metadata.
    pub fn names(&self) -> String {
        if self.0.is_empty() {
            return "none".into();
        }
        self.0.iter().map(|u| u.effect.name()).collect::<Vec<_>>().join(",")
    }
}
