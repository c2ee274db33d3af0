//! Materials: the physical description and the empirical Phong terms of ray casting and Whitted.

use crate::bsdf::RoughCoating;
pub use crate::conductor::{Conductor, Distribution};
use crate::dispersion::Ior;
use crate::spectrum::Channels;
use glam::{Vec2, Vec3};
use std::sync::Arc;

pub use crate::texture::Texture;

/// Empirical Phong coefficients (Phong 1975, extended for ray tracing as in the thesis §3.2).
///
/// Local shading is `ka·C·L_ambient + Σ_lights V·E·(kd·C/π + ks·(h+2)/(2π)·max(0, r·v)^h)` with `E`
/// the irradiance from the light and `C` the surface colour. With `kd = 1, ks = 0` the diffuse
/// term is exactly Lambertian direct lighting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    /// Ambient weight k_a.
    pub ambient: f32,
    /// Diffuse weight k_d.
    pub diffuse: f32,
    /// Specular weight k_s.
    pub specular: f32,
    /// Highlight exponent h.
    pub shininess: f32,
}

/// A homogeneous medium on one side of a dielectric interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// Refractive index, possibly wavelength dependent.
    pub ior: Ior,
    /// Beer–Lambert absorption coefficient per scene unit (RGB).
    pub absorption: Vec3,
}

impl Medium {
    /// A clear medium with a constant index.
    pub fn clear(ior: f32) -> Medium {
        Medium { ior: Ior::Constant(ior), absorption: Vec3::ZERO }
    }

    /// The index at wavelength `lambda` (nm), or the nominal index n_d in RGB mode.
    #[inline]
    pub fn ior_at(&self, lambda: Option<f32>) -> f32 {
        match lambda {
            Some(l) => self.ior.at(l),
            None => self.ior.nominal(),
        }
    }

    /// Fraction of light surviving `distance` through the medium, in the path's `channels`.
    #[inline]
    pub fn transmittance(&self, distance: f32, channels: &Channels) -> Vec3 {
        if self.absorption == Vec3::ZERO {
            Vec3::ONE
        } else {
            (-channels.colour(self.absorption) * distance).exp()
        }
    }
}

/// The physical behaviour of a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflector.
    Diffuse {
        /// Fraction of light reflected, per channel, possibly varying over the surface.
        albedo: Texture,
        /// Whether only the side the surface normal points to reflects (Mitsuba's `diffuse`):
        /// black seen from behind, and light arriving from behind is not reflected.
        one_sided: bool,
    },
    /// Mirror, smooth or (GGX) rough.
    Mirror {
        /// Reflectance per channel, possibly varying over the surface.
        color: Texture,
        /// GGX roughness (α = roughness²); 0 is a perfect mirror.
        roughness: f32,
    },
    /// Conductor with a complex index (Mitsuba's `conductor`/`roughconductor`), smooth or rough
    /// (GGX or Beckmann).
    Conductor(Conductor),
    /// Dielectric interface between two media, smooth or (GGX or Beckmann) rough.
    Dielectric {
        /// Medium on the side opposite the normal.
        inside: Medium,
        /// Medium on the side the normal points to.
        outside: Medium,
        /// Roughness: the distribution's α (Mitsuba's) is roughness²; 0 is smooth.
        roughness: f32,
        /// Microfacet distribution of the rough interface.
        distribution: Distribution,
    },
    /// An infinitely thin dielectric slab (Mitsuba's `thindielectric`): specular reflection of
    /// the slab's reflectance, the rest straight through.
    ThinDielectric {
        /// The slab's refractive index.
        ior: f32,
        /// The index of the medium around it (on both sides).
        ior_outside: f32,
    },
    /// A diffuse base under a smooth dielectric coating (Mitsuba's `plastic`): the coating's
    /// mirror reflection plus the base's light through it; black from behind unless two-sided.
    Plastic {
        /// The base's diffuse reflectance (Mitsuba's `diffuse_reflectance`).
        diffuse: Vec3,
        /// Scale of the coating's specular reflection (Mitsuba's `specular_reflectance`).
        specular: Vec3,
        /// The coating's refractive index.
        ior: f32,
        /// The index of the medium outside.
        ior_outside: f32,
        /// Whether the light bouncing inside the coating shifts the colour (Mitsuba's
        /// `nonlinear`).
        nonlinear: bool,
        /// Whether the back is the same plastic (Mitsuba's `twosided` wrapper) instead of black.
        two_sided: bool,
    },
    /// A diffuse base under a rough dielectric coating (Mitsuba's `roughplastic`): the coating's
    /// microfacet reflection plus the base's light through it; black from behind unless
    /// two-sided.
    RoughPlastic {
        /// The base's diffuse reflectance (Mitsuba's `diffuse_reflectance`).
        diffuse: Vec3,
        /// Scale of the coating's specular reflection (Mitsuba's `specular_reflectance`).
        specular: Vec3,
        /// The coating's refractive index.
        ior: f32,
        /// The index of the medium outside.
        ior_outside: f32,
        /// Whether the light bouncing inside the coating shifts the colour (Mitsuba's
        /// `nonlinear`).
        nonlinear: bool,
        /// Whether the back is the same plastic (Mitsuba's `twosided` wrapper) instead of black.
        two_sided: bool,
        /// The width α of the coating's microfacet distribution, as Mitsuba defines it.
        alpha: f32,
        /// The coating's microfacet distribution.
        distribution: Distribution,
        /// The coating of index `ior / ior_outside` over `distribution` with width `alpha`, and
        /// its tables, computed once ([`Bsdf::rough_plastic`]).
        coating: Arc<RoughCoating>,
    },
}

