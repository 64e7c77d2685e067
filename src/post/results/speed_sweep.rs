//! What the interaction map and the report read back of the speed sweeps (issue 39, item 4):
//! `speed_sweep/speed_sweep.json`, written by `forced_speed_output` (per sweep: its crossing,
//! peak, speeds in contact, largest contact force, folds and stability), and the forced verdict
//! of each engine-order crossing of the Campbell diagram: the sweeps through it, or none ("not
//! swept"). Speeds in rpm, frequencies in Hz, amplitudes over the running gap, forces in N (Pa
//! for a pressure load). The sweeps: DESIGN §10.10; docs/ROTATION.md "Forced response at speed
//! and speed sweeps".

use std::path::Path;

use anyhow::Result;
use serde::Deserialize;

/// A sweep's crossing matches a Campbell crossing of the same engine order when their speeds
/// differ by less than this share (the two are computed on different models: the parametric
/// model's curve and the Campbell stage's Ritz curves, measured 7e-5 apart on the coarse blade).
const SAME_CROSSING: f64 = 0.02;

/// `speed_sweep.json` as the report reads it.
#[derive(Debug, Clone, Deserialize)]
pub struct SpeedSweepFile {
    /// The traced mode (0-based, `[forced] mode`).
    pub mode: usize,
    /// `[forced] harmonics`: the N each sweep is first traced at (`SweepRecord::harmonics_note`
    /// says the N it kept).
    pub harmonics: usize,
    pub sweeps: Vec<SweepRecord>,
}

/// A fold of a sweep: where (rpm) and which way (`turns_back`: a run-up jumps there;
/// `turns_forward`: a run-down jumps there).
#[derive(Debug, Clone, Deserialize)]
pub struct FoldEntry {
    pub speed_rpm: f64,
    pub kind: String,
}

/// One sweep's summary (`forced_speed_output::SweepSummary`).
#[derive(Debug, Clone, Deserialize)]
pub struct SweepRecord {
    pub engine_order: usize,
    /// The level as given (`[forced] level_unit`) and its load scale (N, or Pa).
    pub level: f64,
    pub force: f64,
    pub crossing_rpm: f64,
    pub range_rpm: [f64; 2],
    pub peak_rpm: f64,
    pub peak_q1_over_g0: f64,
    pub folds: Vec<FoldEntry>,
    /// Speed intervals in contact, in the order of the sweep.
    pub contact_rpm: Vec<[f64; 2]>,
    /// Lowest and highest speed with contact.
    #[serde(default)]
    pub contact_span_rpm: Option<[f64; 2]>,
    pub max_contact_force_n: f64,
    pub max_contact_force_rpm: Option<f64>,
    /// Points stable, unstable, undetermined: all, and those in contact.
    pub stability: [usize; 3],
    #[serde(default)]
    pub contact_stability: Option<[usize; 3]>,
    #[serde(default)]
    pub peak_stability: Option<String>,
    pub complete: bool,
    pub end: String,
    /// The sweep's N and its check at 2N in words (absent from files of earlier versions).
    #[serde(default)]
    pub harmonics_note: Option<String>,
    /// Every trace's N and its check at 2N (absent from files of earlier versions).
    #[serde(default)]
    pub retraces: Vec<super::RetraceHead>,
}

/// How stable a sweep's response is: the headline word of the verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stability {
    /// Every point with a verdict is stable and none is undetermined.
    Stable,
    /// Some points are unstable (with folds: the branch between them, where the response jumps).
    Unstable,
    /// No point unstable, some undetermined.
    Undetermined,
    /// No Floquet analysis.
    NotComputed,
}

impl Stability {
    pub fn word(self) -> &'static str {
        match self {
            Stability::Stable => "stable",
            Stability::Unstable => "unstable in part",
            Stability::Undetermined => "undetermined",
            Stability::NotComputed => "not computed",
        }
    }
}

