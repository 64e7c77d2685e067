//! The Snakemake workflow of a study (docs/STUDIES.md): `Snakefile`, one rule per stage of
//! `nlmodes run` whose jobs are the plan's (`crate::study::study_plan`, read from `plan.json`), each
//! running `nlmodes study-job`, then `gather`; and two Snakemake 7 profiles for SLURM in
//! `profiles/`: `slurm` (7.19+'s own SLURM executor, `--slurm`) and `cluster` (`sbatch` through
//! the generic `--cluster` support, also for older Snakemake or another scheduler's submit
//! command). Threads and resources per rule are defaults sized on the default blade
//! (docs/STUDIES.md); Snakemake's `--set-threads` and `--set-resources` change them.

use std::fmt::Write as _;
use std::path::Path;

use crate::study::study_plan::JobKind;

/// Threads, memory (MB) and wall time (minutes) of a stage's jobs.
struct RuleResources {
    threads: usize,
    mem_mb: usize,
    runtime: usize,
}

/// The defaults per stage. Measured on the default blade (cases/blade_study.toml, Snakemake's
/// benchmark files; docs/STUDIES.md): reduce, speed and campbell 1.1-1.2 GB, the others under
/// 0.8 GB; the longest job 196 s of CPU (a forced job at 0.2 % damping). Mesh, modes, reduce,
/// speed and campbell grow with the mesh (docs/LARGE_MODELS.md: 14.5 GB for a 1M-DOF
/// reduction), campbell with its speeds, forced with its levels and points.
fn resources(kind: JobKind) -> RuleResources {
    let r = |threads, mem_mb, runtime| RuleResources {
        threads,
        mem_mb,
        runtime,
    };
    match kind {
        JobKind::Mesh => r(1, 2000, 30),
        JobKind::Modes => r(1, 4000, 60),
        JobKind::Reduce | JobKind::Speed => r(2, 8000, 60),
        JobKind::Campbell => r(2, 8000, 240),
        JobKind::Backbone | JobKind::Forced => r(2, 4000, 120),
        JobKind::Run => r(1, 4000, 60),
    }
}

/// The Snakefile of the study `name` made from `study_file`, running `nlmodes` (absolute).
pub fn snakefile(name: &str, study_file: &Path, nlmodes: &Path) -> String {
    let mut s = format!(
        r#"# The Snakemake workflow of the nlmodes study "{name}" (docs/STUDIES.md), written by
#   nlmodes study {file}
# which rewrites it, plan.json and cases/ at each call: edit the study file, not these.
#
# Each job is one make-like stage of `nlmodes run` (mesh, modes, reduce, speed, campbell,
# backbone, forced), shared by every run with the same inputs to it, in stages/<stage>/<key>/
# (<key>: the hash of its inputs); a run job then makes runs/<run>/ from its stages' results and
# post-processes it; gather writes study.csv, figures/ and report.md.
#
# Here, from this folder:    snakemake --cores 2
# SLURM (Snakemake 7.21):    snakemake --profile profiles/slurm     (set its account, partition)
#   or  snakemake --slurm --jobs 50 --default-resources "slurm_account='ACCOUNT'" "slurm_partition='PARTITION'"
#   sbatch via --cluster:    snakemake --profile profiles/cluster
# Each rule's threads (SLURM: --cpus-per-task), mem_mb (--mem) and runtime (minutes, --time) are
# below; change them with e.g. --set-threads forced=8 --set-resources reduce:mem_mb=32000.
# The compute nodes must see this folder and nlmodes at the path below, or give its path there
# with --config nlmodes=/path/to/nlmodes.

import json

NLMODES = config.get("nlmodes", {exe})
with open("plan.json") as f:
    PLAN = json.load(f)

wildcard_constraints:
    key="[0-9a-z]+"

localrules: all, gather


def needs(kind):
    """The markers of the jobs a job starts from (plan.json)."""

    def done(wildcards):
        return ["done/" + n for n in PLAN["jobs"][kind + "-" + wildcards.key]["needs"]]

    return done


rule all:
    input:
        "study.csv",
"#,
        file = study_file.display(),
        exe = python_string(&nlmodes.display().to_string()),
    );
    for kind in JobKind::ALL {
        s += &rule(kind);
    }
    s += r#"

rule gather:
    input:
        ["done/run-" + run["id"] for run in PLAN["runs"]],
    output:
        "study.csv",
        "report.md",
    log:
        "logs/gather.log",
    shell:
        "{NLMODES:q} study-gather . > {log:q} 2>&1"
"#;
    s
}

/// The rule of a stage.
fn rule(kind: JobKind) -> String {
    let name = kind.name();
    let r = resources(kind);
    let mut s = String::new();
    let _ = write!(
        s,
        r#"

rule {name}:
    input:
        needs("{name}"),
    output:
        touch("done/{name}-{{key}}"),
    log:
        "logs/{name}-{{key}}.log",
    benchmark:
        "benchmarks/{name}-{{key}}.tsv"
    threads: {threads}
    resources:
        mem_mb={mem_mb},
        runtime={runtime},
    shell:
        "RAYON_NUM_THREADS={{threads}} OPENBLAS_NUM_THREADS={{threads}} "
        "{{NLMODES:q}} study-job . {name}-{{wildcards.key}} > {{log:q}} 2>&1"
"#,
        threads = r.threads,
        mem_mb = r.mem_mb,
        runtime = r.runtime,
    );
    s
}

/// A Python string literal.
fn python_string(s: &str) -> String {
    format!("{:?}", s)
}

/// `profiles/slurm/config.yaml` and `profiles/cluster/config.yaml`.
pub fn profiles() -> [(&'static str, &'static str); 2] {
    [
        (
            "profiles/slurm/config.yaml",
            r#"# Snakemake 7.19+ (Debian 12: 7.21) profile: each job of the study as a SLURM batch job, by
# Snakemake's own SLURM executor. Run from the study folder:  snakemake --profile profiles/slurm
# Set the account and partition (the quotes keep them strings); each rule's threads become
# --cpus-per-task, mem_mb --mem, runtime (minutes) --time: see the Snakefile, and change them
# with set-threads / set-resources below or on the command line.
slurm: true
jobs: 50
default-resources:
  - "slurm_account='CHANGE_ME'"
  - "slurm_partition='CHANGE_ME'"
# set-threads:
#   - forced=8
# set-resources:
#   - reduce:mem_mb=32000
keep-going: true
rerun-incomplete: true
latency-wait: 60
printshellcmds: true
"#,
        ),
        (
            "profiles/cluster/config.yaml",
            r#"# Snakemake profile: each job of the study submitted with sbatch through Snakemake's generic
# cluster support (--cluster; any Snakemake 7, and another scheduler's submit command works
# the same way). Run from the study folder:  snakemake --profile profiles/cluster
# Add --account=... / --partition=... to the command if your cluster needs them.
cluster: "sbatch --parsable --job-name=nlmodes-{rule} --cpus-per-task={threads} --mem={resources.mem_mb} --time={resources.runtime} --output=logs/slurm/{rule}-%j.out"
cluster-cancel: scancel
jobs: 50
keep-going: true
rerun-incomplete: true
latency-wait: 60
printshellcmds: true
"#,
        ),
    ]
}
