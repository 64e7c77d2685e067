//! The gathered table of a study (`nlmodes study-gather STUDY_DIR`, the workflow's last job;
//! docs/STUDIES.md): one row per run, its parameter values, its status, then the headline
//! results read from the files its jobs wrote (the same files `nlmodes run` writes):
//!
//! * `f1_hz`: the first linear frequency of the reduced model (`model/model.json`);
//! * the backbone at rest (per traced mode, `mode<k>_` before the names when several): the
//!   grazing amplitude `grazing_q_over_g0` and the reach, the point of largest q/g0 of the
//!   linear and main branches (`backbone/backbone.csv`): `backbone_reach_q_over_g0`,
//!   `backbone_reach_omega_ratio` (w/w1), `backbone_reach_frequency_hz`;
//! * with `[rotation]`: `f1_at_speed_hz` and the reach of the backbone at the operating speed;
//! * with `[forced]`, per level L: the peak, the row of largest `q1_over_g0` of that level in
//!   `forced/frf.csv` (the report's peak): `peak_q1_over_g0_level_L`, `peak_omega_ratio_level_L`
//!   (W/w_mode), `peak_frequency_hz_level_L`.
//!
//! A run whose jobs did not all complete keeps what they wrote, with its status saying which
//! job stopped or failed, or did not run.

use anyhow::Result;
use nlmodes_output::{CsvTable, CsvValue};
use std::collections::BTreeMap;
use std::path::Path;

use crate::study::study_job::JobStatus;
use crate::study::study_plan::{job_id, Job, JobKind, Plan, PlanRun};

/// One run's row.
#[derive(Debug, Clone)]
pub struct Row {
    pub run: String,
    /// One cell per parameter.
    pub values: Vec<CsvValue>,
    pub status: String,
    /// Headline results by column name.
    pub results: BTreeMap<String, f64>,
}

/// The gathered runs and the column order of their results.
#[derive(Debug, Clone)]
pub struct Gathered {
    pub parameters: Vec<String>,
    pub columns: Vec<String>,
    pub rows: Vec<Row>,
    /// The forced levels met, ascending.
    pub levels: Vec<f64>,
}

/// The name of the column `what` of forced level `level`.
pub fn level_column(what: &str, level: f64) -> String {
    format!("{what}_level_{level}")
}

/// Reads every run's results from its jobs' folders.
pub fn gather(dir: &Path, plan: &Plan) -> Result<Gathered> {
    let mut rows = Vec::new();
    let mut levels: Vec<f64> = Vec::new();
    for run in &plan.runs {
        let mut results = BTreeMap::new();
        let run_levels = read_run(dir, plan, run, &mut results)?;
        levels.extend(run_levels);
        rows.push(Row {
            run: run.id.clone(),
            values: run.values.iter().map(cell).collect(),
            status: status(dir, plan, run),
            results,
        });
    }
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let columns = column_order(&rows, &levels);
    Ok(Gathered {
        parameters: plan.parameters.clone(),
        columns,
        rows,
        levels,
    })
}

/// The headline results of one run into `out`; returns its forced levels.
fn read_run(
    dir: &Path,
    plan: &Plan,
    run: &PlanRun,
    out: &mut BTreeMap<String, f64>,
) -> Result<Vec<f64>> {
    let jobs: Vec<(&String, &Job)> = run
        .jobs
        .iter()
        .map(|id| plan.job(id).map(|j| (id, j)))
        .collect::<Result<_>>()?;
    let of_kind = |k: JobKind| jobs.iter().filter(move |(_, j)| j.kind == k);
    let mut levels = Vec::new();
    for (id, job) in of_kind(JobKind::Reduce) {
        insert(
            out,
            "f1_hz",
            first_frequency(&dir.join(&job.dir).join("model")),
        );
        let backbones: Vec<&Job> = of_kind(JobKind::Backbone)
            .filter(|(_, b)| b.needs.first() == Some(*id))
            .map(|(_, b)| *b)
            .collect();
        for b in &backbones {
            let prefix = match (backbones.len(), b.place.strip_prefix("mode_")) {
                (1, _) | (_, None) => String::new(),
                (_, Some(k)) => format!("mode{k}_"),
            };
            reach(
                &dir.join(&b.dir).join(&b.place).join("backbone"),
                &prefix,
                out,
            );
        }
    }
    for (id, job) in of_kind(JobKind::Speed).filter(|(_, j)| j.place == "speed") {
        let speed = dir.join(&job.dir).join("speed");
        insert(out, "f1_at_speed_hz", first_frequency(&speed.join("model")));
        for (_, b) in of_kind(JobKind::Backbone).filter(|(_, b)| b.needs.first() == Some(*id)) {
            reach(
                &dir.join(&b.dir).join(&b.place).join("backbone"),
                "speed_",
                out,
            );
        }
    }
    for (_, job) in of_kind(JobKind::Forced) {
        for p in forced_peaks(&dir.join(&job.dir).join("forced").join("frf.csv")) {
            insert(
                out,
                &level_column("peak_q1_over_g0", p.level),
                Some(p.q1_over_g0),
            );
            insert(
                out,
                &level_column("peak_omega_ratio", p.level),
                Some(p.omega_ratio),
            );
            insert(
                out,
                &level_column("peak_frequency_hz", p.level),
                Some(p.frequency_hz),
            );
            levels.push(p.level);
        }
    }
    Ok(levels)
}