impl Bsdf {
    /// A rough plastic with its coating's tables computed (the one way to build
    /// [`Bsdf::RoughPlastic`], so that the tables match the parameters).
    #[allow(clippy::too_many_arguments)]
    pub fn rough_plastic(
        diffuse: Vec3,
        specular: Vec3,
        ior: f32,
        ior_outside: f32,
        nonlinear: bool,
        two_sided: bool,
        alpha: f32,
        distribution: Distribution,
    ) -> Bsdf {
        let coating = Arc::new(RoughCoating::new(ior / ior_outside, distribution.with_alpha(alpha)));
        Bsdf::RoughPlastic {
            diffuse,
            specular,
            ior,
            ior_outside,
            nonlinear,
            two_sided,
            alpha,
            distribution,
            coating,
        }
    }

    /// Whether the surface is an interface whose index varies with wavelength on either side.
    pub fn is_dispersive(&self) -> bool {
        matches!(self, Bsdf::Dielectric { inside, outside, .. }
            if inside.ior.is_dispersive() || outside.ior.is_dispersive())
    }

    /// Whether the surface is a rough mirror, conductor or dielectric (roughness or α above 0);
    /// false for the plastics, whose base and coating the empirical methods render alike.
    pub fn is_rough(&self) -> bool {
        match self {
            Bsdf::Diffuse { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::Plastic { .. }
            | Bsdf::RoughPlastic { .. } => false,
            Bsdf::Mirror { roughness, .. } | Bsdf::Dielectric { roughness, .. } => *roughness > 0.0,
            Bsdf::Conductor(c) => c.is_rough(),
        }
    }

    /// Whether the surface scatters only into delta directions (a mirror, conductor or
    /// dielectric whose roughness the BSDFs treat as smooth): no light can be connected to it.
    pub fn is_specular(&self) -> bool {
        match self {
            Bsdf::Diffuse { .. } | Bsdf::Plastic { .. } | Bsdf::RoughPlastic { .. } => false,
            Bsdf::ThinDielectric { .. } => true,
            Bsdf::Mirror { roughness, .. } => {
                crate::bsdf::TrowbridgeReitz::from_roughness(*roughness).effectively_smooth()
            }
            Bsdf::Dielectric { roughness, distribution, .. } => {
                distribution.with_alpha(roughness * roughness).effectively_smooth()
            }
            Bsdf::Conductor(c) => c.microfacets().effectively_smooth(),
        }
    }
}

/// A material: physical behaviour plus its empirical Phong terms.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name in the scene file (composite bodies add a suffix for derived interfaces).
    pub name: String,
    /// Physical description.
    pub bsdf: Bsdf,
    /// Empirical terms for `raycast` and `whitted`.
    pub phong: Phong,
}

