//! False colour for error maps, with a labelled colour bar.
//!
//! Values are shown on a log10 scale in viridis (perceptually uniform, readable in grey and by
//! colour-blind readers). The scale spans whole decades chosen from the data by [`log_range`]:
//! the top is the power of ten at or above the 99th percentile of the finite positive values
//! (so a few fireflies do not darken the whole map), the bottom the power of ten at or below the
//! 1st percentile, with at least one and at most [`MAX_DECADES`] decades (zeros and values below
//! the bottom take the bottom colour; the bar's bottom label then reads "≤"). Values above the
//! top, the fireflies the scale leaves out, are drawn in [`ABOVE_COLOR`], a colour the scale
//! does not use, and counted ([`above_scale`]) in the legend: "> 10ᵏ: N px". Non-finite values
//! are drawn in [`NAN_COLOR`]; a swatch under the bar explains each. Use
//! [`error_map_in_range`] to give several maps the same scale.

use super::canvas::{Canvas, Rgb, BLACK, WHITE};

/// The colour of NaN or infinite values: magenta, as in the PNG previews; no viridis colour is near it.
pub const NAN_COLOR: Rgb = [255, 0, 255];

/// The colour of values above the top of the scale: pure red, far from every viridis colour
/// and from [`NAN_COLOR`].
pub const ABOVE_COLOR: Rgb = [255, 0, 0];

/// The most decades a data-driven scale spans (below that, detail is rarely worth the contrast lost).
pub const MAX_DECADES: i32 = 6;

/// The scale used when no value is finite and positive: 10⁻⁴ to 1.
const DEFAULT_DECADES: (i32, i32) = (-4, 0);

/// Maps are magnified by a whole factor until their longer side is at least this many pixels.
const MIN_MAP_SIDE: usize = 256;

/// matplotlib's viridis sampled at every 17th of its 256 entries (t = 0, 1/15, …, 1), in sRGB;
/// linear interpolation between them stays within 7/255 of the full table.
pub const VIRIDIS: [Rgb; 16] = [
    [68, 1, 84],
    [72, 26, 108],
    [71, 47, 125],
    [65, 68, 135],
    [57, 86, 140],
    [49, 104, 142],
    [42, 120, 142],
    [35, 136, 142],
    [31, 152, 139],
    [34, 168, 132],
    [53, 183, 121],
    [84, 197, 104],
    [122, 209, 81],
    [165, 219, 54],
    [210, 226, 27],
    [253, 231, 37],
];

/// The viridis colour at `t` in [0, 1] (clamped; NaN gives the bottom colour).
pub fn viridis(t: f32) -> Rgb {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (VIRIDIS.len() - 1) as f32;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f32;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    [0, 1, 2].map(|c| (a[c] as f32 + (b[c] as f32 - a[c] as f32) * f).round() as u8)
}

/// Whether the finite value `v` lies above the top 10^hi of a scale (with the tolerance of
/// [`log_range`], so that 10^hi rounded to f32 is still on the scale).
fn is_above(v: f32, hi: i32) -> bool {
    v.is_finite() && v > 0.0 && f64::from(v).log10() - 1e-6 > f64::from(hi)
}

/// How many of `values` lie above the top of the scale `(lo, hi)`: the pixels drawn in
/// [`ABOVE_COLOR`].
pub fn above_scale(values: &[f32], (_, hi): (i32, i32)) -> usize {
    values.iter().filter(|&&v| is_above(v, hi)).count()
}

/// The legend text for values above the scale's top, e.g. "> 10⁰: 3 px".
pub fn above_label(hi: i32, count: usize) -> String {
    format!("> {}: {count} px", power_of_ten_label(hi))
}

