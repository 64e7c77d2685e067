//! The Floquet stability of each point of a response curve (docs/STABILITY.md Secs. 8-9): the
//! exact monodromy of the massless contact boundary's shot orbit for points in contact where
//! that model applies (under a casing distortion with the gaps moving, Sec. 9.5), else the
//! switched monodromy of the harmonic-balance orbit backed by one period of independent time
//! integration (`period_check`); then the changes of stability between consecutive determined
//! points of one piece.

use nlmodes_hb::floquet::{SampledMonodromy, Verdict};

use crate::boundary::BoundaryMonodromy;
use crate::error::ForcedError;
use crate::solver::{ForcedPoint, ForcedSolver};
use nlmodes_boundary::check_driven_by_rk4;

/// What a change of stability between two points is, from the multiplier that crossed the unit
/// circle (its argument within 0.05 rad of 0 or pi, else a complex pair).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ForcedBifurcation {
    /// Through +1 (at a fold of the curve, or a branch point).
    Fold,
    /// Through -1.
    PeriodDoubling,
    /// A complex pair (quasi-periodic motion sets in).
    NeimarkSacker,
}

/// The Floquet stability of one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointStability {
    /// Stable, unstable or undetermined (within the margin).
    pub verdict: Verdict,
    /// Largest multiplier modulus (`None` where the monodromy was not computed: the period
    /// check already made the point undetermined).
    pub largest_multiplier: Option<f64>,
    /// Argument of that multiplier (rad).
    pub argument: Option<f64>,
    /// Liouville error of the monodromy (see `nlmodes_hb::floquet`).
    pub liouville_error: Option<f64>,
    /// The change of stability since the previous point, if any.
    pub bifurcation: Option<ForcedBifurcation>,
    /// How far one period of time integration of the penalty equation from the orbit's start
    /// lands from it (relative; `period_check`); `None` for exact contact (not checked). Above
    /// `FrfSettings::period_tolerance` the verdict is undetermined.
    pub period_residual: Option<f64>,
    /// On the massless contact boundary (points in contact, docs/STABILITY.md Sec. 9): the
    /// scaled distance from the harmonic-balance orbit's start to the shot orbit's, whose
    /// multipliers these are; above `BOUNDARY_SHIFT_LIMIT` the verdict is undetermined. `None`
    /// where the massive model's monodromy and the period check were used.
    pub boundary_shift: Option<f64>,
    /// Where that boundary verdict was checked by one period of RK4 of the boundary model
    /// (`nlmodes_boundary::check_driven_by_rk4`): the larger of the change of the largest |mu|
    /// and the distance of the RK4 end state from the start (scaled); above
    /// `SHOOTING_CHECK_LIMIT` the verdict is undetermined. `None`: not checked.
    pub rk4_change: Option<f64>,
}

impl PointStability {
    pub(crate) fn on_boundary(b: &crate::boundary::BoundaryMonodromy, margin: f64) -> Self {
        Self::on_boundary_at(b, margin, b.shift, crate::boundary::BOUNDARY_SHIFT_LIMIT)
    }

    /// [`Self::on_boundary`] with the distance between the harmonic-balance orbit and the shot
    /// one measured as the caller says (`distance`, recorded as `boundary_shift`) and judged
    /// against `limit`: undetermined beyond it.
    pub(crate) fn on_boundary_at(
        b: &crate::boundary::BoundaryMonodromy,
        margin: f64,
        distance: f64,
        limit: f64,
    ) -> Self {
        let mut st = Self::of(&b.monodromy, margin);
        st.boundary_shift = Some(distance);
        if distance.is_nan() || distance > limit {
            st.verdict = Verdict::Undetermined;
        }
        // The orbit at the point's own W says otherwise: a bifurcation lies within the shift.
        if let Some(largest) = b.fixed_frequency_largest {
            if b.monodromy.verdict_of(largest, margin) != st.verdict {
                st.verdict = Verdict::Undetermined;
            }
        }
        st
    }

