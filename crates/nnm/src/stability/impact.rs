//! Impact-equivalent contact Jacobian for augmented-Lagrangian (rigid-contact) orbits.
//!
//! At convergence of Algorithm 1 an impact is a short active phase (often one sample) carrying a
//! large penalty kappa. Linearized as is, it is a stiff spring acting for a time tau much shorter
//! than its own half period pi sqrt(m_eff / kappa): the perturbation's normal velocity is barely
//! turned, not reversed as by the elastic impact, and Hill's N harmonics resolve neither. The
//! exact rigid-impact monodromy has a saltation matrix instead (Leine & Nijmeijer 2004). A contact
//! spring that lasts exactly half of its own period, kappa_eq = m_eff (pi / tau)^2 with the
//! contact-point mass m_eff = 1 / (A_j M^-1 A_j^T), is an elastic bounce of the perturbation, and
//! its flow tends to the saltation matrix as tau -> 0 (the penalty-to-rigid limit). We use it with
//! tau_eq = `width` T / N, centred on the active phase, so that its frequency pi / tau_eq =
//! (N w) / (2 width) stays within Hill's band: the linearization converges to the rigid one like
//! the penalty orbits as kappa grows, i.e. O(1 / N) in the location of the transitions.
//!
//! Only phases shorter than tau_eq with a positive multiplier theta (the rigid law; a penalty orbit
//! has theta = 0) are replaced; longer phases are persistent contact, where kappa on the active
//! set acts as the constraint of the closed contact and is kept.

use super::monodromy::Piece;

/// One row's stiffness on [start, end) (times in [0, T)).
struct Segment {
    start: f64,
    end: f64,
    kappa: f64,
}

/// The pieces of constant contact stiffness after replacing the short rigid phases by their
/// impact-equivalent springs. `contact_mass[j]` = m_eff of row j; `width_time` = tau_eq (s).
pub(crate) fn impact_equivalent_pieces(
    pieces: &[Piece],
    period: f64,
    contact_mass: &[f64],
    width_time: f64,
) -> Vec<Piece> {
    let c = contact_mass.len();
    let mut segments: Vec<Vec<Segment>> = (0..c).map(|_| Vec::new()).collect();
    for (j, row) in segments.iter_mut().enumerate() {
        for (start, end, rigid) in active_phases(pieces, j, period) {
            let tau = end - start;
            if rigid && tau < width_time {
                let centre = 0.5 * (start + end);
                let kappa = contact_mass[j] * (std::f64::consts::PI / width_time).powi(2);
                push_wrapped(
                    row,
                    centre - 0.5 * width_time,
                    centre + 0.5 * width_time,
                    kappa,
                    period,
                );
            } else {
                for p in pieces.iter().filter(|p| p.kappa[j] > 0.0) {
                    let mid = 0.5 * (p.start + p.end);
                    let inside = if start <= mid {
                        mid < end
                    } else {
                        mid + period < end
                    };
                    if inside {
                        row.push(Segment {
                            start: p.start,
                            end: p.end,
                            kappa: p.kappa[j],
                        });
                    }
                }
            }
        }
    }
    let mut cuts: Vec<f64> = vec![0.0, period];
    for s in segments.iter().flatten() {
        cuts.push(s.start);
        cuts.push(s.end);
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() <= 1e-15 * period);
    cuts.windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| {
            let mid = 0.5 * (w[0] + w[1]);
            let kappa = segments
                .iter()
                .map(|row| {
                    row.iter()
                        .filter(|s| s.start <= mid && mid < s.end)
                        .map(|s| s.kappa)
                        .sum()
                })
                .collect();
            Piece {
                start: w[0],
                end: w[1],
                kappa,
                theta_positive: vec![false; c],
            }
        })
        .collect()
}

/// Maximal active phases (start, end, rigid) of row j, end > start, start in [0, T); a phase
/// through t = 0 is returned with end > T. `rigid`: some piece of it has theta > 0.
fn active_phases(pieces: &[Piece], j: usize, period: f64) -> Vec<(f64, f64, bool)> {
    let mut phases: Vec<(f64, f64, bool)> = Vec::new();
    for p in pieces.iter().filter(|p| p.kappa[j] > 0.0) {
        match phases.last_mut() {
            Some(last) if (last.1 - p.start).abs() <= 1e-12 * period => {
                last.1 = p.end;
                last.2 |= p.theta_positive[j];
            }
            _ => phases.push((p.start, p.end, p.theta_positive[j])),
        }
    }
    if phases.len() >= 2 {
        let first = phases[0];
        let last = phases[phases.len() - 1];
        if first.0 <= 1e-12 * period && (last.1 - period).abs() <= 1e-12 * period {
            phases.remove(0);
            let merged = phases.last_mut().expect("two phases");
            merged.1 = period + first.1;
            merged.2 |= first.2;
        }
    }
    phases
}

/// Adds [start, end) (possibly outside [0, T)) to `row`, split at the period boundary.
fn push_wrapped(row: &mut Vec<Segment>, start: f64, end: f64, kappa: f64, period: f64) {
    let (s, e) = (
        start.rem_euclid(period),
        start.rem_euclid(period) + (end - start),
    );
    if e <= period {
        row.push(Segment {
            start: s,
            end: e,
            kappa,
        });
    } else {
        row.push(Segment {
            start: s,
            end: period,
            kappa,
        });
        row.push(Segment {
            start: 0.0,
            end: e - period,
            kappa,
        });
    }
}
