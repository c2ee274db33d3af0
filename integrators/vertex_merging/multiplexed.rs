//! One strategy of the bidirectional engine at a time, for multiplexed Metropolis light
//! transport (`mmlt`, Hachisuka et al. 2014, as pbrt-v4's `MLTIntegrator`): a full path of a
//! given depth, a camera sub-path of `t` vertices and a light sub-path of `s` with
//! `s + t = depth + 2`, the strategy (s, t) chosen by a uniform number, and that strategy's
//! contribution weighted by the engine's own MIS weights (`bpt`'s, no merging) times the number
//! of strategies.
//!
//! The numbers come from three interleaved streams of the chain's primary sample vector
//! ([`Sampler::primary_stream`]): the camera's (film point, lens, time, wavelength, then the
//! camera sub-path), the light's (the light sub-path, next-event estimation's light sample, the
//! lens point of a connection to the camera) and the connection's (the strategy), so a change
//! of strategy or of one sub-path's length leaves the other sub-path's numbers where they were.
//!
//! The sub-paths are the engine's ([`Engine::camera_subpath`], [`Engine::light_subpath`],
//! [`Engine::walk`]) without Russian roulette, stopped at their last vertex, and the strategies
//! are the engine's: an emitter hit (s = 0), next-event estimation (s = 1), a connection
//! ([`Engine::connect`]) and light tracing's connection to the camera (t = 1,
//! [`Engine::camera_splat_value`]), which lands on the film point the light vertex projects to.
//! The engine counts `N` light paths per iteration against one camera path per pixel; with
//! `N` the film region's pixel count, its densities are those of one camera path uniform over
//! the region and one light path, which is what a sample here is. Delta vertices cannot be
//! connected: a strategy that would connect one gives zero, as in the engine.
//!
//! # The hero alone at smooth dispersive glass
//! Where smooth dispersive glass parts the wavelengths, the other methods of the engine split
//! the sub-path into one branch per wavelength ([`PathContext::part_wavelengths`]); here the
//! sub-paths keep the hero alone instead ([`PathContext::hero_alone`]: at a refraction its
//! secondary wavelengths end and it goes on at weight 3). A sample's state is one path per
//! strategy (s, t), which the chain mutates and weighs by its contribution: split sub-paths
//! would make a tree of up to three camera and three light ends, whose joins the strategy's
//! MIS weight and the chain's acceptance (a scalar contribution of one path) do not define, and
//! each branch's numbers would have to come from the primary sample vector too. Keeping the
//! hero alone leaves every sample one path; its colour noise at dispersive glass is the price.

use super::light_paths::LightVertex;
use super::{Algorithm, Engine, IterationConstants, Next, SubPath, Vertex, WalkVisitor};
use crate::camera::Camera;
use crate::geometry::{Ray, SurfaceHit};
use crate::integrators::light_index;
use crate::integrators::shadow_queue::{ShadowQueue, Shadows};
use crate::integrators::splat_film::CameraTarget;
use crate::integrators::PathContext;
use crate::render::{CameraDims, RenderOptions};
use crate::sampler::{Dim, Sampler};
use crate::scene::{Intersection, Scene};
use crate::spectrum::{Channels, Wavelengths};
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};

/// The streams of a multiplexed sample: the camera's, the light's, the connection's.
const STREAMS: u32 = 3;

/// The bidirectional engine evaluating one strategy per sample.
pub(crate) struct Multiplexed<'a> {
    engine: Engine<'a>,
    k: IterationConstants,
}

/// A multiplexed sample: where it lands and its value.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StrategySample {
    /// The film point (pixel units).
    pub film: Vec2,
    /// The value in RGB, per unit of the film region's uniform measure.
    pub l: Vec3,
    /// The rays traced.
    pub rays: RayCounts,
}

impl<'a> Multiplexed<'a> {
    /// The engine for `scene` seen by `camera` (its film region of `region` pixels), with
    /// `opts`'s depth and the dimensions `dims`: `bpt`'s strategies, no roulette, one ray at a
    /// time.
    pub fn new(
        scene: &'a Scene,
        opts: &'a RenderOptions,
        camera: Camera,
        dims: CameraDims,
        region: f64,
    ) -> Self {
        let engine = Engine {
            light_paths: (region.round() as usize).max(1),
            roulette: false,
            hero_alone: true,
            ..Engine::one_ray(scene, opts, Algorithm::Bpt, camera, dims)
        };
        let k = engine.constants(0);
        Multiplexed { engine, k }
    }

