//! Primary sample space for Metropolis light transport (Kelemen et al. 2002): a path is a
//! function of an infinite vector of uniform numbers u ∈ [0, 1)^∞, the numbers a method draws
//! through its [`Sampler`](super::Sampler) in order, and a Markov chain mutates that vector.
//!
//! [`PrimarySamples`] holds one chain's vector, mutated lazily as pbrt-v4's `MLTSampler` does: a
//! number is brought up to date only when the path asks for it. A *large step* replaces every
//! number by a fresh uniform one; a *small step* moves each by a normal offset of standard
//! deviation σ, wrapped around [0, 1). A number last touched `n` small steps ago gets their sum
//! at once (one normal offset of deviation σ·√n), one not touched since a large step was
//! accepted gets the fresh value that step gave it. [`PrimarySamples::reject`] puts back every
//! number the proposal changed, bit for bit.
//!
//! Every random number is a pure function of the chain's keys, the proposal's number and the
//! dimension (a counter-based hash, no generator state), so a chain is the same whatever thread
//! runs it and in whatever order its numbers are asked for. A chain starts from the state whose
//! numbers are keyed by `start` at proposal 0 (a bootstrap sample of the method, which evaluates
//! the same numbers alone) and mutates with numbers keyed by `chain`.
//!
//! A method's estimator draws from the chain unchanged: the Metropolis driver installs the chain
//! on its thread around one evaluation ([`with_primary`]) and the evaluation's sampler is
//! [`Sampler::primary`](super::Sampler::primary), whose dimension counter indexes the vector.

use super::{mix64, ONE_MINUS_EPSILON};
use std::cell::RefCell;

/// One number of the primary sample vector, with what undoes its last change.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct PrimarySample {
    /// The value, in [0, 1).
    value: f64,
    /// The iteration that last changed it.
    modified: u64,
    /// The value before the current proposal changed it.
    backup: f64,
    /// `modified` before the current proposal changed it.
    modified_backup: u64,
}

/// What a hashed number is for, so that the numbers of one proposal never coincide.
#[derive(Clone, Copy)]
#[repr(u64)]
enum Purpose {
    /// A dimension's fresh value (a large step).
    Fresh = 1,
    /// A dimension's small-step offset.
    Offset = 2,
    /// Whether the proposal is a large step.
    LargeStep = 3,
    /// The acceptance test.
    Accept = 4,
}

/// The primary sample vector of one Markov chain and its lazy mutations.
#[derive(Clone, Debug, Default)]
pub struct PrimarySamples {
    x: Vec<PrimarySample>,
    /// Key of the starting state's numbers.
    start: u64,
    /// Key of the chain's mutations.
    chain: u64,
    /// Standard deviation of a small step.
    sigma: f64,
    /// Probability that a proposal is a large step.
    large_step_probability: f64,
    /// The iteration of the state being evaluated: the accepted states' count (a rejected
    /// proposal's iteration is used again by the next one, as in pbrt).
    iteration: u64,
    /// The iteration of the last accepted large step (0: the starting state).
    last_large_step: u64,
    /// The proposal of the last accepted large step (0: the starting state).
    last_large_proposal: u64,
    /// Whether the current proposal is a large step.
    large_step: bool,
    /// Proposals made so far: what keys the proposal's random numbers.
    proposal: u64,
}

impl PrimarySamples {
    /// The starting state keyed by `start` (every number fresh, as a large step gives it), whose
    /// mutations are keyed by `chain`: small steps of deviation `sigma`, large steps with
    /// probability `large_step_probability`.
    pub fn new(start: u64, chain: u64, sigma: f64, large_step_probability: f64) -> PrimarySamples {
        PrimarySamples {
            x: Vec::new(),
            start,
            chain,
            sigma,
            large_step_probability,
            iteration: 0,
            last_large_step: 0,
            last_large_proposal: 0,
            large_step: true,
            proposal: 0,
        }
    }

