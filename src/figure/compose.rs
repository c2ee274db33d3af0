//! Method-comparison figures: one column per method with labels, zoomed insets and error maps,
//! optionally led by a column of the reference, in one row or wrapped into several.
//!
//! # Layout
//!
//! For N panels (the M methods, and with a reference the reference first: N = M + 1) rendered at
//! W × H pixels, at most `columns` panels per row (no limit: N), and an optional crop of cw × ch
//! pixels, all sizes in whole pixels, `/` rounding down and ⌈ ⌉ up:
//!
//! ```text
//! column   C = max(W, 160)                 every panel gets one column C wide
//! font     s = C / 11                      text size (ascent to descent), at least 14
//! line     L = 5·s / 4                     height of one line of text
//! gap      g = max(4, C / 40)              around the figure and between all blocks
//! bar      B = s / 2                       thickness of the colour bar
//! zoom     k = max(1, min(W / cw, H / ch))  the inset is the crop magnified k times: k·cw × k·ch
//! per row  P = max(1, min(columns, N))     panels side by side
//! rows     R = max(1, ⌈N / P⌉)             rows of panels
//! row      S = 2·H + 3·L + 3·g             height of one row of panels, without a crop
//!            + g + k·ch                    with a crop
//!
//! width  = P·C + (P + 1)·g
//! height = 3·g + 3·L + B + R·S
//! ```
//!
//! From the top: the title (one line); the R rows of panels, filled left to right in order (the
//! reference first; a last row with fewer than P panels leaves its right-hand columns empty), row
//! r starting r·S below the first; per panel, each block centred in its column, the render, a
//! three-line label (method; samples and seconds; relMSE with its 95% interval when known), the inset when there is a crop, and
//! the error map (W × H, pixel for pixel under the render); then, across the figure, the error
//! maps' caption (one line), their colour bar (B) and its decade labels (one line). Blocks are
//! separated by g. The reference's panel is a method's but for its label ("reference"; its
//! description, e.g. "vcm, 1024 spp"; "relMSE —") and its error map's place, which is left empty:
//! the errors are measured against it. With a crop the crop's rectangle is outlined on every
//! render (the reference's too) and the inset framed, both just outside the pixels they mark. One
//! exposure applies to every render and one logarithmic scale to every error map (the scale of
//! [`colormap::error_map`](super::colormap::error_map), chosen by [`log_range`] from the errors of
//! all methods together), so columns can be compared. Text wider than its room is set smaller to
//! fit: the layout never depends on the text or the data. Without a reference and a column limit
//! the figure is the single row of methods of earlier versions, pixel for pixel.

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
/// The first line of the reference's label.
pub const REFERENCE_LABEL: &str = "reference";
/// The relMSE line of the reference's label: it has no error of its own.
pub const REFERENCE_REL_MSE: &str = "relMSE —";

/// The position and size of every block of a comparison figure (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Figure width.
    pub width: u32,
    /// Figure height.
    pub height: u32,
    /// Number of panels N (the methods, and the reference if any).
    pub panels: u32,
    /// Panels per row P.
    pub per_row: u32,
    /// Number of rows R.
    pub rows: u32,
    /// Height S of one row of panels: how far each row is below the one above.
    pub row_height: u32,
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
    /// Top of the first row's renders.
    pub image_y: u32,
    /// Top of the first row's labels.
    pub label_y: u32,
    /// Top of the first row's insets (with no crop, where the error maps are).
    pub inset_y: u32,
    /// Top of the first row's error maps.
    pub error_y: u32,
    /// Top of the error maps' caption, below all rows.
    pub caption_y: u32,
    /// Top of the colour bar.
    pub bar_y: u32,
    /// Top of the colour bar's decade labels.
    pub ticks_y: u32,
}

