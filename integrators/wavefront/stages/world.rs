//! The world the lane stages shade a chunk's vertices in ([`PathWorld`] over 16 lanes): the
//! stages' tables where they hold a vertex's material, emission or light, and the scalar
//! engine's world ([`OneRay`]) lane by lane where they do not.

// Lane loops index several arrays by the lane, as the kernels they vectorise into do.
#![allow(clippy::needless_range_loop)]

use super::super::super::path::{
    light_draw, manifold_draw, no_sample, LightDraw, OneRay, PathState, PathWorld, VertexBsdf, VertexFrame,
};
use super::super::super::{light_index, PathContext};
use super::{LaneContext, LaneHit, LaneStages, Table, Table3, NONE};
use crate::bsdf::rough_dielectric::smooth_dielectric_sample;
use crate::bsdf::{BsdfSample, Lambert, Scattering, ShadingFrame, TransportMode};
use crate::camera::concentric_disk_point;
use crate::lanes::{sobol_firsts, sobol_pairs, F32x, Mask, Vec3x, WIDTH};
use crate::light::{
    area_to_solid_angle, front_area_sample, front_emitted, point_light_sample, quad_point, LightSampleOf,
};
use crate::lighting::ShadowSegment;
use crate::params::ManifoldParams;
use crate::sampler::Dim;
use crate::scene::Scene;
use crate::texture::checker;
use std::cell::Cell;

/// The scattering at 16 vertices: two-sided diffuse with its albedo, or smooth glass with its
/// relative index; in the lanes the scalar world shades, the scene's own model.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneBsdf<'a, 's> {
    glass: Mask,
    lambert: Lambert<Vec3x>,
    eta: F32x,
    /// Lanes with a model of their own.
    scalar: Mask,
    /// Their models (the world's [`Models`], set for the `scalar` lanes).
    models: &'a Models<'s>,
}

/// The scene's own scattering models of a chunk's lanes the scalar world shades, kept from one
/// vertex to the next (set where a lane needs one, never cleared: only those lanes read theirs).
pub(crate) type Models<'s> = [Cell<Option<Scattering<'s>>>; WIDTH];

/// A chunk's shadow rays: where one can be blocked, the segments, the light each aims at, and
/// the distance from which a hit on that light no longer blocks ([`ShadowRay::reach`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneShadow {
    /// Where a lane has a shadow ray that something can block.
    pub(super) shadowed: Mask,
    /// The rays' segments.
    pub(super) segment: ShadowSegment<Vec3x>,
    /// The light each lane's ray aims at.
    pub(super) light: [u32; WIDTH],
    /// The distance from which a hit on that light no longer blocks.
    pub(super) reach: F32x,
    /// The point aimed at (for scenes whose objects move, traced lane by lane).
    pub(super) target: Vec3x,
    /// The path's time.
    pub(super) time: F32x,
}

/// The world of a chunk's vertices: the stages' tables, and the scene for what the scalar world
/// shades lane by lane, with room for its models.
#[derive(Clone, Copy)]
pub(crate) struct LaneWorld<'a, 's> {
    /// The tables.
    pub(super) stages: &'a LaneStages,
    /// The scene.
    pub(super) scene: &'s Scene,
    /// The models of the lanes the scalar world shades.
    pub(super) models: &'a Models<'s>,
}

/// The random streams and counters of a chunk's paths: the lanes' own ([`LaneContext`]), and
/// each path's context (its channels, and its sampler where it is not Sobol'), at its slot.
pub(crate) struct LaneCtx<'a> {
    /// The lanes' streams and counters.
    pub(super) lanes: &'a mut LaneContext,
    /// The contexts of every path of the batch.
    pub(super) paths: &'a mut [PathContext],
    /// Each lane's path's index into `paths`.
    pub(super) slot: [u32; WIDTH],
}

