//! Progressive renders: an image that grows sample by sample, reported at checkpoints.

use super::*;
use crate::scene::Scene;
use std::time::Instant;

/// How the checkpoints of a progressive render are made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Growth {
    /// One render grows: the checkpoint at N samples is its first N sample indices.
    Incremental,
    /// Every checkpoint is a fresh N-sample render; the text says why.
    Fresh(&'static str),
    /// The method renders one image whatever the sample count: a single checkpoint.
    Fixed(&'static str),
}

/// Where a growing render's samples come from.
pub(super) enum Source<'a> {
    /// The shared camera pass (boxed: it holds the engine choice).
    Camera(Box<Pass<'a>>),
    /// Sample indices the method adds itself.
    Accumulated(&'a dyn Accumulate),
    /// Whole renders (fresh or fixed).
    Renders,
}

/// A render that grows by sample ranges and can report the cumulative image at any count.
pub struct Progressive<'a> {
    pub(super) scene: &'a Scene,
    pub(super) integrator: &'a dyn Integrator,
    pub(super) opts: RenderOptions,
    pub(super) growth: Growth,
    pub(super) source: Source<'a>,
    /// The running sums (incremental growth).
    pub(super) film: Option<Film>,
    /// The latest whole render (fresh or fixed growth).
    pub(super) last: Option<RenderOutput>,
    /// Seconds spent rendering, over all passes or renders.
    pub(super) spent: f64,
}

impl<'a> Progressive<'a> {
    /// A progressive render of `scene` by `integrator` with `opts` (whose budget is ignored: the
    /// caller chooses the sample counts); incremental when the method can grow an image.
    pub fn new(scene: &'a Scene, integrator: &'a dyn Integrator, opts: &RenderOptions) -> Progressive<'a> {
        let (growth, source) = match integrator.progression() {
            Progression::Camera(estimator) => {
                (Growth::Incremental, Source::Camera(Box::new(Pass::new(scene, integrator, estimator, opts))))
            }
            Progression::Accumulated(method) => (Growth::Incremental, Source::Accumulated(method)),
            Progression::Fixed(image) => (Growth::Fixed(image.why()), Source::Renders),
        };
        let film = match &source {
            Source::Camera(pass) => Some(pass.film()),
            Source::Accumulated(method) => Some(method.film(scene, opts)),
            Source::Renders => None,
        };
        Progressive { scene, integrator, opts: opts.clone(), growth, source, film, last: None, spent: 0.0 }
    }

    /// A progressive render whose every checkpoint is a fresh render with the options' own
    /// sampler, for methods that could also grow.
    pub fn fresh(scene: &'a Scene, integrator: &'a dyn Integrator, opts: &RenderOptions) -> Progressive<'a> {
        let mut p = Progressive::new(scene, integrator, opts);
        if p.growth == Growth::Incremental {
            p.growth = Growth::Fresh("each checkpoint is a new render with the scene's sampler, as asked");
            p.source = Source::Renders;
            p.film = None;
        }
        p
    }

    /// How checkpoints are made.
    pub fn growth(&self) -> Growth {
        self.growth
    }

    /// Samples per pixel of the current image (0 before the first advance).
    pub fn spp(&self) -> u32 {
        match (&self.film, &self.last) {
            (Some(film), _) => film.samples,
            (None, Some(out)) => out.spp,
            (None, None) => 0,
        }
    }

    /// Seconds spent rendering so far, over every pass or fresh render.
    pub fn seconds_spent(&self) -> f64 {
        self.spent
    }

    /// Grow the image to `spp` samples per pixel (a fresh `spp`-sample render when the method
    /// cannot grow; nothing after the first render of a fixed method). `progress` gets
    /// (work done, work total) of this step, from worker threads.
    pub fn advance_to(&mut self, spp: u32, progress: &(dyn Fn(u64, u64) + Sync)) {
        let start = Instant::now();
        match (&self.source, self.film.as_mut()) {
            (Source::Camera(pass), Some(film)) if spp > film.samples => {
                pass.add(film, film.samples..spp, 0, progress);
            }
            (Source::Accumulated(method), Some(film)) if spp > film.samples => {
                method.add_samples(self.scene, &self.opts, film.samples..spp, film, progress);
            }
            (Source::Renders, _) => {
                if matches!(self.growth, Growth::Fixed(_)) && self.last.is_some() {
                    return;
                }
                let opts = RenderOptions { budget: Budget::Samples(spp), ..self.opts.clone() };
                let out = render(self.scene, self.integrator, &opts, progress);
                self.spent += out.seconds;
                self.last = Some(out);
                return;
            }
            _ => return,
        }
        let seconds = start.elapsed().as_secs_f64();
        let film = self.film.as_mut().expect("incremental renders have a film");
        let added = spp.saturating_sub(film.samples);
        film.advance(added);
        film.seconds += seconds;
        self.spent += seconds;
    }

    /// The current image: the cumulative render (its seconds are the time spent on all its
    /// passes), or the latest fresh render; `None` before the first advance.
    pub fn output(&self) -> Option<RenderOutput> {
        match (&self.film, &self.last) {
            (Some(film), _) if film.samples > 0 => Some(film.output()),
            (None, Some(out)) => Some(out.clone()),
            _ => None,
        }
    }
}

