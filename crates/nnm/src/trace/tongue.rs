//! Tongues met by the main branch (docs/DESIGN.md §8.3): their detection (energy shares, or a
//! fold of q toward another mode's harmonic), corners that are not tongues, and the tongue
//! followed as its own branch.

use super::{distance, Advance, Continuation, Entry, Trace};
use crate::continuation::{BranchKind, InternalResonance, Termination};
use crate::point::BackbonePoint;

impl<'s, 'c, F: FnMut(&BackbonePoint)> Continuation<'s, 'c, F> {
    /// Whether the main branch enters an internal-resonance tongue at `p`: its energy has moved
    /// into another mode at a harmonic n >= 2 (`ContinuationSettings::tongue`) within
    /// `resonance_tolerance` of that mode's linear frequency, or q turns back (a fold from rising
    /// to falling q; the main branch of a stiffening contact mode rises in q except in the
    /// tongues, where the energy flows into another mode while q passes a maximum), then at any
    /// detuning if the energy has moved.
    /// A turn of q by a step accepted as a jump, or with no other mode's harmonic n >= 2 as the
    /// largest secondary component, is a corner ([`Entry::Corner`]), not a tongue.
    pub(super) fn tongue_entry(
        &self,
        trace: &Trace,
        p: &BackbonePoint,
        xn: &[f64],
    ) -> Option<Entry> {
        let by_energy = self.cont.tongue(p, &self.omegas);
        if let Some(res) = &by_energy {
            if res.detuning.abs() <= self.cont.resonance_tolerance {
                return by_energy.map(Entry::Tongue);
            }
        }
        let xl = self.scaled(self.last_point(trace));
        let turns_back = trace.points.len() > 1 && trace.dq_sign > 0.0 && xn[0] < xl[0];
        if !turns_back || self.cont.skip_folds {
            return None;
        }
        if by_energy.is_some() {
            // q turns back while another mode's harmonic holds the energy: a tongue, however far
            // from its linear frequency (and even at a jump).
            return by_energy.map(Entry::Tongue);
        }
        let resonant = p.secondary_harmonic >= 2 && p.secondary_mode != p.mode;
        if p.jump || !resonant {
            return Some(Entry::Corner);
        }
        let wk = self
            .omegas
            .get(p.secondary_mode)
            .copied()
            .unwrap_or(f64::NAN);
        Some(Entry::Tongue(InternalResonance {
            q: p.q,
            omega_ratio: p.omega_ratio,
            mode: p.secondary_mode,
            harmonic: p.secondary_harmonic,
            share: p.secondary_share,
            detuning: (p.secondary_harmonic as f64 * p.omega - wk) / wk,
            passed: None,
            unjoined: None,
            fill_back_stop: None,
            branch: None,
        }))
    }

    /// The main branch met a tongue at `p`: record it, follow the tongue as its own branch
    /// (unless skipped), then continue the main branch past it. Returns false if the run ends.
    pub(super) fn pass_tongue(
        &mut self,
        main: &mut Trace,
        p: BackbonePoint,
        res: InternalResonance,
    ) -> bool {
        tracing::info!(
            q_over_g0 = p.q / self.g_ref,
            omega_ratio = p.omega_ratio,
            "internal resonance: harmonic {} of the orbit is near linear mode {}",
            res.harmonic,
            res.mode + 1
        );
        let record = self.result.internal_resonances.len();
        self.result.internal_resonances.push(res.clone());
        if !self.cont.skip_internal_resonances {
            let branch = self.follow_tongue(main, p, &res);
            self.result.internal_resonances[record].branch = Some(branch);
        }
        self.unjoined = None;
        let passed = self.step_past(main);
        self.result.internal_resonances[record].passed = passed;
        if let Some((gap, why)) = self.unjoined.take() {
            self.result.internal_resonances[record].unjoined = Some(gap);
            self.result.internal_resonances[record].fill_back_stop = Some(why);
        }
        if passed.is_none() {
            let q = self.last_point(main).q;
            self.result.termination = Termination::InternalResonance {
                q,
                mode: res.mode,
                harmonic: res.harmonic,
            };
            self.end_branch(main.id, "internal resonance not passed");
        }
        passed.is_some()
    }

    /// Follows a tongue from the main branch's last point through its first point `p`, for at
    /// most `tongue_points` points, until it leaves the resonance (its energy shares no longer
    /// show it, and, for a tongue entered by a fold of q, q no longer falls while the primary
    /// component's share shrinks), turns to q <= 0 or passes q_max. Returns the branch id.
    pub(super) fn follow_tongue(
        &mut self,
        main: &Trace,
        p: BackbonePoint,
        res: &InternalResonance,
    ) -> usize {
        let kind = BranchKind::Tongue {
            mode: res.mode,
            harmonic: res.harmonic,
        };
        let id = self.new_branch(Some(main.id), kind);
        let mut trace = Trace {
            id,
            points: vec![main.points[main.points.len() - 1]],
            tangent: main.tangent.clone(),
            ds: main.ds,
            last_ds: main.last_ds,
            dq_sign: main.dq_sign,
            folds: 0,
            penetrate: false,
        };
        // Entered by a fold of q before the energy shares show the resonance: followed while q
        // keeps falling and the primary component's share keeps shrinking (energy flowing out of
        // the traced mode; a fold of the main branch itself, traced back, gains it back), as well
        // as while the shares show it.
        let by_fold = self.cont.tongue(&p, &self.omegas).is_none();
        let mut primary = p.primary_share;
        let xn = self.scaled(&p);
        let step = distance(&xn, &self.scaled(self.last_point(&trace)));
        self.accept(&mut trace, p, &xn, step);
        let mut why = "tongue point limit";
        for _ in 1..self.cont.tongue_points {
            if self.result.points.len() >= self.cont.max_points {
                why = "point limit";
                break;
            }
            let (p, xn, step) = match self.advance(&mut trace, false) {
                Advance::Retry => continue,
                Advance::Stuck(_) => {
                    why = "step too small";
                    break;
                }
                Advance::Converged(p, xn, step) => (p, xn, step),
            };
            if xn[0] <= 0.0 || xn[0] >= self.cont.q_max {
                why = "left the amplitude range";
                break;
            }
            let falling = xn[0] < self.scaled(self.last_point(&trace))[0];
            let draining = p.primary_share < primary;
            primary = p.primary_share;
            let inside =
                self.cont.tongue(&p, &self.omegas).is_some() || (by_fold && falling && draining);
            self.accept(&mut trace, *p, &xn, step);
            if !inside {
                why = "left the resonance";
                break;
            }
        }
        self.end_branch(id, why);
        id
    }

    /// Continues the main branch past a corner (no arc-length step converges there, or q turns
    /// back by a jump or with no other mode taking the energy) as past a tongue, without
    /// recording an internal resonance. Returns whether it got past.
    pub(super) fn pass_corner(&mut self, trace: &mut Trace) -> bool {
        let passed = self.step_past(trace).is_some();
        if passed {
            tracing::info!(
                q_over_g0 = self.last_point(trace).q / self.result.gap_reference,
                "continued past a corner of the main branch"
            );
        }
        passed
    }
}