impl LaneCtx<'_> {
    /// Lane `k`'s path context.
    #[inline]
    fn path(&self, k: usize) -> &PathContext {
        &self.paths[self.slot[k] as usize]
    }

    /// Lane `k`'s path context, to change.
    #[inline]
    fn path_mut(&mut self, k: usize) -> &mut PathContext {
        &mut self.paths[self.slot[k] as usize]
    }
}

/// The lanes set in `mask`, in order.
#[inline(always)]
pub(super) fn lanes_of(mask: Mask) -> impl Iterator<Item = usize> {
    let mut bits = mask.0.iter().enumerate().fold(0u32, |b, (k, &set)| b | ((set as u32) << k));
    std::iter::from_fn(move || {
        (bits != 0).then(|| {
            let k = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            k
        })
    })
}

/// Lane `k` of the samples `s`.
#[inline]
fn sample_lane(s: &BsdfSample<Vec3x>, k: usize) -> BsdfSample {
    BsdfSample {
        wi: s.wi.lane(k),
        f: s.f.lane(k),
        pdf: s.pdf.0[k],
        is_specular: s.is_specular.0[k],
        is_multiple: s.is_multiple.0[k],
        is_transmission: s.is_transmission.0[k],
        eta: s.eta.0[k],
    }
}

/// Puts the sample `one` into lane `k` of `s`.
#[inline]
fn set_sample_lane(s: &mut BsdfSample<Vec3x>, k: usize, one: &BsdfSample) {
    s.wi.set_lane(k, one.wi);
    s.f.set_lane(k, one.f);
    s.pdf.0[k] = one.pdf;
    s.is_specular.0[k] = one.is_specular;
    s.is_multiple.0[k] = one.is_multiple;
    s.is_transmission.0[k] = one.is_transmission;
    s.eta.0[k] = one.eta;
}

impl<'a, 's> PathWorld for LaneWorld<'a, 's> {
    type R = F32x;
    type V = Vec3x;
    type Hit = LaneHit;
    type Bsdf = LaneBsdf<'a, 's>;
    type Frame = ShadingFrame<Vec3x>;
    type Light = [u32; WIDTH];
    type Shadow = LaneShadow;
    type Context = LaneCtx<'a>;

    #[inline(always)]
    fn light_count(&self) -> usize {
        self.stages.lights.count
    }

    #[inline(always)]
    fn has_casters(&self) -> bool {
        !self.scene.casters().is_empty()
    }

    #[inline(always)]
    fn live(&self, hit: &LaneHit) -> Mask {
        hit.live
    }

    #[inline(always)]
    fn found(&self, hit: &LaneHit) -> Mask {
        hit.found
    }

    #[inline(always)]
    fn surface(&self, hit: &LaneHit) -> (F32x, Vec3x, Vec3x, F32x) {
        (F32x(hit.hits.t), hit.records.p, hit.records.n, hit.records.p_error)
    }

    #[inline(always)]
    fn escaped(
        &self,
        dir: Vec3x,
        skip_mis: Mask,
        bsdf_pdf: F32x,
        light_pick: F32x,
        seen: Mask,
        active: Mask,
        ctx: &mut LaneCtx<'a>,
    ) -> Vec3x {
        if let Some(background) = self.stages.background {
            // RGB: nothing seen goes to the context.
            return Vec3x::splat(background);
        }
        let mut le = Vec3x::ZERO;
        let one_ray = OneRay { scene: self.scene };
        for k in lanes_of(active) {
            let (d, pdf, pick) = (dir.lane(k), bsdf_pdf.0[k], light_pick.0[k]);
            let l = one_ray.escaped(d, skip_mis.0[k], pdf, pick, seen.0[k], true, ctx.path_mut(k));
            le.set_lane(k, l);
        }
        le
    }

