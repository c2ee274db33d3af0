//! Method-comparison figures: one column per method with labels, zoomed insets and error maps.
//!
//! # Layout
//!
//! For M methods rendered at W × H pixels and an optional crop of cw × ch pixels, all sizes in
//! whole pixels and `/` rounding down:
//!
//! ```text
//! column   C = max(W, 160)                 every method gets one column C wide
//! font     s = C / 11                      text size (ascent to descent), at least 14
//! line     L = 5·s / 4                     height of one line of text
//! gap      g = max(4, C / 40)              around the figure and between all blocks
//! bar      B = s / 2                       thickness of the colour bar
//! zoom     k = max(1, min(W / cw, H / ch))  the inset is the crop magnified k times: k·cw × k·ch
//!
//! width  = M·C + (M + 1)·g
//! height = 6·g + 6·L + B + 2·H             without a crop
//!        + g + k·ch                        with a crop
//! ```
//!
//! From the top: the title (one line); per column, each centred in it, the render, a three-line
//! label (method; samples and seconds; relMSE), the inset when there is a crop, and the error map
//! (W × H, pixel for pixel under the render); then, across the figure, the error maps' caption
//! (one line), their colour bar (B) and its decade labels (one line). Blocks are separated by g.
//! With a crop the crop's rectangle is outlined on every render and the inset framed, both just
//! outside the pixels they mark. One exposure applies to every render and one logarithmic scale
//! to every error map (the scale of [`colormap::error_map`](super::colormap::error_map), chosen by
//! [`log_range`] from the errors of all methods together), so columns can be compared. Text wider
//! than its room is set smaller to fit: the layout never depends on the text or the data.

use super::canvas::{font, Canvas, Rgb, BLACK, WHITE};
use super::colormap::{above_label, above_scale, error_colour, log_range, power_of_ten_label, viridis};
use crate::image::Image;
use crate::metrics::Crop;
use ab_glyph::{Font, PxScale, ScaleFont};

/// Narrowest column, so labels stay legible under small renders.
pub const MIN_COLUMN: u32 = 160;
/// Colour of the crop outline and the inset frame.
pub const CROP_COLOR: Rgb = [255, 170, 0];
/// What the error maps show (their caption).
pub const ERROR_LABEL: &str = "relative squared error (x−r)²/(r²+0.01), log scale";

/// The position and size of every block of a comparison figure (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Figure width.
    pub width: u32,
    /// Figure height.
    pub height: u32,
    /// Number of method columns M.
    pub methods: u32,
    /// Column width C.
    pub column: u32,
    /// Gap g between blocks and around the figure.
    pub gap: u32,
    /// Text size s.
    pub font: u32,
    /// Line height L.
    pub line: u32,
    /// Colour-bar thickness B.
    pub bar: u32,
    /// Render size W × H (also the size of each error map).
    pub image: (u32, u32),
    /// Inset size k·cw × k·ch, with a crop.
    pub inset: Option<(u32, u32)>,
    /// Inset magnification k (1 without a crop).
    pub zoom: u32,
    /// Top of the renders.
    pub image_y: u32,
    /// Top of the labels.
    pub label_y: u32,
    /// Top of the insets (with no crop, where the error maps are).
    pub inset_y: u32,
    /// Top of the error maps.
    pub error_y: u32,
    /// Top of the error maps' caption.
    pub caption_y: u32,
    /// Top of the colour bar.
    pub bar_y: u32,
    /// Top of the colour bar's decade labels.
    pub ticks_y: u32,
}

impl Layout {
    /// The layout for `methods` columns of `image` (W, H) renders with insets of a crop of `crop`
    /// (cw, ch) pixels.
    pub fn new(image: (u32, u32), methods: u32, crop: Option<(u32, u32)>) -> Layout {
        let (w, h) = image;
        let column = w.max(MIN_COLUMN);
        let font = column / 11;
        let line = 5 * font / 4;
        let gap = (column / 40).max(4);
        let bar = font / 2;
        let zoom = crop.map_or(1, |(cw, ch)| (w / cw.max(1)).min(h / ch.max(1)).max(1));
        let inset = crop.map(|(cw, ch)| (zoom * cw, zoom * ch));
        let image_y = gap + line + gap;
        let label_y = image_y + h + gap;
        let inset_y = label_y + 3 * line + gap;
        let error_y = inset.map_or(inset_y, |(_, ih)| inset_y + ih + gap);
        let caption_y = error_y + h + gap;
        let bar_y = caption_y + line;
        let ticks_y = bar_y + bar;
        Layout {
            width: methods * column + (methods + 1) * gap,
            height: ticks_y + line + gap,
            methods,
            column,
            gap,
            font,
            line,
            bar,
            image,
            inset,
            zoom,
            image_y,
            label_y,
            inset_y,
            error_y,
            caption_y,
            bar_y,
            ticks_y,
        }
    }

