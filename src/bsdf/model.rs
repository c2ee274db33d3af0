//! The scattering model of a material at a hit point, for the physically based methods (`path`,
//! `light`): Lambert, smooth or rough mirror or conductor, smooth or rough dielectric, behind one
//! interface, thin dielectric, plastic smooth or rough.

use super::{
    BsdfEval, BsdfSample, Lambert, Plastic, RoughConductor, RoughDielectric, RoughPlastic, ThinDielectric,
    TransportMode, TrowbridgeReitz,
};
use crate::material::{Bsdf, Material};
use crate::spectrum::Channels;
use glam::{Vec2, Vec3};
use rand::Rng;

/// A material's BSDF at one point, in the local frame of the surface's geometric normal (the
/// `outside` side is +Z); it borrows the material's tables (a rough plastic's coating).
#[derive(Clone, Copy, Debug)]
pub enum Scattering<'a> {
    /// Ideal diffuse reflection.
    Diffuse(Lambert),
    /// Mirror or conductor (a delta lobe when smooth).
    Conductor(RoughConductor),
    /// Dielectric interface (a pair of delta lobes when smooth).
    Dielectric(RoughDielectric),
    /// Thin dielectric slab: mirror reflection and straight transmission (two delta lobes).
    ThinDielectric(ThinDielectric),
    /// Diffuse base under a smooth coating: a delta mirror lobe plus a smooth base lobe.
    Plastic(Plastic),
    /// Diffuse base under a rough coating: a microfacet lobe plus the base's lobe.
    RoughPlastic(RoughPlastic<'a>),
}

impl<'a> Scattering<'a> {
    /// The scattering of `material` at world point `p` with texture coordinates `uv` in the
    /// path's `channels`: colours as RGB or as their spectra at the wavelengths, indices nominal
    /// or at the hero wavelength.
    #[inline(always)]
    pub fn at(material: &'a Material, p: Vec3, uv: Vec2, channels: &Channels) -> Scattering<'a> {
        let lambda = channels.hero();
        match &material.bsdf {
            Bsdf::Diffuse { albedo, one_sided } => Scattering::Diffuse(Lambert {
                albedo: channels.colour(albedo.eval(p, uv)),
                one_sided: *one_sided,
            }),
            Bsdf::Mirror { color, roughness } => Scattering::Conductor(RoughConductor::new(
                channels.colour(color.eval(p, uv)),
                TrowbridgeReitz::from_roughness(*roughness),
            )),
            Bsdf::Conductor(c) => Scattering::Conductor(c.scattering(channels)),
            Bsdf::ThinDielectric { ior, ior_outside } => {
                Scattering::ThinDielectric(ThinDielectric { eta: ior / ior_outside })
            }
            Bsdf::Plastic { diffuse, specular, ior, ior_outside, nonlinear, two_sided } => {
                Scattering::Plastic(Plastic {
                    diffuse: channels.colour(*diffuse),
                    specular: channels.colour(*specular),
                    eta: ior / ior_outside,
                    nonlinear: *nonlinear,
                    // From the RGB reflectances in every mode, as Mitsuba weighs them once per BSDF.
                    specular_weight: Plastic::sampling_weight(*diffuse, *specular),
                    two_sided: *two_sided,
                })
            }
            Bsdf::RoughPlastic { diffuse, specular, nonlinear, two_sided, coating, .. } => {
                Scattering::RoughPlastic(RoughPlastic {
                    diffuse: channels.colour(*diffuse),
                    specular: channels.colour(*specular),
                    nonlinear: *nonlinear,
                    specular_weight: Plastic::sampling_weight(*diffuse, *specular),
                    two_sided: *two_sided,
                    coating,
                })
            }
            Bsdf::Dielectric { inside, outside, roughness, distribution } => {
                Scattering::Dielectric(RoughDielectric::new(
                    inside.ior_at(lambda) / outside.ior_at(lambda),
                    distribution.with_alpha(roughness * roughness),
                ))
            }
        }
    }

    /// Whether the model only scatters into delta directions (eval and pdf are always 0).
    pub fn is_delta(&self) -> bool {
        match self {
            Scattering::Diffuse(_) | Scattering::Plastic(_) | Scattering::RoughPlastic(_) => false,
            Scattering::Conductor(c) => c.distribution.effectively_smooth(),
            Scattering::Dielectric(d) => d.is_specular(),
            Scattering::ThinDielectric(_) => true,
        }
    }

    /// The BSDF value for the local directions `wo`, `wi` (for rough glass, its single scattering).
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match self {
            Scattering::Diffuse(m) => m.eval(wo, wi),
            Scattering::Conductor(m) => m.eval(wo, wi),
            Scattering::Dielectric(m) => m.eval(wo, wi, mode),
            Scattering::ThinDielectric(_) => Vec3::ZERO,
            Scattering::Plastic(m) => m.eval(wo, wi),
            Scattering::RoughPlastic(m) => m.eval(wo, wi),
        }
    }

    /// Whether `eval` leaves out part of the scattering (rough glass's light scattered between
    /// several facets), which [`eval_multiple`](Self::eval_multiple) then estimates.
    pub fn has_multiple_scattering(&self) -> bool {
        matches!(self, Scattering::Dielectric(d) if !d.is_specular())
    }

    /// An unbiased estimate of the scattering that `eval` leaves out (zero for every model but
    /// rough glass), drawn with `rng`.
    pub fn eval_multiple<R: Rng>(&self, wo: Vec3, wi: Vec3, mode: TransportMode, rng: &mut R) -> Vec3 {
        match self {
            Scattering::Dielectric(m) => m.eval_multiple(wo, wi, mode, rng),
            _ => Vec3::ZERO,
        }
    }