    #[inline(always)]
    fn emission(
        &self,
        hit: &LaneHit,
        origin: Vec3x,
        wo: Vec3x,
        seen: Mask,
        active: Mask,
        ctx: &mut LaneCtx<'a>,
    ) -> (Mask, Vec3x, F32x) {
        let (p, n) = (hit.records.p, hit.records.n);
        let lights = &self.stages.lights;
        let (mut emits, mut le, mut pdf_li) = (Mask::NONE, Vec3x::ZERO, F32x::ZERO);
        let quads = active & !hit.scalar_emission & Mask(std::array::from_fn(|k| hit.light[k] != NONE));
        if quads.any() {
            // Light::emitted of a quad.
            le = Vec3x::select(quads, front_emitted(n, wo, lights.radiance.at(&hit.light)), Vec3x::ZERO);
            emits = !le.is_zero();
            if emits.any() {
                pdf_li = area_to_solid_angle(lights.area_pdf.at(&hit.light), origin, p, n);
            }
        }
        let one_ray = OneRay { scene: self.scene };
        for k in lanes_of(active & hit.scalar_emission) {
            let (o, w, seen) = (origin.lane(k), wo.lane(k), seen.0[k]);
            let (e, l, pdf) = one_ray.emission(&hit.isect[k], o, w, seen, true, ctx.path_mut(k));
            (emits.0[k], pdf_li.0[k]) = (e, pdf);
            le.set_lane(k, l);
        }
        (emits, le, pdf_li)
    }

    #[inline(always)]
    fn bsdf(&self, hit: &LaneHit, active: Mask, ctx: &mut LaneCtx<'a>) -> (LaneBsdf<'a, 's>, Vec3x) {
        let (mats, material) = (&self.stages.materials, &hit.material);
        let scalar = active & hit.scalar;
        let tabled = active & !hit.scalar;
        let glass = tabled & mats.glass.set_at(material);
        let albedo = if (tabled & !glass).any() {
            checker(hit.records.p, mats.cell.at(material), mats.color1.at(material), mats.color2.at(material))
        } else {
            Vec3x::ZERO
        };
        let eta = if glass.any() { mats.eta.at(material) } else { F32x::ONE };
        let mut ends = Vec3x::ONE;
        let one_ray = OneRay { scene: self.scene };
        for k in lanes_of(scalar) {
            let (model, end) = one_ray.bsdf(&hit.isect[k], true, ctx.path_mut(k));
            self.models[k].set(Some(model));
            ends.set_lane(k, end);
        }
        // Two-sided diffuse in the tables (a one-sided one is the scalar world's).
        let lambert = Lambert { albedo, one_sided: Mask::NONE };
        (LaneBsdf { glass, lambert, eta, scalar, models: self.models }, ends)
    }

    #[inline(always)]
    fn frame(&self, hit: &LaneHit, wo: Vec3x) -> ShadingFrame<Vec3x> {
        if self.stages.lane_records {
            // Analytic shapes only: every shading normal is the geometric one.
            return ShadingFrame::flat(hit.records.n);
        }
        ShadingFrame::around(hit.records.n, hit.shading_n, wo)
    }

    #[inline(always)]
    fn draw_1d(&self, ctx: &mut LaneCtx<'a>, purpose: Dim, active: Mask) -> F32x {
        if !active.any() {
            return F32x::ZERO;
        }
        if !self.stages.sobol {
            let mut x = F32x::ZERO;
            for k in lanes_of(active) {
                x.0[k] = ctx.path_mut(k).sampler.get_1d(purpose);
            }
            return x;
        }
        let lanes = &mut *ctx.lanes;
        let x = sobol_firsts(self.stages.isa(), &lanes.key, &lanes.reversed, &lanes.dimension);
        lanes.advance(purpose, active, 1);
        F32x::select(active, F32x(x), F32x::ZERO)
    }