    /// Left edge of column `i`.
    pub fn column_x(&self, i: u32) -> u32 {
        self.gap + i * (self.column + self.gap)
    }

    /// Left edge of a block `width` wide centred in column `i`.
    pub fn centred_x(&self, i: u32, width: u32) -> i64 {
        self.column_x(i) as i64 + (self.column as i64 - width as i64) / 2
    }
}

/// One method's column of a comparison figure.
#[derive(Clone, Copy, Debug)]
pub struct Panel<'a> {
    /// Method name.
    pub method: &'a str,
    /// Its render (linear HDR).
    pub image: &'a Image,
    /// Samples (camera rays) per pixel: a whole number, or the real mean of an adaptive method.
    pub spp: f64,
    /// Seconds of rendering.
    pub seconds: f64,
    /// relMSE against the reference.
    pub rel_mse: f64,
    /// Per-pixel relative squared error against the reference, row by row (W·H values; NaN where
    /// a pixel is not finite), as [`crate::metrics::relative_squared_error`] gives it.
    pub error: &'a [f32],
}

/// A number with three significant digits: fixed point from 0.01 to 1000, scientific otherwise.
pub fn format_number(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if !x.is_finite() {
        format!("{x}")
    } else if (0.01..1000.0).contains(&x.abs()) {
        let decimals = (2 - x.abs().log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.2e}")
    }
}

/// Samples per pixel: whole counts as they are, a mean of an adaptive method with two decimals.
pub fn format_spp(spp: f64) -> String {
    if spp.fract() == 0.0 {
        format!("{spp:.0}")
    } else {
        format!("{spp:.2}")
    }
}

/// Seconds with two decimals below 10 s, one below 100 s, none above.
pub fn format_seconds(s: f64) -> String {
    match s {
        s if s < 10.0 => format!("{s:.2}"),
        s if s < 100.0 => format!("{s:.1}"),
        s => format!("{s:.0}"),
    }
}

/// How a line of text is placed in its room.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Align {
    Left,
    Centre,
}

/// Sets `text` at `size`, smaller if needed to fit `room` pixels (less a pixel each side), in the
/// room starting at (x, y); returns the width it took.
fn fitted_text(canvas: &mut Canvas, x: f32, y: f32, size: u32, room: u32, align: Align, text: &str) -> f32 {
    let space = room.saturating_sub(2).max(1) as f32;
    let full = size as f32;
    let natural = Canvas::text_width(full, text);
    let small = if natural > space { full * space / natural } else { full };
    // A shrunk line keeps its baseline where the full-size line would have it.
    let ascent = font().as_scaled(PxScale::from(1.0)).ascent();
    let y = y + (full - small) * ascent;
    let width = natural * small / full;
    let x = match align {
        Align::Left => x + 1.0,
        Align::Centre => x + (room as f32 - width) / 2.0,
    };
    canvas.text(x, y, small, BLACK, text);
    width
}