impl SweepRecord {
    /// The lowest and highest speed with contact (from the intervals for files written before
    /// `contact_span_rpm`).
    pub fn contact_span(&self) -> Option<[f64; 2]> {
        self.contact_span_rpm.or_else(|| {
            let v = self.contact_rpm.iter().flatten().copied();
            v.fold(None, |s, x| match s {
                None => Some([x, x]),
                Some([lo, hi]) => Some([lo.min(x), hi.max(x)]),
            })
        })
    }

    /// The counts the verdict is drawn from: the points in contact when the sweep touches,
    /// else all its points.
    pub fn judged_counts(&self) -> [usize; 3] {
        match (self.contact_span(), self.contact_stability) {
            (Some(_), Some(c)) => c,
            _ => self.stability,
        }
    }

    /// The headline verdict of [`SweepRecord::judged_counts`].
    pub fn stability_verdict(&self) -> Stability {
        match self.judged_counts() {
            [0, 0, 0] => Stability::NotComputed,
            [_, u, _] if u > 0 => Stability::Unstable,
            [_, 0, d] if d > 0 => Stability::Undetermined,
            _ => Stability::Stable,
        }
    }

    /// The verdict with its counts and the jumps, e.g. "unstable in part (in contact: 40
    /// stable, 35 unstable, 60 undetermined points; jumps at the folds 7979, 7605 rpm)".
    pub fn stability_text(&self) -> String {
        let [s, u, d] = self.judged_counts();
        let verdict = self.stability_verdict();
        if verdict == Stability::NotComputed {
            return verdict.word().into();
        }
        let within = if self.contact_span().is_some() {
            "in contact: "
        } else {
            ""
        };
        let mut text = format!(
            "{} ({within}{s} stable, {u} unstable, {d} undetermined points",
            verdict.word()
        );
        if !self.folds.is_empty() {
            let at: Vec<String> = (self.folds.iter())
                .map(|f| {
                    let way = match f.kind.as_str() {
                        "turns_back" => " on a run-up",
                        "turns_forward" => " on a run-down",
                        _ => "",
                    };
                    format!("{:.0} rpm{way}", f.speed_rpm)
                })
                .collect();
            text += &format!("; the response jumps at {}", at.join(", "));
        }
        text + ")"
    }

    /// The peak's verdict, "" when not recorded.
    pub fn peak_verdict(&self) -> &str {
        self.peak_stability.as_deref().unwrap_or("")
    }
}

/// A crossing of an engine-order line with a Campbell curve (the Campbell stage's).
#[derive(Debug, Clone, Copy)]
pub struct CrossingRef {
    pub engine_order: i64,
    /// 1-based curve of the diagram.
    pub mode: usize,
    pub speed_rpm: f64,
}

/// The forced verdict of one crossing: the sweeps through it (empty: not swept).
#[derive(Debug, Clone)]
pub struct CrossingVerdict {
    pub crossing: CrossingRef,
    pub sweeps: Vec<SweepRecord>,
}

/// `speed_sweep.json` in `dir`, `None` when absent.
pub fn read(dir: &Path) -> Result<Option<SpeedSweepFile>> {
    let path = dir.join("speed_sweep.json");
    if !path.exists() {
        return Ok(None);
    }
    super::read_json(&path).map(Some)
}

/// `dir/casing.json` (`[speed_sweep.casing]`, written by `crate::speed_sweep::forced_speed_casing` as its
/// `CasingSummary`), when written.
pub fn read_casing<T: for<'de> Deserialize<'de>>(dir: &Path) -> Result<Option<T>> {
    let path = dir.join("casing.json");
    if !path.exists() {
        return Ok(None);
    }
    super::read_json(&path).map(Some)
}