/// The false colour of the error `v` on the log scale 10^lo … 10^hi: viridis, clamped at the
/// bottom (zero takes the bottom colour), [`ABOVE_COLOR`] above the top, [`NAN_COLOR`] when `v`
/// is not finite.
pub fn error_colour(v: f32, (lo, hi): (i32, i32)) -> Rgb {
    if !v.is_finite() {
        NAN_COLOR
    } else if is_above(v, hi) {
        ABOVE_COLOR
    } else if v <= 0.0 {
        viridis(0.0)
    } else {
        viridis(((f64::from(v).log10() - f64::from(lo)) / f64::from(hi - lo)) as f32)
    }
}

/// `10^k` written with superscript digits, e.g. "10⁻³" (the embedded font has the glyphs).
pub fn power_of_ten_label(k: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let exponent: String = k
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => d.to_digit(10).map_or(d, |d| DIGITS[d as usize]),
        })
        .collect();
    format!("10{exponent}")
}

/// The decades `(lo, hi)` (exponents of ten, `lo < hi`) the scale of [`error_map`] spans for
/// `values`: see the module documentation.
pub fn log_range(values: &[f32]) -> (i32, i32) {
    let mut positive: Vec<f32> = values.iter().copied().filter(|v| v.is_finite() && *v > 0.0).collect();
    if positive.is_empty() {
        return DEFAULT_DECADES;
    }
    let mut percentile = |p: f64| {
        let index = ((positive.len() - 1) as f64 * p).round() as usize;
        f64::from(*positive.select_nth_unstable_by(index, f32::total_cmp).1)
    };
    let (low, high) = (percentile(0.01), percentile(0.99));
    // The tolerance keeps an exact power of ten (after f32 rounding) on its own decade.
    let hi = (high.log10() - 1e-6).ceil() as i32;
    let lo = ((low.log10() + 1e-6).floor() as i32).clamp(hi - MAX_DECADES, hi - 1);
    (lo, hi)
}

/// A `width`×`height` map of `values` (e.g. relative squared error per pixel) in false colour on a
/// logarithmic scale, with a colour bar labelled `label` beside it; NaN pixels are marked.
pub fn error_map(values: &[f32], width: usize, height: usize, label: &str) -> Canvas {
    error_map_in_range(values, width, height, label, log_range(values))
}

/// [`error_map`] on the fixed scale `10^lo .. 10^hi` given as `decades = (lo, hi)` (an empty
/// range is widened to one decade), so that several maps can share one scale.
pub fn error_map_in_range(
    values: &[f32],
    width: usize,
    height: usize,
    label: &str,
    decades: (i32, i32),
) -> Canvas {
    let (lo, hi) = if decades.1 > decades.0 { decades } else { (decades.0, decades.0.saturating_add(1)) };
    let value = |i: usize| values.get(i).copied().unwrap_or(f32::NAN);
    let count = width.saturating_mul(height);
    let clipped_low = (0..count).any(|i| value(i).is_finite() && f64::from(value(i)) < 10f64.powi(lo));
    let above = (0..count).filter(|&i| is_above(value(i), hi)).count();
    let non_finite = (0..count).filter(|&i| !value(i).is_finite()).count();

    let tick_labels: Vec<String> = (lo..=hi)
        .map(|k| {
            let prefix = if k == lo && clipped_low { "≤ " } else { "" };
            format!("{prefix}{}", power_of_ten_label(k))
        })
        .collect();
    let above_text = above_label(hi, above);
    let nan_label = format!("NaN/Inf: {non_finite} px");
    let layout = Layout::new(width, height, label, &tick_labels, &[&above_text, &nan_label]);
    let mut canvas = Canvas::new(layout.width, layout.height, WHITE);

    // The map, magnified by a whole factor.
    let colour_of = |v: f32| error_colour(v, (lo, hi));
    let zoom = layout.zoom;
    for y in 0..height {
        for x in 0..width {
            let colour = colour_of(value(y * width + x));
            canvas.fill_rect(
                layout.map_x + (x as u32 * zoom) as i64,
                layout.top + (y as u32 * zoom) as i64,
                zoom,
                zoom,
                colour,
            );
        }
    }

    // The label above the bar.
    let size = layout.text_size;
    canvas.text(layout.bar_x as f32, layout.pad as f32, size, BLACK, label);

    // The bar: top row = 10^hi, bottom row = 10^lo, the same mapping as the map.
    let bar_h = layout.bar_h;
    for j in 0..bar_h {
        let t = if bar_h > 1 { (bar_h - 1 - j) as f32 / (bar_h - 1) as f32 } else { 1.0 };
        canvas.fill_rect(layout.bar_x, layout.top + j as i64, layout.bar_w, 1, viridis(t));
    }
    canvas.stroke_rect(layout.bar_x - 1, layout.top - 1, layout.bar_w + 2, bar_h + 2, 1, BLACK);
    let tick_len = (size * 0.4).round() as u32;
    for (k, text) in (lo..=hi).zip(&tick_labels) {
        let y = layout.tick_y(k, lo, hi);
        let x = layout.bar_x + layout.bar_w as i64;
        canvas.fill_rect(x, y, tick_len, 1, BLACK);
        canvas.text((x + tick_len as i64) as f32 + size * 0.3, y as f32 - size * 0.55, size, BLACK, text);
    }

    // What the colours outside the scale mean: above the top, then not finite.
    let s = size.round() as u32;
    let text_x = (layout.bar_x + layout.bar_w as i64 + tick_len as i64) as f32 + size * 0.3;
    for (row, (colour, text)) in [(ABOVE_COLOR, &above_text), (NAN_COLOR, &nan_label)].into_iter().enumerate()
    {
        let swatch_y = layout.swatch_y(row);
        canvas.fill_rect(layout.bar_x, swatch_y, layout.bar_w, s, colour);
        canvas.stroke_rect(layout.bar_x - 1, swatch_y - 1, layout.bar_w + 2, s + 2, 1, BLACK);
        canvas.text(text_x, swatch_y as f32 - size * 0.05, size, BLACK, text);
    }
    canvas
}

