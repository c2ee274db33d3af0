//! Pixel reconstruction filters, as Mitsuba 3 defines and applies them (`src/rfilters/`): `box`
//! (one pixel wide, vitrum's default), `tent` (`1 − |x|/r` out to the radius r, default 1) and
//! `gaussian` (`exp(−x²/2σ²) − exp(−r²/2σ²)` with σ the `stddev`, default 0.5, cut off at r = 4σ,
//! so that it reaches 0 there). Each is separable: its value at a film offset (x, y) from a
//! pixel's centre is `f(x)·f(y)` with `f` the one-dimensional profile.
//!
//! Mitsuba's film does not weight its samples by that profile itself but by its table
//! (`ReconstructionFilter::eval_discretized`, which `ImageBlock::put` calls): the profile at
//! `r·i/31` for i = 0…30, held over each step `[r·i/31, r·(i+1)/31)` of |x|, 0 beyond. vitrum's
//! filter is that step function, so its images are Mitsuba's (measured: a sharp edge's pixels
//! are within about one standard error of the table's integral across the edge, five from the
//! smooth profile's; see `scenes/README.md`).
//!
//! A pixel's value is the filter-weighted mean of the radiance over the film around its centre,
//! `I_c = ∫ f(x − c) L(x) dx / ∫ f(x − c) dx`, both integrals over the film (a footprint that
//! reaches past the film's edge is cut there, as Mitsuba's `hdrfilm` does by default). vitrum
//! estimates it by importance sampling the filter (pbrt-v4's approach): a camera sample of pixel
//! c is drawn from the normalised filter by inverting its cumulative distribution along each
//! axis ([`PixelFilter::film_point`]), so every sample keeps the weight 1 and the film's
//! per-sample sums and variance estimates are unchanged. The step function's distribution is
//! piecewise linear, so its inverse is exact (up to rounding) and a pure function of the sample.
//!
//! Light-path splats reach every pixel whose footprint covers their film point, each with the
//! normalised weight `f(x − c) / ∫ f(x − c) dx` ([`PixelFilter::splat_weights`]), so that the
//! splatted and the camera-sampled estimates of a pixel have the same expectation.
//!
//! The box keeps the old arithmetic bit for bit: its film point is the pixel's corner plus the
//! sample, and a splat goes to the one pixel it lands in with weight 1.

use glam::Vec2;

/// Which filter, with its parameter (Mitsuba's plugin and its property).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FilterKind {
    /// The one-pixel box: the mean over the pixel's square (Mitsuba's `box`, radius ½).
    Box,
    /// Mitsuba's `tent`: `max(0, 1 − |x|/radius)` per axis.
    Tent {
        /// Where the filter reaches 0, in pixels.
        radius: f32,
    },
    /// Mitsuba's `gaussian`: `max(0, exp(−x²/2σ²) − exp(−(4σ)²/2σ²))` per axis, radius 4σ.
    Gaussian {
        /// The standard deviation σ in pixels.
        stddev: f32,
    },
}

/// Steps of Mitsuba's filter table over one radius (its `MI_FILTER_RESOLUTION`).
pub const TABLE_STEPS: usize = 31;

/// A pixel reconstruction filter (module documentation): its kind and Mitsuba's table of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFilter {
    /// Which filter.
    pub kind: FilterKind,
    /// The profile at the start of each step of |x|, `r·i/31` (unused for the box).
    steps: [f64; TABLE_STEPS],
    /// `∫_0^{r·i/31}` of the step function, for i = 0…31.
    cumulative: [f64; TABLE_STEPS + 1],
}

impl Default for PixelFilter {
    fn default() -> PixelFilter {
        PixelFilter::BOX
    }
}

/// What the filter means for each method (`vitrum info`, docs/methods.md): the methods that draw
/// camera samples place them by the filter, the splatting methods share splats by it, and the
/// deterministic patterns say what they do with it.
pub const METHOD_MEANING: &str = "path, distributed, bpt, ppm, bpm, vcm and raycast/whitted with more than one sample place \
each camera sample by the filter; light, bpt, vcm (and ppm, bpm) share each camera splat among the pixels it covers by the \
normalised filter weight; one sample per pixel (raycast, whitted) goes through the pixel's centre; ssaa's grid is a \
midpoint quadrature of the filter, its adaptive mode always the box";

