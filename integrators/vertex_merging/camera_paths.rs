//! The camera sub-paths of an iteration: a camera path gathers emitters it hits, next-event
//! estimation, connections to the vertices of its partner light path (camera path `j` with
//! light path `j mod N`) and merges with every photon of the iteration, each weighted against
//! the other strategies. The terms of a row of camera paths are summed per pixel in the order
//! the path makes them; those that need a clear line of sight (next-event estimation,
//! connections) wait for their shadow rays in the row's queue ([`CameraRow`]), which tests them
//! 16 at a time.

use super::light_paths::{LightPaths, LightVertex};
use super::photon_grid::{Buckets, Found};
use super::{
    joined, mis, Algorithm, Engine, IterationConstants, Mis, Next, PhotonGrid, SubPath, Vertex, Walk,
    WalkVisitor,
};
use crate::bsdf::{Scattering, ShadingFrame, TransportMode};
use crate::geometry::{spawn_origin, Ray};
use crate::integrators::shadow_queue::{ShadowQueue, Shadows, Ticket};
use crate::integrators::{pick_light, PathContext, Strategy};
use crate::lanes::WIDTH;
use crate::sampler::{Dim, Sampler};
use crate::scene::Intersection;
use crate::spectrum::Channels;
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};

/// A term that counts where its shadow ray reaches its target (the connection or the light
/// sample's point): its value, the target and the light aimed at; `None` where the term is 0
/// before any ray.
type Shadowed = Option<(Vec3, Vec3, Option<u32>)>;

/// The bytes a [`CameraRow`] holds per pixel (its rows are those of a band being traced, so at
/// most [`super::CAMERA_BAND_PIXELS`] pixels' worth at once).
pub(super) const ROW_BYTES_PER_PIXEL: u64 = (2 * std::mem::size_of::<Vec3>()
    + std::mem::size_of::<Option<Channels>>()
    + std::mem::size_of::<u32>()) as u64;

/// The camera paths of one row of pixels: per pixel its radiance so far, summed term by term in
/// the order the path made them (a term waits in `terms` for its shadow ray, if it has one).
pub(super) struct CameraRow<'s> {
    shadows: Shadows<'s>,
    /// Per pixel of the row, the sum of its terms so far, in the path's channels.
    radiance: Vec<Vec3>,
    /// Per pixel of the row, the channels of its path at its end (`None`: no path, 0).
    channels: Vec<Option<Channels>>,
    /// Per pixel of the row, in RGB, what its camera ray itself meets (an emitter, the
    /// background) in spectral mode, as `path` adds it ([`PathContext::seen_rgb`]): the
    /// expectation of its spectral estimate over the wavelengths is exactly its RGB.
    seen: Vec<Vec3>,
    /// Per pixel of the row, its terms waiting in `terms` (a term of a pixel with none waiting
    /// whose ray is answered, or that has none, is added at once).
    waiting: Vec<u32>,
    /// (pixel, factor, value): `factor * value` is added where the ray reaches its target,
    /// `factor * 0` where it does not (the sum the one-ray form made).
    terms: ShadowQueue<(u32, Vec3, Vec3)>,
    /// The rays of the row's paths.
    pub rays: RayCounts,
}

