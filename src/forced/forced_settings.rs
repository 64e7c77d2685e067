//! `[forced]`: the forced-response study of a case or of `nlmodes forced --settings FILE`
//! (issue 22; docs/DESIGN.md §10). Every key has a default ([`ForcedSection::default`]), units
//! are SI, frequencies are ratios to the linear frequency w_r of the chosen mode.

use serde::{Deserialize, Serialize};

use crate::problems::Problems;

/// How the forced response converges N (`[forced] adapt_harmonics`; DESIGN §10.8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HarmonicAdaptation {
    /// Follow N point by point on models with at most `AUTO_FOLLOW_ROWS` contact rows, retrace
    /// the whole curve at 2N on larger ones.
    Auto,
    /// The trace raises N where a point needs it, up to `max_harmonics`.
    Follow,
    /// The whole curve at one N, traced again at 2N while its peak, folds, deepest contact or
    /// a few points spread over its contact move at 2N by more than `harmonic_tolerance`.
    Retrace,
    /// The trace keeps `harmonics`; each point in contact is checked once at 2N.
    Check,
}

/// The most contact rows on which `adapt_harmonics = "auto"` follows N point by point. On the
/// default blade (24 rows) following N costs 6x (level 2) to 70x (level 5) the fixed-N curve and
/// its switching between neighbouring points adds folds (docs/BENCHMARKS.md, session 17); the
/// whole curve traced again at 2N gives the same peak at a fraction of that. The small systems of
/// the acceptance tests (1-2 rows) are followed, as they were verified.
pub const AUTO_FOLLOW_ROWS: usize = 8;

impl HarmonicAdaptation {
    /// The policy on a model with `rows` contact rows.
    pub fn policy(self, rows: usize) -> nlmodes_forced::HarmonicPolicy {
        use nlmodes_forced::HarmonicPolicy;
        match self {
            Self::Auto if rows <= AUTO_FOLLOW_ROWS => HarmonicPolicy::Follow,
            Self::Auto | Self::Retrace => HarmonicPolicy::Retrace,
            Self::Follow => HarmonicPolicy::Follow,
            Self::Check => HarmonicPolicy::Check,
        }
    }
}

/// The contact law of the forced study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ForcedContact {
    /// Algorithm 1 (augmented Lagrangian, exact contact). On the default blade its frequency
    /// continuation stalls near W / w1 = 1.05 (corners where the curve is not unique; see the
    /// README's known limits): use it on models whose contact coordinates carry little mass.
    Exact,
    /// The penalty law kc (g)_+ with kc = `penalty_factor` times each row's static contact
    /// stiffness (well posed; converges to exact contact as the factor grows, see BENCHMARKS).
    Penalty,
}

/// What the force acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ForcedLoadKind {
    /// A point force on the master coordinate (the tip contact DOF the backbone follows).
    Master,
    /// The inertia pattern M phi_r of linear mode `load_mode` of the reduced model, scaled so
    /// that its largest entry is the level: it drives mode r alone in the linear regime.
    Mode,
    /// The pattern of `F.mtx` in the reduced-model directory (N per reduced coordinate): n rows,
    /// one column (the cosine part at `harmonic`) or a (cosine, sine) pair of columns per entry
    /// of `load_harmonics`; an engine-order pattern with amplitude A_i and phase p_i per
    /// coordinate is cos = A_i cos(p_i), sin = A_i sin(p_i). Scaled so that its largest entry
    /// is the level.
    File,
    /// A total force of 1 N along `load_direction`, shared equally by the nodes of the mesh group
    /// `load_group`; the levels are the total force (N). The reduce stage adds its static
    /// correction to the Craig-Bampton basis (so the reduced model carries it exactly in the
    /// static limit) and writes its reduced form T^T f as `F.mtx` of the model directory.
    Group,
    /// A uniform pressure of 1 Pa on the surface group `load_group` (a Physical Surface, dim 2),
    /// positive into the solid, as consistent nodal forces f_i = -p ∫ N_i n dA
    /// (`nlmodes_fem::surface_load`); the levels are the pressure amplitude (Pa). Same path as
    /// `Group`: static correction in the basis, T^T f as `F.mtx`.
    Pressure,
}

