//! What the check of a point's N found (DESIGN §10.8): the verdict each point of a forced
//! response carries, set by `ladder`.

/// What the check of a point's N found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HarmonicCheck {
    /// Not checked (the default of a solve).
    Unchecked,
    /// No contact: the orbit is exact at any N.
    Linear,
    /// Doubling N moved the master's first harmonic and W by the relative `change` = [q, W],
    /// both within the tolerance.
    Converged {
        /// [|dq1| / q1, |dW| / W] at 2N.
        change: [f64; 2],
    },
    /// Still moving at the top of the ladder (`change` at its last doubling), or the solve at
    /// 2N failed (`change` None).
    NotConverged {
        /// [|dq1| / q1, |dW| / W] at the last doubling, when that solve converged.
        change: Option<[f64; 2]>,
    },
}