impl<'s> CameraRow<'s> {
    /// A row of `pixels` pixels whose shadow rays are tested by `shadows`.
    pub fn new(pixels: usize, shadows: Shadows<'s>) -> CameraRow<'s> {
        CameraRow {
            shadows,
            radiance: vec![Vec3::ZERO; pixels],
            channels: vec![None; pixels],
            seen: vec![Vec3::ZERO; pixels],
            waiting: vec![0; pixels],
            terms: ShadowQueue::default(),
            rays: RayCounts::default(),
        }
    }

    /// Adds `factor * value` to pixel `slot` where the ray of `ticket` reaches its target.
    #[inline]
    fn add(&mut self, slot: u32, factor: Vec3, value: Vec3, ticket: Ticket) {
        if let Some(visible) = ticket.known().filter(|_| self.waiting[slot as usize] == 0) {
            self.radiance[slot as usize] += factor * if visible { value } else { Vec3::ZERO };
        } else {
            self.wait(slot, factor, value, ticket);
        }
    }

    /// Queues the term `factor * value` of pixel `slot` behind its ray or the pixel's terms
    /// that wait, answering the rays once 16 wait.
    #[inline(never)]
    fn wait(&mut self, slot: u32, factor: Vec3, value: Vec3, ticket: Ticket) {
        self.waiting[slot as usize] += 1;
        self.terms.add((slot, factor, value), ticket);
        if self.terms.full() {
            self.settle(false);
        }
    }

    /// Adds `term` to pixel `slot` (multiplied by 1, exactly: in turn with its other terms).
    #[inline]
    fn add_clear(&mut self, slot: u32, term: Vec3) {
        self.add(slot, term, Vec3::ONE, Ticket::CLEAR);
    }

    /// Adds the RGB radiance `rgb` that the camera ray of pixel `slot` meets itself (weight
    /// `weight`), in the path's `channels`: in RGB where those are wavelengths.
    #[inline]
    fn add_seen(&mut self, slot: u32, channels: &Channels, rgb: Vec3, weight: f32) {
        if channels.is_spectral() {
            self.seen[slot as usize] += rgb * weight;
        } else {
            self.add_clear(slot, channels.colour(rgb) * weight);
        }
    }

    /// Adds `factor` times the shadowed term `term` of the path at `from` (time `time`) to pixel
    /// `slot`, asking for its shadow ray.
    fn add_shadowed(
        &mut self,
        slot: u32,
        factor: Vec3,
        term: Shadowed,
        from: &crate::geometry::SurfaceHit,
        time: f32,
        rays: &mut RayCounts,
    ) {
        match term {
            None => self.add(slot, factor, Vec3::ZERO, Ticket::CLEAR),
            Some((value, target, light)) => {
                let ticket = self.terms.ray(&self.shadows, from, target, light, time, rays);
                self.add(slot, factor, value, ticket);
            }
        }
    }

    /// Tests the waiting shadow rays (all with `all`, else whole batches) and adds their terms.
    fn settle(&mut self, all: bool) {
        let (radiance, waiting) = (&mut self.radiance, &mut self.waiting);
        self.terms.answer(&self.shadows, all, |(slot, factor, value), visible| {
            radiance[slot as usize] += factor * if visible { value } else { Vec3::ZERO };
            waiting[slot as usize] -= 1;
        });
    }

    /// The row's estimates in RGB once every term is in, and how many are not finite.
    pub fn finish(mut self) -> (Vec<Vec3>, RayCounts, u64) {
        self.settle(true);
        let values: Vec<Vec3> = (self.radiance.iter().zip(&self.channels).zip(&self.seen))
            .map(|((&l, channels), &seen)| channels.map_or(Vec3::ZERO, |c| c.to_rgb(l) + seen))
            .collect();
        let non_finite = values.iter().filter(|l| !l.is_finite()).count() as u64;
        (values, self.rays, non_finite)
    }
}

impl Engine<'_> {
    /// The camera paths of pixels `first..first + count` of the whole film (a run of one row),
    /// into pixels `0..count` of `row`, with the light paths of the batch `light`: 16 at a time
    /// side by side where the scene has a lane form ([`Engine::walk_lanes`]), else one by one.
    /// Camera path `j` gathers by its own strategies; it connects to light path `j mod N`.
    /// Emitters it hits and next-event estimation count in the first batch only; in later ones
    /// the path walks again as in the first (its random numbers do not depend on the batch)
    /// for the connections and merges with their light paths.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn camera_paths(
        &self,
        first: usize,
        count: usize,
        s: u32,
        k: &IterationConstants,
        light: &LightPaths,
        first_batch: bool,
        row: &mut CameraRow,
    ) {
        let start = |slot: usize| self.camera_start(first + slot, slot, s, light, first_batch);
        let Some(lanes) = &self.lanes else {
            for slot in 0..count {
                let Some((walk, mut path, lane)) = start(slot) else { continue };
                let mut visitor = lane.visitor(self, k, light, first_batch, row);
                self.walk(walk.ray, &mut path, k, walk.from_infinity, &mut visitor);
                lane.end(&path, row);
            }
            return;
        };
        let (mut walks, mut paths, mut ends) = (Vec::new(), Vec::new(), Vec::new());
        for base in (0..count).step_by(WIDTH) {
            walks.clear();
            paths.clear();
            ends.clear();
            for (walk, path, lane) in (base..count.min(base + WIDTH)).filter_map(start) {
                walks.push(walk);
                paths.push(path);
                ends.push(lane);
            }
            self.walk_lanes(lanes, &mut walks, &mut paths, |i, walk, path, isect| {
                let mut visitor = ends[i].visitor(self, k, light, first_batch, row);
                self.step(walk, path, k, &mut visitor, isect)
            });
            for (path, lane) in paths.iter().zip(&ends) {
                lane.end(path, row);
            }
        }
    }

    /// Camera path `j` (the whole film's pixel `j`) of iteration `s` at its start, for pixel
    /// `slot` of its row: its first ray, its state and what its visitor needs; `None` where
    /// the batch `light` holds nothing for it.
    fn camera_start(
        &self,
        j: usize,
        slot: usize,
        s: u32,
        light: &LightPaths,
        first_batch: bool,
    ) -> Option<(Walk, SubPath, CameraLane)> {
        let cam = &self.camera;
        let partner = j % self.light_paths;
        if !first_batch && light.grid.is_none() && light.of(partner).is_none() {
            // Nothing of this batch for the path to use.
            return None;
        }
        let (channels, time) = self.channels_and_time(partner, s);
        let stream = self.replicas.stream(self.seed, s, 0);
        let mut ctx = PathContext::new(Sampler::of_stream(self.sampler, stream, j as u64));
        ctx.channels = channels;
        ctx.hero_alone = self.hero_alone;
        let (x, y) = ((j % cam.width as usize) as u32, (j / cam.width as usize) as u32);
        let film = cam.film_point(x, y, ctx.sampler.get_2d(Dim::Pixel));
        let lens = if self.dims.lens { ctx.sampler.get_2d(Dim::Lens) } else { Vec2::ZERO };
        let (walk, path) = self.camera_subpath(ctx, film, lens, time);
        Some((walk, path, CameraLane { partner, time, slot: slot as u32 }))
    }

    /// A camera sub-path through the film point `film` (pixel units) from the lens point
    /// `lens` at time `time`, drawing its numbers from `ctx`: its first ray and its state,
    /// its density that of a film point uniform in its pixel (per light path of the
    /// iteration's `N`).
    pub(super) fn camera_subpath(
        &self,
        mut ctx: PathContext,
        film: Vec2,
        lens: Vec2,
        time: f32,
    ) -> (Walk, SubPath) {
        let cam = &self.camera;
        let ray = cam.generate_ray_lens(film, lens, time);
        ctx.rays.primary += 1;
        let cos = ray.dir.dot(cam.forward);
        let camera_pdf_w = 1.0 / (self.pixel_area * cos * cos * cos);
        let mis = Mis::camera(self.light_paths as f32, camera_pdf_w);
        let mut path = SubPath::new(ctx, TransportMode::Radiance, Vec3::ONE, mis);
        path.start_offset = cam.near_clip / cos;
        (Walk { ray, absorption: Vec3::ZERO, from_infinity: false }, path)
    }

    /// The random numbers of next-event estimation at a camera vertex, from `sampler`: the
    /// light's index and the point on it.
    pub(super) fn next_event_draw(&self, sampler: &mut Sampler) -> (usize, Vec2) {
        let index = pick_light(self.lights, sampler);
        (index, sampler.get_2d(Dim::Light))
    }

    /// Next-event estimation at a camera vertex with the numbers `draw`, weighted against
    /// every other strategy: its value where the light's point is visible, that point and
    /// the light.
    pub(super) fn next_event(
        &self,
        at: &Vertex,
        path: &SubPath,
        k: &IterationConstants,
        pick: f32,
        (index, u): (usize, Vec2),
    ) -> Shadowed {
        let light = &self.scene.lights[index];
        let ls = light.sample_li(at.hit.p, u)?;
        let wi_local = at.frame.to_local(ls.wi);
        if at.frame.factor(at.wo, ls.wi, TransportMode::Radiance) == 0.0 {
            return None;
        }
        let e = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
        if e.f == Vec3::ZERO {
            return None;
        }
        let cos_to_light = wi_local.z.abs();
        let (direct_w, emit_w, cos_at_light) =
            if let Some((direct, emit)) = light.delta_pdfs(&self.sphere, ls.distance) {
                (direct, emit, 1.0)
            } else if !ls.distance.is_finite() {
                let (emit, direct) = light.environment_pdfs(&self.sphere, ls.wi);
                (direct, emit, 1.0)
            } else {
                let cos_at_light = ls.normal.dot(-ls.wi).abs();
                if cos_at_light <= 0.0 {
                    // A grazing sample (a point of an emitter's own plane): its geometry term is 0.
                    return None;
                }
                (ls.pdf, light.emission_pdfs(at.hit.p, ls.position, ls.normal, -ls.wi).0, cos_at_light)
            };
        // A delta light cannot be hit by BSDF sampling.
        let dir_pdf = if ls.delta { 0.0 } else { e.pdf };
        let emit_ratio = emit_w * cos_to_light / (direct_w * cos_at_light);
        let weight =
            self.weighted(mis::next_event(&path.mis, k, dir_pdf, e.pdf_rev, pick * direct_w, emit_ratio));
        let target = if ls.distance.is_finite() {
            ls.position
        } else {
            at.hit.p + ls.wi * self.scene.far_distance(at.hit.p)
        };
        // Where the point is visible its transmittance is 1: the value is the same bits.
        let value = e.f * path.ctx.channels.colour(ls.radiance) * (weight * cos_to_light / (pick * ls.pdf));
        Some((value, target, Some(index as u32)))
    }

    /// The connection of a camera vertex to light vertex `v`, weighted: its value where the
    /// two see each other, and the point the shadow ray aims at.
    pub(super) fn connect(
        &self,
        at: &Vertex,
        path: &SubPath,
        v: &LightVertex,
        k: &IterationConstants,
    ) -> Shadowed {
        // Halves that share no channel (a branch of another wavelength) join to nothing.
        let joined = joined(path.carries, v.carries);
        if joined == 0.0 {
            return None;
        }
        let d = v.p - at.hit.p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        let dir = d / dist2.sqrt();
        let wi_local = at.frame.to_local(dir);
        if at.frame.factor(at.wo, dir, TransportMode::Radiance) == 0.0 {
            return None;
        }
        let camera = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
        if camera.f == Vec3::ZERO {
            return None;
        }
        let material = self.scene.material_of(v.primitive);
        let light_bsdf = Scattering::at(material, v.p, v.uv, &v.carries.channels(&path.ctx.channels));
        let light_frame = ShadingFrame::at(&v.hit(), v.wo);
        let light_wo = light_frame.to_local(v.wo);
        let light_wi = light_frame.to_local(-dir);
        let light = light_bsdf.evaluate(light_wo, light_wi, TransportMode::Importance);
        if light.f == Vec3::ZERO {
            return None;
        }
        let (cos_camera, cos_light) = (wi_local.z.abs(), light_wi.z.abs());
        let camera_dir_a = camera.pdf * cos_light / dist2;
        let light_dir_a = light.pdf * cos_camera / dist2;
        let weight = self.weighted(mis::connection(
            &path.mis,
            &v.mis,
            k,
            camera_dir_a,
            light_dir_a,
            camera.pdf_rev,
            light.pdf_rev,
        ));
        let target = spawn_origin(&v.hit(), -dir);
        let g = cos_camera * cos_light / dist2 * light_frame.factor(v.wo, -dir, TransportMode::Importance);
        // Where the two see each other the transmittance is 1: the value is the same bits.
        let value = camera.f * light.f * v.beta * (weight * g * joined);
        Some((value, target, None))
    }

    /// The merges of a camera vertex with the photons around it, weighted.
    fn merge(
        &self,
        at: &Vertex,
        path: &SubPath,
        k: &IterationConstants,
        vertices: &[LightVertex],
        grid: &PhotonGrid,
        (buckets, found): &(Buckets, Found),
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let ppm = self.algorithm == Algorithm::Ppm;
        found.visit(grid, buckets, |i| {
            let v = &vertices[i];
            let joined = joined(path.carries, v.carries);
            if v.segments + path.segments > self.max_segments || joined == 0.0 {
                return;
            }
            if at.frame.factor(at.wo, v.wo, TransportMode::Radiance) == 0.0 {
                return;
            }
            let wi_local = at.frame.to_local(v.wo);
            // Unweighted merges (`ppm`, a strategy alone) need the value only.
            let (f, weight) = if ppm || self.only.is_some() {
                (at.bsdf.eval(at.wo_local, wi_local, TransportMode::Radiance), 1.0)
            } else {
                let e = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
                (e.f, mis::merge(&path.mis, &v.mis, k, e.pdf, e.pdf_rev))
            };
            if f == Vec3::ZERO {
                return;
            }
            sum += f * v.beta * (weight * joined);
        });
        sum * k.vm_norm
    }
}