impl ForcedLoadKind {
    /// Whether the reduce stage builds this load on the full model (static correction, `F.mtx`).
    pub fn is_full_model_load(self) -> bool {
        matches!(self, ForcedLoadKind::Group | ForcedLoadKind::Pressure)
    }

    /// The unit of the load's scale (its levels with `level_unit = "N"`): Pa for a pressure, N
    /// for the others.
    pub fn unit(self) -> &'static str {
        if self == ForcedLoadKind::Pressure {
            "Pa"
        } else {
            "N"
        }
    }
}

/// How `levels` are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LevelUnit {
    /// Load amplitudes in newtons (in pascals for `load = "pressure"`).
    #[serde(rename = "N")]
    Newton,
    /// Multiples of the force whose linear resonant response of the master reaches the
    /// grazing amplitude of the mode (1 grazes, 3 drives three times past contact).
    #[serde(rename = "grazing")]
    Grazing,
}

/// Largest `[forced] harmonics`: the forced solver's condensed Newton matrix is dense in
/// (2 N + 1) x (contact rows), 8 ((2 N + 1) r)^2 bytes per level solved in parallel: 0.74 GB at
/// N = 200 on the blade's 24 rows, 18 GB at N = 1000. Ten times the 21 harmonics of the NLvib
/// comparison (docs/PEER_NLVIB.md), the most any study here uses.
pub const MAX_HARMONICS: usize = 200;

/// Largest `[forced] samples`: the Fourier matrices of the full basis are m x (2 N + 1) each
/// (synthesis and analysis), 0.42 GB at m = 65536 and N = 200; 65536 samples resolve the
/// highest of 200 harmonics with 160 samples per period, twenty times the default's 8.
pub const MAX_SAMPLES: usize = 65_536;

/// `[forced]` (see the module docs; keys documented in cases/blade.toml and the README).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ForcedSection {
    /// Run the forced study in `nlmodes run` (default true, as in cases/blade.toml: the defaults
    /// are the default study's; `enabled = false` leaves the stage out).
    pub enabled: bool,
    /// Linear mode swept around (0-based).
    pub mode: usize,
    /// Frequency range [start, end] as W / w_mode (default [0.9, 1.2]); the curve starts from
    /// the linear response.
    pub range: [f64; 2],
    /// Highest harmonic N of the response where the orbit is out of contact, and the first N
    /// of a point in contact (raised there until the point converges; docs/DESIGN.md §10.8).
    pub harmonics: usize,
    /// The largest N a point in contact may be raised to (0: four times `harmonics`).
    pub max_harmonics: usize,
    /// "follow": the trace raises N where a point needs it (up to `max_harmonics`); "retrace":
    /// the whole curve at one N, traced again at 2N while its checked points move; "check":
    /// the trace keeps `harmonics` and every point in contact is checked once at 2N; "auto"
    /// (the default): follow on models with at most `AUTO_FOLLOW_ROWS` contact rows, retrace
    /// on larger ones.
    pub adapt_harmonics: HarmonicAdaptation,
    /// A point's N is enough when doubling it moves the master's first harmonic and W by at
    /// most this (relative).
    pub harmonic_tolerance: f64,
    /// Time samples per period m (0: the default 4 (2N + 1) rounded up to a power of two).
    pub samples: usize,
    /// Harmonic h >= 1 of the response at which the force acts (1: at W).
    pub harmonic: usize,
    /// Modal damping ratio of every linear mode (dimensionless), unless `damping_ratios` or
    /// `rayleigh` is given.
    pub damping_ratio: f64,
    /// One ratio per linear mode, ascending frequency (the last applies to the rest).
    pub damping_ratios: Vec<f64>,
    /// Rayleigh damping [alpha (1/s), beta (s)]: C = alpha M + beta K.
    pub rayleigh: Option<[f64; 2]>,
    /// Take C from `C.mtx` of the reduced-model directory (a symmetric Matrix Market file of
    /// the model's order, N s/m), for a model that brings its own damping.
    pub damping_matrix: bool,
    /// The load pattern.
    pub load: ForcedLoadKind,
    /// The mode of `load = "mode"` (0-based).
    pub load_mode: usize,
    /// The harmonics of the (cosine, sine) column pairs of `F.mtx` for `load = "file"` (empty:
    /// one pair or one cosine column at `harmonic`).
    pub load_harmonics: Vec<usize>,
    /// The mesh group of `load = "group"` (any dimension: its nodes) or of `load = "pressure"`
    /// (a surface group, dim 2: its triangles).
    pub load_group: String,
    /// The direction of `load = "group"` (normalized; any non-zero length).
    pub load_direction: [f64; 3],
    /// Load levels, one curve each (N, or Pa for a pressure; see `level_unit`).
    pub levels: Vec<f64>,
    /// Unit of `levels` and of `level_range`.
    pub level_unit: LevelUnit,
    /// Frequencies W / w_mode at which the response is also continued in force level over
    /// `level_range`, one curve each (`forced/level_sweeps.csv`, `level_sweeps.png`; default
    /// none).
    pub level_sweeps: Vec<f64>,
    /// The force range [start, end] of the level sweeps, in `level_unit` (default [0.1, 10]);
    /// each sweep starts from the linear response at the start.
    pub level_range: [f64; 2],
    /// Contact law.
    pub contact: ForcedContact,
    /// kc / (static contact stiffness of the row) for `contact = "penalty"`.
    pub penalty_factor: f64,
    /// Floquet stability of every point.
    pub stability: bool,
    /// Each level's exact response curve on the massless contact boundary, by shooting
    /// (`forced/frf_boundary.csv`, drawn on the FRF figures; docs/STABILITY.md Sec. 9.2).
    pub exact_curve: bool,
    /// Write each level's peak orbit (largest first-harmonic amplitude of the master) as a
    /// ParaView series (`forced/orbits/`).
    pub keep_peaks: bool,
    /// Frequencies W / w_mode at which each level's orbits are written as ParaView series (every
    /// crossing of the curve).
    pub keep: Vec<f64>,
    /// Frames per period of those series.
    pub frames: usize,
    /// `[forced.distortion]`: an n-lobed casing whose gap varies in time, the excitation with
    /// or without the load (docs/DESIGN.md §10.11); absent: constant gaps.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distortion: Option<crate::forced::forced_distortion::DistortionSection>,
}

