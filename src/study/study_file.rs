//! The study file of `nlmodes study` (docs/STUDIES.md): a `[study]` table naming the case keys
//! to vary and their values, over a base case: the case file `[study] case` names (relative to
//! the study file), with the study file's own case tables over it; or, without `case`, the study
//! file's case tables alone (a case file with a `[study]` table). The runs are every
//! combination of the values (the first parameter varies slowest).
//!
//! Everything is checked before anything runs or is written: an unknown key, an empty list, a
//! value of the wrong type, and then every run's case by `validate::check_case`; each problem
//! names the file, the key and the value (bad input, exit code 2).

use anyhow::Result;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::case::{merge, Case};
use crate::exit::bad_input;
use crate::validate::Problems;

/// The largest number of runs a study may have (a larger grid is refused as bad input: the
/// workflow's plan and the Snakemake graph grow with it).
pub const MAX_RUNS: usize = 10_000;

/// One varied case key and its values, in the order of the file.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// The dotted case key: `forced.damping_ratio`, `mesh.parameters.mesh_size`, ...
    pub key: String,
    pub values: Vec<toml::Value>,
}

/// One run of the study: its id (`r001`, ...), one value per parameter, its case.
#[derive(Debug, Clone)]
pub struct Run {
    pub id: String,
    pub values: Vec<toml::Value>,
    pub case: Case,
}

/// A study file, read and checked.
#[derive(Debug)]
pub struct Study {
    /// The study file.
    pub path: PathBuf,
    /// Its name (`[study] name`, default the file's stem).
    pub name: String,
    /// Where it writes: `<results_dir of the base case>/<name>`, absolute.
    pub dir: PathBuf,
    /// Each run's post-processing (figures, report), as `nlmodes run` makes them.
    pub post: bool,
    pub parameters: Vec<Parameter>,
    pub runs: Vec<Run>,
}

/// The `[study]` table.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StudyTable {
    /// The base case file, relative to the study file.
    case: Option<PathBuf>,
    name: Option<String>,
    #[serde(default = "yes")]
    post: bool,
    parameters: OrderedTable,
}

fn yes() -> bool {
    true
}

/// The study file's `[study]` (other tables are the case's).
#[derive(Deserialize)]
struct Head {
    study: Option<StudyTable>,
}

/// A TOML table's entries in the order of the file (`toml::Table` sorts them).
struct OrderedTable(Vec<(String, toml::Value)>);

impl<'de> Deserialize<'de> for OrderedTable {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Entries;
        impl<'de> serde::de::Visitor<'de> for Entries {
            type Value = OrderedTable;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table of case keys, each with a list of values")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut m: A,
            ) -> Result<OrderedTable, A::Error> {
                let mut v = Vec::new();
                while let Some(entry) = m.next_entry::<String, toml::Value>()? {
                    v.push(entry);
                }
                Ok(OrderedTable(v))
            }
        }
        d.deserialize_map(Entries)
    }
}

impl Study {
    /// Reads and checks the study file `path`: every problem at once, as bad input.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            bad_input(format!(
                "cannot read the study file {}: {e}",
                path.display()
            ))
        })?;
        let invalid = |e: &dyn std::fmt::Display| {
            bad_input(format!("invalid study file {}: {e}", path.display()))
        };
        let head: Head = toml::from_str(&text).map_err(|e| invalid(&e))?;
        let table = head.study.ok_or_else(|| {
            bad_input(format!(
                "{}: no [study] table: a study names the case keys it varies in \
                 [study.parameters] (docs/STUDIES.md)",
                path.display()
            ))
        })?;
        let mut own: toml::Table = toml::from_str(&text).map_err(|e| invalid(&e))?;
        own.remove("study");
        let base = base_table(path, table.case.as_deref(), own)?;
        let base_case = case_of_table(base.clone()).map_err(|e| {
            bad_input(format!(
                "{}: the case tables of the study file: {e}",
                path.display()
            ))
        })?;
        // Every key present, so that a parameter below a value (not a table) is named.
        let base = full_table(&base_case)?;
        let name = table.name.clone().unwrap_or_else(|| stem(path));
        let dir = absolute(&base_case.results_dir)?.join(&name);
        let mut p = Problems::of_file(path);
        check_name(&name, &mut p);
        let parameters = check_parameters(table.parameters.0, &base, &mut p);
        p.finish()?;
        let runs = runs_of(path, &base, &parameters, &dir)?;
        Ok(Self {
            path: path.to_path_buf(),
            name,
            dir,
            post: table.post,
            parameters,
            runs,
        })
    }
}

