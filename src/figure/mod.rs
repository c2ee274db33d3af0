//! Figures for papers and theses: an sRGB canvas with text in an embedded font, false-colour
//! error maps, log-log plots, and composed method comparisons.

pub mod canvas;
pub mod colormap;
pub mod compose;
pub mod plot;
