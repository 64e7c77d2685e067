//! The casing distortion in the speed sweeps (issue 39, item 3; docs/DESIGN.md §10.11): an
//! n-lobed casing whose gap is g0_j(Omega) - delta cos(n Omega t + phase) beside the load at
//! e Omega, so that the orbit's fundamental is gcd(e, n) Omega (`nlmodes_forced::LobedCasing`).
//! Alone (no level above 0), the sweeps run through the crossing of the lobes' line n Omega.

use anyhow::Result;
use nlmodes_forced::LobedCasing;
use nlmodes_nnm::System;
use serde::Serialize;

use crate::exit::bad_input;
use crate::forced::forced_settings::ForcedSection;
use crate::problems::Problems;
use crate::speed_sweep::speed_sweep_settings::SpeedSweepSection;

/// The levels of the sweeps: `[speed_sweep] levels`, or `[forced]`'s (none: the distortion
/// alone, level 0).
pub fn levels(forced: &ForcedSection, sweep: &SpeedSweepSection) -> Vec<f64> {
    if sweep.levels.is_empty() {
        forced.curve_levels()
    } else {
        sweep.levels.clone()
    }
}

/// The casing's lobes when it alone excites the sweeps (a distortion that moves the gap, no
/// level above 0).
pub fn alone(forced: &ForcedSection, sweep: &SpeedSweepSection) -> Option<usize> {
    let d = forced.distortion.as_ref().filter(|d| d.excites())?;
    let loaded = levels(forced, sweep).iter().any(|&l| l > 0.0);
    (!loaded).then_some(d.lobes.max(1) as usize)
}

/// What the sweeps need of `[forced.distortion]`, from the keys: the harmonic left at 1 (the
/// sweeps place the gap's harmonic themselves), zero levels only with a distortion that moves
/// the gap, and with the distortion alone no engine order other than the lobes.
pub fn check(forced: &ForcedSection, sweep: &SpeedSweepSection, p: &mut Problems) {
    let distorted = forced.distortion.as_ref().filter(|d| d.excites());
    if let Some(d) = &forced.distortion {
        p.check(
            d.harmonic == 1,
            "forced.distortion.harmonic",
            d.harmonic,
            "1 with [speed_sweep] (a speed sweep places the gap at harmonic n / gcd(e, n) of \
             its fundamental gcd(e, n) Omega itself)",
        );
    }
    if distorted.is_none() {
        for l in sweep.levels.iter().filter(|&&l| l == 0.0) {
            p.check(
                false,
                "speed_sweep.levels",
                l,
                "levels > 0 (0 only with a [forced.distortion] amplitude > 0: the casing alone)",
            );
        }
    }
    if let (Some(n), false) = (alone(forced, sweep), sweep.engine_orders.is_empty()) {
        p.check(
            sweep.engine_orders == [n as i64],
            "speed_sweep.engine_orders",
            &sweep.engine_orders,
            &format!(
                "[] or [{n}] with the casing distortion alone (no level above 0): it excites \
                 the blade at the lobes' order, forced.distortion.lobes = {n}"
            ),
        );
    }
}

/// The casing of the sweep at engine order `e` (None without a distortion that moves the
/// gap), its amplitude in metres from the mean running gap `g0` at the crossing's speed when
/// given in gaps; checked against the basis (the load's harmonics e h / gcd(e, n) and the
/// gap's n / gcd(e, n) at most `[forced] harmonics`) and, for the distortion alone, against
/// the running gaps at the crossing (`system`): a casing that never reaches the blade there
/// leaves it at rest. Bad input names `source`.
pub fn casing(
    forced: &ForcedSection,
    e: usize,
    (system, alone): (&System, bool),
    source: &str,
) -> Result<Option<LobedCasing>> {
    let Some(d) = forced.distortion.as_ref().filter(|d| d.excites()) else {
        return Ok(None);
    };
    let lobes = d.lobes.max(1) as usize;
    let casing = LobedCasing {
        lobes,
        amplitude: d.amplitude_m(system.gap_reference()),
        phase: d.phase,
    };
    let k = casing.fundamental_order(e);
    let load = crate::forced::forced_settings::file_load_harmonics(forced);
    let highest = (lobes / k).max(load.iter().copied().max().unwrap_or(1) * e / k);
    if highest > forced.harmonics {
        return Err(bad_input(format!(
            "{source}: forced.harmonics = {}: expected at least {highest} for the sweep at \
             engine order {e} with forced.distortion.lobes = {lobes}: the orbit's fundamental \
             is gcd = {k} x speed, the load at its harmonic {} and the gap at {}",
            forced.harmonics,
            e / k,
            lobes / k
        )));
    }
    let smallest = system.gaps().iter().copied().fold(f64::INFINITY, f64::min);
    if alone && casing.amplitude <= smallest {
        return Err(bad_input(format!(
            "{source}: forced.distortion.amplitude = {} ({:e} m) with no load: expected more \
             than the smallest running gap at the crossing's speed, {smallest:e} m: a casing \
             that never reaches the blade leaves it at rest",
            d.amplitude, casing.amplitude
        )));
    }
    Ok(Some(casing))
}