impl Default for ForcedSection {
    fn default() -> Self {
        Self {
            enabled: true,
            mode: 0,
            range: [0.9, 1.2],
            harmonics: 10,
            max_harmonics: 0,
            adapt_harmonics: HarmonicAdaptation::Auto,
            harmonic_tolerance: 1e-3,
            samples: 0,
            harmonic: 1,
            damping_ratio: 0.003,
            damping_ratios: Vec::new(),
            rayleigh: None,
            damping_matrix: false,
            load: ForcedLoadKind::Master,
            load_mode: 0,
            load_harmonics: Vec::new(),
            load_group: "tip".into(),
            load_direction: [1.0, 0.0, 0.0],
            levels: vec![0.5, 2.0, 5.0],
            level_unit: LevelUnit::Grazing,
            level_sweeps: Vec::new(),
            level_range: [0.1, 10.0],
            contact: ForcedContact::Penalty,
            penalty_factor: 1e3,
            stability: true,
            exact_curve: true,
            keep_peaks: true,
            keep: Vec::new(),
            frames: 24,
            distortion: None,
        }
    }
}

impl ForcedSection {
    /// The largest N of a point in contact (`max_harmonics`, 0: four times `harmonics`, at most
    /// `MAX_HARMONICS`).
    pub fn top_harmonics(&self) -> usize {
        if self.max_harmonics == 0 {
            (4 * self.harmonics).min(MAX_HARMONICS).max(self.harmonics)
        } else {
            self.max_harmonics
        }
    }

