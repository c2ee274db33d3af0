//! The world of one ray ([`OneRay`]): `path`'s vertex ([`PathState::advance`]) asked of the
//! scene's own primitives, materials and lights, one path at a time. The scalar engine runs it,
//! and the wavefront engine asks it lane by lane for what its tables do not hold.

use super::*;

/// The world of one ray: the scene's primitives, materials and lights as they are.
#[derive(Clone, Copy)]
pub(crate) struct OneRay<'a> {
    /// The scene.
    pub scene: &'a Scene,
}

/// Light `light` of `scene` sampled from the point `p` with the numbers `u`, its radiance in
/// the channels of `ctx`: next-event estimation's light sample, for one ray or for one lane.
#[inline(always)]
pub(crate) fn light_draw(
    scene: &Scene,
    p: Vec3,
    light: usize,
    u: (f32, f32),
    ctx: &PathContext,
) -> LightDraw<Vec3> {
    match scene.lights[light].sample_li(p, u.into()) {
        None => LightDraw { sample: LightSampleOf::none(), delta: true, target: p },
        Some(ls) => LightDraw {
            sample: LightSampleOf {
                sampled: true,
                wi: ls.wi,
                distance: ls.distance,
                radiance: ctx.channels.colour(ls.radiance),
                pdf: ls.pdf,
            },
            delta: ls.delta,
            target: if ls.distance.is_finite() { ls.position } else { p + ls.wi * scene.far_distance(p) },
        },
    }
}

impl<'a> PathWorld for OneRay<'a> {
    type R = f32;
    type V = Vec3;
    type Hit = Option<Intersection>;
    type Bsdf = Scattering<'a>;
    type Frame = ShadingFrame;
    type Light = usize;
    type Shadow = Option<ShadowRay>;
    type Context = PathContext;

    #[inline]
    fn light_count(&self) -> usize {
        self.scene.lights.len()
    }

    #[inline]
    fn has_casters(&self) -> bool {
        !self.scene.casters().is_empty()
    }

    #[inline]
    fn live(&self, _: &Self::Hit) -> bool {
        true
    }

    #[inline]
    fn found(&self, hit: &Self::Hit) -> bool {
        hit.is_some()
    }

    #[inline]
    fn surface(&self, hit: &Self::Hit) -> (f32, Vec3, Vec3, f32) {
        let h = &surface(hit).hit;
        (h.t, h.p, h.n, h.p_error)
    }

    #[inline(always)]
    fn escaped(
        &self,
        dir: Vec3,
        skip_mis: bool,
        bsdf_pdf: f32,
        light_pick: f32,
        seen: bool,
        _: bool,
        ctx: &mut PathContext,
    ) -> Vec3 {
        let scene = self.scene;
        let rgb = match scene.environment_light() {
            Some(i) if !skip_mis => {
                let env = &scene.lights[i];
                env.environment_radiance(dir)
                    * power_heuristic(bsdf_pdf, light_pick * env.environment_pdf(dir))
            }
            _ => scene.background(dir),
        };
        ctx.radiance_seen(rgb, seen)
    }

    #[inline(always)]
    fn emission(
        &self,
        hit: &Self::Hit,
        origin: Vec3,
        wo: Vec3,
        seen: bool,
        _: bool,
        ctx: &mut PathContext,
    ) -> (bool, Vec3, f32) {
        let isect = surface(hit);
        let Some(index) = self.scene.light_of(isect.primitive) else {
            return (false, Vec3::ZERO, 0.0);
        };
        let light = &self.scene.lights[index as usize];
        let le = ctx.radiance_seen(light.emitted(&isect.hit, wo), seen);
        if le == Vec3::ZERO {
            return (false, le, 0.0);
        }
        (true, le, light.pdf_li(origin, isect.hit.p, isect.hit.n))
    }

    #[inline(always)]
    fn bsdf(&self, hit: &Self::Hit, _: bool, ctx: &mut PathContext) -> (Scattering<'a>, Vec3) {
        let isect = surface(hit);
        let material = self.scene.material_of(isect.primitive);
        let bsdf = Scattering::at(material, isect.hit.p, isect.hit.uv, &ctx.channels);
        // Rough dispersive glass ends the secondaries only in the estimator kept to compare
        // against; otherwise they go on, weighted by MIS over the wavelengths.
        let ends = if ctx.hero_alone { ctx.end_secondaries_at(&material.bsdf, &bsdf) } else { Vec3::ONE };
        (bsdf, ends)
    }

