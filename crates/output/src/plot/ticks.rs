//! "Nice" axis ticks (Heckbert, "Nice numbers for graph labels", Graphics Gems, 1990).

/// Axis limits rounded outward to whole tick steps, and the ticks between them.
#[derive(Debug, Clone, PartialEq)]
pub struct Ticks {
    /// Lower axis limit (a multiple of `step`).
    pub lo: f64,
    /// Upper axis limit (a multiple of `step`).
    pub hi: f64,
    /// Tick spacing: 1, 2 or 5 times a power of ten.
    pub step: f64,
    /// Tick values from `lo` to `hi`.
    pub values: Vec<f64>,
}

/// The number of the form {1, 2, 5, 10} x 10^k nearest to `x` > 0 (in the sense of Heckbert's
/// rounding thresholds 1.5, 3, 7).
fn nice_number(x: f64) -> f64 {
    let exp = x.log10().floor();
    let p = 10f64.powf(exp);
    let f = x / p;
    let nf = if f < 1.5 {
        1.0
    } else if f < 3.0 {
        2.0
    } else if f < 7.0 {
        5.0
    } else {
        10.0
    };
    nf * p
}

/// Ticks covering [`lo`, `hi`] with about `target` intervals. A range that is empty or flat to
/// 1e-9 relative (e.g. a frequency ratio equal to 1 up to solver tolerance) is widened to
/// +-5 % of the value (+-1 around zero) so that noise is not magnified. Inputs must be finite.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> Ticks {
    let (mut lo, mut hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    let mag = lo.abs().max(hi.abs());
    if hi - lo <= 1e-9 * mag || hi == lo {
        let c = 0.5 * (lo + hi);
        let half = if c == 0.0 { 1.0 } else { 0.05 * c.abs() };
        lo = c - half;
        hi = c + half;
    }
    let target = target.max(1) as f64;
    let step = nice_number((hi - lo) / target);
    let i0 = (lo / step).floor();
    let i1 = (hi / step).ceil();
    let values: Vec<f64> = (0..=((i1 - i0) as usize))
        .map(|k| {
            let v = (i0 + k as f64) * step;
            if v.abs() < 1e-9 * step {
                0.0
            } else {
                v
            }
        })
        .collect();
    Ticks {
        lo: i0 * step,
        hi: i1 * step,
        step,
        values,
    }
}

/// Text of tick `v` for ticks of spacing `step`: as many decimals as the step needs, exponent
/// notation for magnitudes >= 1e5 or < 1e-3.
pub(crate) fn tick_label(v: f64, step: f64, max_abs: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    let step_exp = step.log10().floor() as i32;
    if !(1e-3..1e5).contains(&max_abs) {
        let digits = (max_abs.log10().floor() as i32 - step_exp).max(0) as usize;
        return format!("{v:.digits$e}");
    }
    let decimals = (-step_exp).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        "0".to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_and_cover_the_range() {
        let t = nice_ticks(0.0, 31.3, 6);
        assert_eq!((t.lo, t.hi, t.step), (0.0, 35.0, 5.0));
        assert_eq!(t.values.len(), 8);
        let t = nice_ticks(0.97, 1.34, 6);
        assert_eq!(t.step, 0.05);
        assert!(t.lo <= 0.97 && t.hi >= 1.34);
        assert!((t.lo - 0.95).abs() < 1e-12 && (t.hi - 1.35).abs() < 1e-12);
        let t = nice_ticks(-2.2e-4, 7.9e-4, 5);
        assert!((t.step - 2e-4).abs() < 1e-18);
        for (k, v) in t.values.iter().enumerate() {
            assert!((v - (t.lo + k as f64 * t.step)).abs() < 1e-15);
        }
    }

    #[test]
    fn flat_ranges_are_widened() {
        let t = nice_ticks(1.0, 1.0 + 1e-13, 5);
        assert!(t.lo <= 0.95 && t.hi >= 1.05 && t.hi - t.lo < 0.5, "{t:?}");
        let t = nice_ticks(0.0, 0.0, 5);
        assert!(t.lo <= -1.0 && t.hi >= 1.0);
    }

    #[test]
    fn labels() {
        assert_eq!(tick_label(0.30000000000000004, 0.1, 1.0), "0.3");
        assert_eq!(tick_label(35.0, 5.0, 35.0), "35");
        assert_eq!(tick_label(1.25, 0.05, 1.35), "1.25");
        assert_eq!(tick_label(2e-4, 1e-4, 8e-4), "2e-4");
        assert_eq!(tick_label(250000.0, 50000.0, 3e5), "2.5e5");
        assert_eq!(tick_label(-1e-17, 0.1, 1.0), "0");
    }
}
