//! Refractive index as a function of wavelength: constant, Cauchy's two-term formula, fits from
//! the Abbe number, and a few named glasses.
//!
//! Wavelengths are in nanometres, Cauchy's `b` in nm². A two-term Cauchy fit through the helium
//! d line and the hydrogen F and C lines ([`Ior::from_abbe`]) is exact at d and reproduces the
//! catalogue dispersion n_F − n_C; away from those lines it is an approximation (for dense flints
//! it underestimates the index in the deep blue by ~0.01), which is ample for rendering.
//! In RGB mode the renderer uses [`Ior::nominal`] (n_d); in spectral mode [`Ior::at`] the sampled λ.

/// The helium d line (nm), where catalogues quote n_d.
const LAMBDA_D: f64 = 587.56;
/// The hydrogen F line (nm).
const LAMBDA_F: f64 = 486.13;
/// The hydrogen C line (nm).
const LAMBDA_C: f64 = 656.27;

/// The named glasses: (name, n_d, Abbe number V_d).
const GLASSES: [(&str, f32, f32); 6] = [
    // Schott N-BK7 borosilicate crown.
    ("bk7", 1.5168, 64.17),
    // Fused silica (e.g. Corning 7980).
    ("fused-silica", 1.4585, 67.82),
    // Schott F2 flint.
    ("f2", 1.62004, 36.37),
    // Schott SF11 dense flint.
    ("sf11", 1.78472, 25.68),
    // Water at room temperature: an approximation (a liquid, not a glass; n varies with temperature).
    ("water", 1.333, 55.7),
    // Diamond.
    ("diamond", 2.417, 55.3),
];

/// The names accepted by [`Ior::named`], lowercase.
const NAMES: [&str; 6] = [GLASSES[0].0, GLASSES[1].0, GLASSES[2].0, GLASSES[3].0, GLASSES[4].0, GLASSES[5].0];

/// Refractive index as a function of wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ior {
    /// The same index at every wavelength (no dispersion).
    Constant(f32),
    /// Cauchy's formula n(λ) = a + b / λ², with λ in nm and `b` in nm².
    Cauchy {
        /// The index the formula tends to at long wavelengths.
        a: f32,
        /// The dispersion coefficient, in nm² (positive for normal dispersion).
        b: f32,
    },
}

impl Ior {
    /// The refractive index at wavelength `lambda_nm` (nanometres).
    #[inline]
    pub fn at(&self, lambda_nm: f32) -> f32 {
        match *self {
            Ior::Constant(n) => n,
            Ior::Cauchy { a, b } => a + b / (lambda_nm * lambda_nm),
        }
    }

    /// n_d at 587.56 nm (helium d line): the index used when the scene is rendered in RGB.
    #[inline]
    pub fn nominal(&self) -> f32 {
        self.at(LAMBDA_D as f32)
    }

    /// Whether the index varies with wavelength (a Cauchy formula with b ≠ 0).
    #[inline]
    pub fn is_dispersive(&self) -> bool {
        matches!(*self, Ior::Cauchy { b, .. } if b != 0.0)
    }

    /// Cauchy fit with n(587.56 nm) = `n_d`, n_F − n_C = (n_d − 1)/`abbe_vd`; V_d = ∞ gives a constant.
    pub fn from_abbe(n_d: f32, abbe_vd: f32) -> Ior {
        if abbe_vd == f32::INFINITY {
            return Ior::Constant(n_d);
        }
        let inv2 = |l: f64| 1.0 / (l * l);
        let (n_d, v) = (n_d as f64, abbe_vd as f64);
        let b = (n_d - 1.0) / v / (inv2(LAMBDA_F) - inv2(LAMBDA_C));
        let a = n_d - b * inv2(LAMBDA_D);
        Ior::Cauchy { a: a as f32, b: b as f32 }
    }