/// What a camera path's visitor needs besides the engine's and the iteration's state.
pub(super) struct CameraLane {
    /// The light path the camera path connects to.
    partner: usize,
    /// The path's time.
    time: f32,
    /// Its pixel in its row.
    slot: u32,
}

impl CameraLane {
    /// The path's visitor, summing into `row`.
    fn visitor<'e, 'a, 's>(
        &self,
        engine: &'e Engine<'a>,
        k: &'e IterationConstants,
        light: &'e LightPaths<'e>,
        first_batch: bool,
        row: &'e mut CameraRow<'s>,
    ) -> CameraVisitor<'e, 'a, 's> {
        CameraVisitor {
            engine,
            partner: self.partner,
            k,
            light,
            time: self.time,
            pick: 1.0 / engine.lights.max(1) as f32,
            only_merges: engine.algorithm.merges() && !engine.algorithm.connects(),
            first_batch,
            row,
            slot: self.slot,
        }
    }

    /// The path ended: its rays and its channels (which turn its radiance into RGB) go to `row`.
    fn end(&self, path: &SubPath, row: &mut CameraRow) {
        row.rays += path.ctx.rays;
        row.channels[self.slot as usize] = Some(path.ctx.channels);
    }
}

/// A camera sub-path: emitters it hits, next-event estimation, connections to the vertices of
/// its light sub-path and merges with the iteration's photons, summed into its pixel of `row`.
struct CameraVisitor<'e, 'a, 's> {
    engine: &'e Engine<'a>,
    /// The light path the camera path connects to.
    partner: usize,
    k: &'e IterationConstants,
    light: &'e LightPaths<'e>,
    /// The path's time (its shadow rays').
    time: f32,
    /// The probability of picking a given light.
    pick: f32,
    /// Whether the method merges without connecting (`ppm`, `bpm`).
    only_merges: bool,
    /// Whether this is the iteration's first batch of light paths, the one in which emitters
    /// hit and next-event estimation count.
    first_batch: bool,
    /// Where the path's terms are summed, and its pixel there.
    row: &'e mut CameraRow<'s>,
    slot: u32,
}