    /// The strategies of a path of `depth` scattering vertices: `depth + 2` (t from 1 to
    /// `depth + 2`), but one for a light seen directly (the engine connects no emission point
    /// to the camera).
    pub fn strategies(depth: u32) -> u32 {
        if depth == 0 {
            1
        } else {
            depth + 2
        }
    }

    /// The sample of depth `depth` whose camera ray passes the film point `origin + u·size`,
    /// drawn from the primary sample vector installed on this thread
    /// ([`crate::sampler::primary::with_primary`]).
    pub fn sample(&self, depth: u32, origin: Vec2, size: Vec2) -> StrategySample {
        let e = &self.engine;
        let mut camera = Sampler::primary_stream(0, STREAMS);
        let light = Sampler::primary_stream(1, STREAMS);
        let mut connection = Sampler::primary_stream(2, STREAMS);
        let n = Multiplexed::strategies(depth);
        let s = if n == 1 { 0 } else { light_index(connection.get_1d(Dim::Other), n as usize) as u32 };
        let t = depth + 2 - s;
        // The camera's numbers first, in the camera pass's order; the light path shares the
        // wavelengths and the time.
        let film = origin + camera.get_2d(Dim::Pixel) * size;
        let lens = if e.dims.lens { camera.get_2d(Dim::Lens) } else { Vec2::ZERO };
        let (open, close) = e.camera.shutter;
        let time = if e.dims.time { open + (close - open) * camera.get_1d(Dim::Time) } else { open };
        let channels = if e.dims.wavelength {
            Channels::Spectral(Wavelengths::sample(camera.get_1d(Dim::Wavelength)))
        } else {
            Channels::Rgb
        };
        let mut rays = RayCounts::default();
        let mut light_ctx = PathContext { hero_alone: e.hero_alone, ..PathContext::new(light) };
        light_ctx.channels = channels;
        let mut camera_ctx = PathContext { hero_alone: e.hero_alone, ..PathContext::new(camera) };
        camera_ctx.channels = channels;
        let n = n as f32;
        if e.lights == 0 && s > 0 {
            return StrategySample { film, l: Vec3::ZERO, rays };
        }
        // The light sub-path's last vertex, or its connection to the camera (t = 1).
        let mut end = LightEnd { vertex: None, splat: None };
        if s >= 2 {
            let to_camera = t == 1;
            rays += self.light_walk(light_ctx.clone(), s - 1, to_camera, time, &mut end);
            if to_camera {
                let l = end.splat.map_or(Vec3::ZERO, |(_, v)| v * (n / (e.pixel_area * (size.x * size.y))));
                return StrategySample { film: end.splat.map_or(film, |(f, _)| f), l, rays };
            }
            if end.vertex.is_none() {
                return StrategySample { film, l: Vec3::ZERO, rays };
            }
        }
        let (walk, mut path) = e.camera_subpath(camera_ctx, film, lens, time);
        let mut visitor = CameraEnd {
            multiplexed: self,
            last: t - 1,
            s,
            light: light_ctx.sampler,
            vertex: end.vertex.as_ref(),
            time,
            value: Vec3::ZERO,
        };
        e.walk(walk.ray, &mut path, &self.k, false, &mut visitor);
        let value = visitor.value;
        rays += path.ctx.rays;
        StrategySample { film, l: path.ctx.channels.to_rgb(value) * n, rays }
    }

    /// The light sub-path up to its vertex `last` (segments from the light), from `ctx`: into
    /// `end` that vertex, or with `to_camera` its connection to the camera. Returns the rays
    /// traced.
    fn light_walk(
        &self,
        ctx: PathContext,
        last: u32,
        to_camera: bool,
        time: f32,
        end: &mut LightEnd,
    ) -> RayCounts {
        let e = &self.engine;
        let Some((_, emission, mut path)) = e.light_subpath(ctx, &self.k) else {
            return RayCounts::default();
        };
        let mut ray = emission.ray;
        ray.time = time;
        path.ctx.rays.primary += 1;
        let mut visitor = LightVisitor { multiplexed: self, last, to_camera, time, end };
        e.walk(ray, &mut path, &self.k, emission.infinite, &mut visitor);
        path.ctx.rays
    }

    /// Whether the opaque shadow ray from `from` reaches `target` (on light `light`) at `time`,
    /// counted in `rays`.
    fn visible(
        &self,
        from: &SurfaceHit,
        target: Vec3,
        light: Option<u32>,
        time: f32,
        rays: &mut RayCounts,
    ) -> bool {
        let shadows = Shadows::new(self.engine.scene, None);
        let ticket = ShadowQueue::<()>::default().ray(&shadows, from, target, light, time, rays);
        ticket.known() == Some(true)
    }
}

