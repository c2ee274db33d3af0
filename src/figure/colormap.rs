//! False colour for error maps, with a labelled colour bar.

use super::canvas::Canvas;

/// A `width`×`height` map of `values` (e.g. relative squared error per pixel) in false colour on a
/// logarithmic scale, with a colour bar labelled `label` beside it; NaN pixels are marked.
pub fn error_map(_values: &[f32], _width: usize, _height: usize, _label: &str) -> Canvas {
    unimplemented!("under construction")
}
