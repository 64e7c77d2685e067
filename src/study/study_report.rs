//! What a study's last job writes (docs/STUDIES.md): `study.csv` (`crate::study::study_gather`), one
//! figure per numeric parameter (`figures/peak_vs_<key>`: the forced peak q1/g0 of each level
//! against it, one line per value of the other parameters; `backbone_reach_vs_<key>`: the
//! backbone's reach w/w1 when there is no forced stage), and
//! `report.md`: the parameters, how many jobs each stage took and how many runs they served,
//! the table, the figures, the runs that did not complete.

use anyhow::Result;
use nlmodes_output::plot::{LinePlot, Series};
use nlmodes_output::CsvValue;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use crate::study::study_gather::{cell, gather, level_column, table, Gathered, Row};
use crate::study::study_job::JobStatus;
use crate::study::study_plan::{job_counts, JobKind, Plan};

/// Rows of the table shown in the report (all are in study.csv).
const REPORT_ROWS: usize = 100;
/// The case key of the forced levels.
const LEVELS: &str = "forced.levels";
/// Lines of a figure that get a legend entry (more are drawn without).
const LEGEND_LINES: usize = 12;

/// `nlmodes study-gather DIR`: study.csv, the figures and report.md from what the jobs wrote.
pub fn write_gathered(dir: &Path) -> Result<Gathered> {
    let plan = Plan::read(dir)?;
    let g = gather(dir, &plan)?;
    table(&g)?.write(&dir.join("study.csv"))?;
    let figures = figures(dir, &plan, &g)?;
    crate::post::output::write_atomic(
        &dir.join("report.md"),
        report(dir, &plan, &g, &figures).as_bytes(),
    )?;
    let complete = g.rows.iter().filter(|r| r.status == "complete").count();
    crate::ui::say(&format!(
        "study {}: {complete} of {} runs complete; table {}, report {}",
        plan.study,
        g.rows.len(),
        dir.join("study.csv").display(),
        dir.join("report.md").display()
    ));
    Ok(g)
}

/// The plotted quantity: (column of a row, line label) for each line family, the axis label
/// and the figures' file prefix.
fn quantities(g: &Gathered) -> (Vec<(String, String)>, &'static str, &'static str) {
    if !g.levels.is_empty() {
        let q = g
            .levels
            .iter()
            .map(|&l| (level_column("peak_q1_over_g0", l), format!("level {l}")))
            .collect();
        return (q, "peak q1 / g0 (forced response)", "peak");
    }
    let q = vec![("backbone_reach_omega_ratio".to_string(), String::new())];
    (q, "w / w1 at the backbone's reach", "backbone_reach")
}

/// One figure per parameter with at least two numeric values; returns the files' names.
fn figures(dir: &Path, plan: &Plan, g: &Gathered) -> Result<Vec<(String, String)>> {
    let (quantities, y_label, prefix) = quantities(g);
    let mut written = Vec::new();
    for (k, key) in plan.parameters.iter().enumerate() {
        let numeric = |r: &Row| match r.values[k] {
            CsvValue::Num(x) => Some(x),
            _ => None,
        };
        let mut xs: Vec<f64> = g.rows.iter().filter_map(numeric).collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        if xs.len() < 2 || g.rows.iter().any(|r| numeric(r).is_none()) {
            continue;
        }
        let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        // Against the levels themselves, one line joins the levels of the runs.
        let by_level = key == LEVELS;
        for r in &g.rows {
            for (column, level) in &quantities {
                if let (Some(x), Some(&y)) = (numeric(r), r.results.get(column)) {
                    let level = if by_level { "" } else { level.as_str() };
                    lines
                        .entry(line_label(plan, r, k, level))
                        .or_default()
                        .push((x, y));
                }
            }
        }
        if lines.is_empty() {
            continue;
        }
        let mut plot = LinePlot::new(format!("{y_label} against {key}"), key.clone(), y_label);
        let legend = lines.len() <= LEGEND_LINES;
        for (label, mut points) in lines {
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (x, y): (Vec<f64>, Vec<f64>) = points.into_iter().unzip();
            let label = if legend { label } else { String::new() };
            plot = plot.with_series(Series::new(label, x, y).markers(true));
        }
        let name = format!("figures/{prefix}_vs_{}", file_part(key));
        std::fs::create_dir_all(dir.join("figures"))?;
        plot.write_svg_and_png(&dir.join(&name))?;
        written.push((key.clone(), format!("{name}.png")));
    }
    Ok(written)
}

/// A line's label: the level, and the values of the other parameters.
fn line_label(plan: &Plan, r: &Row, skip: usize, level: &str) -> String {
    let mut parts: Vec<String> = Vec::new();
    if !level.is_empty() {
        parts.push(level.to_string());
    }
    // The forced levels are named by the line's level.
    let others = plan
        .parameters
        .iter()
        .enumerate()
        .filter(|(k, key)| *k != skip && *key != LEVELS);
    for (k, key) in others {
        parts.push(format!("{} = {}", short_key(key), cell_text(&r.values[k])));
    }
    parts.join(", ")
}

fn short_key(key: &str) -> &str {
    key.rsplit('.').next().unwrap_or(key)
}

fn cell_text(c: &CsvValue) -> String {
    match c {
        CsvValue::Num(x) => format!("{x}"),
        CsvValue::Int(i) => i.to_string(),
        CsvValue::Text(t) => t.clone(),
    }
}