/// Where the parts of an error map go.
#[derive(Clone, Copy, Debug)]
struct Layout {
    /// Magnification of the map.
    zoom: u32,
    /// Text height in pixels.
    text_size: f32,
    /// Margin around everything.
    pad: u32,
    /// Left edge of the map.
    map_x: i64,
    /// Top edge of the map and of the bar.
    top: i64,
    /// Left edge of the colour bar.
    bar_x: i64,
    /// Width of the colour bar.
    bar_w: u32,
    /// Height of the colour bar.
    bar_h: u32,
    /// Canvas width.
    width: u32,
    /// Canvas height.
    height: u32,
}

impl Layout {
    /// The layout for a `width`×`height` map with these texts (`swatch_labels`: one per swatch
    /// under the bar).
    fn new(
        width: usize,
        height: usize,
        label: &str,
        tick_labels: &[String],
        swatch_labels: &[&str],
    ) -> Layout {
        let longer = width.max(height).max(1);
        let zoom = MIN_MAP_SIDE.div_ceil(longer).max(1) as u32;
        let side = |n: usize| u32::try_from(n).unwrap_or(u32::MAX).saturating_mul(zoom);
        let (map_w, map_h) = (side(width), side(height));
        let text_size = (map_h.max(map_w) as f32 / 40.0).clamp(14.0, 24.0);
        let pad = (text_size * 0.8).round() as u32;
        let top = pad + (text_size * 1.6).round() as u32;
        let bar_w = (text_size * 1.3).round() as u32;
        let bar_h = map_h.max((text_size * 12.0) as u32);
        let bar_x = pad.saturating_add(map_w).saturating_add(2 * pad);
        let text_w = |t: &str| Canvas::text_width(text_size, t).ceil() as u32;
        let widest = tick_labels
            .iter()
            .map(|t| text_w(t))
            .chain(swatch_labels.iter().map(|t| text_w(t)))
            .max()
            .unwrap_or(0);
        let column = (bar_w + (text_size * 0.7).round() as u32 + widest).max(text_w(label));
        let swatch_bottom = bar_h + (1 + 2 * swatch_labels.len() as u32) * text_size.round() as u32;
        Layout {
            zoom,
            text_size,
            pad,
            map_x: pad as i64,
            top: top as i64,
            bar_x: bar_x as i64,
            bar_w,
            bar_h,
            width: bar_x.saturating_add(column).saturating_add(pad),
            height: top.saturating_add(map_h.max(swatch_bottom)).saturating_add(pad),
        }
    }