/// The tent's default radius (Mitsuba's), in pixels.
pub const DEFAULT_TENT_RADIUS: f32 = 1.0;
/// The Gaussian's default standard deviation (Mitsuba's), in pixels.
pub const DEFAULT_GAUSSIAN_STDDEV: f32 = 0.5;

impl FilterKind {
    /// Half the width of the footprint along each axis, in pixels.
    pub fn radius(&self) -> f32 {
        match *self {
            FilterKind::Box => 0.5,
            FilterKind::Tent { radius } => radius,
            FilterKind::Gaussian { stddev } => 4.0 * stddev,
        }
    }

    /// The plugin's smooth profile at offset `x` (Mitsuba's `eval`), from which the table is made.
    pub fn profile(&self, x: f64) -> f64 {
        let r = self.radius() as f64;
        if x.is_nan() || x.abs() > r {
            return 0.0;
        }
        match *self {
            FilterKind::Box => 1.0,
            FilterKind::Tent { radius } => (1.0 - x.abs() / radius as f64).max(0.0),
            FilterKind::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev as f64 * stddev as f64);
                ((alpha * x * x).exp() - (alpha * r * r).exp()).max(0.0)
            }
        }
    }
}

impl PixelFilter {
    /// The one-pixel box.
    pub const BOX: PixelFilter =
        PixelFilter { kind: FilterKind::Box, steps: [0.0; TABLE_STEPS], cumulative: [0.0; TABLE_STEPS + 1] };

    /// The filter `kind`, its table made as Mitsuba makes it.
    pub fn new(kind: FilterKind) -> PixelFilter {
        if kind == FilterKind::Box {
            return PixelFilter::BOX;
        }
        let width = kind.radius() as f64 / TABLE_STEPS as f64;
        let steps: [f64; TABLE_STEPS] = std::array::from_fn(|i| kind.profile(width * i as f64));
        let mut cumulative = [0.0; TABLE_STEPS + 1];
        for i in 0..TABLE_STEPS {
            cumulative[i + 1] = cumulative[i] + steps[i] * width;
        }
        PixelFilter { kind, steps, cumulative }
    }

    /// Whether this is the box (the old pixel square, handled by the old arithmetic).
    pub fn is_box(&self) -> bool {
        self.kind == FilterKind::Box
    }