/// A parameter key as part of a file name.
fn file_part(key: &str) -> String {
    key.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '.' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// report.md.
fn report(dir: &Path, plan: &Plan, g: &Gathered, figures: &[(String, String)]) -> String {
    let complete = g.rows.iter().filter(|r| r.status == "complete").count();
    let mut s = format!(
        "# Study {}\n\nStudy file `{}`: {} runs, every combination of the values below (the \
         first parameter varies slowest); {complete} complete. The workflow is `Snakefile` \
         (Snakemake), each run's results are in `runs/<run>/` as `nlmodes run` lays them out, \
         the table is `study.csv` (docs/STUDIES.md).\n\n| parameter | values |\n|---|---|\n",
        plan.study,
        plan.study_file,
        g.rows.len()
    );
    for (k, key) in plan.parameters.iter().enumerate() {
        let mut values: Vec<String> = Vec::new();
        for v in plan.runs.iter().map(|r| cell_text(&cell(&r.values[k]))) {
            if !values.contains(&v) {
                values.push(v);
            }
        }
        let _ = writeln!(s, "| `{key}` | {} |", values.join(", "));
    }
    s += &jobs_section(dir, plan);
    s += &table_section(g);
    for (key, file) in figures {
        let _ = writeln!(s, "![against {key}]({file})\n");
    }
    s + &incomplete_section(dir, plan, g)
}

/// How many jobs each stage took, the runs they served, their summed wall time and their
/// largest memory (Snakemake's benchmark of each job: `max_rss`, MB).
fn jobs_section(dir: &Path, plan: &Plan) -> String {
    let mut s = String::from(
        "\n## Jobs\n\nRuns whose inputs to a stage are the same share its job.\n\n| stage | jobs \
         | runs served | wall time (s, all its jobs) | largest max_rss (MB) |\n|---|---|---|---|---|\n",
    );
    for (kind, (jobs, served)) in job_counts(plan) {
        let ids = || {
            plan.jobs
                .iter()
                .filter(move |(_, j)| j.kind == kind)
                .map(|(id, _)| id)
        };
        let seconds: f64 = ids()
            .filter_map(|id| JobStatus::read(dir, id))
            .map(|st| st.seconds)
            .sum();
        let rss = ids()
            .filter_map(|id| max_rss(&dir.join("benchmarks").join(format!("{id}.tsv"))))
            .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.max(v))));
        let rss = rss.map_or_else(|| "-".to_string(), |v| format!("{v:.0}"));
        let _ = writeln!(
            s,
            "| {} | {jobs} | {served} | {seconds:.1} | {rss} |",
            kind.name()
        );
    }
    s
}

/// `max_rss` (MB) of a Snakemake benchmark file.
fn max_rss(tsv: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(tsv).ok()?;
    let mut lines = text.lines();
    let column = lines.next()?.split('\t').position(|h| h == "max_rss")?;
    lines.next()?.split('\t').nth(column)?.parse().ok()
}

/// The table's first rows in Markdown.
fn table_section(g: &Gathered) -> String {
    let mut header = vec!["run".to_string()];
    header.extend(g.parameters.iter().map(|p| format!("`{p}`")));
    header.push("status".into());
    header.extend(g.columns.iter().map(|c| format!("`{c}`")));
    let mut s = format!(
        "\n## Results\n\n| {} |\n|{}\n",
        header.join(" | "),
        "---|".repeat(header.len())
    );
    for r in g.rows.iter().take(REPORT_ROWS) {
        let mut cells = vec![r.run.clone()];
        cells.extend(r.values.iter().map(cell_text));
        cells.push(r.status.clone());
        cells.extend(g.columns.iter().map(|c| {
            r.results
                .get(c)
                .map_or(String::new(), |v| format!("{v:.6}"))
        }));
        let _ = writeln!(s, "| {} |", cells.join(" | "));
    }
    if g.rows.len() > REPORT_ROWS {
        let _ = writeln!(
            s,
            "\n{} more rows in `study.csv`.",
            g.rows.len() - REPORT_ROWS
        );
    }
    s.push('\n');
    s
}

/// The runs that did not complete, with the message of the job that stopped them.
fn incomplete_section(dir: &Path, plan: &Plan, g: &Gathered) -> String {
    let failed: Vec<&Row> = g.rows.iter().filter(|r| r.status != "complete").collect();
    if failed.is_empty() {
        return String::new();
    }
    let mut s = String::from("## Runs not complete\n\n");
    for r in failed {
        let run = plan.runs.iter().find(|p| p.id == r.run);
        let jobs = run.map(|p| p.jobs.clone()).unwrap_or_default();
        let own = crate::study::study_plan::job_id(JobKind::Run, &r.run);
        let why = jobs
            .iter()
            .chain(std::iter::once(&own))
            .filter_map(|id| JobStatus::read(dir, id).map(|st| (id, st)))
            .find(|(_, st)| st.status != "complete")
            .map(|(id, st)| {
                format!(
                    "{id}: {} (log `logs/{id}.log`)",
                    st.message.lines().next().unwrap_or("")
                )
            })
            .unwrap_or_else(|| "a job it needs did not run".into());
        let _ = writeln!(s, "- {}: {}: {why}", r.run, r.status);
    }
    s
}