    /// The top of swatch `row` under the bar (0 first), one text line apart.
    fn swatch_y(&self, row: usize) -> i64 {
        let line = self.text_size.round() as i64;
        self.top + self.bar_h as i64 + line + 2 * line * row as i64
    }

    /// The row of the tick for 10^k on a bar spanning 10^lo .. 10^hi.
    fn tick_y(&self, k: i32, lo: i32, hi: i32) -> i64 {
        let f = f64::from(hi - k) / f64::from(hi - lo);
        self.top + (f * f64::from(self.bar_h.saturating_sub(1))).round() as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn distance(a: Rgb, b: Rgb) -> i32 {
        (0..3).map(|c| (a[c] as i32 - b[c] as i32).abs()).sum()
    }

    #[test]
    fn viridis_ends_and_middle() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        // matplotlib: viridis(0.5) = (33, 145, 140).
        assert!(distance(viridis(0.5), [33, 145, 140]) <= 6, "{:?}", viridis(0.5));
        // NaN and above-the-scale marks stand apart from every colour of the scale and each other.
        for mark in [NAN_COLOR, ABOVE_COLOR] {
            assert!((0..=100).all(|i| distance(viridis(i as f32 / 100.0), mark) > 200), "{mark:?}");
        }
        assert!(distance(NAN_COLOR, ABOVE_COLOR) > 200);
    }

    #[test]
    fn superscript_powers() {
        assert_eq!(power_of_ten_label(-3), "10⁻³");
        assert_eq!(power_of_ten_label(0), "10⁰");
        assert_eq!(power_of_ten_label(12), "10¹²");
    }

    #[test]
    fn range_follows_the_data_in_whole_decades() {
        assert_eq!(log_range(&[]), DEFAULT_DECADES);
        assert_eq!(log_range(&[0.0, f32::NAN, -1.0]), DEFAULT_DECADES);
        assert_eq!(log_range(&[0.002, 0.5]), (-3, 0));
        // An exact power of ten keeps its decade; a single value spans one decade.
        assert_eq!(log_range(&[0.001]), (-4, -3));
        assert_eq!(log_range(&[0.003]), (-3, -2));
        // At most MAX_DECADES, counted down from the top.
        assert_eq!(log_range(&[1e-12, 10.0]), (1 - MAX_DECADES, 1));
        // One firefly among 1000 values does not move the top.
        let mut v = vec![0.05f32; 999];
        v.push(1e6);
        assert_eq!(log_range(&v), (-2, -1));
    }

