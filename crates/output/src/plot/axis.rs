//! Axis limits and ticks of a line plot, from its data and reference lines.

use super::line::LinePlot;
use super::series::Orientation;
use super::ticks::{nice_ticks, tick_label};
use crate::finite::check_finite;
use crate::OutputError;

/// Margin added above and below the y data range (fraction of the range), as in most plotting
/// tools: curves do not run along the frame. The x axis spans the data exactly.
pub(crate) const Y_PAD: f64 = 0.05;
/// Axis limits and ticks.
pub(crate) struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub ticks: Vec<f64>,
    step: f64,
}

impl Axis {
    /// Fixed limits if given; otherwise the data range widened by `pad` (fraction of the span) on
    /// both sides. Ticks are the nice values inside the limits.
    pub fn new(
        what: &str,
        fixed: Option<(f64, f64)>,
        data: (f64, f64),
        pad: f64,
    ) -> Result<Self, OutputError> {
        let (data_lo, data_hi) = data;
        let (lo, hi) = match fixed {
            Some((lo, hi)) => {
                check_finite(what, &[lo, hi])?;
                if lo >= hi {
                    return Err(OutputError::invalid(
                        what.to_string(),
                        format!("range ({lo}, {hi}) is empty; expected lo < hi"),
                    ));
                }
                (lo, hi)
            }
            None => {
                // A flat range is widened the way nice_ticks does it.
                let t = nice_ticks(data_lo, data_hi, 6);
                let (lo, hi) = if data_hi - data_lo <= 1e-9 * data_lo.abs().max(data_hi.abs())
                    || data_hi == data_lo
                {
                    (t.lo, t.hi)
                } else {
                    (data_lo, data_hi)
                };
                let span = hi - lo;
                (lo - pad * span, hi + pad * span)
            }
        };
        let t = nice_ticks(lo, hi, 6);
        let eps = 1e-9 * (hi - lo);
        Ok(Axis {
            lo,
            hi,
            ticks: t
                .values
                .into_iter()
                .filter(|v| *v >= lo - eps && *v <= hi + eps)
                .collect(),
            step: t.step,
        })
    }

    pub fn label(&self, v: f64) -> String {
        tick_label(v, self.step, self.lo.abs().max(self.hi.abs()))
    }

    pub fn contains(&self, v: f64) -> bool {
        v >= self.lo && v <= self.hi
    }
}

/// Data range (x, y) of the series and reference lines; (0, 1) for an empty axis.
pub(crate) fn data_ranges(plot: &LinePlot) -> ((f64, f64), (f64, f64)) {
    let (mut xl, mut xh, mut yl, mut yh) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for s in &plot.series {
        for (&x, &y) in s.x.iter().zip(&s.y) {
            (xl, xh, yl, yh) = (xl.min(x), xh.max(x), yl.min(y), yh.max(y));
        }
    }
    for r in &plot.ref_lines {
        match r.orientation {
            Orientation::Horizontal => (yl, yh) = (yl.min(r.value), yh.max(r.value)),
            Orientation::Vertical => (xl, xh) = (xl.min(r.value), xh.max(r.value)),
        }
    }
    let fix = |lo: f64, hi: f64| if lo > hi { (0.0, 1.0) } else { (lo, hi) };
    (fix(xl, xh), fix(yl, yh))
}