impl Layout {
    /// The layout for `panels` panels of `image` (W, H) renders, at most `columns` of them per row
    /// (`None`: all in one row), with insets of a crop of `crop` (cw, ch) pixels.
    pub fn new(image: (u32, u32), panels: u32, crop: Option<(u32, u32)>, columns: Option<u32>) -> Layout {
        let (w, h) = image;
        let column = w.max(MIN_COLUMN);
        let font = column / 11;
        let line = 5 * font / 4;
        let gap = (column / 40).max(4);
        let bar = font / 2;
        let zoom = crop.map_or(1, |(cw, ch)| (w / cw.max(1)).min(h / ch.max(1)).max(1));
        let inset = crop.map(|(cw, ch)| (zoom * cw, zoom * ch));
        let per_row = columns.unwrap_or(panels).min(panels).max(1);
        let rows = panels.div_ceil(per_row).max(1);
        let image_y = gap + line + gap;
        let label_y = image_y + h + gap;
        let inset_y = label_y + 3 * line + gap;
        let error_y = inset.map_or(inset_y, |(_, ih)| inset_y + ih + gap);
        let row_height = error_y + h + gap - image_y;
        let caption_y = image_y + rows * row_height;
        let bar_y = caption_y + line;
        let ticks_y = bar_y + bar;
        Layout {
            width: per_row * column + (per_row + 1) * gap,
            height: ticks_y + line + gap,
            panels,
            per_row,
            rows,
            row_height,
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

    /// The column and the row of panel `i` (the reference, if any, is panel 0): (i mod P, i / P).
    pub fn cell(&self, i: u32) -> (u32, u32) {
        (i % self.per_row, i / self.per_row)
    }

    /// How far row `r` is below the first row: r·S.
    pub fn row_offset(&self, r: u32) -> u32 {
        r * self.row_height
    }

    /// Left edge of column `i`.
    pub fn column_x(&self, i: u32) -> u32 {
        self.gap + i * (self.column + self.gap)
    }

    /// Left edge of a block `width` wide centred in column `i`.
    pub fn centred_x(&self, i: u32, width: u32) -> i64 {
        self.column_x(i) as i64 + (self.column as i64 - width as i64) / 2
    }

    /// Thickness of the crop outline and the inset frame: it fits in the gap around what it marks.
    fn outline(&self) -> u32 {
        (self.image.0 / 200).clamp(1, self.gap / 2)
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
    /// Its 95% confidence interval, shown after it when known.
    pub rel_mse_interval: Option<(f64, f64)>,
    /// Per-pixel relative squared error against the reference, row by row (W·H values; NaN where
    /// a pixel is not finite), as [`crate::metrics::relative_squared_error`] gives it.
    pub error: &'a [f32],
}

/// The reference the methods are measured against, drawn as the figure's first column.
#[derive(Clone, Copy, Debug)]
pub struct ReferencePanel<'a> {
    /// The reference render (linear HDR), of the methods' size.
    pub image: &'a Image,
    /// What it is, e.g. "vcm, 1024 spp": the second line of its label.
    pub description: &'a str,
}

/// How a comparison figure is drawn, besides its title and its method panels.
#[derive(Clone, Copy, Debug, Default)]
pub struct FigureOptions<'a> {
    /// Exposure of every render, in stops.
    pub exposure_ev: f32,
    /// The rectangle outlined on every render and shown magnified in the insets.
    pub crop: Option<Crop>,
    /// The reference, drawn as the first column (before the methods).
    pub reference: Option<ReferencePanel<'a>>,
    /// The most panels per row, the reference counting as one; `None`: all in one row.
    pub columns: Option<u32>,
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

/// The comparison figure of `panels` (renders of one size) under `title`, drawn as `options` say
/// (see the [module docs](self) for the layout).
pub fn compose(title: &str, panels: &[Panel], options: &FigureOptions) -> Canvas {
    let reference = options.reference;
    let first = reference.map(|r| r.image).or_else(|| panels.first().map(|p| p.image));
    let (w, h) = first.map_or((0, 0), |image| (image.width as u32, image.height as u32));
    let crop_size = options.crop.map(|c| (c.width as u32, c.height as u32));
    let shift = u32::from(reference.is_some());
    let layout = Layout::new((w, h), panels.len() as u32 + shift, crop_size, options.columns);
    let mut fig = Canvas::new(layout.width, layout.height, WHITE);
    let content = layout.width - 2 * layout.gap;
    fitted_text(&mut fig, layout.gap as f32, layout.gap as f32, layout.font, content, Align::Left, title);

    let scale = ErrorScale::of(panels);
    if let Some(reference) = reference {
        draw_render(&mut fig, &layout, 0, reference.image, options);
        draw_label(&mut fig, &layout, 0, &reference_label(&reference));
    }
    for (i, panel) in (shift..).zip(panels) {
        draw_render(&mut fig, &layout, i, panel.image, options);
        draw_label(&mut fig, &layout, i, &method_label(panel));
        draw_error_map(&mut fig, &layout, i, panel.error, scale.decades);
    }

    let (gx, gy) = (layout.gap as f32, layout.caption_y as f32);
    fitted_text(&mut fig, gx, gy, layout.font, content, Align::Left, &scale.caption());
    colour_bar(&mut fig, &layout, scale.decades, scale.clipped_low);
    fig
}

/// The one logarithmic scale of all error maps, and what falls outside it.
struct ErrorScale {
    /// The decades 10^lo .. 10^hi the colours span.
    decades: (i32, i32),
    /// Whether some finite errors lie below the scale.
    clipped_low: bool,
    /// How many errors lie above the scale.
    above: usize,
    /// How many errors are NaN or infinite.
    non_finite: usize,
}

impl ErrorScale {
    /// The scale of the errors of all `panels` together.
    fn of(panels: &[Panel]) -> ErrorScale {
        let all: Vec<f32> = panels.iter().flat_map(|p| p.error.iter().copied()).collect();
        let decades = log_range(&all);
        let finite = || all.iter().copied().filter(|v| v.is_finite());
        ErrorScale {
            decades,
            clipped_low: finite().any(|v| f64::from(v) < 10f64.powi(decades.0)),
            above: above_scale(&all, decades),
            non_finite: all.len() - finite().count(),
        }
    }

    /// The caption of the error maps: what they show, and what the out-of-scale colours mean.
    fn caption(&self) -> String {
        let mut caption = format!("{ERROR_LABEL}; red: {}", above_label(self.decades.1, self.above));
        if self.non_finite > 0 {
            caption += &format!("; magenta: NaN/Inf ({} px)", self.non_finite);
        }
        caption
    }
}

/// The column of panel `i` and the distance of its row below the first row.
fn place(layout: &Layout, i: u32) -> (u32, u32) {
    let (column, row) = layout.cell(i);
    (column, layout.row_offset(row))
}

/// Draws `image` as panel `i`'s render, tone-mapped, with the crop outlined on it and magnified
/// in the panel's inset.
fn draw_render(fig: &mut Canvas, layout: &Layout, i: u32, image: &Image, options: &FigureOptions) {
    let (column, dy) = place(layout, i);
    let mut render = Canvas::from_image(image, options.exposure_ev);
    if let (Some(crop), Some(size)) = (options.crop, layout.inset) {
        draw_inset(fig, layout, &mut render, crop, size, (column, dy));
    }
    fig.blit(layout.centred_x(column, layout.image.0), (layout.image_y + dy) as i64, &render);
}

/// Outlines `crop` on `render` and draws it magnified, framed, as the inset (`size`) of the panel
/// at `(column, dy)`.
fn draw_inset(
    fig: &mut Canvas,
    layout: &Layout,
    render: &mut Canvas,
    crop: Crop,
    size: (u32, u32),
    at: (u32, u32),
) {
    let ((column, dy), (iw, ih)) = (at, size);
    let (cx, cy, cw, ch) = (crop.x as u32, crop.y as u32, crop.width as u32, crop.height as u32);
    let inset = render.crop(cx, cy, cw, ch).magnified(layout.zoom);
    let outline = layout.outline();
    let t = outline as i64;
    render.stroke_rect(cx as i64 - t, cy as i64 - t, cw + 2 * outline, ch + 2 * outline, outline, CROP_COLOR);
    let (ix, iy) = (layout.centred_x(column, iw), (layout.inset_y + dy) as i64);
    fig.blit(ix, iy, &inset);
    fig.stroke_rect(ix - t, iy - t, iw + 2 * outline, ih + 2 * outline, outline, CROP_COLOR);
}

/// The label of a method: its name; samples and seconds; relMSE.
fn method_label(panel: &Panel) -> [String; 3] {
    [
        panel.method.to_string(),
        format!("{} spp, {} s", format_spp(panel.spp), format_seconds(panel.seconds)),
        match panel.rel_mse_interval {
            Some((low, high)) => {
                format!(
                    "relMSE {} [{}, {}]",
                    format_number(panel.rel_mse),
                    format_number(low),
                    format_number(high)
                )
            }
            None => format!("relMSE {}", format_number(panel.rel_mse)),
        },
    ]
}

/// The label of the reference: "reference"; its description; no relMSE.
fn reference_label(reference: &ReferencePanel) -> [String; 3] {
    [REFERENCE_LABEL.to_string(), reference.description.to_string(), REFERENCE_REL_MSE.to_string()]
}

/// Sets the three `lines` of panel `i`'s label, each centred in its column.
fn draw_label(fig: &mut Canvas, layout: &Layout, i: u32, lines: &[String; 3]) {
    let (column, dy) = place(layout, i);
    let left = layout.column_x(column) as f32;
    for (j, line) in (0..).zip(lines) {
        let y = (layout.label_y + dy + j * layout.line) as f32;
        fitted_text(fig, left, y, layout.font, layout.column, Align::Centre, line);
    }
}

/// Draws `error` (W·H values, row by row) in the colours of `decades` as panel `i`'s error map.
fn draw_error_map(fig: &mut Canvas, layout: &Layout, i: u32, error: &[f32], decades: (i32, i32)) {
    let (column, dy) = place(layout, i);
    let (w, h) = layout.image;
    let (x, y) = (layout.centred_x(column, w), (layout.error_y + dy) as i64);
    for py in 0..h {
        for px in 0..w {
            let v = error.get((py * w + px) as usize).copied().unwrap_or(f32::NAN);
            fig.set(x + px as i64, y + py as i64, error_colour(v, decades));
        }
    }
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
        let l = Layout::new((800, 600), 3, None, None);
        assert_eq!((l.column, l.font, l.line, l.gap, l.bar), (800, 72, 90, 20, 36));
        assert_eq!(l.width, 3 * 800 + 4 * 20);
        assert_eq!(l.height, 6 * 20 + 6 * 90 + 36 + 2 * 600);
        assert_eq!((l.zoom, l.inset), (1, None));
        assert_eq!(l.column_x(2), 20 + 2 * 820);
        assert_eq!(l.centred_x(1, 800), (20 + 820) as i64);
    }

    #[test]
    fn small_renders_get_the_minimum_column() {
        let l = Layout::new((32, 24), 2, None, None);
        assert_eq!((l.column, l.font, l.line, l.gap, l.bar), (160, 14, 17, 4, 7));
        assert_eq!((l.width, l.height), (2 * 160 + 3 * 4, 6 * 4 + 6 * 17 + 7 + 2 * 24));
        assert_eq!(l.centred_x(0, 32), 4 + 64);
    }

    #[test]
    fn a_crop_adds_its_magnified_inset_and_one_gap() {
        let plain = Layout::new((400, 300), 4, None, None);
        let cropped = Layout::new((400, 300), 4, Some((50, 20)), None);
        // k = min(400 / 50, 300 / 20) = 8
        assert_eq!((cropped.zoom, cropped.inset), (8, Some((400, 160))));
        assert_eq!(cropped.width, plain.width);
        assert_eq!(cropped.height, plain.height + 160 + plain.gap);
        assert_eq!(cropped.error_y, plain.error_y + 160 + plain.gap);
        // A crop of the whole image is shown at its own size.
        assert_eq!(Layout::new((400, 300), 1, Some((400, 300)), None).zoom, 1);
        // A tall, narrow crop is limited by the height.
        assert_eq!(Layout::new((400, 300), 1, Some((10, 100)), None).inset, Some((30, 300)));
    }

    #[test]
    fn blocks_are_stacked_without_overlap() {
        let l = Layout::new((200, 100), 2, Some((20, 10)), None);
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
        Panel { method, image, spp: 16.0, seconds: 1.5, rel_mse: 0.01, rel_mse_interval: None, error }
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
        let options = FigureOptions { crop: Some(crop), ..FigureOptions::default() };
        let fig = compose("cornell-glass · equal samples", &panels, &options);
        let l = Layout::new((40, 30), 2, Some((5, 5)), None);
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
        let fig = compose("t", &[panel(&image, long, &errors)], &FigureOptions::default());
        let l = Layout::new((8, 8), 1, None, None);
        assert_eq!((fig.width, fig.height), (l.width, l.height));
        // Nothing of the label spills into the outer gaps.
        for y in l.label_y..l.label_y + l.line {
            for x in (0..l.gap).chain(l.width - l.gap..l.width) {
                assert_eq!(fig.get(x, y), WHITE, "({x}, {y})");
            }
        }
    }

    #[test]
    fn panels_wrap_into_rows_of_at_most_the_given_columns() {
        let one_row = Layout::new((200, 100), 5, Some((20, 10)), None);
        let wrapped = Layout::new((200, 100), 5, Some((20, 10)), Some(2));
        let (c, g, line, bar) = (wrapped.column, wrapped.gap, wrapped.line, wrapped.bar);
        assert_eq!((one_row.per_row, one_row.rows), (5, 1));
        assert_eq!((wrapped.per_row, wrapped.rows), (2, 3));
        // S = 2·H + 3·L + 3·g + g + k·ch, with k = min(200 / 20, 100 / 10) = 10.
        assert_eq!(wrapped.row_height, 2 * 100 + 3 * line + 3 * g + g + 10 * 10);
        assert_eq!(wrapped.row_height, one_row.row_height);
        assert_eq!(wrapped.width, 2 * c + 3 * g);
        assert_eq!(wrapped.height, 3 * g + 3 * line + bar + 3 * wrapped.row_height);
        assert_eq!(one_row.height, 3 * g + 3 * line + bar + one_row.row_height);
        // Left to right, then down; the shared caption below the last row.
        assert_eq!(
            [wrapped.cell(0), wrapped.cell(1), wrapped.cell(2), wrapped.cell(4)],
            [(0, 0), (1, 0), (0, 1), (0, 2)]
        );
        assert_eq!(wrapped.row_offset(2), 2 * wrapped.row_height);
        assert_eq!(wrapped.caption_y, wrapped.image_y + 3 * wrapped.row_height);
        assert_eq!(wrapped.error_y + 100 + g + 2 * wrapped.row_height, wrapped.caption_y);
        // A limit of N or more is one row; a limit of 0 counts as 1.
        assert_eq!(Layout::new((200, 100), 5, None, Some(5)), Layout::new((200, 100), 5, None, None));
        assert_eq!(Layout::new((200, 100), 5, None, Some(9)), Layout::new((200, 100), 5, None, None));
        let single = Layout::new((200, 100), 3, None, Some(0));
        assert_eq!((single.per_row, single.rows, single.width), (1, 3, c + 2 * g));
    }

    /// A `width` × `height` render of one linear colour.
    fn solid(width: usize, height: usize, colour: Vec3) -> Image {
        let mut image = Image::new(width, height);
        image.pixels = vec![colour; width * height];
        image
    }

    /// Whether every pixel of the `w` × `h` rectangle at (x, y) is `colour`.
    fn filled(fig: &Canvas, (x, y): (i64, u32), (w, h): (u32, u32), colour: Rgb) -> bool {
        (y..y + h).all(|py| (0..w).all(|px| fig.get(x as u32 + px, py) == colour))
    }

    #[test]
    fn the_reference_is_the_first_column_with_render_inset_and_label_but_no_error_map() {
        let (green, blue) =
            (solid(40, 30, Vec3::new(0.0, 1.0, 0.0)), solid(40, 30, Vec3::new(0.0, 0.0, 1.0)));
        let errors = vec![1e-1; 40 * 30];
        let panels = [panel(&blue, "path", &errors)];
        let crop = Crop { x: 10, y: 10, width: 10, height: 10 };
        let reference = ReferencePanel { image: &green, description: "vcm, 1024 spp" };
        let options =
            FigureOptions { crop: Some(crop), reference: Some(reference), ..FigureOptions::default() };
        let fig = compose("t", &panels, &options);
        let l = Layout::new((40, 30), 2, Some((10, 10)), None);
        assert_eq!((fig.width, fig.height), (l.width, l.height));
        let (x0, x1) = (l.centred_x(0, 40), l.centred_x(1, 40));
        // The reference's render fills its place in column 0, left of the method's in column 1
        // (outside the crop's outline, inside its own pixels).
        assert!(filled(&fig, (x0, l.image_y), (40, 8), [0, 255, 0]));
        assert!(filled(&fig, (x0 + 21, l.image_y + 21), (19, 9), [0, 255, 0]));
        assert!(filled(&fig, (x1, l.image_y), (40, 8), [0, 0, 255]));
        assert_eq!(fig.get(x0 as u32 + 9, l.image_y + 12), CROP_COLOR);
        // Its inset (k = 3) is the magnified crop, as the method's is.
        let inset = (l.centred_x(0, 30), l.inset_y);
        assert!(filled(&fig, inset, (30, 30), [0, 255, 0]));
        // Its label has text; where the methods have their error map it has nothing.
        assert!(ink(&fig, l.label_y, l.label_y + 3 * l.line));
        assert!(filled(&fig, (l.column_x(0) as i64, l.error_y), (l.column, 30), WHITE));
        assert!(filled(&fig, (x1, l.error_y), (40, 30), viridis(1.0)));
    }

    #[test]
    fn wrapped_rows_repeat_the_panel_stack_under_one_title_and_one_colour_bar() {
        let reference = solid(40, 30, Vec3::new(0.0, 1.0, 0.0));
        let renders: Vec<Image> =
            [0.0, 0.25, 0.5, 1.0].iter().map(|&v| solid(40, 30, Vec3::new(v, 0.0, 0.0))).collect();
        let errors = vec![1e-1; 40 * 30];
        let names = ["a", "b", "c", "d"];
        let panels: Vec<Panel> =
            renders.iter().zip(names).map(|(image, name)| panel(image, name, &errors)).collect();
        let reference = ReferencePanel { image: &reference, description: "path, 64 spp" };
        let options =
            FigureOptions { reference: Some(reference), columns: Some(2), ..FigureOptions::default() };
        let fig = compose("t", &panels, &options);
        let l = Layout::new((40, 30), 5, None, Some(2));
        assert_eq!((fig.width, fig.height, l.rows), (l.width, l.height, 3));
        // Panel i is in column i mod 2 of row i / 2: method "c" (panel 3) is right in row 1,
        // method "d" (panel 4) left in row 2, whose right-hand column is empty.
        let s = l.row_height;
        let (x0, x1) = (l.centred_x(0, 40), l.centred_x(1, 40));
        assert!(filled(&fig, (x0, l.image_y), (40, 30), [0, 255, 0]));
        assert!(filled(&fig, (x1, l.image_y + s), (40, 30), [188, 0, 0]));
        assert!(filled(&fig, (x0, l.image_y + 2 * s), (40, 30), [255, 0, 0]));
        assert!(filled(&fig, (x0, l.error_y + 2 * s), (40, 30), viridis(1.0)));
        let empty = (l.column_x(1) as i64, l.image_y + 2 * s);
        assert!(filled(&fig, empty, (l.column, s - l.gap), WHITE));
        // No error map under the reference; one under every method.
        assert!(filled(&fig, (x0, l.error_y), (40, 30), WHITE));
        assert!(filled(&fig, (x1, l.error_y), (40, 30), viridis(1.0)));
        // Labels in every row; one caption and one bar below the last.
        for r in 0..3 {
            assert!(ink(&fig, l.label_y + r * s, l.label_y + r * s + 3 * l.line), "row {r}");
        }
        assert!(ink(&fig, l.caption_y, l.bar_y));
        assert_eq!(l.caption_y, l.error_y + 2 * s + 30 + l.gap);
    }

    /// FNV-1a of the figure's bytes.
    fn pixel_hash(fig: &Canvas) -> u64 {
        let bytes = fig.pixels.iter().flatten();
        bytes.fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3))
    }

    #[test]
    fn without_reference_and_column_limit_the_figure_is_that_of_earlier_versions() {
        let mut image = Image::new(40, 30);
        image.pixels =
            (0..40 * 30).map(|i| Vec3::new((i % 40) as f32 / 40.0, (i / 40) as f32 / 30.0, 0.25)).collect();
        let low: Vec<f32> = (0..40 * 30).map(|i| 1e-4 * (1.0 + (i % 7) as f32)).collect();
        let high: Vec<f32> = (0..40 * 30).map(|i| 1e-2 * (1.0 + (i % 13) as f32)).collect();
        let panels = [
            Panel {
                method: "whitted",
                image: &image,
                spp: 16.0,
                seconds: 1.5,
                rel_mse: 0.01,
                rel_mse_interval: None,
                error: &low,
            },
            Panel {
                method: "path",
                image: &image,
                spp: 4.25,
                seconds: 12.0,
                rel_mse: 0.2,
                rel_mse_interval: None,
                error: &high,
            },
            Panel {
                method: "vcm",
                image: &image,
                spp: 8.0,
                seconds: 3.0,
                rel_mse: 0.05,
                rel_mse_interval: None,
                error: &low,
            },
        ];
        let crop = Crop { x: 18, y: 10, width: 5, height: 5 };
        // Sizes and hashes of the figures the code before reference columns and rows drew.
        let cases =
            [(None, (496, 193, 0x3670_07d7_bf54_c3b7)), (Some(crop), (496, 227, 0xc6fb_1b79_8a70_85af))];
        for (crop, expected) in cases {
            let options = FigureOptions { exposure_ev: 0.5, crop, ..FigureOptions::default() };
            let fig = compose("old layout", &panels, &options);
            assert_eq!((fig.width, fig.height, pixel_hash(&fig)), expected, "crop {crop:?}");
        }
    }
}