    #[inline]
    fn frame(&self, hit: &Self::Hit, wo: Vec3) -> ShadingFrame {
        ShadingFrame::at(&surface(hit).hit, wo)
    }

    #[inline]
    fn draw_1d(&self, ctx: &mut PathContext, purpose: Dim, active: bool) -> f32 {
        if active {
            ctx.sampler.get_1d(purpose)
        } else {
            0.0
        }
    }

    #[inline]
    fn draw_2d(&self, ctx: &mut PathContext, purpose: Dim, active: bool) -> (f32, f32) {
        if active {
            ctx.sampler.get_2d(purpose).into()
        } else {
            (0.0, 0.0)
        }
    }

    #[inline]
    fn light_at(&self, u: f32) -> usize {
        light_index(u, self.scene.lights.len())
    }

    #[inline(always)]
    fn sample_light(
        &self,
        hit: &Self::Hit,
        light: usize,
        u: (f32, f32),
        _: bool,
        ctx: &PathContext,
    ) -> LightDraw<Vec3> {
        light_draw(self.scene, surface(hit).hit.p, light, u, ctx)
    }

    #[inline]
    fn no_shadow(&self) -> Option<ShadowRay> {
        None
    }

    #[inline(always)]
    fn shadow(
        &self,
        hit: &Self::Hit,
        target: Vec3,
        light: usize,
        time: f32,
        active: bool,
        ctx: &mut PathContext,
    ) -> Option<ShadowRay> {
        if !active {
            return None;
        }
        ShadowRay::new(&surface(hit).hit, target, Some(light as u32), time, &mut ctx.rays)
    }

    #[inline]
    fn split_wavelengths(
        &self,
        hit: &Self::Hit,
        s: &BsdfSample,
        wo_local: Vec3,
        uc: f32,
        u: (f32, f32),
        path: &PathState,
        _: bool,
        ctx: &mut PathContext,
    ) -> Vec3 {
        let replay = ctx.sampler.dimension();
        ctx.split_wavelengths(self.scene, surface(hit), s, wo_local, (uc, u), path, replay)
    }

    #[inline]
    fn mixes_wavelengths(&self, hit: &Self::Hit, active: bool, ctx: &PathContext) -> bool {
        active && {
            let isect = surface(hit);
            ctx.mixes_wavelengths(self.scene.material_of(isect.primitive), &isect.hit)
        }
    }

    #[inline]
    fn eval_wavelengths(
        &self,
        hit: &Self::Hit,
        wo: Vec3,
        wi: Vec3,
        _: bool,
        ctx: &PathContext,
    ) -> (Vec3, f32) {
        let isect = surface(hit);
        ctx.eval_wavelengths(
            self.scene.material_of(isect.primitive),
            &isect.hit,
            wo,
            wi,
            None,
            TransportMode::Radiance,
        )
    }

    #[inline]
    fn sample_wavelengths(
        &self,
        hit: &Self::Hit,
        wo: Vec3,
        uc: f32,
        u: (f32, f32),
        active: bool,
        ctx: &PathContext,
    ) -> (bool, BsdfSample) {
        if !active {
            return (false, no_sample());
        }
        let isect = surface(hit);
        let material = self.scene.material_of(isect.primitive);
        match ctx.sample_wavelengths(material, &isect.hit, wo, uc, u, TransportMode::Radiance) {
            Some(s) => (true, s),
            None => (false, no_sample()),
        }
    }

    #[inline]
    fn resume(&self, path: &mut PathState, ended: bool, ctx: &mut PathContext) -> bool {
        match ended.then(|| ctx.resume_branch(path)).flatten() {
            Some(replay) => {
                ctx.sampler.replay_from(replay);
                true
            }
            None => false,
        }
    }

    #[inline(always)]
    fn medium_after(
        &self,
        hit: &Self::Hit,
        dir: Vec3,
        transmitted: bool,
        _: bool,
        ctx: &PathContext,
    ) -> (bool, Vec3) {
        medium_after(self.scene, surface(hit), dir, transmitted, &ctx.channels)
    }

