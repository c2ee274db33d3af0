//! A sub-path of the bidirectional engine: its running state, what its channels carry (for
//! joining it with another half), and the branches smooth dispersive glass splits from it, one
//! wavelength each, which the engine walks when the walk in flight ends.

use super::{Engine, IterationConstants, Mis, Vertex, Walk};
use crate::bsdf::TransportMode;
use crate::geometry::spawn_origin;
use crate::integrators::PathContext;
use crate::lighting::crossing;
use crate::material::Material;
use crate::render::{Branch, PendingBranches};
use crate::spectrum::Channels;
use glam::Vec3;

/// The running state of a sub-path.
pub(super) struct SubPath {
    pub(super) ctx: PathContext,
    /// Camera paths gather radiance, light paths carry importance.
    pub(super) mode: TransportMode,
    /// The path's weight: its value over its density, the light's emitted power included.
    pub(super) beta: Vec3,
    /// `beta` without the light's emission and the spectral factors: the roulette's measure of
    /// a light path.
    pub(super) throughput: Vec3,
    /// The product of η² over the refractions so far: the radiance scaling a camera path's
    /// roulette leaves out (pbrt-v4's `etaScale`).
    pub(super) eta_scale: f32,
    pub(super) mis: Mis,
    pub(super) segments: u32,
    pub(super) specular_path: bool,
    /// The distance from the sub-path's true start to its first ray's origin: a camera ray
    /// clipped by the near plane starts that far from the lens point, which the first
    /// segment's density conversion must count (0 otherwise).
    pub(super) start_offset: f32,
    /// What its channels carry (for joining it with another half).
    pub(super) carries: Carries,
    /// The branches smooth dispersive glass split from it (one wavelength each), waiting for the
    /// walk in flight to end ([`SubPath::resume_branch`]).
    branches: PendingBranches<BranchStart>,
}

/// What a sub-path's channels carry, which decides the factor of a full path joined from two
/// halves ([`joined`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Carries {
    /// Every channel, each at weight 1 (RGB, or the three wavelengths together).
    All,
    /// The hero's channel alone at weight 3 ([`crate::spectrum::HERO_ONLY`]): its secondary
    /// wavelengths ended (rough dispersive glass; `mmlt`'s smooth dispersive refraction).
    Hero,
    /// This one channel at weight 1: the sub-path split its wavelengths at smooth dispersive
    /// glass (its lead goes on with its own channel, every branch with its own).
    Channel(u8),
}

impl Carries {
    /// The channel it carries alone, if it does (the hero's is channel 0).
    fn channel(self) -> Option<u8> {
        match self {
            Carries::All => None,
            Carries::Hero => Some(0),
            Carries::Channel(c) => Some(c),
        }
    }

    /// The channels a vertex of a sub-path carrying this evaluates its scattering in, from a
    /// path's `channels`: those of its own wavelength where it carries one channel.
    pub(super) fn channels(self, channels: &Channels) -> Channels {
        match (self, channels) {
            (Carries::Channel(c), Channels::Spectral(w)) => Channels::Spectral(w.led_by(c as usize)),
            _ => *channels,
        }
    }
}

/// Where a branch of a split sub-path starts: its walk and its state past the glass.
#[derive(Clone, Copy)]
struct BranchStart {
    walk: Walk,
    pub(super) beta: Vec3,
    pub(super) throughput: Vec3,
    pub(super) eta_scale: f32,
    pub(super) mis: Mis,
    pub(super) segments: u32,
    pub(super) specular_path: bool,
}

impl SubPath {
    /// A sub-path of weight `beta` and MIS state `mis` at its first segment.
    pub(super) fn new(ctx: PathContext, mode: TransportMode, beta: Vec3, mis: Mis) -> SubPath {
        SubPath {
            ctx,
            mode,
            beta,
            throughput: Vec3::ONE,
            eta_scale: 1.0,
            mis,
            segments: 1,
            specular_path: true,
            start_offset: 0.0,
            carries: Carries::All,
            branches: PendingBranches::default(),
        }
    }

    /// Puts the next branch waiting (if one does) in the place of the sub-path, whose walk
    /// `walk` has ended: its state and walk, its channels' indices taken at its wavelength, its
    /// random stream replaying from the split. False where none waits.
    #[inline]
    pub(super) fn resume_branch(&mut self, walk: &mut Walk) -> bool {
        let Some(branch) = self.branches.resume(&mut self.ctx.channels) else { return false };
        self.ctx.sampler.replay_from(branch.replay);
        let b = branch.state;
        *walk = b.walk;
        (self.beta, self.throughput, self.eta_scale) = (b.beta, b.throughput, b.eta_scale);
        (self.mis, self.segments, self.specular_path) = (b.mis, b.segments, b.specular_path);
        self.carries = Carries::Channel(branch.channel as u8);
        true
    }