/// The comparison figure of `panels` (renders of one size) under `title`, tone-mapped with
/// `exposure_ev`, with insets of `crop` (see the [module docs](self) for the layout).
pub fn compose(title: &str, panels: &[Panel], exposure_ev: f32, crop: Option<Crop>) -> Canvas {
    let (w, h) = panels.first().map_or((0, 0), |p| (p.image.width as u32, p.image.height as u32));
    let crop_size = crop.map(|c| (c.width as u32, c.height as u32));
    let layout = Layout::new((w, h), panels.len() as u32, crop_size);
    let mut fig = Canvas::new(layout.width, layout.height, WHITE);
    let content = layout.width - 2 * layout.gap;
    fitted_text(&mut fig, layout.gap as f32, layout.gap as f32, layout.font, content, Align::Left, title);

    // One scale for every map: the decades of all errors together.
    let all: Vec<f32> = panels.iter().flat_map(|p| p.error.iter().copied()).collect();
    let decades = log_range(&all);
    let finite = || all.iter().copied().filter(|v| v.is_finite());
    let clipped_low = finite().any(|v| f64::from(v) < 10f64.powi(decades.0));
    let above = above_scale(&all, decades);
    let non_finite = all.len() - finite().count();

    // The outline sits outside the pixels it marks, within the gap.
    let outline = (w / 200).clamp(1, layout.gap / 2);
    for (i, panel) in panels.iter().enumerate() {
        let i = i as u32;
        let mut render = Canvas::from_image(panel.image, exposure_ev);
        let x = layout.centred_x(i, w);
        if let (Some(c), Some((iw, ih))) = (crop, layout.inset) {
            let (cx, cy, cw, ch) = (c.x as u32, c.y as u32, c.width as u32, c.height as u32);
            let inset = render.crop(cx, cy, cw, ch).magnified(layout.zoom);
            let t = outline as i64;
            render.stroke_rect(
                cx as i64 - t,
                cy as i64 - t,
                cw + 2 * outline,
                ch + 2 * outline,
                outline,
                CROP_COLOR,
            );
            let (ix, iy) = (layout.centred_x(i, iw), layout.inset_y as i64);
            fig.blit(ix, iy, &inset);
            fig.stroke_rect(ix - t, iy - t, iw + 2 * outline, ih + 2 * outline, outline, CROP_COLOR);
        }
        fig.blit(x, layout.image_y as i64, &render);

        let lines = [
            panel.method.to_string(),
            format!("{} spp, {} s", format_spp(panel.spp), format_seconds(panel.seconds)),
            format!("relMSE {}", format_number(panel.rel_mse)),
        ];
        let left = layout.column_x(i) as f32;
        for (j, line) in lines.iter().enumerate() {
            let y = (layout.label_y + j as u32 * layout.line) as f32;
            fitted_text(&mut fig, left, y, layout.font, layout.column, Align::Centre, line);
        }

        for py in 0..h {
            for px in 0..w {
                let v = panel.error.get((py * w + px) as usize).copied().unwrap_or(f32::NAN);
                fig.set(x + px as i64, (layout.error_y + py) as i64, error_colour(v, decades));
            }
        }
    }

    let mut caption = format!("{ERROR_LABEL}; red: {}", above_label(decades.1, above));
    if non_finite > 0 {
        caption += &format!("; magenta: NaN/Inf ({non_finite} px)");
    }
    let (gx, gy) = (layout.gap as f32, layout.caption_y as f32);
    fitted_text(&mut fig, gx, gy, layout.font, content, Align::Left, &caption);
    colour_bar(&mut fig, &layout, decades, clipped_low);
    fig
}