/// What the light sub-path ended with.
struct LightEnd {
    /// Its last vertex (on a surface that can be connected).
    vertex: Option<LightVertex>,
    /// Its connection to the camera: the film point and the splat (RGB, visible).
    splat: Option<(Vec2, Vec3)>,
}

/// A light sub-path walking to its vertex `last`.
struct LightVisitor<'m, 'a, 'x> {
    multiplexed: &'m Multiplexed<'a>,
    last: u32,
    to_camera: bool,
    time: f32,
    end: &'x mut LightEnd,
}

impl WalkVisitor for LightVisitor<'_, '_, '_> {
    fn visit(&mut self, path: &mut SubPath, at: &Vertex, primitive: u32) -> Next {
        if path.segments < self.last {
            return Next::Any;
        }
        if at.bsdf.is_delta() {
            return Next::Stop;
        }
        let m = self.multiplexed;
        let e = &m.engine;
        if !self.to_camera {
            self.end.vertex = Some(LightVertex::at(at, path, primitive));
            return Next::Stop;
        }
        let target =
            CameraTarget { camera: &e.camera, lens: e.dims.lens, shadows: Shadows::new(e.scene, None) };
        let (beta, light_mis) = (path.beta, path.mis);
        let projected =
            target.project(at.hit, &mut path.ctx, |_, c| e.camera_splat_value(at, beta, &light_mis, &m.k, c));
        if let Some((c, splat)) = projected {
            if m.visible(at.hit, c.start, None, self.time, &mut path.ctx.rays) {
                self.end.splat = Some((c.film, splat));
            }
        }
        Next::Stop
    }
}

/// A camera sub-path walking to its vertex `last`, where strategy `s` completes the path.
struct CameraEnd<'m, 'a, 'v> {
    multiplexed: &'m Multiplexed<'a>,
    last: u32,
    s: u32,
    /// The light stream (next-event estimation's numbers).
    light: Sampler,
    /// The light sub-path's last vertex (s ≥ 2).
    vertex: Option<&'v LightVertex>,
    time: f32,
    /// The weighted contribution, in the path's channels.
    value: Vec3,
}

impl CameraEnd<'_, '_, '_> {
    /// The probability of picking a given light.
    fn pick(&self) -> f32 {
        1.0 / self.multiplexed.engine.lights.max(1) as f32
    }
}

impl WalkVisitor for CameraEnd<'_, '_, '_> {
    fn escaped(&mut self, path: &mut SubPath, dir: Vec3, absorbed: bool) {
        if self.s != 0 || path.segments != self.last || absorbed {
            return;
        }
        let e = &self.multiplexed.engine;
        // Without an environment light the background is no light: it is seen with weight 1.
        let weight = match e.environment {
            None => 1.0,
            Some(i) => e.emitter_weight(path, self.pick(), false, || {
                e.scene.lights[i].environment_pdfs(&e.sphere, dir)
            }),
        };
        self.value = path.beta * path.ctx.channels.colour(e.scene.background(dir)) * weight;
    }

    fn reached(&mut self, path: &mut SubPath, ray: &Ray, isect: &Intersection) -> bool {
        if path.segments < self.last {
            return true;
        }
        if self.s > 0 {
            return true; // the vertex's strategy, in `visit`
        }
        let e = &self.multiplexed.engine;
        if let Some(index) = e.scene.light_of(isect.primitive) {
            let emitter = &e.scene.lights[index as usize];
            let (hit, wo) = (&isect.hit, -ray.dir);
            let le = emitter.emitted(hit, wo);
            if le != Vec3::ZERO {
                let weight = e.emitter_weight(path, self.pick(), false, || {
                    emitter.emission_pdfs(ray.origin, hit.p, hit.n, wo)
                });
                self.value = path.beta * path.ctx.channels.colour(le) * weight;
            }
        }
        false
    }

    fn visit(&mut self, path: &mut SubPath, at: &Vertex, _: u32) -> Next {
        if path.segments < self.last {
            return Next::Any;
        }
        if at.bsdf.is_delta() {
            return Next::Stop;
        }
        let m = self.multiplexed;
        let (e, k) = (&m.engine, &m.k);
        let term = if self.s == 1 {
            let draw = e.next_event_draw(&mut self.light);
            e.next_event(at, path, k, self.pick(), draw)
        } else {
            self.vertex.and_then(|v| e.connect(at, path, v, k))
        };
        if let Some((value, target, light)) = term {
            if m.visible(at.hit, target, light, self.time, &mut path.ctx.rays) {
                self.value = path.beta * value;
            }
        }
        Next::Stop
    }
}