    /// Every value checked (order-independent ones; the mode indices against the model later).
    pub fn check(&self, p: &mut Problems) {
        let finite_pos = |v: f64| v.is_finite() && v > 0.0;
        let [a, b] = self.range;
        p.check(
            finite_pos(a),
            "forced.range",
            self.range,
            "start > 0 (W / w_mode)",
        );
        p.check(
            b.is_finite() && b > a,
            "forced.range",
            self.range,
            "a non-empty range [start, end] with end > start",
        );
        p.check(
            self.harmonics >= 1,
            "forced.harmonics",
            self.harmonics,
            ">= 1",
        );
        p.check(
            self.harmonics <= MAX_HARMONICS,
            "forced.harmonics",
            self.harmonics,
            &format!(
                "N <= {MAX_HARMONICS} (the forced solver's condensed Newton matrix is dense \
                 in (2 N + 1) x contact rows: 0.74 GB per level at N = 200 on the blade's 24 rows)"
            ),
        );
        p.check(
            self.max_harmonics == 0
                || (self.max_harmonics >= self.harmonics && self.max_harmonics <= MAX_HARMONICS),
            "forced.max_harmonics",
            self.max_harmonics,
            &format!("0 (four times harmonics) or harmonics <= N <= {MAX_HARMONICS}"),
        );
        p.check(
            self.harmonic_tolerance.is_finite()
                && self.harmonic_tolerance > 0.0
                && self.harmonic_tolerance < 1.0,
            "forced.harmonic_tolerance",
            self.harmonic_tolerance,
            "a relative change 0 < tolerance < 1",
        );
        p.check(
            self.samples == 0 || self.samples > 2 * self.harmonics,
            "forced.samples",
            self.samples,
            "0 (default) or m >= 2 N + 1",
        );
        p.check(
            self.samples <= MAX_SAMPLES,
            "forced.samples",
            self.samples,
            &format!("at most {MAX_SAMPLES} time samples per period"),
        );
        p.check(
            (1..=self.harmonics).contains(&self.harmonic),
            "forced.harmonic",
            self.harmonic,
            "1 <= h <= harmonics",
        );
        for (i, h) in self.load_harmonics.iter().enumerate() {
            p.check(
                (1..=self.harmonics).contains(h) && !self.load_harmonics[..i].contains(h),
                "forced.load_harmonics",
                h,
                "distinct harmonics 1 <= h <= harmonics",
            );
        }
        if self.load.is_full_model_load() {
            p.check(
                !self.load_group.is_empty(),
                "forced.load_group",
                &self.load_group,
                "the name of a mesh group",
            );
        }
        if self.load == ForcedLoadKind::Group {
            let d = self.load_direction;
            let len = d.iter().map(|v| v * v).sum::<f64>().sqrt();
            p.check(
                len.is_finite() && len > 0.0,
                "forced.load_direction",
                d,
                "a finite, non-zero direction [x, y, z]",
            );
        }
        for k in &self.keep {
            p.check(
                finite_pos(*k),
                "forced.keep",
                k,
                "finite frequencies W / w_mode > 0",
            );
            if finite_pos(*k) && finite_pos(a) && b.is_finite() && b > a {
                p.check(
                    (a..=b).contains(k),
                    "forced.keep",
                    k,
                    &format!(
                        "a frequency W / w_mode within forced.range = [{a}, {b}] (the curves \
                         cross no other)"
                    ),
                );
            }
        }
        p.check(
            (2..=1000).contains(&self.frames),
            "forced.frames",
            self.frames,
            "between 2 and 1000 frames per period",
        );
        let ratio_ok = |z: f64| z.is_finite() && (0.0..1.0).contains(&z);
        p.check(
            ratio_ok(self.damping_ratio),
            "forced.damping_ratio",
            self.damping_ratio,
            "a ratio 0 <= zeta < 1",
        );
        for z in &self.damping_ratios {
            p.check(
                ratio_ok(*z),
                "forced.damping_ratios",
                z,
                "ratios 0 <= zeta < 1",
            );
        }
        if let Some(r) = self.rayleigh {
            let ok = r.iter().all(|v| v.is_finite() && *v >= 0.0);
            p.check(
                ok,
                "forced.rayleigh",
                r,
                "[alpha >= 0 (1/s), beta >= 0 (s)]",
            );
            p.check(
                self.damping_ratios.is_empty(),
                "forced.damping_ratios",
                &self.damping_ratios,
                &format!(
                    "no list beside forced.rayleigh = {r:?}: give one damping (the ratios or \
                     Rayleigh's coefficients)"
                ),
            );
        }
        self.check_levels(p);
        p.check(
            finite_pos(self.penalty_factor),
            "forced.penalty_factor",
            self.penalty_factor,
            "a finite factor > 0",
        );
        self.check_level_sweeps(p);
        self.check_grazing_unit(p);
    }