    /// The MIS update on scattering into `wi` with forward density `pdf` and reverse density
    /// `rev` (both ignored for specular and multiply scattered samples).
    pub(super) fn scatter(
        &mut self,
        k: &IterationConstants,
        cos_out: f32,
        pdf: f32,
        rev: f32,
        evaluable: bool,
    ) {
        self.mis.scatter(k, cos_out, pdf, rev, evaluable);
        self.specular_path &= !evaluable;
    }

    /// The probability Russian roulette keeps the path with (before clamping to 1): a camera
    /// path's weight without the radiance scaling of refraction, a light path's throughput.
    pub(super) fn survival(&self) -> f32 {
        match self.mode {
            TransportMode::Radiance => (self.beta * self.eta_scale).max_element(),
            TransportMode::Importance => self.throughput.max_element(),
        }
    }
}

/// The factor of a full path joined from two halves that carry `a` and `b`: 1/3 when both
/// carry the hero alone at weight 3 (the path counts the factor 3 once); 0 when they carry no
/// channel in common (a branch of one wavelength with another's, or with the hero alone); 1
/// otherwise (a branch's one channel at weight 1 joined with anything that carries it).
#[inline]
pub(super) fn joined(a: Carries, b: Carries) -> f32 {
    match (a.channel(), b.channel()) {
        _ if a == Carries::Hero && b == Carries::Hero => 1.0 / 3.0,
        (Some(x), Some(y)) if x != y => 0.0,
        _ => 1.0,
    }
}

impl Engine<'_> {
    /// Wavelength splitting at smooth dispersive glass `material` at vertex `at` of `path`
    /// (walking `walk`), after `smp`, the lead wavelength's sample drawn with `numbers`, as
    /// [`PathContext::part_wavelengths`] decides: the factor the sub-path's own weight takes
    /// (its lead's channel alone where the wavelengths part). Every wavelength parted from it
    /// becomes a branch set aside in `path` ([`SubPath::resume_branch`]): the sub-path's state
    /// here, updated by the branch's own sample (its weight, direction, medium and η², the MIS
    /// update of a specular sample), replaying the sub-path's numbers from here on.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn split_wavelengths(
        &self,
        walk: &Walk,
        path: &mut SubPath,
        k: &IterationConstants,
        at: &Vertex,
        material: &Material,
        smp: &crate::bsdf::BsdfSample,
        numbers: (f32, glam::Vec2),
    ) -> Vec3 {
        let hero_only = path.ctx.hero_only;
        let (factor, parted) = path.ctx.part_wavelengths(
            material,
            at.hit,
            at.frame,
            at.wo,
            smp,
            at.wo_local,
            numbers,
            path.mode,
        );
        if hero_only || !path.ctx.hero_only {
            return factor;
        }
        let Channels::Spectral(w) = path.ctx.channels else { return factor };
        if path.ctx.hero_alone {
            // The secondaries ended at a refraction: the hero alone, weight 3.
            path.carries = Carries::Hero;
            return factor;
        }
        path.carries = Carries::Channel(w.lead() as u8);
        let replay = path.ctx.sampler.dimension();
        for p in parted.into_iter().flatten() {
            let mut mis = path.mis;
            mis.scatter(k, p.sample.wi.z.abs(), p.sample.pdf, 0.0, false);
            let absorption = crossing(&material.bsdf, walk.ray.dir, at.hit.n, p.channels.hero()).map_or(
                walk.absorption,
                |c| {
                    let medium = if p.sample.is_transmission { c.transmitted } else { c.incident };
                    p.channels.colour(medium.absorption)
                },
            );
            let eta = if p.sample.is_transmission { p.sample.eta * p.sample.eta } else { 1.0 };
            let state = BranchStart {
                walk: Walk { ray: walk.ray.spawn(spawn_origin(at.hit, p.wi), p.wi), absorption, ..*walk },
                beta: path.beta * p.weight,
                throughput: path.throughput * p.weight,
                eta_scale: path.eta_scale * eta,
                mis,
                segments: path.segments + 1,
                specular_path: path.specular_path,
            };
            path.branches.push(Branch { channel: p.channel, state, replay });
        }
        factor
    }
}