    /// This boundary verdict checked by one period of RK4 of `b`'s model (module docs of
    /// `nlmodes_boundary::rk4_check`): undetermined where the check disagrees or fails.
    pub(crate) fn verified(mut self, b: &BoundaryMonodromy) -> Self {
        match check_driven_by_rk4(b) {
            Ok(check) => {
                self.rk4_change = Some(check.max_multiplier_change.max(check.periodicity));
                if !check.agrees() {
                    tracing::warn!(
                        ?check,
                        "the RK4 check disagrees with the boundary's verdict"
                    );
                    self.verdict = Verdict::Undetermined;
                }
            }
            Err(e) => {
                tracing::warn!("the RK4 check of a boundary verdict failed: {e}");
                self.verdict = Verdict::Undetermined;
            }
        }
        self
    }

    pub(crate) fn of(mono: &SampledMonodromy, margin: f64) -> Self {
        let first = mono.multipliers.first().copied().unwrap_or([0.0, 0.0]);
        Self {
            verdict: mono.verdict(margin),
            largest_multiplier: Some(mono.largest()),
            argument: Some(first[1].atan2(first[0])),
            liouville_error: mono.liouville_error,
            bifurcation: None,
            period_residual: None,
            boundary_shift: None,
            rk4_change: None,
        }
    }

    /// Undetermined without a monodromy (see [`FrfSettings::period_tolerance`]).
    pub(crate) fn unchecked() -> Self {
        Self {
            verdict: Verdict::Undetermined,
            largest_multiplier: None,
            argument: None,
            liouville_error: None,
            bifurcation: None,
            period_residual: None,
            boundary_shift: None,
            rk4_change: None,
        }
    }

    /// The bifurcation between `previous` (the last determined point before this one) and this
    /// point, when this one is determined and differs.
    pub(crate) fn classify(&mut self, previous: &PointStability) {
        let determined = |v: Verdict| v != Verdict::Undetermined;
        if !(determined(self.verdict) && determined(previous.verdict))
            || self.verdict == previous.verdict
        {
            return;
        }
        let unstable = if self.verdict == Verdict::Unstable {
            *self
        } else {
            *previous
        };
        let arg = unstable.argument.unwrap_or(0.0).abs();
        self.bifurcation = Some(if arg < 0.05 {
            ForcedBifurcation::Fold
        } else if arg > std::f64::consts::PI - 0.05 {
            ForcedBifurcation::PeriodDoubling
        } else {
            ForcedBifurcation::NeimarkSacker
        });
    }
}

/// How a point is assessed: `margin` around |mu| = 1 (undetermined inside), the largest period
/// residual given a verdict (`FrfSettings`), and whether a verdict of the massless boundary is
/// checked by RK4 (`PointStability::rk4_change`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Assessment {
    pub margin: f64,
    pub period_tolerance: f64,
    pub verify: bool,
}

/// The Floquet stability of one converged `point` of `solver` (module docs): the massless
/// contact boundary's exact monodromy in contact, else the harmonic-balance orbit's backed by
/// one period of time integration, as `how` says (under a casing distortion the massless boundary's gaps
/// move with it: `ForcedSolver::boundary_monodromy`).
pub(crate) fn assess_point_with(
    solver: &ForcedSolver<'_>,
    point: &ForcedPoint,
    how: &Assessment,
) -> Result<PointStability, ForcedError> {
    let (margin, period_tolerance) = (how.margin, how.period_tolerance);
    let on_boundary = |b: &BoundaryMonodromy| {
        let st = PointStability::on_boundary(b, margin);
        if how.verify {
            st.verified(b)
        } else {
            st
        }
    };
    let boundary = |keep_all: bool| solver.boundary_monodromy(point, keep_all);
    let touching = point.touches();
    if touching {
        if let Some(b) = boundary(false)? {
            return Ok(on_boundary(&b));
        }
    }
    let residual = solver.period_residual(point);
    let mut st = if residual.is_some_and(|r| r > period_tolerance) {
        // Not a periodic solution of the equation the monodromy linearizes. Under a
        // penalty law on a model whose modes are all resolved, the exact periodic
        // orbit of that equation next to the point answers (its verdict, unless
        // farther than the shift limit); otherwise no verdict to compute.
        let exact = if touching && solver.every_mode_resolved(point.omega) {
            boundary(true)?
        } else {
            None
        };
        exact.map_or_else(PointStability::unchecked, |b| on_boundary(&b))
    } else {
        let mono = solver.monodromy(point)?;
        PointStability::of(&mono, margin)
    };
    st.period_residual = residual;
    Ok(st)
}