    /// `levels`: at least one, each finite and > 0; with a casing distortion that moves the
    /// gap, none (the distortion alone) or zeros among them (docs/DESIGN.md §10.11).
    fn check_levels(&self, p: &mut Problems) {
        if let Some(d) = &self.distortion {
            d.check(p, self.harmonics);
        }
        let distorted = self.distortion.as_ref().is_some_and(|d| d.excites());
        p.check(
            !self.levels.is_empty() || distorted,
            "forced.levels",
            &self.levels,
            "at least one level (or none, with a [forced.distortion] amplitude > 0: the casing \
             distortion alone)",
        );
        for l in &self.levels {
            let ok = l.is_finite() && (*l > 0.0 || (distorted && *l == 0.0));
            let expected = if distorted {
                "finite force levels >= 0 (0: the casing distortion alone)"
            } else {
                "finite force levels > 0"
            };
            p.check(ok, "forced.levels", l, expected);
        }
    }

    /// The levels of the curves: `levels`, or one curve without load (level 0) when it is
    /// empty under a casing distortion.
    pub fn curve_levels(&self) -> Vec<f64> {
        if self.levels.is_empty() {
            vec![0.0]
        } else {
            self.levels.clone()
        }
    }

    /// Whether some curve has a load (a level > 0).
    pub fn loaded(&self) -> bool {
        self.levels.iter().any(|&l| l > 0.0)
    }

    /// `level_unit = "grazing"` scales the levels by the force whose damped linear resonance of
    /// `mode` grazes: it needs damping on that mode and a load that drives it. Known here from
    /// the keys alone; C.mtx, F.mtx and the model's modes are checked against the model
    /// (`crate::forced::forced_inputs`).
    fn check_grazing_unit(&self, p: &mut Problems) {
        if self.level_unit != LevelUnit::Grazing {
            return;
        }
        let undamped = format!(
            "damping on the swept mode (forced.mode = {}) with forced.level_unit = \"grazing\": \
             its levels are multiples of the force whose damped linear resonance grazes, which \
             is zero without damping (give damping > 0 or level_unit = \"N\")",
            self.mode
        );
        if !self.damping_matrix {
            match (self.rayleigh, self.damping_ratios.as_slice()) {
                (Some(r), _) => p.check(r != [0.0, 0.0], "forced.rayleigh", r, &undamped),
                (None, []) => p.check(
                    self.damping_ratio != 0.0,
                    "forced.damping_ratio",
                    self.damping_ratio,
                    &undamped,
                ),
                (None, z) => {
                    let k = self.mode.min(z.len() - 1);
                    let key = format!("forced.damping_ratios[{k}]");
                    p.check(z[k] != 0.0, &key, z[k], &undamped);
                }
            }
        }
        if self.load == ForcedLoadKind::Mode {
            p.check(
                self.load_mode == self.mode,
                "forced.load_mode",
                self.load_mode,
                &format!(
                    "a linear mode index equal to forced.mode = {} with load = \"mode\" and \
                     level_unit = \"grazing\": the pattern M phi of another mode does not drive \
                     mode {} (the modes are M-orthogonal), so no force makes it graze (or \
                     level_unit = \"N\")",
                    self.mode, self.mode
                ),
            );
        }
    }

    /// `level_sweeps` and `level_range`.
    fn check_level_sweeps(&self, p: &mut Problems) {
        for w in &self.level_sweeps {
            p.check(
                w.is_finite() && *w > 0.0,
                "forced.level_sweeps",
                w,
                "frequencies W / w_mode > 0",
            );
        }
        let [a, b] = self.level_range;
        p.check(
            a.is_finite() && a > 0.0,
            "forced.level_range",
            self.level_range,
            "start > 0 (in level_unit)",
        );
        p.check(
            b.is_finite() && b > a,
            "forced.level_range",
            self.level_range,
            "a non-empty range [start, end] with end > start",
        );
    }