impl CameraVisitor<'_, '_, '_> {
    /// The weight of emission found by the camera path itself ([`Engine::emitter_weight`]).
    fn emitter_weight(&self, path: &SubPath, densities: impl FnOnce() -> (f32, f32)) -> f32 {
        self.engine.emitter_weight(path, self.pick, self.only_merges, densities)
    }
}

impl Engine<'_> {
    /// The weight of emission found by the camera path itself, a light picked with
    /// probability `pick`; `only_merges` for the methods that merge without connecting;
    /// `densities` gives the emitter's (emission, direct) densities of the arrival.
    pub(super) fn emitter_weight(
        &self,
        path: &SubPath,
        pick: f32,
        only_merges: bool,
        densities: impl FnOnce() -> (f32, f32),
    ) -> f32 {
        if path.segments == 1 || self.only.is_some() {
            1.0
        } else if only_merges {
            // Merging's paths: only a specular chain reaches an emitter by itself.
            if path.specular_path {
                1.0
            } else {
                0.0
            }
        } else {
            let (emit, direct) = densities();
            mis::emitter_hit(&path.mis, pick * direct, pick * emit)
        }
    }
}

impl WalkVisitor for CameraVisitor<'_, '_, '_> {
    fn escaped(&mut self, path: &mut SubPath, dir: Vec3, absorbed: bool) {
        let e = self.engine;
        if absorbed || !e.keeps(Strategy::EmitterHit) || !self.first_batch {
            return;
        }
        // Without an environment light the background is no light: it is seen with weight 1.
        let weight = match e.environment {
            None => 1.0,
            Some(i) => self.emitter_weight(path, || e.scene.lights[i].environment_pdfs(&e.sphere, dir)),
        };
        let background = e.scene.background(dir);
        if path.segments == 1 {
            // The camera ray itself (its weight is 1).
            self.row.add_seen(self.slot, &path.ctx.channels, background, weight);
        } else {
            self.row.add_clear(self.slot, path.beta * path.ctx.channels.colour(background) * weight);
        }
    }

    fn reached(&mut self, path: &mut SubPath, ray: &Ray, isect: &Intersection) -> bool {
        let e = self.engine;
        if let Some(index) = e.scene.light_of(isect.primitive) {
            let emitter = &e.scene.lights[index as usize];
            let (hit, wo) = (&isect.hit, -ray.dir);
            let le = emitter.emitted(hit, wo);
            if le != Vec3::ZERO && e.keeps(Strategy::EmitterHit) && self.first_batch {
                let weight =
                    self.emitter_weight(path, || emitter.emission_pdfs(ray.origin, hit.p, hit.n, wo));
                if path.segments == 1 {
                    // The camera ray itself (its weight is 1).
                    self.row.add_seen(self.slot, &path.ctx.channels, le, weight);
                } else {
                    self.row.add_clear(self.slot, path.beta * path.ctx.channels.colour(le) * weight);
                }
            }
        }
        path.segments < e.max_segments
    }

    fn visit(&mut self, path: &mut SubPath, at: &Vertex, _: u32) -> Next {
        let (e, k, light) = (self.engine, self.k, self.light);
        if at.bsdf.is_delta() {
            return Next::Any;
        }
        // The merge's buckets, asked for in the cache now, its first photons after next-event
        // estimation and the vertices of the photons it finds before the connections, so that
        // their cache misses overlap the shadow rays (hints only).
        let mut merge = light.grid.filter(|_| e.keeps(Strategy::Merge)).map(|grid| {
            let buckets = grid.buckets(at.hit.p, k.radius);
            grid.prefetch_starts(&buckets);
            (grid, buckets)
        });
        let mut found = None;
        if e.algorithm.connects() {
            if e.lights > 0 && e.keeps(Strategy::NextEvent) {
                let draw = e.next_event_draw(&mut path.ctx.sampler);
                if self.first_batch {
                    let term = e.next_event(at, path, k, self.pick, draw);
                    self.row.add_shadowed(self.slot, path.beta, term, at.hit, self.time, &mut path.ctx.rays);
                }
            }
            if let Some((grid, buckets)) = merge.take() {
                grid.prefetch_photons(&buckets);
                let ahead = grid.find(&buckets, light.vertices);
                found = Some((grid, (buckets, ahead)));
            }
            if let Some(partner) = light.of(self.partner).filter(|_| e.keeps(Strategy::Connection)) {
                // (The branches' vertices follow the path's: the segments do not grow along them.)
                for v in partner {
                    if v.segments + path.segments + 1 > e.max_segments {
                        continue;
                    }
                    let term = e.connect(at, path, v, k);
                    self.row.add_shadowed(self.slot, path.beta, term, at.hit, self.time, &mut path.ctx.rays);
                }
            }
        }
        if let Some((grid, buckets)) = merge {
            // Without connections (`ppm`, `bpm`) there is nothing to overlap.
            let ahead = grid.find(&buckets, light.vertices);
            found = Some((grid, (buckets, ahead)));
        }
        if light.grid.is_none() {
            return Next::Any;
        }
        if let Some((grid, merge)) = &found {
            self.row.add_clear(self.slot, path.beta * e.merge(at, path, k, light.vertices, grid, merge));
        }
        // Photon mapping merges once: only the specular chain (multiply scattered samples of
        // rough glass included) goes on past a merge.
        if e.algorithm == Algorithm::Ppm {
            Next::SpecularOnly
        } else {
            Next::Any
        }
    }
}