    #[inline(always)]
    fn draw_2d(&self, ctx: &mut LaneCtx<'a>, purpose: Dim, active: Mask) -> (F32x, F32x) {
        if !active.any() {
            return (F32x::ZERO, F32x::ZERO);
        }
        if !self.stages.sobol {
            let (mut x, mut y) = (F32x::ZERO, F32x::ZERO);
            for k in lanes_of(active) {
                let u = ctx.path_mut(k).sampler.get_2d(purpose);
                (x.0[k], y.0[k]) = (u.x, u.y);
            }
            return (x, y);
        }
        let lanes = &mut *ctx.lanes;
        let (x, y) = sobol_pairs(self.stages.isa(), &lanes.key, &lanes.reversed, &lanes.dimension);
        lanes.advance(purpose, active, 2);
        (F32x::select(active, F32x(x), F32x::ZERO), F32x::select(active, F32x(y), F32x::ZERO))
    }

    #[inline(always)]
    fn light_at(&self, u: F32x) -> [u32; WIDTH] {
        std::array::from_fn(|k| light_index(u.0[k], self.stages.lights.count) as u32)
    }

    #[inline(always)]
    fn sample_light(
        &self,
        hit: &LaneHit,
        l: [u32; WIDTH],
        (ux, uy): (F32x, F32x),
        active: Mask,
        ctx: &LaneCtx<'a>,
    ) -> LightDraw<Vec3x> {
        let lights = &self.stages.lights;
        let p = hit.records.p;
        // One light is the same in every lane: no gathers.
        let one = lights.count == 1;
        let flag = |t: &Table| if one { Mask::splat(t.0[0] != 0.0) } else { t.set_at(&l) };
        let scalar = active & flag(&lights.scalar);
        let tabled = active & !scalar;
        let mut draw = LightDraw { sample: LightSampleOf::none(), delta: Mask::NONE, target: p };
        if tabled.any() {
            let vector = |t: &Table3| if one { Vec3x::splat(t.get(0)) } else { t.at(&l) };
            let point = flag(&lights.point);
            // Light::sample_li of a quad (a point on it) or of a point light, where some lane has one.
            let (corner, emitted) = (vector(&lights.corner), vector(&lights.radiance));
            let quads = tabled & !point;
            let at_point = if (tabled & point).any() {
                point_light_sample(p, corner, emitted)
            } else {
                LightSampleOf::none()
            };
            draw = if !quads.any() {
                LightDraw { sample: at_point, delta: point, target: corner }
            } else {
                let y = quad_point(corner, vector(&lights.u), vector(&lights.v), ux, uy);
                let area_pdf = if one { F32x::splat(lights.area_pdf.0[0]) } else { lights.area_pdf.at(&l) };
                let on_quad = front_area_sample(p, y, vector(&lights.normal), emitted, area_pdf);
                let sample = LightSampleOf::select(point, &at_point, &on_quad);
                LightDraw { sample, delta: point, target: Vec3x::select(point, corner, y) }
            };
        }
        for k in lanes_of(scalar) {
            let one = light_draw(self.scene, p.lane(k), l[k] as usize, (ux.0[k], uy.0[k]), ctx.path(k));
            let s = &mut draw.sample;
            (s.sampled.0[k], s.distance.0[k], s.pdf.0[k]) =
                (one.sample.sampled, one.sample.distance, one.sample.pdf);
            s.wi.set_lane(k, one.sample.wi);
            s.radiance.set_lane(k, one.sample.radiance);
            draw.delta.0[k] = one.delta;
            draw.target.set_lane(k, one.target);
        }
        draw
    }

    #[inline(always)]
    fn no_shadow(&self) -> LaneShadow {
        let zero = F32x::ZERO;
        LaneShadow {
            shadowed: Mask::NONE,
            segment: ShadowSegment { origin: Vec3x::ZERO, dir: Vec3x::ZERO, tmax: zero, remaining: zero },
            light: [NONE; WIDTH],
            reach: zero,
            target: Vec3x::ZERO,
            time: zero,
        }
    }