    /// The damping definition; `matrix` is the model's C.mtx when `damping_matrix` is set.
    pub fn damping(&self, matrix: Option<faer::Mat<f64>>) -> nlmodes_forced::Damping {
        if let Some(c) = matrix {
            return nlmodes_forced::Damping::Matrix(c);
        }
        match (self.rayleigh, self.damping_ratios.is_empty()) {
            (Some([alpha, beta]), _) => nlmodes_forced::Damping::Rayleigh { alpha, beta },
            (None, false) => nlmodes_forced::Damping::ModalRatios(self.damping_ratios.clone()),
            (None, true) => nlmodes_forced::Damping::ModalRatios(vec![self.damping_ratio]),
        }
    }
}

/// The `[forced]` table of a TOML file (other tables ignored; a missing table gives the
/// defaults); unknown keys and unreadable files are bad input naming the file.
pub fn load(path: &std::path::Path) -> anyhow::Result<ForcedSection> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| crate::exit::bad_input(format!("cannot read {}: {e}", path.display())))?;
    let value: toml::Value = toml::from_str(&text)
        .map_err(|e| crate::exit::bad_input(format!("{}: invalid TOML: {e}", path.display())))?;
    match value.get("forced") {
        None => Ok(ForcedSection::default()),
        Some(t) => t
            .clone()
            .try_into()
            .map_err(|e| crate::exit::bad_input(format!("{}: [forced]: {e}", path.display()))),
    }
}

/// The model's `C.mtx` when `[forced] damping_matrix` asks for it, checked against `system`:
/// entries at most 1e30 (the bound of K.mtx and M.mtx), of its order, finite, symmetric and
/// positive semi-definite (`nlmodes_forced::Damping::matrix`).
/// A missing, unreadable or refused file is bad input naming it.
pub fn damping_matrix(
    s: &ForcedSection,
    model_dir: &std::path::Path,
    system: &nlmodes_nnm::System,
) -> anyhow::Result<Option<faer::Mat<f64>>> {
    if !s.damping_matrix {
        return Ok(None);
    }
    let path = model_dir.join("C.mtx");
    let bad = |what: String| {
        crate::exit::bad_input(format!(
            "forced.damping_matrix = true: {}: {what}",
            path.display()
        ))
    };
    let c = nlmodes_modal::matrix_market::read_symmetric_dense(&path)
        .map_err(|e| bad(format!("cannot read it: {e}")))?;
    let largest = (0..c.nrows())
        .flat_map(|i| (0..c.ncols()).map(move |j| (i, j)))
        .fold(0.0_f64, |a, (i, j)| a.max(c[(i, j)].abs()));
    let (_, high) = nlmodes_modal::model_checks::MAGNITUDE_RANGE;
    if largest > high {
        return Err(bad(format!(
            "the largest entry of C is {largest:e}: expected at most {high:e} N s/m, the bound \
             K.mtx and M.mtx are held to (check the units or the file)"
        )));
    }
    let n = system.n_dofs();
    nlmodes_forced::Damping::Matrix(c.clone())
        .matrix(system)
        .map_err(|e| {
            bad(format!(
                "{e} (C in N s/m of the reduced model, order n = {n})"
            ))
        })?;
    Ok(Some(c))
}

/// The harmonics of `load = "file"`'s column pairs: `load_harmonics`, or `harmonic` alone.
pub fn file_load_harmonics(s: &ForcedSection) -> Vec<usize> {
    if s.load_harmonics.is_empty() {
        vec![s.harmonic]
    } else {
        s.load_harmonics.clone()
    }
}