impl Material {
    /// The Phong defaults derived from a physical material: a diffuse surface is pure Lambert
    /// (k_a = k_d = 1, no highlight); a mirror, a conductor or a dielectric has no diffuse or ambient part and
    /// a sharp highlight (h = 200) weighted by its normal-incidence reflectance, the Phong stand-in
    /// for the reflection of a point light that a perfectly specular surface cannot otherwise show.
    pub fn default_phong(bsdf: &Bsdf) -> Phong {
        let highlight = |ks: f32| Phong { ambient: 0.0, diffuse: 0.0, specular: ks, shininess: 200.0 };
        match bsdf {
            Bsdf::Diffuse { .. } => Phong { ambient: 1.0, diffuse: 1.0, specular: 0.0, shininess: 1.0 },
            Bsdf::Mirror { color, .. } => highlight(color.max_value()),
            Bsdf::Conductor(c) => highlight(c.normal_reflectance().max_element()),
            Bsdf::Dielectric { inside, outside, .. } => {
                let (n1, n2) = (inside.ior.nominal(), outside.ior.nominal());
                highlight(((n1 - n2) / (n1 + n2)).powi(2))
            }
            Bsdf::ThinDielectric { ior, ior_outside } => {
                let r = ((ior - ior_outside) / (ior + ior_outside)).powi(2);
                highlight(2.0 * r / (1.0 + r))
            }
            // Lambert for the base, the coating's normal-incidence reflection as the highlight.
            Bsdf::Plastic { specular, ior, ior_outside, .. }
            | Bsdf::RoughPlastic { specular, ior, ior_outside, .. } => {
                let r = ((ior - ior_outside) / (ior + ior_outside)).powi(2);
                Phong { ambient: 1.0, diffuse: 1.0, specular: r * specular.max_element(), shininess: 200.0 }
            }
        }
    }

    /// Whether the surface reflects only on the side its normal points to (a one-sided diffuse
    /// or plastic, smooth or rough).
    pub fn is_one_sided(&self) -> bool {
        matches!(
            self.bsdf,
            Bsdf::Diffuse { one_sided: true, .. }
                | Bsdf::Plastic { two_sided: false, .. }
                | Bsdf::RoughPlastic { two_sided: false, .. }
        )
    }

    /// The surface colour `C` of the Phong model at point `p` with texture coordinates `uv`.
    pub fn phong_color(&self, p: Vec3, uv: Vec2) -> Vec3 {
        match &self.bsdf {
            Bsdf::Diffuse { albedo, .. } => albedo.eval(p, uv),
            Bsdf::Mirror { color, .. } => color.eval(p, uv),
            Bsdf::Conductor(c) => c.normal_reflectance(),
            Bsdf::Plastic { diffuse, .. } | Bsdf::RoughPlastic { diffuse, .. } => *diffuse,
            Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. } => Vec3::ONE,
        }
    }

    /// The same interface seen from the other side (inside and outside indices swapped), used
    /// for the inner surfaces of hollow bodies.
    pub fn swapped_interface(&self) -> Material {
        let bsdf = match self.bsdf {
            Bsdf::Dielectric { inside, outside, roughness, distribution } => {
                Bsdf::Dielectric { inside: outside, outside: inside, roughness, distribution }
            }
            ref other => other.clone(),
        };
        Material { name: format!("{} (inner)", self.name), bsdf, phong: self.phong }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swapping_an_interface_twice_is_the_identity() {
        let bsdf = Bsdf::Dielectric {
            inside: Medium { ior: Ior::Constant(1.5), absorption: Vec3::new(0.1, 0.2, 0.3) },
            outside: Medium::clear(1.0),
            roughness: 0.2,
            distribution: Distribution::Beckmann,
        };
        let glass = Material { name: "glass".into(), phong: Material::default_phong(&bsdf), bsdf };
        let inner = glass.swapped_interface();
        let Bsdf::Dielectric { inside, outside, roughness, .. } = inner.bsdf else { panic!() };
        assert_eq!((inside, outside.ior, roughness), (Medium::clear(1.0), Ior::Constant(1.5), 0.2));
        assert_eq!(outside.absorption, Vec3::new(0.1, 0.2, 0.3));
        assert_eq!(inner.swapped_interface().bsdf, glass.bsdf);
    }

    #[test]
    fn beer_lambert_transmittance() {
        let m = Medium { ior: Ior::Constant(1.5), absorption: Vec3::new(0.0, 1.0, 2.0) };
        let t = m.transmittance(0.5, &Channels::Rgb);
        assert_eq!(t.x, 1.0);
        assert!((t.y - (-0.5f32).exp()).abs() < 1e-7 && (t.z - (-1.0f32).exp()).abs() < 1e-7);
    }
}
