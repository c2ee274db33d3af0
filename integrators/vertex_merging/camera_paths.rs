//! The camera sub-paths of an iteration: a camera path gathers emitters it hits, next-event
//! estimation, connections to the vertices of its partner light path (camera path `j` with
//! light path `j mod N`) and merges with every photon of the iteration, each weighted against
//! the other strategies.

use super::light_paths::{LightPaths, LightVertex};
use super::photon_grid::{Buckets, Found};
use super::{
    joined, mis, Algorithm, Engine, IterationConstants, Mis, Next, PhotonGrid, SubPath, Vertex, WalkVisitor,
};
use crate::bsdf::{Scattering, ShadingFrame, TransportMode};
use crate::geometry::{spawn_origin, Ray};
use crate::integrators::{pick_light, PathContext, Strategy};
use crate::lighting::{transmittance, ShadowMode, ShadowRays};
use crate::sampler::{Dim, Sampler};
use crate::scene::Intersection;
use crate::stats::RayCounts;
use glam::{Vec2, Vec3};

impl Engine<'_> {
    /// The radiance camera path `j` (the whole film's pixel `j`) of iteration `s` gathers by its
    /// own strategies with the light paths of the batch `light`; it connects to light path
    /// `j mod N`. Emitters it hits and next-event estimation count in the first batch only;
    /// in later ones the path walks again as in the first (its random numbers do not depend
    /// on the batch) for the connections and merges with their light paths.
    pub(super) fn camera_path(
        &self,
        j: usize,
        s: u32,
        k: &IterationConstants,
        light: &LightPaths,
        first_batch: bool,
        rays: &mut RayCounts,
    ) -> Vec3 {
        let cam = &self.camera;
        let partner = j % self.light_paths;
        if !first_batch && light.grid.is_none() && light.of(partner).is_none() {
            // Nothing of this batch for the path to use.
            return Vec3::ZERO;
        }
        let (channels, time) = self.channels_and_time(partner, s);
        let stream = self.replicas.stream(self.seed, s, 0);
        let mut ctx = PathContext::new(Sampler::of_stream(self.sampler, stream, j as u64));
        ctx.channels = channels;
        let (x, y) = ((j % cam.width as usize) as u32, (j / cam.width as usize) as u32);
        let film = cam.film_point(x, y, ctx.sampler.get_2d(Dim::Pixel));
        let lens = if self.dims.lens { ctx.sampler.get_2d(Dim::Lens) } else { Vec2::ZERO };
        let ray = cam.generate_ray_lens(film, lens, time);
        ctx.rays.primary += 1;
        let cos = ray.dir.dot(cam.forward);
        let camera_pdf_w = 1.0 / (self.pixel_area * cos * cos * cos);
        let mis = Mis::camera(self.light_paths as f32, camera_pdf_w);
        let mut path = SubPath::new(ctx, TransportMode::Radiance, Vec3::ONE, mis);
        path.start_offset = cam.near_clip / cos;
        let mut visitor = CameraVisitor {
            engine: self,
            partner,
            k,
            light,
            shadow: ShadowRays { mode: ShadowMode::Opaque, channels, time },
            pick: 1.0 / self.lights.max(1) as f32,
            only_merges: self.algorithm.merges() && !self.algorithm.connects(),
            first_batch,
            radiance: Vec3::ZERO,
        };
        self.walk(ray, &mut path, k, false, &mut visitor);
        *rays += path.ctx.rays;
        path.ctx.channels.to_rgb(visitor.radiance)
    }

    /// The random numbers of next-event estimation at a camera vertex: the light's index and
    /// the point on it.
    fn next_event_draw(&self, path: &mut SubPath) -> (usize, Vec2) {
        let index = pick_light(self.lights, &mut path.ctx.sampler);
        (index, path.ctx.sampler.get_2d(Dim::Light))
    }

    /// Next-event estimation at a camera vertex with the numbers `draw`, weighted against
    /// every other strategy.
    fn next_event(
        &self,
        at: &Vertex,
        path: &mut SubPath,
        k: &IterationConstants,
        shadow: ShadowRays,
        pick: f32,
        (index, u): (usize, Vec2),
    ) -> Vec3 {
        let light = &self.scene.lights[index];
        let Some(ls) = light.sample_li(at.hit.p, u) else { return Vec3::ZERO };
        let wi_local = at.frame.to_local(ls.wi);
        if at.frame.factor(at.wo, ls.wi, TransportMode::Radiance) == 0.0 {
            return Vec3::ZERO;
        }
        let e = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
        if e.f == Vec3::ZERO {
            return Vec3::ZERO;
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
                    return Vec3::ZERO;
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
        let visible =
            transmittance(self.scene, at.hit, target, Some(index as u32), shadow, &mut path.ctx.rays);
        if visible == Vec3::ZERO {
            return Vec3::ZERO;
        }
        e.f * path.ctx.channels.colour(ls.radiance) * visible * (weight * cos_to_light / (pick * ls.pdf))
    }

    /// The connection of a camera vertex to light vertex `v`, weighted.
    fn connect(
        &self,
        at: &Vertex,
        path: &mut SubPath,
        v: &LightVertex,
        k: &IterationConstants,
        shadow: ShadowRays,
    ) -> Vec3 {
        let d = v.p - at.hit.p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return Vec3::ZERO;
        }
        let dir = d / dist2.sqrt();
        let wi_local = at.frame.to_local(dir);
        if at.frame.factor(at.wo, dir, TransportMode::Radiance) == 0.0 {
            return Vec3::ZERO;
        }
        let camera = at.bsdf.evaluate(at.wo_local, wi_local, TransportMode::Radiance);
        if camera.f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let material = self.scene.material_of(v.primitive);
        let light_bsdf = Scattering::at(material, v.p, v.uv, &path.ctx.channels);
        let light_frame = ShadingFrame::at(&v.hit(), v.wo);
        let light_wo = light_frame.to_local(v.wo);
        let light_wi = light_frame.to_local(-dir);
        let light = light_bsdf.evaluate(light_wo, light_wi, TransportMode::Importance);
        if light.f == Vec3::ZERO {
            return Vec3::ZERO;
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
        let visible = transmittance(self.scene, at.hit, target, None, shadow, &mut path.ctx.rays);
        if visible == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let g = cos_camera * cos_light / dist2 * light_frame.factor(v.wo, -dir, TransportMode::Importance);
        camera.f * light.f * v.beta * visible * (weight * g * joined(path.ctx.hero_only, v.hero_only))
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
            if v.segments + path.segments > self.max_segments {
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
            sum += f * v.beta * (weight * joined(path.ctx.hero_only, v.hero_only));
        });
        sum * k.vm_norm
    }
}