    #[test]
    fn map_colours_size_and_bar() {
        // 4×1 values at the bottom, middle and top of 10⁻⁴..10⁰, and a NaN; magnified 64×.
        let values = [1e-4, 1e-2, 1.0, f32::NAN];
        let canvas = error_map_in_range(&values, 4, 1, "relative squared error", (-4, 0));
        let labels: Vec<String> = (-4..=0).map(power_of_ten_label).collect();
        let layout = Layout::new(4, 1, "relative squared error", &labels, &["> 10⁰: 0 px", "NaN/Inf: 1 px"]);
        assert_eq!(layout.zoom, 64);
        assert_eq!((canvas.width, canvas.height), (layout.width, layout.height));
        assert!(canvas.width > 256 + layout.bar_w && canvas.height >= layout.bar_h);
        let at = |x: usize| canvas.get(layout.map_x as u32 + 64 * x as u32 + 32, layout.top as u32 + 32);
        assert_eq!(at(0), viridis(0.0));
        assert_eq!(at(1), viridis(0.5));
        assert_eq!(at(2), viridis(1.0));
        assert_eq!(at(3), NAN_COLOR);
        // The bar runs from the top colour down to the bottom colour.
        let bar = |y: i64| canvas.get(layout.bar_x as u32 + layout.bar_w / 2, y as u32);
        assert_eq!(bar(layout.top + 1), viridis(1.0 - 1.0 / (layout.bar_h - 1) as f32));
        assert_eq!(bar(layout.top + layout.bar_h as i64 - 2), viridis(1.0 / (layout.bar_h - 1) as f32));
        // The swatches below it: above the scale, then NaN.
        let swatch = |row: usize| bar(layout.swatch_y(row) + (layout.text_size / 2.0) as i64);
        assert_eq!((swatch(0), swatch(1)), (ABOVE_COLOR, NAN_COLOR));
        // Text was set: the label row and the tick-label column have ink.
        let ink = |x0: u32, x1: u32, y0: u32, y1: u32| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| canvas.get(x, y).iter().all(|&c| c < 100))
                .count()
        };
        assert!(ink(layout.bar_x as u32, canvas.width, 0, layout.top as u32 - 2) > 0, "no label");
        let labels_x = layout.bar_x as u32 + layout.bar_w + 4;
        assert!(
            ink(labels_x, canvas.width, layout.top as u32, (layout.top + layout.bar_h as i64) as u32) > 50
        );
    }

    #[test]
    fn large_maps_are_one_to_one_and_bad_input_does_not_panic() {
        let values = vec![0.01f32; 300 * 200];
        let canvas = error_map(&values, 300, 200, "relMSE");
        let labels: Vec<String> = (-3..=-2).map(power_of_ten_label).collect();
        let layout = Layout::new(300, 200, "relMSE", &labels, &["> 10⁻²: 0 px", "NaN/Inf: 0 px"]);
        assert_eq!(layout.zoom, 1);
        assert_eq!(canvas.height, layout.height);
        assert_eq!(canvas.get(layout.map_x as u32 + 299, layout.top as u32 + 199), viridis(1.0));
        // Too few values: the missing ones are marked as not finite; an empty map still has its bar.
        let short = error_map(&[0.5], 2, 1, "x");
        assert!(short.pixels.contains(&NAN_COLOR));
        let empty = error_map(&[], 0, 0, "x");
        assert!(empty.width > 0 && empty.height > 0);
    }

    #[test]
    fn fireflies_above_the_scale_are_marked_and_counted() {
        // 1000 values of 0.05 (scale 10⁻²..10⁻¹) and three fireflies: the scale ignores them,
        // the map draws them in ABOVE_COLOR, and the legend counts them.
        let mut values = vec![0.05f32; 1000];
        for i in [10, 500, 999] {
            values[i] = 1e4;
        }
        let decades = log_range(&values);
        assert_eq!(decades, (-2, -1));
        assert_eq!(above_scale(&values, decades), 3);
        assert_eq!(above_label(decades.1, 3), "> 10⁻¹: 3 px");
        assert_eq!(error_colour(1e4, decades), ABOVE_COLOR);
        // The top itself is inside the scale: its colour is viridis's top.
        assert_eq!(error_colour(0.1, decades), viridis(1.0));
        let canvas = error_map(&values, 40, 25, "relMSE");
        let red = canvas.pixels.iter().filter(|p| **p == ABOVE_COLOR).count();
        let labels: Vec<String> = (-2..=-1).map(power_of_ten_label).collect();
        let layout = Layout::new(40, 25, "relMSE", &labels, &["> 10⁻¹: 3 px", "NaN/Inf: 0 px"]);
        let zoom = layout.zoom as usize;
        let swatch = layout.bar_w as usize * layout.text_size.round() as usize;
        // Three magnified pixels and the legend's swatch, nothing else.
        assert_eq!(red, 3 * zoom * zoom + swatch, "zoom {zoom}");
    }
}