    /// Mitsuba's plugin name: `box`, `tent` or `gaussian`.
    pub fn name(&self) -> &'static str {
        match self.kind {
            FilterKind::Box => "box",
            FilterKind::Tent { .. } => "tent",
            FilterKind::Gaussian { .. } => "gaussian",
        }
    }

    /// The filter in words, with its parameters (`vitrum info`).
    pub fn describe(&self) -> String {
        match self.kind {
            FilterKind::Box => "box (one pixel)".to_string(),
            FilterKind::Tent { radius } => format!("tent, radius {radius} px"),
            FilterKind::Gaussian { stddev } => {
                format!("gaussian, stddev {stddev} px (radius {} px)", 4.0 * stddev)
            }
        }
    }

    /// Half the width of the footprint along each axis, in pixels.
    pub fn radius(&self) -> f32 {
        self.kind.radius()
    }

    /// The width of one step of the table, in pixels.
    fn step_width(&self) -> f64 {
        self.radius() as f64 / TABLE_STEPS as f64
    }

    /// The one-dimensional filter at offset `x` (pixels) from a pixel's centre, unnormalised:
    /// Mitsuba's table (`eval_discretized`); the box is 1 on [−½, ½].
    pub fn eval(&self, x: f32) -> f32 {
        self.eval64(x as f64) as f32
    }

    fn eval64(&self, x: f64) -> f64 {
        if self.is_box() {
            return if x.abs() <= 0.5 { 1.0 } else { 0.0 };
        }
        let i = (x.abs() / self.step_width()) as usize;
        if i < TABLE_STEPS {
            self.steps[i]
        } else {
            0.0
        }
    }

    /// `∫_0^t f` for 0 ≤ t (the table's half integral; beyond the radius, all of it).
    fn half_integral(&self, t: f64) -> f64 {
        let width = self.step_width();
        let i = (t / width) as usize;
        if i >= TABLE_STEPS {
            return self.cumulative[TABLE_STEPS];
        }
        self.cumulative[i] + self.steps[i] * (t - i as f64 * width)
    }

    /// The t ≥ 0 with `∫_0^t f = g` (0 ≤ g ≤ the half integral).
    fn invert_half(&self, g: f64) -> f64 {
        let width = self.step_width();
        // The step whose cumulative range holds g (the last step with its start at or below g).
        let i = self.cumulative[1..].partition_point(|&c| c < g).min(TABLE_STEPS - 1);
        let within = if self.steps[i] > 0.0 { (g - self.cumulative[i]) / self.steps[i] } else { 0.0 };
        (i as f64 * width + within.clamp(0.0, width)).min(self.radius() as f64)
    }

    /// `∫_{−r}^{x} f`: the filter's integral from the left end of its footprint to `x`.
    fn integral_to(&self, x: f64) -> f64 {
        let r = self.radius() as f64;
        let x = x.clamp(-r, r);
        if self.is_box() {
            return x + r;
        }
        let half = self.cumulative[TABLE_STEPS];
        if x < 0.0 {
            half - self.half_integral(-x)
        } else {
            half + self.half_integral(x)
        }
    }

    /// `∫ f` over the whole footprint (along one axis).
    pub fn integral(&self) -> f64 {
        self.integral_to(self.radius() as f64)
    }

    /// The offset x in [−r, r] with `∫_{−r}^{x} f = target` (0 ≤ target ≤ ∫ f).
    fn invert(&self, target: f64) -> f64 {
        if self.is_box() {
            return target - 0.5;
        }
        let half = self.cumulative[TABLE_STEPS];
        if target < half {
            -self.invert_half(half - target)
        } else {
            self.invert_half(target - half)
        }
    }

    /// The footprint of the centre at `centre` cut to the film's extent [0, `n`] along one axis:
    /// the integrals `∫_{−r}^{lo} f` and `∫_{−r}^{hi} f` at its ends.
    fn cut(&self, centre: f64, n: u32) -> (f64, f64) {
        let r = self.radius() as f64;
        let lo = (-centre).max(-r);
        let hi = (n as f64 - centre).min(r);
        (self.integral_to(lo), self.integral_to(hi))
    }

    /// The offset from the centre of pixel `i` (of `n` along the axis) for the sample `u` in
    /// [0, 1): the inverse of the filter's distribution cut to the film.
    fn axis_offset(&self, u: f32, i: u32, n: u32) -> f32 {
        let (a, b) = self.cut(i as f64 + 0.5, n);
        self.invert(a + u as f64 * (b - a)) as f32
    }

    /// The film position (pixels, x right and y down) of the camera sample `u` in [0, 1)² of
    /// pixel (`x`, `y`) on a film of `width`×`height` pixels: drawn from the filter around the
    /// pixel's centre, the footprint cut to the film. The box gives `(x, y) + u`.
    #[inline]
    pub fn film_point(&self, x: u32, y: u32, u: Vec2, width: u32, height: u32) -> Vec2 {
        match self.kind {
            FilterKind::Box => Vec2::new(x as f32, y as f32) + u,
            _ => Vec2::new(
                x as f32 + 0.5 + self.axis_offset(u.x, x, width),
                y as f32 + 0.5 + self.axis_offset(u.y, y, height),
            ),
        }
    }

    /// The normalised weight along one axis of pixel `i` (of `n`) for a film coordinate `p`:
    /// `f(p − c) / ∫_film f(· − c)`.
    fn axis_weight(&self, p: f32, i: u32, n: u32) -> f32 {
        let c = i as f64 + 0.5;
        let (a, b) = self.cut(c, n);
        (self.eval64(p as f64 - c) / (b - a)) as f32
    }

    /// Every pixel (x, y) of a `width`×`height` film whose footprint covers the film point `p`,
    /// with its normalised weight `f(p − c)/∫ f` (footprints cut to the film), passed to `visit`
    /// row by row. The box visits the one pixel `p` lies in with weight 1.
    pub fn splat_weights(&self, p: Vec2, width: u32, height: u32, mut visit: impl FnMut(u32, u32, f32)) {
        if !(p.x >= 0.0 && p.y >= 0.0 && p.x < width as f32 && p.y < height as f32) {
            return;
        }
        if self.is_box() {
            visit(p.x as u32, p.y as u32, 1.0);
            return;
        }
        let r = self.radius();
        let span = |q: f32, n: u32| {
            let first = (q - 0.5 - r).ceil().max(0.0) as u32;
            let last = ((q - 0.5 + r).floor().max(0.0) as u32).min(n - 1);
            first..=last
        };
        for y in span(p.y, height) {
            let wy = self.axis_weight(p.y, y, height);
            if wy == 0.0 {
                continue;
            }
            for x in span(p.x, width) {
                let wx = self.axis_weight(p.x, x, width);
                if wx != 0.0 {
                    visit(x, y, wx * wy);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::chi2::outcome_of_counts;

    fn filters() -> [PixelFilter; 4] {
        [
            PixelFilter::new(FilterKind::Tent { radius: 1.0 }),
            PixelFilter::new(FilterKind::Tent { radius: 2.5 }),
            PixelFilter::new(FilterKind::Gaussian { stddev: 0.5 }),
            PixelFilter::new(FilterKind::Gaussian { stddev: 0.8 }),
        ]
    }

    /// Mitsuba's tent and Gaussian, written out from their definitions, and their tables as
    /// Mitsuba 3.9's `eval_discretized` gives them (read from its Python bindings).
    #[test]
    fn profiles_and_tables_are_mitsubas() {
        let tent = FilterKind::Tent { radius: 2.0 };
        assert_eq!(tent.profile(0.0), 1.0);
        assert_eq!(tent.profile(1.0), 0.5);
        assert_eq!(tent.profile(2.5), 0.0);
        let g = FilterKind::Gaussian { stddev: 0.5 };
        assert_eq!(g.radius(), 2.0);
        let want = |x: f64| ((-2.0 * x * x).exp() - (-8.0f64).exp()).max(0.0);
        for x in [0.0, 0.3, 1.0, 1.9, 2.0, 2.1] {
            assert!((g.profile(x) - want(x)).abs() < 1e-12, "x = {x}");
        }
        assert_eq!(g.profile(2.0), 0.0, "the Gaussian reaches 0 at its radius");
        // mi.load_dict({'type': 'gaussian'}).eval_discretized(x), Mitsuba 3.9.1, scalar_rgb: its
        // single-precision exp differs from the exact one by up to 4.2·10⁻⁴ (its eval(0) is
        // 0.999247, the formula's 0.999665), hence the tolerance of 5·10⁻⁴.
        let table = PixelFilter::new(g);
        let mitsuba = [
            (0.0f32, 0.999_247_13),
            (1.0, 0.153_261_32),
            (1.5, 0.011_879_71),
            (1.9, 0.000_574_584_64),
            (1.95, 0.000_220_787_14),
        ];
        for (x, m) in mitsuba {
            assert!((table.eval(x) - m).abs() < 5e-4, "x = {x}: {} vs Mitsuba's {m}", table.eval(x));
        }
        // The tent's table (radius 1.5) is exact: 1 − i/31 on step i.
        let tent = PixelFilter::new(FilterKind::Tent { radius: 1.5 });
        for (x, m) in [(0.0f32, 1.0f32), (0.75, 0.516129), (1.0, 0.35483873), (1.49, 0.032258034)] {
            assert!((tent.eval(x) - m).abs() < 1e-6, "tent at {x}: {} vs Mitsuba's {m}", tent.eval(x));
        }
        assert_eq!(table.eval(2.0), 0.0);
    }

    /// The integrals against a midpoint sum of the table, and the inverse against them.
    #[test]
    fn integrals_and_inverses_agree() {
        for f in filters() {
            // Cells aligned with the table's steps (3000 per step), so no cell straddles a jump.
            let r = f.radius() as f64;
            let n = 2 * TABLE_STEPS * 3000;
            let h = 2.0 * r / n as f64;
            let mut sum = 0.0;
            for i in 0..n {
                let x = -r + (i as f64 + 0.5) * h;
                sum += f.eval64(x) * h;
                if i % 20_011 == 0 {
                    let want = sum - 0.5 * f.eval64(x) * h;
                    assert!((f.integral_to(x) - want).abs() < 1e-9, "{} at {x}", f.describe());
                }
            }
            assert!((f.integral() - sum).abs() < 1e-9, "{}: {} vs {sum}", f.describe(), f.integral());
            for t in [0.0, 0.013, 0.25, 0.5, 0.77, 0.999, 1.0] {
                let x = f.invert(t * f.integral());
                assert!((f.integral_to(x) - t * f.integral()).abs() < 1e-9, "{} at {t}", f.describe());
            }
        }
    }

    /// χ² of the sampled offsets of an interior pixel against the filter's own cell masses
    /// (16×16 cells over the footprint, 40 000 samples; p above 10⁻³ for each of the 4 cases).
    #[test]
    fn sampled_offsets_follow_the_filter() {
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        for f in filters() {
            let cells = 16usize;
            let n = 40_000usize;
            let r = f.radius() as f64;
            let mut counts = vec![0u64; cells * cells];
            for _ in 0..n {
                let p = f.film_point(32, 32, Vec2::new(next(), next()), 64, 64);
                let (dx, dy) = (p.x as f64 - 32.5, p.y as f64 - 32.5);
                assert!(dx.abs() <= r + 1e-5 && dy.abs() <= r + 1e-5, "{}: ({dx}, {dy})", f.describe());
                let cell = |d: f64| (((d + r) / (2.0 * r) * cells as f64) as usize).min(cells - 1);
                counts[cell(dy) * cells + cell(dx)] += 1;
            }
            let edge = |i: usize| -r + 2.0 * r * i as f64 / cells as f64;
            let mass = |i: usize| (f.integral_to(edge(i + 1)) - f.integral_to(edge(i))) / f.integral();
            let expected: Vec<f64> =
                (0..cells * cells).map(|k| n as f64 * mass(k % cells) * mass(k / cells)).collect();
            let o = outcome_of_counts(&expected, &counts);
            assert!(
                o.p_value > 1e-3,
                "{}: χ² = {} with {} dof, p = {}",
                f.describe(),
                o.chi2,
                o.dof,
                o.p_value
            );
        }
    }

    /// At the film's edge the footprint is cut: samples stay on the film and follow the cut
    /// filter, and splat weights of the cut pixel integrate to 1 over the film.
    #[test]
    fn footprints_are_cut_at_the_film_edge() {
        for f in filters() {
            for i in 0..64 {
                let u = (i as f32 + 0.5) / 64.0;
                let p = f.film_point(0, 3, Vec2::new(u, u), 8, 4);
                assert!(p.x >= 0.0 && p.x <= 8.0 && p.y >= 0.0 && p.y <= 4.0, "{}: {p}", f.describe());
            }
            // ∫ over the film of the weight of pixel (0, 0) is 1 (midpoint rule).
            let (w, h) = (6u32, 5u32);
            let n = 600;
            let mut sum = 0.0f64;
            for j in 0..n {
                for i in 0..n {
                    let p = Vec2::new(
                        (i as f32 + 0.5) * w as f32 / n as f32,
                        (j as f32 + 0.5) * h as f32 / n as f32,
                    );
                    f.splat_weights(p, w, h, |x, y, weight| {
                        if (x, y) == (0, 0) {
                            sum += weight as f64;
                        }
                    });
                }
            }
            let cell = (w * h) as f64 / (n * n) as f64;
            assert!((sum * cell - 1.0).abs() < 2e-3, "{}: {}", f.describe(), sum * cell);
        }
    }

    #[test]
    fn the_box_is_the_old_pixel_square() {
        let u = Vec2::new(0.3, 0.71);
        let b = PixelFilter::new(FilterKind::Box);
        assert_eq!(b, PixelFilter::BOX);
        assert_eq!(b.film_point(5, 7, u, 10, 10), Vec2::new(5.0, 7.0) + u);
        let mut seen = Vec::new();
        b.splat_weights(Vec2::new(3.99, 0.01), 4, 2, |x, y, w| seen.push((x, y, w)));
        assert_eq!(seen, [(3, 0, 1.0)]);
        b.splat_weights(Vec2::new(4.0, 0.5), 4, 2, |_, _, _| panic!("off the film"));
    }
}