/// The base case's table: the file `[study] case` names (checked on its own first, so that its
/// errors name it), with the study file's own case tables `own` merged over it.
fn base_table(study: &Path, case: Option<&Path>, own: toml::Table) -> Result<toml::Table> {
    let Some(case) = case else {
        return Ok(own);
    };
    let case = study.parent().unwrap_or(Path::new("")).join(case);
    Case::load(&case).map_err(|e| e.context(format!("the base case of {}", study.display())))?;
    let text = std::fs::read_to_string(&case)?;
    let base: toml::Table = toml::from_str(&text)
        .map_err(|e| bad_input(format!("invalid TOML file {}: {e}", case.display())))?;
    let mut merged = toml::Value::Table(base);
    merge(&mut merged, toml::Value::Table(own));
    match merged {
        toml::Value::Table(t) => Ok(t),
        _ => unreachable!("a table merged over a table is a table"),
    }
}

/// The case of a table of case keys, over the defaults (as `Case::load` reads a file); the
/// error is serde's message (unknown field, invalid type).
pub fn case_of_table(table: toml::Table) -> Result<Case, String> {
    let mut merged = toml::Value::try_from(Case::default()).map_err(|e| e.to_string())?;
    merge(&mut merged, toml::Value::Table(table));
    merged
        .try_into::<Case>()
        .map_err(|e| e.to_string().trim().to_string())
}

/// A case as the table of all its keys.
fn full_table(case: &Case) -> Result<toml::Table> {
    match toml::Value::try_from(case)? {
        toml::Value::Table(t) => Ok(t),
        _ => anyhow::bail!("a case serializes to a TOML table"),
    }
}

/// Sets the dotted `key` of `table` to `value`, creating the tables on the way.
fn set_key(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().unwrap_or_default();
    let mut t = table;
    for (i, part) in parts.iter().enumerate() {
        let entry = t
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        t = entry.as_table_mut().ok_or_else(|| {
            format!(
                "`{}` is a value of the case, not a table",
                parts[..=i].join(".")
            )
        })?;
    }
    t.insert(last.to_string(), value);
    Ok(())
}

/// The keys the study sets itself (each run's results folder) or that are not case keys.
const RESERVED: [&str; 3] = ["name", "results_dir", "study"];

/// Each parameter's key and values checked against the base case: a dotted case key, a
/// non-empty list of distinct values, each of the key's type. Returns the parameters.
fn check_parameters(
    entries: Vec<(String, toml::Value)>,
    base: &toml::Table,
    p: &mut Problems,
) -> Vec<Parameter> {
    if entries.is_empty() {
        p.note(
            "study.parameters",
            "no parameter: name at least one case key and its values",
        );
    }
    let mut out = Vec::new();
    for (key, value) in entries {
        let label = format!("study.parameters.\"{key}\"");
        let root = key.split('.').next().unwrap_or_default();
        if key.split('.').any(str::is_empty) || RESERVED.contains(&root) {
            p.check(false, &label, &key, "a dotted case key such as \"forced.damping_ratio\" (not name, results_dir or study: the study sets them)");
            continue;
        }
        let values = match value {
            toml::Value::Array(v) if !v.is_empty() => v,
            other => {
                p.check(
                    false,
                    &label,
                    other.to_string(),
                    "a non-empty list of values, one per run",
                );
                continue;
            }
        };
        let mut seen = BTreeMap::new();
        for (i, v) in values.iter().enumerate() {
            let text = v.to_string();
            if let Some(first) = seen.insert(text.clone(), i) {
                p.check(
                    false,
                    &format!("{label}[{i}]"),
                    &text,
                    &format!("a value not given before (it is [{first}])"),
                );
            }
            let mut t = base.clone();
            if let Err(e) =
                set_key(&mut t, &key, v.clone()).and_then(|()| case_of_table(t).map(drop))
            {
                p.note(&format!("{label}[{i}] = {text}"), &e);
            }
        }
        out.push(Parameter { key, values });
    }
    out
}