    /// The solid-angle density with which `sample` produces `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Scattering::Diffuse(m) => m.pdf(wo, wi),
            Scattering::Conductor(m) => m.pdf(wo, wi),
            Scattering::Dielectric(m) => m.pdf(wo, wi),
            Scattering::ThinDielectric(_) => 0.0,
            Scattering::Plastic(m) => m.pdf(wo, wi),
            Scattering::RoughPlastic(m) => m.pdf(wo, wi),
        }
    }

    /// The BSDF value for `wo`, `wi` with the forward density (of `wi` sampled from `wo`) and
    /// the reverse density (of `wo` sampled from `wi`), in one call: what a connection or a
    /// merge of the bidirectional methods needs at each end. The same numbers as
    /// [`eval`](Self::eval) and [`pdf`](Self::pdf) both ways (tested to the bit), so renders do
    /// not depend on which form a method calls.
    pub fn evaluate(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> BsdfEval {
        BsdfEval { f: self.eval(wo, wi, mode), pdf: self.pdf(wo, wi), pdf_rev: self.pdf(wi, wo) }
    }

    /// Whether [`Scattering::sample`] uses its `uc`: glass (reflection or refraction) and the
    /// plastics (coating or base) choose between lobes; the other models draw a direction from
    /// `u` alone.
    pub fn chooses_lobe(&self) -> bool {
        // Every variant named: a new model must say whether it uses `uc`.
        match self {
            Scattering::Diffuse(_) | Scattering::Conductor(_) => false,
            Scattering::Dielectric(_)
            | Scattering::ThinDielectric(_)
            | Scattering::Plastic(_)
            | Scattering::RoughPlastic(_) => true,
        }
    }

    /// A scattered direction for `wo` from the uniforms `uc`, `u`.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        match self {
            Scattering::Diffuse(m) => m.sample(wo, u),
            Scattering::Conductor(m) => m.sample(wo, u),
            Scattering::Dielectric(m) => m.sample(wo, uc, u, mode),
            Scattering::ThinDielectric(m) => m.sample(wo, uc),
            Scattering::Plastic(m) => m.sample(wo, uc, u),
            Scattering::RoughPlastic(m) => m.sample(wo, uc, u),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::uniform_sphere;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn evaluate_gives_the_value_and_both_densities_of_every_model() {
        let rough = TrowbridgeReitz::from_roughness(0.3);
        let coating = crate::bsdf::RoughCoating::new(1.49, crate::bsdf::Beckmann::new(0.2).into());
        let models = [
            Scattering::Diffuse(Lambert::two_sided(Vec3::new(0.2, 0.5, 0.8))),
            Scattering::Diffuse(Lambert { albedo: Vec3::new(0.2, 0.5, 0.8), one_sided: true }),
            Scattering::Conductor(RoughConductor::new(Vec3::splat(0.9), rough)),
            Scattering::Conductor(RoughConductor::with_fresnel(
                crate::bsdf::ConductorFresnel::Complex {
                    eta: Vec3::new(0.2, 0.9, 1.1),
                    k: Vec3::new(3.9, 2.5, 2.1),
                    scale: Vec3::ONE,
                },
                crate::bsdf::Beckmann::new(0.2),
            )),
            Scattering::Dielectric(RoughDielectric::new(1.5, rough)),
            Scattering::Dielectric(RoughDielectric::new(1.0 / 1.33, rough)),
            Scattering::ThinDielectric(ThinDielectric { eta: 1.5 }),
            Scattering::Plastic(Plastic {
                diffuse: Vec3::new(0.2, 0.4, 0.8),
                specular: Vec3::ONE,
                eta: 1.49,
                nonlinear: false,
                specular_weight: 0.6,
                two_sided: false,
            }),
            Scattering::Plastic(Plastic {
                diffuse: Vec3::new(0.7, 0.4, 0.1),
                specular: Vec3::splat(0.8),
                eta: 1.33,
                nonlinear: true,
                specular_weight: 0.4,
                two_sided: true,
            }),
            Scattering::RoughPlastic(RoughPlastic {
                diffuse: Vec3::new(0.7, 0.4, 0.1),
                specular: Vec3::splat(0.9),
                nonlinear: true,
                specular_weight: 0.4,
                two_sided: true,
                coating: &coating,
            }),
        ];
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let mut u = || Vec2::new(rng.random(), rng.random());
        for model in models {
            for _ in 0..2000 {
                let (wo, wi) = (uniform_sphere(u()), uniform_sphere(u()));
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let e = model.evaluate(wo, wi, mode);
                    assert_eq!(e.f, model.eval(wo, wi, mode));
                    assert_eq!(e.pdf.to_bits(), model.pdf(wo, wi).to_bits());
                    assert_eq!(e.pdf_rev.to_bits(), model.pdf(wi, wo).to_bits());
                }
                if let Scattering::Diffuse(lambert) = model {
                    // Cosine sampling from wi picks wo with |cos θo|/π on wi's side (the front
                    // only when one-sided).
                    let e = model.evaluate(wo, wi, TransportMode::Radiance);
                    let side = wo.z * wi.z > 0.0 && (wo.z > 0.0 || !lambert.one_sided);
                    let expected = if side { wo.z.abs() / std::f32::consts::PI } else { 0.0 };
                    assert!((e.pdf_rev - expected).abs() < 1e-6, "{} vs {expected}", e.pdf_rev);
                }
            }
        }
    }
}
