//! The report's `index.html`: the static structure of every section (details, tabs, controls,
//! canvas, table, a table per region) with every text escaped, and the numbers the viewer needs
//! as JSON.

use super::{data, RegionTable, Report, Section, TableRow};
use crate::figure::colormap::{log_range, ABOVE_COLOR, NAN_COLOR, VIRIDIS};
use crate::figure::compose::{format_number, format_spp};
use crate::metrics::relative_squared_error;
use serde_json::json;
use std::fmt::Write as _;

/// `text` safe inside HTML text and attribute values: `& < > " '` become entities.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// JSON safe inside a `<script type="application/json">` element: `<`, `>` and `&` (which occur
/// only inside strings) are written as `\u` escapes, so no `</script>` or comment can appear.
pub fn script_json(value: &serde_json::Value) -> String {
    serde_json::to_string(value)
        .expect("JSON")
        .replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026")
}

/// The keys the viewer answers to, as the page's header explains them.
const KEYS: &str = "Keys act on the viewer under the mouse (else the last one used): \
    <kbd>1</kbd>–<kbd>9</kbd>, <kbd>0</kbd> the methods, <kbd>r</kbd> the reference; \
    hold <kbd>b</kbd> to flip to image B; <kbd>s</kbd> split A | B (drag the slider); \
    <kbd>e</kbd> error map; <kbd>+</kbd> / <kbd>-</kbd> exposure ±0.5 EV; <kbd>[</kbd> / <kbd>]</kbd> gamma; \
    <kbd>g</kbd> sRGB curve on/off; <kbd>f</kbd> fit, <kbd>o</kbd> 1:1. The wheel zooms (by powers of two, \
    nearest-neighbour), dragging pans; zoom and pan are shared by all images of a scene.";

/// The columns of the results table: header text, tooltip.
const COLUMNS: [(&str, &str); 14] = [
    ("method", "the rendering method"),
    ("spp", "samples per pixel (ssaa: mean camera rays per pixel)"),
    ("seconds", "render seconds"),
    ("rays", "rays traced (camera, secondary, shadow)"),
    ("Mrays/s", "millions of rays per second"),
    ("MSE", "mean squared error against the reference"),
    ("relMSE [95%]", "mean over pixels and channels of (x − r)² / (r² + 0.01), with its 95% interval (jackknife over the replicas)"),
    ("relMSE 99.9%", "the relMSE without the 0.1% worst pixels"),
    ("PSNR", "PSNR on the HDR values, dB (peak: the largest reference value)"),
    ("SSIM", "SSIM of the 8-bit preview's luma"),
    ("HDR-FLIP", "mean HDR-FLIP (Andersson et al.): 0 identical, 1 the largest perceived difference"),
    ("bias part", "relative error − the variance parts of the render and the reference (weights 1/(r̃² + 0.01), r̃ the neighbours' reference), ± one standard error"),
    ("efficiency [95%]", "1 / (relMSE · seconds) with its 95% interval, only where no bias is detected"),
    ("verdict", "biased; reference too noisy; inconclusive (too noisy to tell); no bias detected"),
];

/// The whole page.
pub fn html(report: &Report) -> String {
    let mut s = String::new();
    let title = escape(&report.title);
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{title}</title>\n<link rel=\"stylesheet\" href=\"report.css\">\n</head>\n<body>\n\
         <header>\n<h1>{title}</h1>\n<p class=\"keys\">{KEYS}</p>\n</header>\n<main>\n"
    );
    for (i, section) in report.sections.iter().enumerate() {
        section_html(&mut s, i, section);
    }
    s.push_str("</main>\n<footer>\n<dl>\n");
    let scenes: Vec<&str> = report.sections.iter().map(|x| x.scene.as_str()).collect();
    for (label, value) in [
        ("scenes", scenes.join(", ")),
        ("vitrum", crate::VERSION.to_string()),
        ("machine", report.machine.clone()),
        ("command", report.command.clone()),
    ] {
        let _ = writeln!(s, "<dt>{label}</dt><dd>{}</dd>", escape(&value));
    }
    s.push_str("</dl>\n</footer>\n");
    let sections: Vec<serde_json::Value> =
        report.sections.iter().enumerate().map(|(i, x)| section_json(i, x)).collect();
    let data = json!({
        "sections": sections,
        "viridis": VIRIDIS,
        "nan": NAN_COLOR,
        "above": ABOVE_COLOR,
    });
    let _ =
        writeln!(s, "<script type=\"application/json\" id=\"vitrum-data\">{}</script>", script_json(&data));
    s.push_str("<script src=\"report.js\"></script>\n");
    for (i, section) in report.sections.iter().enumerate() {
        for layer in std::iter::once(&section.reference).chain(&section.layers) {
            let _ = writeln!(s, "<script src=\"{}\"></script>", data::file_name(&data::key(i, &layer.label)));
        }
    }
    s.push_str("</body>\n</html>\n");
    s
}