/// A camera sub-path: emitters it hits, next-event estimation, connections to the vertices of
/// its light sub-path and merges with the iteration's photons, summed in `radiance`.
struct CameraVisitor<'e, 'a> {
    engine: &'e Engine<'a>,
    /// The light path the camera path connects to.
    partner: usize,
    k: &'e IterationConstants,
    light: &'e LightPaths<'e>,
    shadow: ShadowRays,
    /// The probability of picking a given light.
    pick: f32,
    /// Whether the method merges without connecting (`ppm`, `bpm`).
    only_merges: bool,
    /// Whether this is the iteration's first batch of light paths, the one in which emitters
    /// hit and next-event estimation count.
    first_batch: bool,
    radiance: Vec3,
}

impl CameraVisitor<'_, '_> {
    /// The weight of emission found by the camera path itself; `densities` gives the
    /// emitter's (emission, direct) densities of the arrival.
    fn emitter_weight(&self, path: &SubPath, densities: impl FnOnce() -> (f32, f32)) -> f32 {
        if path.segments == 1 || self.engine.only.is_some() {
            1.0
        } else if self.only_merges {
            // Merging's paths: only a specular chain reaches an emitter by itself.
            if path.specular_path {
                1.0
            } else {
                0.0
            }
        } else {
            let (emit, direct) = densities();
            mis::emitter_hit(&path.mis, self.pick * direct, self.pick * emit)
        }
    }
}

impl WalkVisitor for CameraVisitor<'_, '_> {
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
        self.radiance += path.beta * path.ctx.channels.colour(e.scene.background(dir)) * weight;
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
                self.radiance += path.beta * path.ctx.channels.colour(le) * weight;
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
                let draw = e.next_event_draw(path);
                if self.first_batch {
                    self.radiance += path.beta * e.next_event(at, path, k, self.shadow, self.pick, draw);
                }
            }
            if let Some((grid, buckets)) = merge.take() {
                grid.prefetch_photons(&buckets);
                let ahead = grid.find(&buckets, light.vertices);
                found = Some((grid, (buckets, ahead)));
            }
            if let Some(partner) = light.of(self.partner).filter(|_| e.keeps(Strategy::Connection)) {
                for v in partner {
                    if v.segments + path.segments + 1 > e.max_segments {
                        break;
                    }
                    self.radiance += path.beta * e.connect(at, path, v, k, self.shadow);
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
            self.radiance += path.beta * e.merge(at, path, k, light.vertices, grid, merge);
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