/// The study's name must be a plain folder name.
fn check_name(name: &str, p: &mut Problems) {
    let plain =
        !name.is_empty() && name != "." && name != ".." && !name.contains(['/', '\\', '\0']);
    p.check(
        plain,
        "study.name",
        name,
        "a plain directory name (no '/', not empty)",
    );
}

/// Every combination of the values (the first parameter slowest), each a checked case whose
/// results go to `<dir>/runs/<id>/`; the problems of all runs at once, each line once with the
/// runs it concerns.
fn runs_of(path: &Path, base: &toml::Table, params: &[Parameter], dir: &Path) -> Result<Vec<Run>> {
    let count = params.iter().map(|q| q.values.len()).product::<usize>();
    if count > MAX_RUNS {
        return Err(bad_input(format!(
            "{}: study.parameters: {count} runs: expected at most {MAX_RUNS} (split the study)",
            path.display()
        )));
    }
    let width = count.to_string().len().max(3);
    let mut runs = Vec::with_capacity(count);
    let mut problems: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for index in 0..count {
        let values = combination(params, index);
        let id = format!("r{:0width$}", index + 1);
        let mut t = base.clone();
        for (q, v) in params.iter().zip(&values) {
            set_key(&mut t, &q.key, v.clone()).map_err(bad_input)?;
        }
        let mut case = case_of_table(t).map_err(bad_input)?;
        case.name = Some(id.clone());
        case.results_dir = dir.join("runs");
        case.mesh.geo = absolute(&case.mesh.geo)?;
        if let Err(e) = crate::validate::check_case(&case, path) {
            let runs_text = describe(&id, params, &values);
            for line in e.to_string().lines() {
                problems
                    .entry(line.to_string())
                    .or_default()
                    .push(runs_text.clone());
            }
        }
        runs.push(Run { id, values, case });
    }
    if problems.is_empty() {
        return Ok(runs);
    }
    let lines: Vec<String> = problems
        .into_iter()
        .map(|(line, runs)| format!("{line} (run {})", shorten(&runs)))
        .collect();
    Err(bad_input(lines.join("\n")))
}

/// The values of combination `index` (the last parameter varies fastest).
fn combination(params: &[Parameter], mut index: usize) -> Vec<toml::Value> {
    let mut values = vec![toml::Value::Boolean(false); params.len()];
    for (k, q) in params.iter().enumerate().rev() {
        values[k] = q.values[index % q.values.len()].clone();
        index /= q.values.len();
    }
    values
}

/// `r003 (forced.damping_ratio = 0.01, forced.levels = [2.0])`.
pub fn describe(id: &str, params: &[Parameter], values: &[toml::Value]) -> String {
    let pairs: Vec<String> = params
        .iter()
        .zip(values)
        .map(|(q, v)| format!("{} = {v}", q.key))
        .collect();
    format!("{id}: {}", pairs.join(", "))
}

/// The first few of a list of runs, and how many more.
fn shorten(runs: &[String]) -> String {
    let shown: Vec<&str> = runs.iter().take(3).map(String::as_str).collect();
    match runs.len() {
        n if n > 3 => format!("{}; and {} more", shown.join("; "), n - 3),
        _ => shown.join("; "),
    }
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "study".into(), |s| s.to_string_lossy().into_owned())
}