    #[inline(always)]
    fn shadow(
        &self,
        hit: &LaneHit,
        target: Vec3x,
        light: [u32; WIDTH],
        time: F32x,
        active: Mask,
        ctx: &mut LaneCtx<'a>,
    ) -> LaneShadow {
        let r = &hit.records;
        let segment = ShadowSegment::toward(r.p, r.n, r.p_error, target);
        for k in 0..WIDTH {
            ctx.lanes.rays[0][k] += active.0[k] as u32;
        }
        let shadowed = active & !segment.remaining.le(F32x::ZERO);
        // ShadowRay::reach: from where a hit on the light aimed at no longer blocks; a target
        // inside its light (only lights without a lane form can hold one) is reached at once.
        let mut reach = segment.remaining * (1.0 - 1e-3);
        let lights = &self.stages.lights;
        if lights.count > 1 || lights.scalar.0[0] != 0.0 {
            for k in lanes_of(shadowed & lights.scalar.set_at(&light)) {
                if self.scene.lights[light[k] as usize].encloses(target.lane(k)) {
                    reach.0[k] = f32::NEG_INFINITY;
                }
            }
        }
        LaneShadow { shadowed, segment, light, reach, target, time }
    }

    #[inline(always)]
    fn split_wavelengths(
        &self,
        hit: &LaneHit,
        s: &BsdfSample<Vec3x>,
        wo_local: Vec3x,
        uc: F32x,
        (ux, uy): (F32x, F32x),
        path: &PathState<Vec3x>,
        active: Mask,
        ctx: &mut LaneCtx<'a>,
    ) -> Vec3x {
        if self.stages.tables {
            return Vec3x::ONE;
        }
        // Without tables every lane is the scalar world's (wavelengths among the reasons).
        let mut factor = Vec3x::ONE;
        for k in lanes_of(active & hit.scalar) {
            // The lane's stream where it is Sobol', the path's own otherwise.
            let replay =
                if self.stages.sobol { ctx.lanes.dimension[k] } else { ctx.path(k).sampler.dimension() };
            let f = ctx.path_mut(k).split_wavelengths(
                self.scene,
                hit.isect[k].as_ref().expect("a lane that scatters found a surface"),
                &sample_lane(s, k),
                wo_local.lane(k),
                (uc.0[k], (ux.0[k], uy.0[k])),
                &path.lane(k),
                replay,
            );
            factor.set_lane(k, f);
        }
        factor
    }

    #[inline(always)]
    fn mixes_wavelengths(&self, hit: &LaneHit, active: Mask, ctx: &LaneCtx<'a>) -> Mask {
        let mut mixes = Mask::NONE;
        if self.stages.tables {
            // RGB: no wavelengths.
            return mixes;
        }
        let one_ray = OneRay { scene: self.scene };
        for k in lanes_of(active & hit.scalar) {
            mixes.0[k] = one_ray.mixes_wavelengths(&hit.isect[k], true, ctx.path(k));
        }
        mixes
    }

    #[inline(always)]
    fn eval_wavelengths(
        &self,
        hit: &LaneHit,
        wo: Vec3x,
        wi: Vec3x,
        active: Mask,
        ctx: &LaneCtx<'a>,
    ) -> (Vec3x, F32x) {
        let (mut f, mut pdf) = (Vec3x::ZERO, F32x::ZERO);
        let one_ray = OneRay { scene: self.scene };
        for k in lanes_of(active) {
            let (fk, pk) = one_ray.eval_wavelengths(&hit.isect[k], wo.lane(k), wi.lane(k), true, ctx.path(k));
            f.set_lane(k, fk);
            pdf.0[k] = pk;
        }
        (f, pdf)
    }