/// The number key of tab `k` (1-based among the methods): 1–9, then 0 for the tenth.
fn tab_key(k: usize) -> Option<char> {
    match k {
        1..=9 => char::from_digit(k as u32, 10),
        10 => Some('0'),
        _ => None,
    }
}

/// One scene's section.
fn section_html(s: &mut String, i: usize, section: &Section) {
    let (w, h) = (section.reference.image.width, section.reference.image.height);
    let _ = writeln!(s, "<section class=\"scene\" id=\"s{i}\" data-section=\"{i}\">");
    let _ = writeln!(s, "<h2>{}</h2>\n<dl class=\"details\">", escape(&section.scene));
    for (label, value) in &section.details {
        let _ = writeln!(s, "<dt>{}</dt><dd>{}</dd>", escape(label), escape(value));
    }
    s.push_str("</dl>\n<div class=\"viewer\">\n<div class=\"tabs\" role=\"tablist\">\n");
    for (k, layer) in section.layers.iter().enumerate() {
        let key = tab_key(k + 1).map_or(String::new(), |c| format!("<kbd>{c}</kbd> "));
        let _ = writeln!(
            s,
            "<button class=\"tab\" role=\"tab\" data-layer=\"{}\" title=\"{}\">{key}{}</button>",
            k + 1,
            escape(&layer.note),
            escape(&layer.label)
        );
    }
    let _ = writeln!(
        s,
        "<button class=\"tab\" role=\"tab\" data-layer=\"0\" title=\"{}\"><kbd>r</kbd> reference</button>\n</div>",
        escape(&section.reference.note)
    );
    s.push_str("<div class=\"controls\">\n<label>B <select class=\"b-layer\">\n");
    for (k, layer) in std::iter::once(&section.reference).chain(&section.layers).enumerate() {
        let label = if k == 0 { "reference" } else { &layer.label };
        let _ = writeln!(s, "<option value=\"{k}\">{}</option>", escape(label));
    }
    let exposure = section.exposure;
    let outlines = if section.regions.is_empty() {
        ""
    } else {
        "<label><input type=\"checkbox\" class=\"regions\" checked> region outlines</label>\n"
    };
    let _ = write!(
        s,
        "</select></label>\n\
         <label><input type=\"checkbox\" class=\"split\"> split A | B</label>\n\
         <label><input type=\"checkbox\" class=\"error\"> error map</label>\n\
         <label>exposure <input type=\"range\" class=\"exposure\" min=\"-16\" max=\"16\" step=\"any\" value=\"{exposure}\">\
         <output class=\"exposure-value\">{exposure:+.1}</output> EV</label>\n\
         <label>gamma <input type=\"range\" class=\"gamma\" min=\"1\" max=\"3\" step=\"0.05\" value=\"2.2\" disabled>\
         <output class=\"gamma-value\">2.20</output></label>\n\
         <label><input type=\"checkbox\" class=\"srgb\" checked> sRGB curve</label>\n{outlines}</div>\n\
         <canvas class=\"view\" width=\"{w}\" height=\"{h}\" aria-label=\"render\"></canvas>\n\
         <input type=\"range\" class=\"split-position\" min=\"0\" max=\"1\" step=\"0.001\" value=\"0.5\" hidden>\n\
         <div class=\"readout\">move the mouse over the image to read its values</div>\n\
         <div class=\"legend\" hidden></div>\n</div>\n"
    );
    table_html(s, &section.rows, None);
    for region in &section.regions {
        table_html(s, &region.rows, Some(&region_caption(region)));
    }
    if !section.convergence.is_empty() {
        s.push_str("<div class=\"convergence\"></div>\n");
    }
    if !section.files.is_empty() {
        let _ = writeln!(
            s,
            "<p class=\"files\">EXR renders and tables: <a href=\"{0}/\">{0}/</a></p>",
            escape(&section.files)
        );
    }
    s.push_str("</section>\n");
}

/// `v` as the CSV writes it where it is finite (Rust's shortest round-trip form), and as
/// JavaScript's `Number()` reads it where it is not: `Infinity`, `-Infinity`, `NaN`.
fn js_number(v: f64) -> String {
    if v.is_finite() {
        v.to_string()
    } else if v.is_nan() {
        "NaN".into()
    } else if v > 0.0 {
        "Infinity".into()
    } else {
        "-Infinity".into()
    }
}

/// "1.23e-3 [1.1e-3, 1.4e-3]", or the value alone without an interval.
fn interval(value: f64, bounds: Option<(f64, f64)>) -> String {
    match bounds {
        Some((lo, hi)) => {
            let hi = if hi.is_finite() { format_number(hi) } else { "∞".into() };
            format!("{} [{}, {hi}]", format_number(value), format_number(lo))
        }
        None => format_number(value),
    }
}

/// "Region caustic: x 8, y 6, 8 × 6 pixels (every metric over the region only)".
fn region_caption(region: &RegionTable) -> String {
    let (x, y, w, h) = region.rect;
    let what = if region.mask { "mask pixels within " } else { "" };
    format!(
        "Region {}: {what}x {x}, y {y}, {w} × {h} pixels (every metric over the region only)",
        region.name
    )
}