/// The colour bar across the figure, low errors left, with labelled decades.
fn colour_bar(fig: &mut Canvas, layout: &Layout, (lo, hi): (i32, i32), clipped_low: bool) {
    let (x0, length) = (layout.gap as i64 + 1, layout.width.saturating_sub(2 * layout.gap + 2).max(2));
    for i in 0..length {
        let colour = viridis(i as f32 / (length - 1) as f32);
        fig.fill_rect(x0 + i as i64, layout.bar_y as i64, 1, layout.bar, colour);
    }
    let tick_x = |k: i32| x0 + ((k - lo) as f64 / (hi - lo) as f64 * (length - 1) as f64).round() as i64;
    let labels: Vec<(i32, String)> = (lo..=hi)
        .map(|k| {
            let prefix = if k == lo && clipped_low { "≤ " } else { "" };
            (k, format!("{prefix}{}", power_of_ten_label(k)))
        })
        .collect();
    // Label every decade when the labels fit, else every second, third, ... (always both ends).
    let size = layout.font as f32;
    let widest = labels.iter().map(|(_, t)| Canvas::text_width(size, t)).fold(0.0, f32::max);
    let spacing = (length - 1) as f32 / (hi - lo) as f32;
    let step = ((widest * 1.3 / spacing).ceil() as i32).max(1);
    for (k, text) in &labels {
        let x = tick_x(*k);
        fig.fill_rect(x, layout.bar_y as i64, 1, layout.bar, BLACK);
        let shown = *k == lo || *k == hi || ((k - lo) % step == 0 && hi - k >= step);
        if !shown {
            continue;
        }
        let width = Canvas::text_width(size, text);
        // Centred under its tick, kept inside the figure.
        let left = (x as f32 - width / 2.0).clamp(x0 as f32, (x0 + length as i64) as f32 - width);
        fig.text(left, layout.ticks_y as f32, size, BLACK, text);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::figure::colormap::{ABOVE_COLOR, NAN_COLOR};
    use glam::Vec3;

    #[test]
    fn layout_of_large_renders_follows_the_documented_formula() {
        let l = Layout::new((800, 600), 3, None);
        assert_eq!((l.column, l.font, l.line, l.gap, l.bar), (800, 72, 90, 20, 36));
        assert_eq!(l.width, 3 * 800 + 4 * 20);
        assert_eq!(l.height, 6 * 20 + 6 * 90 + 36 + 2 * 600);
        assert_eq!((l.zoom, l.inset), (1, None));
        assert_eq!(l.column_x(2), 20 + 2 * 820);
        assert_eq!(l.centred_x(1, 800), (20 + 820) as i64);
    }

    #[test]
    fn small_renders_get_the_minimum_column() {
        let l = Layout::new((32, 24), 2, None);
        assert_eq!((l.column, l.font, l.line, l.gap, l.bar), (160, 14, 17, 4, 7));
        assert_eq!((l.width, l.height), (2 * 160 + 3 * 4, 6 * 4 + 6 * 17 + 7 + 2 * 24));
        assert_eq!(l.centred_x(0, 32), 4 + 64);
    }

    #[test]
    fn a_crop_adds_its_magnified_inset_and_one_gap() {
        let plain = Layout::new((400, 300), 4, None);
        let cropped = Layout::new((400, 300), 4, Some((50, 20)));
        // k = min(400 / 50, 300 / 20) = 8
        assert_eq!((cropped.zoom, cropped.inset), (8, Some((400, 160))));
        assert_eq!(cropped.width, plain.width);
        assert_eq!(cropped.height, plain.height + 160 + plain.gap);
        assert_eq!(cropped.error_y, plain.error_y + 160 + plain.gap);
        // A crop of the whole image is shown at its own size.
        assert_eq!(Layout::new((400, 300), 1, Some((400, 300))).zoom, 1);
        // A tall, narrow crop is limited by the height.
        assert_eq!(Layout::new((400, 300), 1, Some((10, 100))).inset, Some((30, 300)));
    }

    #[test]
    fn blocks_are_stacked_without_overlap() {
        let l = Layout::new((200, 100), 2, Some((20, 10)));
        assert_eq!(l.image_y, l.gap + l.line + l.gap);
        assert_eq!(l.label_y, l.image_y + 100 + l.gap);
        assert_eq!(l.inset_y, l.label_y + 3 * l.line + l.gap);
        assert_eq!(l.error_y, l.inset_y + l.inset.unwrap().1 + l.gap);
        assert_eq!(l.caption_y, l.error_y + 100 + l.gap);
        assert_eq!((l.bar_y, l.ticks_y), (l.caption_y + l.line, l.caption_y + l.line + l.bar));
        assert_eq!(l.height, l.ticks_y + l.line + l.gap);
        assert_eq!(l.column_x(1), l.column_x(0) + l.column + l.gap);
        assert_eq!(l.column_x(1) + l.column + l.gap, l.width);
    }

    #[test]
    fn numbers_keep_three_significant_digits() {
        assert_eq!(format_number(0.012345), "0.0123");
        assert_eq!(format_number(1.5), "1.50");
        assert_eq!(format_number(123.4), "123");
        assert_eq!(format_number(0.0), "0");
        assert_eq!(format_number(1.234e-5), "1.23e-5");
        assert_eq!(format_number(f64::INFINITY), "inf");
        assert_eq!(format_seconds(1.234), "1.23");
        assert_eq!(format_seconds(12.34), "12.3");
        assert_eq!(format_seconds(123.4), "123");
    }

    /// A panel of `image` with the given errors.
    fn panel<'a>(image: &'a Image, method: &'a str, error: &'a [f32]) -> Panel<'a> {
        Panel { method, image, spp: 16.0, seconds: 1.5, rel_mse: 0.01, error }
    }

    /// Whether any pixel of rows y0..y1 is dark (text).
    fn ink(fig: &Canvas, y0: u32, y1: u32) -> bool {
        (y0..y1).any(|y| (0..fig.width).any(|x| fig.get(x, y).iter().all(|&c| c < 100)))
    }

    #[test]
    fn the_figure_has_the_layout_size_and_shows_renders_insets_and_maps() {
        let mut image = Image::new(40, 30);
        image.pixels = vec![Vec3::splat(0.5); 40 * 30];
        image.pixels[12 * 40 + 20] = Vec3::new(1.0, 0.0, 0.0);
        let (low, mut high) = (vec![1e-4; 40 * 30], vec![1e-1; 40 * 30]);
        high[5] = f32::NAN;
        high[7] = 1e3; // a firefly above the scale
        let panels = [panel(&image, "whitted", &low), panel(&image, "path", &high)];
        let crop = Crop { x: 18, y: 10, width: 5, height: 5 };
        let fig = compose("cornell-glass · equal samples", &panels, 0.0, Some(crop));
        let l = Layout::new((40, 30), 2, Some((5, 5)));
        assert_eq!((fig.width, fig.height), (l.width, l.height));
        assert_eq!(l.zoom, 6);
        // The red pixel of the second column's render, at its own place ...
        let x1 = l.centred_x(1, 40) as u32;
        assert_eq!(fig.get(x1 + 20, l.image_y + 12), [255, 0, 0]);
        // ... and magnified six times in its inset: pixel (2, 2) of the crop.
        let ix = l.centred_x(1, 30) as u32;
        for (dx, dy) in [(12, 12), (17, 17)] {
            assert_eq!(fig.get(ix + dx, l.inset_y + dy), [255, 0, 0]);
        }
        assert_ne!(fig.get(ix + 18, l.inset_y + 12), [255, 0, 0]);
        // The crop is outlined just outside its pixels.
        assert_eq!(fig.get(x1 + 17, l.image_y + 10), CROP_COLOR);
        // One scale for both maps: 10⁻⁴ .. 10⁻¹, the bottom and top colours; NaN in magenta.
        let x0 = l.centred_x(0, 40) as u32;
        assert_eq!(fig.get(x0 + 3, l.error_y + 3), viridis(0.0));
        assert_eq!(fig.get(x1 + 3, l.error_y + 3), viridis(1.0));
        assert_eq!(fig.get(x1 + 5, l.error_y), NAN_COLOR);
        assert_eq!(fig.get(x1 + 7, l.error_y), ABOVE_COLOR);
        // The bar runs from the bottom colour on the left to the top colour on the right.
        let near = |a: Rgb, b: Rgb| (0..3).all(|c| a[c].abs_diff(b[c]) <= 8);
        assert!(near(fig.get(l.gap + 3, l.bar_y + 1), viridis(0.0)));
        assert!(near(fig.get(l.width - l.gap - 4, l.bar_y + 1), viridis(1.0)));
        // Text in the title, the labels, the caption and under the bar.
        assert!(ink(&fig, l.gap, l.gap + l.line));
        assert!(ink(&fig, l.label_y, l.label_y + 3 * l.line));
        assert!(ink(&fig, l.caption_y, l.bar_y));
        assert!(ink(&fig, l.ticks_y, l.ticks_y + l.line));
    }

    #[test]
    fn long_text_is_shrunk_to_its_column() {
        let image = Image::new(8, 8);
        let long = "a-method-name-far-too-long-for-its-column-of-one-hundred-and-sixty-pixels";
        let errors = [0.0; 64];
        let fig = compose("t", &[panel(&image, long, &errors)], 0.0, None);
        let l = Layout::new((8, 8), 1, None);
        assert_eq!((fig.width, fig.height), (l.width, l.height));
        // Nothing of the label spills into the outer gaps.
        for y in l.label_y..l.label_y + l.line {
            for x in (0..l.gap).chain(l.width - l.gap..l.width) {
                assert_eq!(fig.get(x, y), WHITE, "({x}, {y})");
            }
        }
    }
}