    #[inline(always)]
    fn sample_wavelengths(
        &self,
        hit: &LaneHit,
        wo: Vec3x,
        uc: F32x,
        (ux, uy): (F32x, F32x),
        active: Mask,
        ctx: &LaneCtx<'a>,
    ) -> (Mask, BsdfSample<Vec3x>) {
        let (mut ok, mut s) = (Mask::NONE, no_sample());
        let one_ray = OneRay { scene: self.scene };
        for k in lanes_of(active) {
            let (sampled, one) = one_ray.sample_wavelengths(
                &hit.isect[k],
                wo.lane(k),
                uc.0[k],
                (ux.0[k], uy.0[k]),
                true,
                ctx.path(k),
            );
            ok.0[k] = sampled;
            set_sample_lane(&mut s, k, &one);
        }
        (ok, s)
    }

    #[inline(always)]
    fn resume(&self, path: &mut PathState<Vec3x>, ended: Mask, ctx: &mut LaneCtx<'a>) -> Mask {
        let mut resumed = Mask::NONE;
        if self.stages.tables {
            // RGB: no path splits.
            return resumed;
        }
        for k in lanes_of(ended) {
            let mut one = path.lane(k);
            if let Some(replay) = ctx.path_mut(k).resume_branch(&mut one) {
                if self.stages.sobol {
                    ctx.lanes.dimension[k] = replay;
                } else {
                    ctx.path_mut(k).sampler.replay_from(replay);
                }
                path.set_lane(k, &one);
                resumed.0[k] = true;
            }
        }
        resumed
    }

    #[inline(always)]
    fn medium_after(
        &self,
        hit: &LaneHit,
        dir: Vec3x,
        transmitted: Mask,
        active: Mask,
        ctx: &LaneCtx<'a>,
    ) -> (Mask, Vec3x) {
        let (mats, material) = (&self.stages.materials, &hit.material);
        let glass = active & !hit.scalar & mats.glass.set_at(material);
        let (mut crosses, mut absorption) = (glass, Vec3x::ZERO);
        if glass.any() {
            // lighting::crossing: the medium a reflected ray stays in or a refracted one enters.
            let (inside, outside) = (mats.inside.at(material), mats.outside.at(material));
            let enters = dir.dot(hit.records.n).lt(F32x::ZERO);
            let incident = Vec3x::select(enters, outside, inside);
            let entered = Vec3x::select(enters, inside, outside);
            absorption = Vec3x::select(transmitted, entered, incident);
        }
        let one_ray = OneRay { scene: self.scene };
        for k in lanes_of(active & hit.scalar) {
            let (c, a) =
                one_ray.medium_after(&hit.isect[k], dir.lane(k), transmitted.0[k], true, ctx.path(k));
            crosses.0[k] = c;
            absorption.set_lane(k, a);
        }
        (crosses, absorption)
    }

    #[inline(always)]
    fn count_scattered(ctx: &mut LaneCtx<'a>, reflected: Mask, active: Mask) {
        for k in 0..WIDTH {
            ctx.lanes.rays[1][k] += (active.0[k] & reflected.0[k]) as u32;
            ctx.lanes.rays[2][k] += (active.0[k] & !reflected.0[k]) as u32;
        }
    }

    // Manifold next-event estimation is a sequence of traced chains per vertex: lane by lane.
    #[inline]
    fn manifold(
        &self,
        hit: &LaneHit,
        l: [u32; WIDTH],
        (ux, uy): (F32x, F32x),
        u_seed: F32x,
        settings: &ManifoldParams,
        time: F32x,
        active: Mask,
        ctx: &mut LaneCtx<'a>,
    ) -> (Mask, Vec3x, Vec3x) {
        let (mut found, mut wi, mut radiance) = (Mask::NONE, Vec3x::ZERO, Vec3x::ZERO);
        for k in lanes_of(active) {
            let (p, n) = (hit.records.p.lane(k), hit.records.n.lane(k));
            let (f, w, r) = manifold_draw(
                self.scene,
                p,
                n,
                time.0[k],
                l[k] as usize,
                (ux.0[k], uy.0[k]),
                u_seed.0[k],
                settings,
                ctx.path_mut(k),
            );
            found.0[k] = f;
            wi.set_lane(k, w);
            radiance.set_lane(k, r);
        }
        (found, wi, radiance)
    }