/// The checkpoints of a progressive render up to `max` samples: every power of two below it,
/// then `max` itself.
pub fn power_of_two_checkpoints(max: u32) -> Vec<u32> {
    let mut out: Vec<u32> = (0..32).map(|k| 1u32 << k).take_while(|&n| n < max).collect();
    if max > 0 {
        out.push(max);
    }
    out
}

/// Render progressively under `opts.budget` and call `checkpoint` with the cumulative render at
/// every power of two: up to `Budget::Samples(max)` (and at `max`), or until the render time
/// reaches `Budget::Time` (and where it stops, growing by 1-sample passes). With `fresh`, every
/// checkpoint is rendered anew ([`Progressive::fresh`]). A fixed method has one checkpoint.
/// `progress` gets (done, total) in thousandths of a sample per pixel (sample budgets) or in
/// milliseconds (time budgets). Returns how the checkpoints were made.
pub fn render_progressive(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    fresh: bool,
    progress: &(dyn Fn(u64, u64) + Sync),
    checkpoint: &mut dyn FnMut(&RenderOutput),
) -> Growth {
    let mut p = if fresh {
        Progressive::fresh(scene, integrator, opts)
    } else {
        Progressive::new(scene, integrator, opts)
    };
    let growth = p.growth();
    // Progress of a step from `from` to `to` work units out of `total`.
    let step = |from: u64, to: u64, total: u64| {
        move |done: u64, of: u64| progress((from + (to - from) * done / of.max(1)).min(total), total)
    };
    match opts.budget {
        Budget::Samples(max) => {
            let targets = match growth {
                Growth::Fixed(_) => vec![max],
                _ => power_of_two_checkpoints(max),
            };
            // Work in thousandths of a sample: what each step renders.
            let cost = |prev: u32, t: u32| match growth {
                Growth::Incremental => (t - prev) as u64 * 1000,
                _ => t as u64 * 1000,
            };
            let (mut total, mut prev) = (0u64, 0u32);
            for &t in &targets {
                total += cost(prev, t);
                prev = t;
            }
            let (mut done, mut prev) = (0u64, 0u32);
            for &target in &targets {
                let next = done + cost(prev, target);
                p.advance_to(target, &step(done, next, total));
                checkpoint(&p.output().expect("rendered"));
                (done, prev) = (next, target);
            }
        }
        Budget::Time(limit) => {
            let total = limit.as_millis().max(1) as u64;
            let mut spp = 0u32;
            loop {
                spp = match growth {
                    Growth::Incremental => spp + 1,
                    Growth::Fresh(_) => (spp * 2).max(1),
                    Growth::Fixed(_) => 1,
                };
                // Progress in milliseconds of render time.
                let (before, start) = ((p.seconds_spent() * 1000.0) as u64, Instant::now());
                let timed = |_: u64, _: u64| {
                    progress((before + start.elapsed().as_millis() as u64).min(total), total)
                };
                p.advance_to(spp, &timed);
                let out_of_time =
                    p.seconds_spent() >= limit.as_secs_f64() || matches!(growth, Growth::Fixed(_));
                if spp.is_power_of_two() || out_of_time {
                    checkpoint(&p.output().expect("rendered"));
                }
                progress(((p.seconds_spent() * 1000.0) as u64).min(total), total);
                if out_of_time || spp == u32::MAX {
                    break;
                }
            }
        }
    }
    growth
}