    /// A uniform number in [0, 1) for `purpose` at dimension `d` of proposal `proposal` (the
    /// starting state's numbers, proposal 0, are keyed by `start`, the others by `chain`).
    fn uniform(&self, proposal: u64, purpose: Purpose, d: u64) -> f64 {
        let key = if proposal == 0 { self.start } else { self.chain };
        let h = mix64(
            key ^ mix64(
                proposal.wrapping_mul(0x9e37_79b9_7f4a_7c15)
                    ^ (purpose as u64).wrapping_mul(0xd6e8_feb8_6659_fd93)
                    ^ d.wrapping_mul(0xa076_1d64_78bd_642f),
            ),
        );
        (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Begin the next proposal: a large step with the chain's probability, else a small step.
    pub fn start_iteration(&mut self) {
        self.proposal += 1;
        self.iteration += 1;
        self.large_step = self.uniform(self.proposal, Purpose::LargeStep, 0) < self.large_step_probability;
    }

    /// Whether the current proposal is a large step.
    pub fn is_large_step(&self) -> bool {
        self.large_step
    }

    /// The uniform number of the current proposal's acceptance test.
    pub fn accept_draw(&self) -> f64 {
        self.uniform(self.proposal, Purpose::Accept, 0)
    }

    /// Keep the proposal: it becomes the chain's state.
    pub fn accept(&mut self) {
        if self.large_step {
            self.last_large_step = self.iteration;
            self.last_large_proposal = self.proposal;
        }
    }

    /// Drop the proposal: every number it changed gets back its value, bit for bit.
    pub fn reject(&mut self) {
        for x in &mut self.x {
            if x.modified == self.iteration {
                x.value = x.backup;
                x.modified = x.modified_backup;
            }
        }
        self.iteration -= 1;
    }

    /// The number of dimension `d` in the current proposal, in [0, 1), brought up to date.
    pub fn get(&mut self, d: u32) -> f32 {
        let d = d as usize;
        if d >= self.x.len() {
            // Never drawn: its value is the one the last accepted large step (or the start)
            // gave every dimension.
            let (from, proposal) = (self.last_large_step, self.last_large_proposal);
            let fresh = |i: usize| self.uniform(proposal, Purpose::Fresh, i as u64);
            let grown: Vec<PrimarySample> = (self.x.len()..=d)
                .map(|i| PrimarySample { value: fresh(i), modified: from, ..Default::default() })
                .collect();
            self.x.extend(grown);
        }
        let x = self.x[d];
        let mut x = if x.modified < self.last_large_step {
            // Untouched since a large step was accepted: the value that step gave it.
            PrimarySample {
                value: self.uniform(self.last_large_proposal, Purpose::Fresh, d as u64),
                modified: self.last_large_step,
                ..x
            }
        } else {
            x
        };
        if x.modified < self.iteration {
            x.backup = x.value;
            x.modified_backup = x.modified;
            x.value = if self.large_step {
                self.uniform(self.proposal, Purpose::Fresh, d as u64)
            } else {
                // The sum of the small steps since it last changed: one normal offset.
                let n = (self.iteration - x.modified) as f64;
                let offset = self.sigma * n.sqrt() * self.normal(d as u64);
                wrap(x.value + offset)
            };
            x.modified = self.iteration;
        }
        self.x[d] = x;
        (x.value as f32).min(ONE_MINUS_EPSILON)
    }

    /// A standard normal number for dimension `d` of the current proposal (Box–Muller).
    fn normal(&self, d: u64) -> f64 {
        let u1 = 1.0 - self.uniform(self.proposal, Purpose::Offset, 2 * d);
        let u2 = self.uniform(self.proposal, Purpose::Offset, 2 * d + 1);
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// The value of dimension `d` in the chain's current state, without mutating it (`None` if
    /// it was never drawn): what a test reads to see a rejection undone.
    pub fn held(&self, d: u32) -> Option<f64> {
        let x = self.x.get(d as usize)?;
        Some(if x.modified < self.last_large_step {
            // Untouched since a large step was accepted: the value that step gave it.
            self.uniform(self.last_large_proposal, Purpose::Fresh, d as u64)
        } else {
            x.value
        })
    }

    /// The dimensions drawn so far.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// Whether no dimension was drawn yet.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
}

/// `v` wrapped around [0, 1).
fn wrap(v: f64) -> f64 {
    let w = v - v.floor();
    // A tiny negative `v` rounds to 1.
    if w < 1.0 {
        w
    } else {
        0.0
    }
}

thread_local! {
    /// The chain whose numbers the primary samplers of this thread draw.
    static PRIMARY: RefCell<Option<PrimarySamples>> = const { RefCell::new(None) };
}

/// Run `f` with `state` installed as this thread's primary sample vector: every
/// [`Sampler::primary`](super::Sampler::primary) stream that `f` draws from reads it. The state
/// (moved in and back out, no copy) carries the numbers `f` drew.
pub fn with_primary<T>(state: &mut PrimarySamples, f: impl FnOnce() -> T) -> T {
    let previous = PRIMARY.with(|p| p.borrow_mut().replace(std::mem::take(state)));
    debug_assert!(previous.is_none(), "primary sample vectors do not nest");
    let out = f();
    *state = PRIMARY.with(|p| p.borrow_mut().take()).expect("the installed state is still there");
    out
}

/// Dimension `d` of this thread's installed primary sample vector.
///
/// # Panics
/// Outside [`with_primary`]: a primary sampler drawn from where no chain is installed is a
/// mistake of the method, not of any input.
pub(super) fn draw(d: u32) -> f32 {
    PRIMARY.with(|p| p.borrow_mut().as_mut().expect("a primary sampler draws inside `with_primary`").get(d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_stays_in_the_unit_interval() {
        for v in [-1e-300, -0.0, 0.0, 0.999_999_999_999_999_9, 1.0, 2.5, -0.25, -1e-17] {
            let w = wrap(v);
            assert!((0.0..1.0).contains(&w), "{v} → {w}");
        }
    }
}
