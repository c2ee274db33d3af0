//! The render drivers: budgets in passes of adaptive size, interrupts, and the entry points
//! (`render`, `camera_pass`, `render_accumulated`, render parts).

use super::*;
use crate::scene::Scene;
use std::ops::Range;
use std::time::{Duration, Instant};

/// Seconds a sample pass should take: long enough that the pass overhead (a parallel loop's
/// start and tail) is negligible, short enough that a stop request is honoured promptly.
pub(super) const PASS_SECONDS: f64 = 0.25;

/// The sample count of the pass after one of `size` samples that took `took`: doubled while
/// passes are short, halved (down to one) when they are long.
pub(super) fn next_pass_size(size: u32, took: Duration) -> u32 {
    let t = took.as_secs_f64();
    if t < PASS_SECONDS / 2.0 {
        size.saturating_mul(2)
    } else if t > 2.0 * PASS_SECONDS {
        (size / 2).max(1)
    } else {
        size
    }
}

/// How a sample range is added to a film: `add(film, samples, total, progress)` adds the sample
/// indices `samples` of `total` planned (0 when the count is not known in advance), reporting
/// (work done, work total) of this call to `progress`.
pub(super) type AddSamples<'f> = dyn FnMut(&mut Film, Range<u32>, u32, &(dyn Fn(u64, u64) + Sync)) + 'f;

/// Spend `budget` on `film` in sample passes, checking `stop()` between passes: after a stop
/// the film holds the whole passes done (at least one), a whole number of samples per pixel.
/// `after_pass` sees the film after every pass (checkpoints). `progress` gets (done, total) of
/// the whole render: thousandths of a sample per pixel for a sample budget, milliseconds for a
/// time budget.
///
/// A sample budget of `n` adds the sample indices from the film's next one up to `n`, in passes
/// of adaptive size (see [`next_pass_size`]), each with `total` = `planned` (or `n`). Films sum
/// every pixel's samples in index order whatever the ranges asked for, so the passes change no
/// bit of the result, and the timing that sizes them cannot either. A time budget adds 1-sample
/// passes until the film's seconds have grown by the limit. Only the passes count as render
/// time, not what `after_pass` does.
pub(super) fn run_budget(
    film: &mut Film,
    budget: Budget,
    planned: Option<u32>,
    stop: &dyn Fn() -> bool,
    progress: &(dyn Fn(u64, u64) + Sync),
    add: &mut AddSamples<'_>,
    after_pass: &mut dyn FnMut(&Film),
) {
    let mut rendered = 0.0f64;
    match budget {
        Budget::Samples(n) => {
            let (first, total) = (film.next_sample().min(n), planned.unwrap_or(n));
            let span = (n - first) as u64 * 1000;
            let mut size = 1u32;
            while film.next_sample() < n {
                let from = film.next_sample();
                let to = from + size.min(n - from);
                let pass_start = Instant::now();
                // Thousandths of a sample per pixel over the whole render.
                let pass_progress = |done: u64, of: u64| {
                    let within = (to - from) as u128 * 1000 * done as u128 / of.max(1) as u128;
                    progress(((from - first) as u64 * 1000 + within as u64).min(span), span)
                };
                add(film, from..to, total, &pass_progress);
                film.advance(to - from);
                let took = pass_start.elapsed();
                film.seconds += took.as_secs_f64();
                after_pass(film);
                if stop() {
                    break;
                }
                size = next_pass_size(size, took);
            }
        }
        // The sample count is unknown in advance: no stratification across passes.
        Budget::Time(limit) => {
            let total = (limit.as_millis() as u64).max(1);
            let limit = limit.as_secs_f64();
            loop {
                let (s, pass_start) = (film.next_sample(), Instant::now());
                let timed = |_: u64, _: u64| {
                    let ms = ((rendered + pass_start.elapsed().as_secs_f64()) * 1000.0) as u64;
                    progress(ms.min(total), total)
                };
                add(film, s..s + 1, 0, &timed);
                film.advance(1);
                let took = pass_start.elapsed().as_secs_f64();
                (rendered, film.seconds) = (rendered + took, film.seconds + took);
                after_pass(film);
                if rendered >= limit || stop() || film.next_sample() == u32::MAX {
                    break;
                }
            }
        }
    }
}

/// Spend `pass`'s budget on `film` with the shared camera pass, stopping on a stop request.
pub(super) fn run_camera_pass(
    pass: &Pass<'_>,
    film: &mut Film,
    progress: &(dyn Fn(u64, u64) + Sync),
    after_pass: &mut dyn FnMut(&Film),
) {
    let opts = &pass.opts;
    let add = &mut |film: &mut Film, samples, total, p: &(dyn Fn(u64, u64) + Sync)| {
        pass.add(film, samples, total, p)
    };
    let stop = &crate::interrupt::stop_requested;
    run_budget(film, opts.budget, opts.planned_spp, stop, progress, add, after_pass);
}