/// The verdict of every crossing of curve `traced + 1` (the swept mode) among `crossings`, in
/// increasing speed, each with the sweeps of `file` through it; a sweep matching none of them
/// (its crossing computed on the parametric model, outside the drawn crossings) gets a row of
/// its own.
pub fn verdicts(
    file: Option<&SpeedSweepFile>,
    crossings: &[CrossingRef],
    traced: usize,
) -> Vec<CrossingVerdict> {
    let mut rows: Vec<CrossingVerdict> = (crossings.iter())
        .filter(|c| c.mode == traced + 1)
        .map(|&crossing| CrossingVerdict {
            crossing,
            sweeps: Vec::new(),
        })
        .collect();
    for s in file.map_or(&[][..], |f| &f.sweeps) {
        let near = |c: &CrossingRef| {
            c.engine_order == s.engine_order as i64
                && (c.speed_rpm - s.crossing_rpm).abs() < SAME_CROSSING * s.crossing_rpm
        };
        match rows.iter_mut().find(|r| near(&r.crossing)) {
            Some(row) => row.sweeps.push(s.clone()),
            None => rows.push(CrossingVerdict {
                crossing: CrossingRef {
                    engine_order: s.engine_order as i64,
                    mode: traced + 1,
                    speed_rpm: s.crossing_rpm,
                },
                sweeps: vec![s.clone()],
            }),
        }
    }
    rows.sort_by(|a, b| a.crossing.speed_rpm.total_cmp(&b.crossing.speed_rpm));
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep(eo: usize, rpm: f64, counts: [usize; 3], contact: Option<[usize; 3]>) -> SweepRecord {
        SweepRecord {
            engine_order: eo,
            level: 2.0,
            force: 0.5,
            crossing_rpm: rpm,
            range_rpm: [0.9 * rpm, 1.2 * rpm],
            peak_rpm: rpm,
            peak_q1_over_g0: 3.0,
            folds: Vec::new(),
            contact_rpm: if contact.is_some() {
                vec![[rpm, 1.01 * rpm], [1.02 * rpm, 0.99 * rpm]]
            } else {
                Vec::new()
            },
            contact_span_rpm: None,
            max_contact_force_n: 1.0,
            max_contact_force_rpm: None,
            stability: counts,
            contact_stability: contact,
            peak_stability: None,
            complete: true,
            end: "complete".into(),
            harmonics_note: None,
            retraces: Vec::new(),
        }
    }

    /// Each sweep lands on the crossing of its engine order near its speed; the other
    /// crossings of the traced curve stay without sweeps; other curves' crossings are left out;
    /// a sweep without a drawn crossing gets its own row.
    #[test]
    fn sweeps_join_their_crossings() {
        let c = |eo, mode, rpm| CrossingRef {
            engine_order: eo,
            mode,
            speed_rpm: rpm,
        };
        let crossings = [c(3, 1, 7525.0), c(4, 1, 5900.0), c(3, 2, 9000.0)];
        let file = SpeedSweepFile {
            mode: 0,
            harmonics: 10,
            sweeps: vec![
                sweep(3, 7524.9, [1, 0, 0], None),
                sweep(6, 3000.0, [1, 0, 0], None),
            ],
        };
        let rows = verdicts(Some(&file), &crossings, 0);
        let got: Vec<(i64, usize)> = rows
            .iter()
            .map(|r| (r.crossing.engine_order, r.sweeps.len()))
            .collect();
        assert_eq!(got, vec![(6, 1), (4, 0), (3, 1)]);
        assert!(verdicts(None, &crossings, 0)
            .iter()
            .all(|r| r.sweeps.is_empty()));
    }

    /// The verdict reads the points in contact when the sweep touches, and its span covers
    /// every edge (a stretch passing a fold ends below its largest speed).
    #[test]
    fn verdict_and_span() {
        let out = sweep(3, 1000.0, [5, 2, 0], None);
        assert_eq!(out.stability_verdict(), Stability::Unstable);
        assert_eq!(out.contact_span(), None);
        let touch = sweep(3, 1000.0, [5, 2, 0], Some([3, 0, 1]));
        assert_eq!(touch.stability_verdict(), Stability::Undetermined);
        assert_eq!(touch.contact_span(), Some([990.0, 1020.0]));
        assert!(touch.stability_text().contains("in contact: 3 stable"));
        assert_eq!(
            sweep(3, 1000.0, [4, 0, 0], None).stability_verdict(),
            Stability::Stable
        );
        assert_eq!(
            sweep(3, 1000.0, [0, 0, 0], None).stability_verdict(),
            Stability::NotComputed
        );
    }
}