/// `F.mtx` of the model directory for `load = "file"`, `"group"` or `"pressure"` (None for the
/// other loads), checked against the model's order `n` and `load_harmonics`: bad input naming
/// the file otherwise.
pub fn file_load(
    s: &ForcedSection,
    model_dir: &std::path::Path,
    n: usize,
) -> anyhow::Result<Option<faer::Mat<f64>>> {
    if !(s.load == ForcedLoadKind::File || s.load.is_full_model_load()) {
        return Ok(None);
    }
    let path = model_dir.join("F.mtx");
    let word = match s.load {
        ForcedLoadKind::Group => "group",
        ForcedLoadKind::Pressure => "pressure",
        _ => "file",
    };
    let bad = |what: String| {
        crate::exit::bad_input(format!(
            "forced.load = \"{word}\": {}: {what}",
            path.display()
        ))
    };
    let f = nlmodes_modal::matrix_market_general::read_dense_general(&path)
        .map_err(|e| bad(format!("cannot read it: {e}")))?;
    if f.nrows() != n {
        return Err(bad(format!(
            "{} rows, expected the model's order n = {n} (one row per reduced coordinate)",
            f.nrows()
        )));
    }
    let pairs = file_load_harmonics(s).len();
    let single = (s.load_harmonics.is_empty() || s.load.is_full_model_load()) && f.ncols() == 1;
    if !single && f.ncols() != 2 * pairs {
        return Err(bad(format!(
            "{} columns, expected {} (a cosine and a sine column for each of the harmonics {:?}{})",
            f.ncols(),
            2 * pairs,
            file_load_harmonics(s),
            if s.load_harmonics.is_empty() {
                ", or one cosine column"
            } else {
                ""
            }
        )));
    }
    if (0..f.ncols()).all(|j| (0..n).all(|i| f[(i, j)] == 0.0)) {
        return Err(bad("every entry is zero: no load".into()));
    }
    Ok(Some(f))
}

/// The load the reduce stage builds on the full model, on its free DOFs, with the comment of
/// `F.mtx` that says what it is.
pub struct FullLoad {
    /// f on the free DOFs (N): 1 N in total for a group load, the forces of 1 Pa for a pressure.
    pub f: Vec<f64>,
    /// One line for `F.mtx` and the log.
    pub description: String,
}

/// The full load of `load = "group"` or `"pressure"` (None for the other loads); bad input
/// naming `forced.load_group`, its value and the mesh's groups when the group is absent, not a
/// surface (pressure) or carries no load on the free DOFs.
pub fn full_load(
    s: &ForcedSection,
    mesh: &nlmodes_fem::Mesh,
    dofs: &nlmodes_fem::DofMap,
) -> anyhow::Result<Option<FullLoad>> {
    let bad = |e: &dyn std::fmt::Display| {
        crate::exit::bad_input(format!(
            "forced.load_group = {:?} (forced.load = \"{}\"): {e}",
            s.load_group,
            if s.load == ForcedLoadKind::Pressure {
                "pressure"
            } else {
                "group"
            }
        ))
    };
    let (f, description) = match s.load {
        ForcedLoadKind::Group => (
            group_load(s, mesh, dofs).map_err(|e| bad(&e))?,
            format!(
                "T^T f of [forced] load = \"group\": 1 N along {:?} on the group {:?}, N per \
                 reduced coordinate",
                s.load_direction, s.load_group
            ),
        ),
        ForcedLoadKind::Pressure => pressure_load(s, mesh, dofs).map_err(|e| bad(&e))?,
        _ => return Ok(None),
    };
    if f.iter().all(|v| *v == 0.0) {
        return Err(bad(
            &"every node of the group is clamped: no load on the free DOFs",
        ));
    }
    Ok(Some(FullLoad { f, description }))
}

/// 1 N in total along the unit direction, shared equally by the group's free nodes.
fn group_load(
    s: &ForcedSection,
    mesh: &nlmodes_fem::Mesh,
    dofs: &nlmodes_fem::DofMap,
) -> Result<Vec<f64>, nlmodes_fem::FemError> {
    let group = mesh.group(&s.load_group)?;
    let d = s.load_direction;
    let len = d.iter().map(|v| v * v).sum::<f64>().sqrt();
    let free: Vec<usize> = group
        .nodes
        .iter()
        .copied()
        .filter(|&n| (0..3).all(|c| dofs.free_index(3 * n + c).is_some()))
        .collect();
    let mut f = vec![0.0; dofs.n_free()];
    for &n in &free {
        for (c, dc) in d.iter().enumerate() {
            let i = dofs.free_index(3 * n + c).expect("free");
            f[i] = dc / len / free.len() as f64;
        }
    }
    Ok(f)
}