    /// A named glass's Abbe fit (see [`Ior::names`]); the name is matched ignoring ASCII case.
    pub fn named(name: &str) -> Option<Ior> {
        GLASSES
            .iter()
            .find(|(n, _, _)| n.eq_ignore_ascii_case(name))
            .map(|&(_, n_d, abbe)| Ior::from_abbe(n_d, abbe))
    }

    /// The names [`Ior::named`] knows: bk7, fused-silica, f2, sf11 (dense flint), water, diamond.
    pub fn names() -> &'static [&'static str] {
        &NAMES
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::refract;
    use glam::Vec3;

    const F: f32 = LAMBDA_F as f32;
    const C: f32 = LAMBDA_C as f32;
    const D: f32 = LAMBDA_D as f32;

    #[test]
    fn cauchy_formula_values() {
        let ior = Ior::Cauchy { a: 1.5, b: 4200.0 };
        assert!((ior.at(500.0) - (1.5 + 4200.0 / 250_000.0)).abs() < 1e-7);
        assert!((ior.at(700.0) - (1.5 + 4200.0 / 490_000.0)).abs() < 1e-7);
        assert!((ior.at(1e6) - 1.5).abs() < 1e-6);
        assert!((ior.nominal() - ior.at(587.56)).abs() < 1e-7);
        assert!(ior.is_dispersive());
        let flat = Ior::Cauchy { a: 1.4, b: 0.0 };
        assert!(!flat.is_dispersive());
        assert_eq!(flat.at(450.0), 1.4);
        let constant = Ior::Constant(1.33);
        assert!(!constant.is_dispersive());
        assert_eq!((constant.at(400.0), constant.at(700.0), constant.nominal()), (1.33, 1.33, 1.33));
    }

    #[test]
    fn abbe_fit_reproduces_n_d_and_the_dispersion() {
        for (n_d, v) in [(1.5168f32, 64.17f32), (1.78472, 25.68), (2.417, 55.3), (1.3, 90.0), (1.9, 20.0)] {
            let ior = Ior::from_abbe(n_d, v);
            assert!(ior.is_dispersive());
            assert!((ior.at(D) - n_d).abs() < 1e-5, "n_d {n_d}: {}", ior.at(D));
            assert!((ior.nominal() - n_d).abs() < 1e-5);
            let dispersion = ior.at(F) - ior.at(C);
            assert!((dispersion - (n_d - 1.0) / v).abs() < 1e-5, "n_d {n_d} V {v}: {dispersion}");
        }
        // The textbook Cauchy coefficients of BK7 are about a = 1.5046, b = 4200 nm².
        let Ior::Cauchy { a, b } = Ior::from_abbe(1.5168, 64.17) else { panic!("not a Cauchy fit") };
        assert!((a - 1.5046).abs() < 5e-4 && (b - 4200.0).abs() < 50.0, "a {a} b {b}");
        assert_eq!(Ior::from_abbe(1.5, f32::INFINITY), Ior::Constant(1.5));
    }

    #[test]
    fn named_glasses() {
        let expected = [
            ("bk7", 1.5168f32, 64.17f32),
            ("fused-silica", 1.4585, 67.82),
            ("f2", 1.62004, 36.37),
            ("sf11", 1.78472, 25.68),
            ("water", 1.333, 55.7),
            ("diamond", 2.417, 55.3),
        ];
        assert_eq!(Ior::names().len(), expected.len());
        for (name, n_d, v) in expected {
            assert!(Ior::names().contains(&name));
            assert_eq!(name, name.to_lowercase());
            let ior = Ior::named(name).unwrap_or_else(|| panic!("{name} missing"));
            assert!(ior.is_dispersive());
            assert!(ior.at(450.0) > ior.at(650.0), "{name}");
            assert!((ior.nominal() - n_d).abs() < 1e-5, "{name}: {}", ior.nominal());
            assert!(((ior.at(F) - ior.at(C)) - (n_d - 1.0) / v).abs() < 1e-5, "{name}");
        }
        assert_eq!(Ior::named("BK7"), Ior::named("bk7"));
        assert_eq!(Ior::named("unobtainium"), None);
        // A dense flint disperses far more than a crown.
        let spread = |n: &str| Ior::named(n).map(|i| i.at(450.0) - i.at(650.0)).unwrap();
        assert!(spread("sf11") > 2.5 * spread("bk7"));
    }

    /// Direction in the prism's plane at `angle` radians from +x, counter-clockwise.
    fn dir(angle: f32) -> Vec3 {
        Vec3::new(angle.cos(), angle.sin(), 0.0)
    }

    /// Deviation (radians, towards the base) of a ray through a prism of apex angle `apex`, traced
    /// with `optics::refract` through both faces; `theta_i` is the incidence angle on the first face.
    /// The apex points along +y, the faces' outward normals are (∓cos(A/2), sin(A/2)).
    fn traced_deviation(apex: f32, n: f32, theta_i: f32) -> (f32, Vec3) {
        let n1 = Vec3::new(-(apex / 2.0).cos(), (apex / 2.0).sin(), 0.0);
        let n2 = Vec3::new((apex / 2.0).cos(), (apex / 2.0).sin(), 0.0);
        // The incoming ray makes theta_i with the inward normal −n1 (at angle −A/2), rotated
        // counter-clockwise so that it bends towards the base.
        let d_in = dir(theta_i - apex / 2.0);
        let inside = refract(-d_in, n1, n).expect("entering glass never reflects totally");
        // Exit face: the away-pointing direction is −inside, on the side of the inward normal −n2.
        let d_out = refract(-inside, -n2, 1.0 / n).expect("no total internal reflection");
        let deviation = d_in.cross(d_out).z.atan2(d_in.dot(d_out));
        (-deviation, inside)
    }

    /// The analytic prism deviation δ = θ_i + asin(n sin(A − asin(sin θ_i / n))) − A, in f64.
    fn analytic_deviation(apex: f64, n: f64, theta_i: f64) -> f64 {
        theta_i + (n * (apex - (theta_i.sin() / n).asin()).sin()).asin() - apex
    }

    #[test]
    fn prism_separates_blue_from_red() {
        let sf11 = Ior::named("sf11").unwrap();
        let apex = 60f32.to_radians();
        // Minimum deviation for 550 nm: symmetric passage, θ_i = asin(n sin(A/2)).
        let n_550 = sf11.at(550.0);
        let theta_i = (n_550 * (apex / 2.0).sin()).asin();
        let (dev_550, inside) = traced_deviation(apex, n_550, theta_i);
        assert!(inside.y.abs() < 1e-5, "at minimum deviation the ray inside runs parallel to the base");
        assert!((dev_550 - (2.0 * theta_i - apex)).abs() < 1e-4, "{dev_550}");
        // It is a minimum: nearby incidence angles deviate more.
        for d in [-0.02f32, 0.02] {
            assert!(traced_deviation(apex, n_550, theta_i + d).0 > dev_550);
        }
        let mut previous = f32::INFINITY;
        for lambda in [450.0f32, 500.0, 550.0, 600.0, 650.0] {
            let n = sf11.at(lambda);
            let (traced, _) = traced_deviation(apex, n, theta_i);
            let analytic = analytic_deviation(apex as f64, n as f64, theta_i as f64);
            assert!((traced as f64 - analytic).abs() < 1e-4, "{lambda} nm: {traced} vs {analytic}");
            assert!(traced < previous, "deviation must fall with wavelength ({lambda} nm)");
            previous = traced;
        }
        let (dev_450, _) = traced_deviation(apex, sf11.at(450.0), theta_i);
        let (dev_650, _) = traced_deviation(apex, sf11.at(650.0), theta_i);
        assert!(dev_450 > dev_650, "blue {dev_450} must bend more than red {dev_650}");
        // SF11's spread over 450–650 nm through a 60° prism is a few degrees.
        let spread = (dev_450 - dev_650).to_degrees();
        assert!((2.0..6.0).contains(&spread), "spread {spread}°");
    }
}