    #[inline]
    fn manifold(
        &self,
        hit: &Self::Hit,
        light: usize,
        u: (f32, f32),
        u_seed: f32,
        settings: &ManifoldParams,
        time: f32,
        active: bool,
        ctx: &mut PathContext,
    ) -> (bool, Vec3, Vec3) {
        if !active {
            return (false, Vec3::ZERO, Vec3::ZERO);
        }
        let h = &surface(hit).hit;
        manifold_draw(self.scene, h.p, h.n, time, light, u, u_seed, settings, ctx)
    }

    #[inline]
    fn is_caster(&self, hit: &Self::Hit, active: bool) -> bool {
        active && crate::manifold::is_caster(&self.scene.material_of(surface(hit).primitive).bsdf)
    }

    #[inline]
    fn count_scattered(ctx: &mut PathContext, reflected: bool, active: bool) {
        if active {
            if reflected {
                ctx.rays.reflected += 1;
            } else {
                ctx.rays.refracted += 1;
            }
        }
    }
}

/// Manifold next-event estimation from the point `p` (geometric normal `n`) at `time` to light
/// `light` with the numbers `u` and `u_seed`, in the channels of `ctx`, its segments counted as
/// shadow rays: where a chain is found, the direction towards it and its radiance over its
/// density. For one ray or for one lane.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn manifold_draw(
    scene: &Scene,
    p: Vec3,
    n: Vec3,
    time: f32,
    light: usize,
    u: (f32, f32),
    u_seed: f32,
    settings: &ManifoldParams,
    ctx: &mut PathContext,
) -> (bool, Vec3, Vec3) {
    let x = crate::manifold::Receiver { p, n, time };
    let (channels, hero_only) = (ctx.channels, ctx.hero_only);
    let found = crate::manifold::sample(
        scene,
        &x,
        light,
        u.into(),
        u_seed,
        settings,
        &channels,
        hero_only,
        &mut ctx.rays.shadow,
    );
    match found {
        Some(m) => (true, m.wi, m.radiance),
        None => (false, Vec3::ZERO, Vec3::ZERO),
    }
}

/// Where `isect` is a dielectric interface, the absorption (in `channels`, the interface's
/// indices at their hero wavelength) of the medium a ray along `dir` scatters into: the one it
/// stays in when reflected, enters when `transmitted`. Elsewhere the medium does not change.
#[inline(always)]
pub(super) fn medium_after(
    scene: &Scene,
    isect: &Intersection,
    dir: Vec3,
    transmitted: bool,
    channels: &Channels,
) -> (bool, Vec3) {
    let bsdf = &scene.material_of(isect.primitive).bsdf;
    match crossing(bsdf, dir, isect.hit.n, channels.hero()) {
        Some(c) => {
            let medium = if transmitted { c.transmitted } else { c.incident };
            (true, channels.colour(medium.absorption))
        }
        None => (false, Vec3::ZERO),
    }
}

/// The surface of a hit the path found (asked only where it found one).
#[inline(always)]
fn surface(hit: &Option<Intersection>) -> &Intersection {
    hit.as_ref().expect("asked only of a path that found a surface")
}

impl<'a> VertexBsdf<Vec3> for Scattering<'a> {
    #[inline]
    fn is_delta(&self) -> bool {
        Scattering::is_delta(self)
    }

    #[inline]
    fn chooses_lobe(&self) -> bool {
        Scattering::chooses_lobe(self)
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        Scattering::eval(self, wo, wi, TransportMode::Radiance)
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        Scattering::pdf(self, wo, wi)
    }

    #[inline]
    fn sample(&self, wo: Vec3, uc: f32, u: (f32, f32), active: bool) -> (bool, BsdfSample) {
        match active.then(|| Scattering::sample(self, wo, uc, u.into(), TransportMode::Radiance)).flatten() {
            Some(s) => (true, s),
            None => (false, no_sample()),
        }
    }
}

impl VertexFrame<Vec3> for ShadingFrame {
    #[inline]
    fn to_local(&self, v: Vec3) -> Vec3 {
        ShadingFrame::to_local(self, v)
    }

    #[inline]
    fn to_world(&self, v: Vec3) -> Vec3 {
        ShadingFrame::to_world(self, v)
    }

    #[inline]
    fn factor(&self, wo: Vec3, wi: Vec3) -> f32 {
        ShadingFrame::factor(self, wo, wi, TransportMode::Radiance)
    }
}