    #[inline]
    fn is_caster(&self, hit: &LaneHit, active: Mask) -> Mask {
        let mut caster = Mask::NONE;
        for k in lanes_of(active) {
            let material = self.scene.material_of(hit.hits.primitive[k]);
            caster.0[k] = crate::manifold::is_caster(&material.bsdf);
        }
        caster
    }
}

impl VertexBsdf<Vec3x> for LaneBsdf<'_, '_> {
    #[inline(always)]
    fn is_delta(&self) -> Mask {
        let mut delta = self.glass;
        for k in lanes_of(self.scalar) {
            delta.0[k] = self.models[k].get().is_some_and(|m| m.is_delta());
        }
        delta
    }

    #[inline(always)]
    fn chooses_lobe(&self) -> Mask {
        let mut lobe = self.glass;
        for k in lanes_of(self.scalar) {
            lobe.0[k] = self.models[k].get().is_some_and(|m| m.chooses_lobe());
        }
        lobe
    }

    #[inline(always)]
    fn eval(&self, wo: Vec3x, wi: Vec3x) -> Vec3x {
        let mut f = self.lambert.eval(wo, wi);
        for k in lanes_of(self.scalar) {
            if let Some(m) = &self.models[k].get() {
                f.set_lane(k, VertexBsdf::eval(m, wo.lane(k), wi.lane(k)));
            }
        }
        f
    }

    #[inline(always)]
    fn pdf(&self, wo: Vec3x, wi: Vec3x) -> F32x {
        let mut pdf = self.lambert.pdf(wo, wi);
        for k in lanes_of(self.scalar) {
            if let Some(m) = &self.models[k].get() {
                pdf.0[k] = VertexBsdf::pdf(m, wo.lane(k), wi.lane(k));
            }
        }
        pdf
    }

    #[inline(always)]
    fn sample(&self, wo: Vec3x, uc: F32x, (ux, uy): (F32x, F32x), active: Mask) -> (Mask, BsdfSample<Vec3x>) {
        let tabled = active & !self.scalar;
        let (glass, diffuse) = (tabled & self.glass, tabled & !self.glass);
        let (mut ok, mut s) = (Mask::NONE, no_sample());
        if glass.any() {
            // Smooth glass: RoughDielectric::sample.
            let (glass_ok, g) = smooth_dielectric_sample(self.eta, wo, uc, TransportMode::Radiance);
            (ok, s) = (glass & glass_ok, g);
        }
        if diffuse.any() {
            // Lambert::sample.
            let (dx, dy) = concentric_disk_point(ux, uy);
            let (diffuse_ok, d) = self.lambert.disk_sample(wo, dx, dy);
            ok = ok | (diffuse & diffuse_ok);
            s = BsdfSample::select(diffuse, &d, &s);
        }
        for k in lanes_of(active & self.scalar) {
            if let Some(m) = &self.models[k].get() {
                let (sampled, one) = VertexBsdf::sample(m, wo.lane(k), uc.0[k], (ux.0[k], uy.0[k]), true);
                ok.0[k] = sampled;
                set_sample_lane(&mut s, k, &one);
            }
        }
        (ok, s)
    }
}

impl VertexFrame<Vec3x> for ShadingFrame<Vec3x> {
    #[inline(always)]
    fn to_local(&self, v: Vec3x) -> Vec3x {
        ShadingFrame::to_local(self, v)
    }

    #[inline(always)]
    fn to_world(&self, v: Vec3x) -> Vec3x {
        ShadingFrame::to_world(self, v)
    }

    #[inline(always)]
    fn factor(&self, wo: Vec3x, wi: Vec3x) -> F32x {
        ShadingFrame::factor(self, wo, wi, TransportMode::Radiance)
    }
}