/// The sortable table: each cell's exact value in `data-value` (as the CSV writes it), its
/// rounded text shown; a region's table (class `region`) under its `caption`.
fn table_html(s: &mut String, rows: &[TableRow], caption: Option<&str>) {
    match caption {
        Some(caption) => {
            let _ = write!(s, "<table class=\"results region\">\n<caption>{}</caption>\n", escape(caption));
        }
        None => s.push_str("<table class=\"results\">\n"),
    }
    s.push_str("<thead><tr>");
    for (k, (name, tip)) in COLUMNS.iter().enumerate() {
        let _ = write!(s, "<th data-column=\"{k}\" title=\"{}\">{name}</th>", escape(tip));
    }
    s.push_str("</tr></thead>\n<tbody>\n");
    let number = |v: f64| (js_number(v), format_number(v));
    for r in rows {
        let cells = [
            (r.method.clone(), r.method.clone()),
            (r.spp.to_string(), format_spp(r.spp)),
            (js_number(r.seconds), interval(r.seconds, r.seconds_interval)),
            (r.rays.to_string(), r.rays.to_string()),
            number(r.mrays_per_second),
            number(r.mse),
            (js_number(r.rel_mse), interval(r.rel_mse, r.rel_mse_interval)),
            number(r.rel_mse_trimmed),
            number(r.psnr),
            number(r.ssim),
            number(r.flip),
            r.bias.map_or((String::new(), "n/a".into()), |(b, se)| {
                (js_number(b), format!("{} ± {}", format_number(b), format_number(se)))
            }),
            r.efficiency.map_or((String::new(), "—".into()), |e| {
                (js_number(e.value), interval(e.value, Some((e.low, e.high))))
            }),
            (r.status.clone(), r.status.clone()),
        ];
        s.push_str("<tr>");
        for (value, text) in cells {
            let _ = write!(s, "<td data-value=\"{}\">{}</td>", escape(&value), escape(&text));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</tbody>\n</table>\n");
}

/// What the viewer needs of a section: image keys and sizes, the error scale, the regions to
/// outline, the curves.
fn section_json(i: usize, section: &Section) -> serde_json::Value {
    let reference = &section.reference.image;
    let errors: Vec<f32> = section
        .layers
        .iter()
        .filter_map(|l| relative_squared_error(&l.image, reference).ok())
        .flatten()
        .collect();
    let (lo, hi) = log_range(&errors);
    let layers: Vec<serde_json::Value> = std::iter::once(&section.reference)
        .chain(&section.layers)
        .map(|l| json!({"key": data::key(i, &l.label), "label": l.label, "note": l.note}))
        .collect();
    json!({
        "scene": section.scene,
        "width": reference.width,
        "height": reference.height,
        "exposure": section.exposure,
        "layers": layers,
        "decades": [lo, hi],
        "regions": section.regions.iter().map(|r| json!({
            "name": r.name,
            "x": r.rect.0,
            "y": r.rect.1,
            "width": r.rect.2,
            "height": r.rect.3,
        })).collect::<Vec<_>>(),
        "convergence": section.convergence.iter().map(|c| json!({
            "method": c.method,
            "legend": c.legend,
            "points": c.points.iter().zip(c.intervals.iter().chain(std::iter::repeat(&(f64::NAN, f64::NAN))))
                .map(|(p, i)| json!([p.0, p.1, p.2, i.0, i.1]))
                .collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_and_json_cannot_open_markup() {
        assert_eq!(
            escape("<script>alert(1)</script> & 'x' \"y\""),
            "&lt;script&gt;alert(1)&lt;/script&gt; &amp; &#39;x&#39; &quot;y&quot;"
        );
        let text = script_json(&json!({"name": "</script><b>"}));
        assert!(!text.contains('<') && !text.contains('>'), "{text}");
        let back: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(back["name"], "</script><b>");
    }

    #[test]
    fn numbers_are_the_csv_digits_or_what_javascript_reads() {
        assert_eq!(js_number(0.125), "0.125");
        assert_eq!(js_number(1e-7), 1e-7f64.to_string());
        assert_eq!(js_number(f64::INFINITY), "Infinity");
        assert_eq!(js_number(f64::NEG_INFINITY), "-Infinity");
        assert_eq!(js_number(f64::NAN), "NaN");
        // Rust reads them back too (the tests compare the page with compare.csv).
        assert_eq!("Infinity".parse::<f64>(), Ok(f64::INFINITY));
    }

    #[test]
    fn number_keys_run_one_to_nine_then_zero() {
        assert_eq!(
            (1..=11).map(tab_key).collect::<Vec<_>>(),
            [
                Some('1'),
                Some('2'),
                Some('3'),
                Some('4'),
                Some('5'),
                Some('6'),
                Some('7'),
                Some('8'),
                Some('9'),
                Some('0'),
                None
            ]
        );
    }
}