fn insert(out: &mut BTreeMap<String, f64>, name: &str, v: Option<f64>) {
    if let Some(v) = v.filter(|v| v.is_finite()) {
        out.insert(name.to_string(), v);
    }
}

/// The columns present in some row, in the documented order.
fn column_order(rows: &[Row], levels: &[f64]) -> Vec<String> {
    let reach = ["reach_q_over_g0", "reach_omega_ratio", "reach_frequency_hz"];
    let mut wanted = vec!["f1_hz".to_string()];
    let mut modes: Vec<String> = vec![String::new()];
    let present = |c: &str| rows.iter().any(|r| r.results.contains_key(c));
    modes.extend(
        (1..=64)
            .map(|k| format!("mode{k}_"))
            .filter(|p| present(&format!("{p}grazing_q_over_g0"))),
    );
    for p in &modes {
        wanted.push(format!("{p}grazing_q_over_g0"));
        wanted.extend(reach.iter().map(|r| format!("{p}backbone_{r}")));
    }
    wanted.push("f1_at_speed_hz".into());
    wanted.push("speed_grazing_q_over_g0".into());
    wanted.extend(reach.iter().map(|r| format!("speed_backbone_{r}")));
    for &l in levels {
        for what in ["peak_q1_over_g0", "peak_omega_ratio", "peak_frequency_hz"] {
            wanted.push(level_column(what, l));
        }
    }
    wanted.into_iter().filter(|c| present(c)).collect()
}

/// A parameter value as a cell: a number, a one-number list as that number, else its TOML text.
pub fn cell(v: &serde_json::Value) -> CsvValue {
    match v {
        serde_json::Value::Number(n) => n
            .as_f64()
            .map_or_else(|| CsvValue::Text(n.to_string()), CsvValue::Num),
        serde_json::Value::Array(a) if a.len() == 1 && a[0].is_number() => cell(&a[0]),
        serde_json::Value::String(s) => CsvValue::Text(s.clone()),
        other => CsvValue::Text(other.to_string()),
    }
}

/// `complete` when every job of the run (its own included) completed; else the first job that
/// did not, and how (`forced stopped_early`, `backbone failed`, `reduce not run`).
fn status(dir: &Path, plan: &Plan, run: &PlanRun) -> String {
    let own = job_id(JobKind::Run, &run.id);
    for id in run.jobs.iter().chain(std::iter::once(&own)) {
        let kind = plan.jobs.get(id).map_or("job", |j| j.kind.name());
        match JobStatus::read(dir, id) {
            Some(s) if s.status == "complete" => {}
            Some(s) => return format!("{kind} {}", s.status),
            None => return format!("{kind} not run"),
        }
    }
    "complete".into()
}

/// The first linear frequency (Hz) of the reduced model in `model`.
fn first_frequency(model: &Path) -> Option<f64> {
    let v: serde_json::Value = crate::post::results::read_json(&model.join("model.json")).ok()?;
    v["linear_frequencies_hz"][0].as_f64()
}

/// The grazing amplitude and the reach of the backbone in `dir`.
fn reach(dir: &Path, prefix: &str, out: &mut BTreeMap<String, f64>) {
    if let Ok(v) = crate::post::results::read_json::<serde_json::Value>(&dir.join("backbone.json"))
    {
        let graze = v["grazing_amplitude"]
            .as_f64()
            .zip(v["gap_reference"].as_f64());
        insert(
            out,
            &format!("{prefix}grazing_q_over_g0"),
            graze.map(|(a, g)| a / g),
        );
    }
    let Some(csv) = Csv::read(&dir.join("backbone.csv")) else {
        return;
    };
    let (kind, q) = (csv.column("branch_kind"), csv.column("q_over_g0"));
    let top = csv
        .rows
        .iter()
        .filter(|r| matches!(text(r, kind), Some("linear" | "main")) && num(r, q).is_finite())
        .max_by(|a, b| num(a, q).total_cmp(&num(b, q)));
    if let Some(top) = top {
        for (name, col) in [
            ("q_over_g0", q),
            ("omega_ratio", csv.column("omega_ratio")),
            ("frequency_hz", csv.column("frequency_hz")),
        ] {
            insert(
                out,
                &format!("{prefix}backbone_reach_{name}"),
                Some(num(top, col)),
            );
        }
    }
}