/// Spend `opts.budget` on `film` with a method that adds sample indices itself, stopping on a
/// stop request.
pub(super) fn run_accumulated(
    scene: &Scene,
    method: &dyn Accumulate,
    opts: &RenderOptions,
    film: &mut Film,
    progress: &(dyn Fn(u64, u64) + Sync),
    after_pass: &mut dyn FnMut(&Film),
) {
    let add = &mut |film: &mut Film, samples, _, p: &(dyn Fn(u64, u64) + Sync)| {
        method.add_samples(scene, opts, samples, film, p)
    };
    let stop = &crate::interrupt::stop_requested;
    run_budget(film, opts.budget, opts.planned_spp, stop, progress, add, after_pass);
}

/// Render `scene` with `integrator`; `progress` is called with (work done, work total) of the
/// whole render, from worker threads. After a stop request ([`crate::interrupt`]) the render
/// ends at its next pass boundary and returns the samples done (`spp` counts them); methods with
/// one fixed pattern (`ssaa`) finish.
pub fn render(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RenderOutput {
    match integrator.progression() {
        Progression::Camera(_) => camera_pass(scene, integrator, opts, progress).0,
        Progression::Accumulated(method) => render_accumulated(scene, method, opts, progress),
        Progression::Fixed(image) => image.render(scene, opts, progress),
    }
}

/// The shared camera pass, with the sampler requests it made per purpose; it stops early, at a
/// whole number of samples per pixel, when a stop is requested ([`crate::interrupt`]).
pub fn camera_pass(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (RenderOutput, DimensionRequests) {
    let film = camera_film(scene, integrator, opts, progress);
    (film.output(), film.requests)
}

/// The film of [`camera_pass`], with its counters (rays, sampler requests).
///
/// # Panics
/// For a method that does not estimate per camera ray ([`Progression::Camera`]).
pub fn camera_film(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Film {
    let pass = camera_pass_of(scene, integrator, opts);
    let mut film = pass.film();
    run_camera_pass(&pass, &mut film, progress, &mut |_| {});
    film
}

/// [`camera_film`] on the engine `engine` instead of the one the method chooses: its caller
/// can hold the engine and read its statistics after the render.
pub fn camera_film_on(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    engine: EngineChoice,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Film {
    let pass = Pass { engine, ..camera_pass_of(scene, integrator, opts) };
    let mut film = pass.film();
    run_camera_pass(&pass, &mut film, progress, &mut |_| {});
    film
}

/// The camera passes of `integrator`, which must estimate per camera ray.
fn camera_pass_of<'a>(scene: &'a Scene, integrator: &'a dyn Integrator, opts: &RenderOptions) -> Pass<'a> {
    let Some(estimator) = integrator.camera() else {
        panic!("the camera pass runs methods that estimate per camera ray, not `{}`", integrator.name())
    };
    Pass::new(scene, integrator, estimator, opts)
}

/// Render `opts.budget` with a method that adds sample indices itself
/// ([`Progression::Accumulated`]): in passes of whole sample indices until the samples are done,
/// the time is up or a stop is requested ([`crate::interrupt`]).
pub fn render_accumulated(
    scene: &Scene,
    method: &dyn Accumulate,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RenderOutput {
    let mut film = method.film(scene, opts);
    run_accumulated(scene, method, opts, &mut film, progress, &mut |_| {});
    film.output()
}

/// An empty film for a render of `scene` by `integrator` whose sample indices start at `first`
/// (a shard of a larger render, see [`render_part`]); `Err` with the reason for a method that
/// cannot grow an image by sample indices (`ssaa`'s one fixed pattern).
pub fn part_film(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    first: u32,
) -> Result<Film, &'static str> {
    let mut film = match integrator.progression() {
        Progression::Camera(estimator) => Pass::new(scene, integrator, estimator, opts).film(),
        Progression::Accumulated(method) => method.film(scene, opts),
        Progression::Fixed(image) => return Err(image.why()),
    };
    film.first = first;
    Ok(film)
}

/// Continue `film` (new from [`part_film`], or read back from a checkpoint) under
/// `opts.budget`: a sample budget of `n` adds the sample indices from [`Film::next_sample`] up
/// to `n` (sample `s` drawn as sample `s` of `opts.planned_spp`, or of `n`), a time budget adds
/// 1-sample passes for that long. `after_pass` sees the film after every pass (to write
/// checkpoints); a stop request ([`crate::interrupt`]) ends the render at a pass boundary. The
/// sums are continued in index order, so a film rendered `a..k`, written, read back and
/// continued `k..b` holds the bits of one render of `a..b`. `Err` as for [`part_film`].
pub fn render_part(
    scene: &Scene,
    integrator: &dyn Integrator,
    opts: &RenderOptions,
    film: &mut Film,
    progress: &(dyn Fn(u64, u64) + Sync),
    after_pass: &mut dyn FnMut(&Film),
) -> Result<(), &'static str> {
    match integrator.progression() {
        Progression::Camera(estimator) => {
            run_camera_pass(&Pass::new(scene, integrator, estimator, opts), film, progress, after_pass)
        }
        Progression::Accumulated(method) => run_accumulated(scene, method, opts, film, progress, after_pass),
        Progression::Fixed(image) => return Err(image.why()),
    }
    Ok(())
}