/// What `speed_sweep.json` says of a sweep's casing.
#[derive(Debug, Clone, Serialize)]
pub struct SweepCasing {
    pub lobes: usize,
    /// delta (m) and over the mean running gap at the crossing's speed.
    pub amplitude_m: f64,
    pub amplitude_over_g0: f64,
    pub phase_rad: f64,
    /// k of the orbit's fundamental k Omega = gcd(e, n) Omega, and the harmonics of it at which
    /// the load (e / k) and the gap (n / k) act.
    pub fundamental_order: usize,
    pub load_harmonic: usize,
    pub gap_harmonic: usize,
}

impl SweepCasing {
    /// The record of `casing` on a sweep at engine order `e` whose crossing's mean running gap
    /// is `g0` (m).
    pub fn of(casing: &LobedCasing, e: usize, g0: f64) -> Self {
        let k = casing.fundamental_order(e);
        Self {
            lobes: casing.lobes,
            amplitude_m: casing.amplitude,
            amplitude_over_g0: casing.amplitude / g0,
            phase_rad: casing.phase,
            fundamental_order: k,
            load_harmonic: e / k,
            gap_harmonic: casing.lobes / k,
        }
    }

    /// The words for a figure's legend or a report's line.
    pub fn label(&self) -> String {
        format!(
            "casing {} lobes, delta {:.3e} m ({:.3} g0)",
            self.lobes, self.amplitude_m, self.amplitude_over_g0
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::forced::forced_distortion::{AmplitudeUnit, DistortionSection};

    fn problems(forced: &ForcedSection, sweep: &SpeedSweepSection) -> String {
        let mut p = Problems::new(|k| format!("case.toml: {k}"));
        check(forced, sweep, &mut p);
        p.finish().err().map(|e| e.to_string()).unwrap_or_default()
    }

    fn distorted(levels: Vec<f64>, harmonic: i64) -> ForcedSection {
        ForcedSection {
            levels,
            distortion: Some(DistortionSection {
                lobes: 4,
                amplitude: 1.2,
                amplitude_unit: AmplitudeUnit::Gap,
                harmonic,
                ..DistortionSection::default()
            }),
            ..ForcedSection::default()
        }
    }

    /// A harmonic other than 1, another engine order than the lobes with the casing alone, a
    /// zero level without a distortion: each named with the key and the value.
    #[test]
    fn what_the_sweeps_need_of_the_distortion_is_named() {
        let sweep = SpeedSweepSection::default();
        assert_eq!(problems(&distorted(vec![], 1), &sweep), "");
        assert_eq!(alone(&distorted(vec![], 1), &sweep), Some(4));
        assert_eq!(alone(&distorted(vec![0.0, 2.0], 1), &sweep), None);
        let text = problems(&distorted(vec![], 2), &sweep);
        assert!(
            text.contains(
                "case.toml: forced.distortion.harmonic = 2: expected 1 with [speed_sweep]"
            ),
            "{text}"
        );
        let three = SpeedSweepSection {
            engine_orders: vec![3],
            ..SpeedSweepSection::default()
        };
        let text = problems(&distorted(vec![], 1), &three);
        assert!(
            text.contains("case.toml: speed_sweep.engine_orders = [3]: expected [] or [4]"),
            "{text}"
        );
        assert_eq!(problems(&distorted(vec![1.0], 1), &three), "");
        let zero = SpeedSweepSection {
            levels: vec![0.0, 1.0],
            ..SpeedSweepSection::default()
        };
        let text = problems(&ForcedSection::default(), &zero);
        assert!(
            text.contains("case.toml: speed_sweep.levels = 0.0: expected levels > 0"),
            "{text}"
        );
    }

    /// The casing alone through the binary's path on the rotating TET10 beam of
    /// `campbell_parametric` (gap 1 mm on its tip face, `forced_speed`'s beam test): 4 lobes
    /// intruding 1.2 x the running gap, no load, so the sweep runs at the lobes' order 4 through
    /// its crossing (fundamental 4 Omega, the gap at its first harmonic); every point touches,
    /// the sweep covers its window, and `speed_sweep.csv` states delta in metres. Too few
    /// harmonics for EO 6 with 4 lobes (fundamental 2 Omega: the load at its harmonic 3) are
    /// bad input naming `forced.harmonics`, before any sweep runs.
    #[test]
    fn the_casing_alone_sweeps_the_beam_through_the_lobes_crossing() {
        let model = crate::campbell::campbell_parametric::tests::beam_model(false);
        let forced = ForcedSection {
            damping_ratio: 0.01,
            harmonics: 3,
            stability: false,
            ..distorted(vec![], 1)
        };
        // N = 3 kept, unchecked: this test is about the casing's path, and a
        // retrace to N = 6 and 12 quadruples its time.
        let sweep = SpeedSweepSection {
            window: [0.97, 1.03],
            adapt_harmonics: crate::speed_sweep::speed_sweep_settings::SweepHarmonics::Fixed,
            ..SpeedSweepSection::default()
        };
        let n = alone(&forced, &sweep);
        let (plans, closure) =
            crate::speed_sweep::forced_speed::plan(&model, 0, &sweep, (&[1, 2, 3], n), "test")
                .unwrap();
        assert_eq!(plans.len(), 1);
        assert_eq!(plans[0].engine_order, 4);
        let inputs = crate::speed_sweep::forced_speed::SweepInputs {
            model: &model,
            forced: &forced,
            sweep: &sweep,
            damping_matrix: None,
            file_load: None,
            source: "test",
        };
        let study = crate::speed_sweep::forced_speed::run(&inputs, &plans, closure).unwrap();
        let run = &study.runs[0];
        let casing = run.casing.as_ref().expect("the casing");
        assert_eq!((casing.fundamental_order, casing.gap_harmonic), (4, 1));
        assert!((casing.amplitude_over_g0 - 1.2).abs() < 1e-12);
        assert!(run.sweep.termination.covers_range());
        assert!(run.sweep.points.iter().all(|p| p.point.touches()));
        let table = crate::speed_sweep::forced_speed_output::csv(&study).unwrap();
        let column = table.header().iter().position(|h| h == "distortion_m");
        let delta = nlmodes_output::CsvValue::Num(casing.amplitude_m);
        assert!(table.rows().iter().all(|r| r[column.unwrap()] == delta));
        println!(
            "beam, 4 lobes alone: {} points, peak q/g0 {:.4}",
            run.sweep.points.len(),
            crate::speed_sweep::forced_speed_output::summarize(&study, run).peak_q1_over_g0
        );
        let loaded = ForcedSection {
            levels: vec![0.3],
            harmonics: 2,
            ..forced.clone()
        };
        let six = SpeedSweepSection {
            engine_orders: vec![6],
            ..sweep.clone()
        };
        let (plans, closure) =
            crate::speed_sweep::forced_speed::plan(&model, 0, &six, (&[6], None), "test").unwrap();
        let inputs = crate::speed_sweep::forced_speed::SweepInputs {
            forced: &loaded,
            sweep: &six,
            ..inputs
        };
        let e = crate::speed_sweep::forced_speed::run(&inputs, &plans, closure)
            .err()
            .unwrap();
        assert!(
            format!("{e:#}").contains("test: forced.harmonics = 2: expected at least 3"),
            "{e:#}"
        );
    }

    #[test]
    fn the_fundamental_is_the_common_divisor() {
        let c = LobedCasing {
            lobes: 2,
            amplitude: 1e-5,
            phase: 0.0,
        };
        let r = SweepCasing::of(&c, 3, 1e-4);
        assert_eq!(
            (r.fundamental_order, r.load_harmonic, r.gap_harmonic),
            (1, 3, 2)
        );
        let r = SweepCasing::of(&c, 4, 1e-4);
        assert_eq!(
            (r.fundamental_order, r.load_harmonic, r.gap_harmonic),
            (2, 2, 1)
        );
        assert!((r.amplitude_over_g0 - 0.1).abs() < 1e-15);
    }
}