/// `p` made absolute against the current directory (not resolving links).
pub fn absolute(p: &Path) -> Result<PathBuf> {
    Ok(std::path::absolute(p)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn geo() -> String {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("meshes/blade.geo")
            .display()
            .to_string()
    }

    /// A study over a case file: parameters in the order of the file, the last fastest, the
    /// study file's own tables over the base case, the runs' folders under the study's.
    #[test]
    fn runs_are_the_combinations_in_file_order() {
        let tmp = tempfile::tempdir().unwrap();
        let res = tmp.path().join("res");
        write(
            tmp.path(),
            "base.toml",
            &format!(
                "results_dir = \"{}\"\n[mesh]\ngeo = \"{}\"\n[forced]\nlevels = [1.0]\n",
                res.display(),
                geo()
            ),
        );
        let s = write(tmp.path(), "s.toml", "[study]\ncase = \"base.toml\"\n[study.parameters]\n\"forced.levels\" = [[0.5], [2.0]]\n\"forced.damping_ratio\" = [0.01, 0.02, 0.03]\n[forced]\nrange = [0.95, 1.1]\n");
        let st = Study::load(&s).unwrap();
        assert_eq!(st.name, "s");
        assert_eq!(st.dir, res.join("s"));
        let keys: Vec<&str> = st.parameters.iter().map(|q| q.key.as_str()).collect();
        assert_eq!(keys, ["forced.levels", "forced.damping_ratio"]);
        assert_eq!(st.runs.len(), 6);
        let r = &st.runs[4];
        assert_eq!(r.id, "r005");
        assert_eq!(
            (r.case.forced.levels.clone(), r.case.forced.damping_ratio),
            (vec![2.0], 0.02)
        );
        assert_eq!(r.case.forced.range, [0.95, 1.1]);
        assert_eq!(r.case.out_dir(), res.join("s/runs/r005"));
        assert!(r.case.mesh.geo.is_absolute());
    }

    /// Unknown keys, empty lists, wrong types and out-of-range values are refused before
    /// anything runs, each naming the file, the key and the value.
    #[test]
    fn bad_parameters_name_the_file_the_key_and_the_value() {
        let tmp = tempfile::tempdir().unwrap();
        let text = format!(
            "[mesh]\ngeo = \"{}\"\n[study]\n[study.parameters]\n\"forced.dampng_ratio\" = [0.1]\n\"forced.levels\" = []\n\"forced.damping_ratio\" = [0.01, \"high\"]\n\"nnm.harmonics\" = [4, 4]\n",
            geo()
        );
        let s = write(tmp.path(), "bad.toml", &text);
        let e = Study::load(&s).unwrap_err();
        assert_eq!(crate::exit::code_of(&e), crate::exit::BAD_INPUT);
        let msg = e.to_string();
        for want in [
            "bad.toml: study.parameters.\"forced.dampng_ratio\"[0] = 0.1: unknown field `dampng_ratio`",
            "bad.toml: study.parameters.\"forced.levels\" = \"[]\": expected a non-empty list",
            "study.parameters.\"forced.damping_ratio\"[1] = \"high\": invalid type: string \"high\"",
            "study.parameters.\"nnm.harmonics\"[1] = \"4\": expected a value not given before",
        ] {
            assert!(msg.contains(want), "{want}\nnot in:\n{msg}");
        }
        let s = write(tmp.path(), "range.toml", &format!("[mesh]\ngeo = \"{}\"\n[study.parameters]\n\"forced.damping_ratio\" = [0.01, -0.5]\n", geo()));
        let msg = Study::load(&s).unwrap_err().to_string();
        assert!(
            msg.contains("range.toml: forced.damping_ratio = -0.5")
                && msg.contains("(run r002: forced.damping_ratio = -0.5)"),
            "{msg}"
        );
        assert!(!tmp.path().join("results").exists(), "nothing written");
    }

    #[test]
    fn a_file_without_a_study_table_or_parameters_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let s = write(tmp.path(), "case.toml", "[nnm]\nharmonics = 4\n");
        let msg = Study::load(&s).unwrap_err().to_string();
        assert!(msg.contains("case.toml: no [study] table"), "{msg}");
        let s = write(
            tmp.path(),
            "s.toml",
            "[study]\npost = 1\n[study.parameters]\n",
        );
        let msg = Study::load(&s).unwrap_err().to_string();
        assert!(msg.contains("s.toml") && msg.contains("post"), "{msg}");
        let s = write(
            tmp.path(),
            "n.toml",
            "[study.parameters]\n\"name\" = [\"a\"]\n\"nnm.harmonics.x\" = [1]\n",
        );
        let msg = Study::load(&s).unwrap_err().to_string();
        assert!(
            msg.contains("study.parameters.\"name\" = \"name\": expected a dotted case key"),
            "{msg}"
        );
        assert!(
            msg.contains("`nnm.harmonics` is a value of the case, not a table"),
            "{msg}"
        );
    }
}
