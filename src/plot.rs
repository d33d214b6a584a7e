//! What the plotting tools share (`convergence`, `sampling-pictures`): the font their labels
//! use, and compact axis labels.

use std::path::PathBuf;

use anyhow::{anyhow, Context, Result};
use plotters::style::FontStyle;

/// Registers the plot font once.
pub fn register_font() -> Result<()> {
    let path = std::env::var_os("STRATA_FONT")
        .map(PathBuf::from)
        .unwrap_or_else(|| "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf".into());
    let bytes = std::fs::read(&path).with_context(|| {
        format!(
            "{}: no font for the plot labels (install fonts-dejavu-core, or set STRATA_FONT to a .ttf)",
            path.display()
        )
    })?;
    plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(bytes.into()))
        .map_err(|_| anyhow!("{}: not a usable TrueType font", path.display()))
}

/// A compact axis label: 3 significant digits, without trailing zeros ("0.25", "10", "1e-4").
pub fn float_label(v: f64) -> String {
    if v != 0.0 && (v.abs() < 1e-3 || v.abs() >= 1e5) {
        return format!("{v:.0e}");
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}