/// The consistent nodal forces of 1 Pa on the surface group, on the free DOFs (the clamped
/// DOFs' share goes to the supports), with a description naming the total force and ∫ n dA.
fn pressure_load(
    s: &ForcedSection,
    mesh: &nlmodes_fem::Mesh,
    dofs: &nlmodes_fem::DofMap,
) -> Result<(Vec<f64>, String), nlmodes_fem::FemError> {
    use nlmodes_fem::surface_load;
    let full = surface_load::pressure_load(mesh, &s.load_group, 1.0)?;
    let area = surface_load::area_vector(mesh, &s.load_group)?;
    let mut f = vec![0.0; dofs.n_free()];
    for (dof, v) in full.iter().enumerate() {
        if let Some(i) = dofs.free_index(dof) {
            f[i] = *v;
        }
    }
    let description = format!(
        "T^T f of [forced] load = \"pressure\": 1 Pa into the surface {:?} (int n dA = \
         [{:.6e}, {:.6e}, {:.6e}] m^2, total force -p int n dA), N per reduced coordinate",
        s.load_group, area[0], area[1], area[2]
    );
    Ok((f, description))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problems_of(s: &ForcedSection) -> String {
        let mut p = Problems::new(|k| format!("f.toml: {k}"));
        s.check(&mut p);
        p.finish().map_or_else(|e| e.to_string(), |_| String::new())
    }

    #[test]
    fn the_defaults_are_valid() {
        assert_eq!(problems_of(&ForcedSection::default()), "");
    }

    /// Issue 37: what the keys alone tell is refused naming the key, the value and why.
    #[test]
    fn sizes_frequencies_and_conflicting_damping_are_named() {
        let s = ForcedSection {
            harmonics: 100_000,
            samples: 10_000_000_000,
            keep: vec![1.5, 1.0],
            rayleigh: Some([1.0, 0.0]),
            damping_ratios: vec![0.01],
            ..ForcedSection::default()
        };
        let msg = problems_of(&s);
        for want in [
            "f.toml: forced.harmonics = 100000: expected N <= 200",
            "f.toml: forced.samples = 10000000000: expected at most 65536",
            "f.toml: forced.keep = 1.5: expected a frequency W / w_mode within forced.range = \
             [0.9, 1.2]",
            "f.toml: forced.damping_ratios = [0.01]: expected no list beside forced.rayleigh",
        ] {
            assert!(msg.contains(want), "missing `{want}` in:\n{msg}");
        }
        assert!(!msg.contains("forced.keep = 1.0"), "{msg}");
        let at_limits = ForcedSection {
            harmonics: MAX_HARMONICS,
            samples: MAX_SAMPLES,
            keep: vec![0.9, 1.2],
            ..ForcedSection::default()
        };
        assert_eq!(problems_of(&at_limits), "");
    }

    /// `level_unit = "grazing"` needs damping on the swept mode and a load that drives it; with
    /// `level_unit = "N"` the same damping and load are accepted.
    #[test]
    fn grazing_levels_need_a_damped_driven_mode() {
        let grazing = ForcedSection::default();
        let cases = [
            (
                ForcedSection {
                    damping_ratio: 0.0,
                    ..grazing.clone()
                },
                "forced.damping_ratio = 0.0: expected damping on the swept mode (forced.mode = 0)",
            ),
            (
                ForcedSection {
                    mode: 4,
                    damping_ratios: vec![0.01, 0.0],
                    ..grazing.clone()
                },
                "forced.damping_ratios[1] = 0.0: expected damping on the swept mode (forced.mode = 4)",
            ),
            (
                ForcedSection {
                    rayleigh: Some([0.0, 0.0]),
                    ..grazing.clone()
                },
                "forced.rayleigh = [0.0, 0.0]: expected damping on the swept mode",
            ),
            (
                ForcedSection {
                    load: ForcedLoadKind::Mode,
                    load_mode: 2,
                    ..grazing.clone()
                },
                "forced.load_mode = 2: expected a linear mode index equal to forced.mode = 0",
            ),
        ];
        for (s, want) in cases {
            let msg = problems_of(&s);
            assert!(msg.contains(want), "missing `{want}` in:\n{msg}");
            let newtons = ForcedSection {
                level_unit: LevelUnit::Newton,
                ..s
            };
            assert_eq!(problems_of(&newtons), "");
        }
        let damped_second = ForcedSection {
            mode: 1,
            damping_ratios: vec![0.0, 0.01],
            ..grazing
        };
        assert_eq!(problems_of(&damped_second), "");
    }
}