/// A forced level's peak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    pub level: f64,
    pub q1_over_g0: f64,
    pub omega_ratio: f64,
    pub frequency_hz: f64,
}

/// Each level's row of largest `q1_over_g0` in `frf.csv` (levels in the file's order).
pub fn forced_peaks(frf: &Path) -> Vec<Peak> {
    let Some(csv) = Csv::read(frf) else {
        return Vec::new();
    };
    let cols = ["level", "q1_over_g0", "omega_ratio", "frequency_hz"].map(|c| csv.column(c));
    let mut peaks: Vec<Peak> = Vec::new();
    for r in &csv.rows {
        let [level, q1_over_g0, omega_ratio, frequency_hz] = cols.map(|c| num(r, c));
        let p = Peak {
            level,
            q1_over_g0,
            omega_ratio,
            frequency_hz,
        };
        match peaks.iter_mut().find(|q| q.level == p.level) {
            Some(q) if p.q1_over_g0 > q.q1_over_g0 => *q = p,
            Some(_) => {}
            None if p.q1_over_g0.is_finite() => peaks.push(p),
            None => {}
        }
    }
    peaks
}

/// A CSV file written by nlmodes (no quoted commas in the columns read here).
struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    fn read(path: &Path) -> Option<Self> {
        let text = std::fs::read_to_string(path).ok()?;
        let mut lines = text.lines();
        let split = |l: &str| l.split(',').map(str::to_string).collect::<Vec<_>>();
        let header = split(lines.next()?);
        Some(Self {
            header,
            rows: lines.map(split).collect(),
        })
    }

    fn column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }
}

fn text(row: &[String], col: Option<usize>) -> Option<&str> {
    col.and_then(|i| row.get(i)).map(String::as_str)
}

/// The number in a row's column; NaN when absent or empty (left out by `insert`).
fn num(row: &[String], col: Option<usize>) -> f64 {
    text(row, col)
        .and_then(|t| t.parse().ok())
        .unwrap_or(f64::NAN)
}

/// `study.csv`: run, the parameters, status, the results.
pub fn table(g: &Gathered) -> Result<CsvTable> {
    let mut header = vec!["run".to_string()];
    header.extend(g.parameters.iter().cloned());
    header.push("status".into());
    header.extend(g.columns.iter().cloned());
    let mut t = CsvTable::new(&header);
    for r in &g.rows {
        let mut row = vec![CsvValue::Text(r.run.clone())];
        row.extend(r.values.iter().cloned());
        row.push(CsvValue::Text(r.status.clone()));
        row.extend(g.columns.iter().map(|c| {
            r.results
                .get(c)
                .map_or_else(|| CsvValue::Text(String::new()), |&v| CsvValue::Num(v))
        }));
        t.push_row(row)?;
    }
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each level's peak is its row of largest q1/g0, whatever the order of the rows.
    #[test]
    fn peaks_are_each_levels_largest_first_harmonic() {
        let tmp = tempfile::tempdir().unwrap();
        let frf = tmp.path().join("frf.csv");
        std::fs::write(
            &frf,
            "level,force_N,point,omega_rad_s,frequency_hz,omega_ratio,q1_over_g0\n\
             0.5,1,0,10,1.5,0.9,1.0\n0.5,1,1,11,1.6,1.0,3.0\n0.5,1,2,12,1.7,1.1,2.0\n\
             2,4,0,10,1.5,0.9,2.5\n2,4,1,12,1.8,1.2,9.5\n",
        )
        .unwrap();
        let p = forced_peaks(&frf);
        assert_eq!(p.len(), 2);
        assert_eq!(
            (
                p[0].level,
                p[0].q1_over_g0,
                p[0].omega_ratio,
                p[0].frequency_hz
            ),
            (0.5, 3.0, 1.0, 1.6)
        );
        assert_eq!(
            (p[1].level, p[1].q1_over_g0, p[1].omega_ratio),
            (2.0, 9.5, 1.2)
        );
        assert!(forced_peaks(&tmp.path().join("absent.csv")).is_empty());
    }

    #[test]
    fn parameter_cells_are_numbers_where_they_can_be() {
        let v = |s: &str| serde_json::from_str::<serde_json::Value>(s).unwrap();
        assert_eq!(cell(&v("0.003")), CsvValue::Num(0.003));
        assert_eq!(cell(&v("[2.0]")), CsvValue::Num(2.0));
        assert_eq!(cell(&v("\"exact\"")), CsvValue::Text("exact".into()));
        assert_eq!(cell(&v("[0.5,2.0]")), CsvValue::Text("[0.5,2.0]".into()));
    }
}
