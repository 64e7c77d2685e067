//! The structure's block of a massless-boundary piece, decomposed once per active set and kept
//! across excitation frequencies (DESIGN §10.6).
//!
//! On the active set a the augmented generator of `driven_flow` is block upper triangular,
//!
//! ```text
//! X_a = [ A_a  F_a ]     A_a = [ 0, I; -W^2 - B_a^T R_aa^-1 B_a, -C_q ]   (2r x 2r),
//!       [ 0    D   ]     D   = diag([0, -h W; h W, 0] per drive harmonic h, 0),
//! ```
//!
//! and only D depends on the excitation frequency W, F_a on the drive and the gaps. A shooting
//! moves W at every Newton iteration (W is one of its unknowns, and its last column is a
//! difference in W), so decomposing X_a whole cost one eigen-decomposition per active set and
//! per W: the largest cost of the settled stability verdicts (session 28). A_a's decomposition
//! is kept here instead, by active set, for every W of one model ([`StructureCache`], shared by
//! `DrivenBoundary::at`), and `driven_flow` completes it for the drive in closed form.

use std::collections::HashMap;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::sync::{Arc, Mutex};

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef};

use nlmodes_dense::{balance, eigen_checked, Balanced};
use nlmodes_hb::HbError;

/// A_a = V diag(l) V^-1 (2r x 2r).
#[derive(Debug)]
pub(crate) struct StructureModes {
    /// l: the damped modes' eigenvalues (1/s).
    pub values: Vec<c64>,
    /// V.
    pub vectors: Mat<c64>,
    /// V^-1.
    pub inverse: Mat<c64>,
}

impl StructureModes {
    /// The decomposition of `a`, balanced first: A_a mixes q and q' ~ W q with entries from 1 to
    /// w_max^2, and unbalanced its eigenvectors carried errors of 1e-8..1e-6 of the orbit into
    /// the flow (docs/STABILITY.md 9.2).
    fn of(a: MatRef<'_, f64>) -> Result<Self, HbError> {
        let n = a.nrows();
        let Balanced { matrix, scales } = balance(a);
        let what = "a piece of the massless boundary";
        let (values, u) = eigen_checked(matrix.as_ref(), what).map_err(HbError::dense(what))?;
        let u_inverse = u.partial_piv_lu().solve(Mat::<c64>::identity(n, n));
        // A = D A_b D^-1 = (D U) diag(l) (U^-1 D^-1).
        Ok(Self {
            values,
            vectors: Mat::from_fn(n, n, |i, k| u[(i, k)] * scales[i]),
            inverse: Mat::from_fn(n, n, |i, k| u_inverse[(i, k)] / scales[k]),
        })
    }
}

/// The structure's decompositions of one model by active set, shared by its copies at other
/// W (`Clone` shares them). Each is stored with a fingerprint of the matrices it was made from
/// and made again when they differ (a model whose public fields were changed after its first
/// flow).
#[derive(Clone, Default)]
pub struct StructureCache {
    decompositions: Arc<Mutex<Decompositions>>,
}

/// The decompositions by active set, each with the fingerprint of its matrices.
type Decompositions = HashMap<Vec<bool>, (u64, Arc<StructureModes>)>;

impl std::fmt::Debug for StructureCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let held = self.decompositions.lock().map(|d| d.len()).unwrap_or(0);
        write!(f, "StructureCache({held} active sets)")
    }
}

/// Active sets kept at most: a period of the blade visits a few, a continuation of the exact
/// curve some tens; at 46 dynamic modes each holds two 92 x 92 complex matrices (270 kB), so a
/// full cache is about 17 MB (emptied, then refilled, past this).
const MOST_SETS: usize = 64;

impl StructureCache {
    /// The decomposition of A_a for `active`, made from `a` when none is held for the
    /// matrices of `fingerprint`.
    pub(crate) fn modes(
        &self,
        active: &[bool],
        fingerprint: u64,
        a: MatRef<'_, f64>,
    ) -> Result<Arc<StructureModes>, HbError> {
        let held = self.lock().get(active).cloned();
        if let Some((print, modes)) = held {
            if print == fingerprint {
                return Ok(modes);
            }
        }
        let modes = shared_modes(active, fingerprint, a)?;
        let mut map = self.lock();
        if map.len() >= MOST_SETS {
            map.clear();
        }
        map.insert(active.to_vec(), (fingerprint, Arc::clone(&modes)));
        Ok(modes)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Decompositions> {
        // A panic elsewhere while the map was held leaves it whole (inserts are single calls).
        self.decompositions
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

/// Decompositions shared by every model of the run, keyed by the fingerprint and the active set
/// and held with the matrix they were made from: a hit is one whose matrix equals `a` to the
/// bit, so it is the decomposition `a` would get. The settled verdicts of a curve's points (a
/// new model per point and rung, the same dynamic modes from one point to the next), its exact
/// force and its exact curve decompose the same A_a again otherwise (session 30: 5 % of the CPU
/// of the default blade's level 5).
type Shared = HashMap<(u64, Vec<bool>), (Mat<f64>, Arc<StructureModes>)>;

/// Shared decompositions kept at most (at 46 dynamic modes a 92 x 92 matrix and its
/// decomposition, about 340 kB each: 44 MB full; emptied, then refilled, past this).
const MOST_SHARED: usize = 128;

/// The decomposition of `a` from the run's shared ones, made and shared when none matches.
fn shared_modes(
    active: &[bool],
    fingerprint: u64,
    a: MatRef<'_, f64>,
) -> Result<Arc<StructureModes>, HbError> {
    static SHARED: std::sync::OnceLock<Mutex<Shared>> = std::sync::OnceLock::new();
    let shared = SHARED.get_or_init(Default::default);
    let lock = || {
        shared
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    };
    let key = (fingerprint, active.to_vec());
    let same = |held: &Mat<f64>| {
        held.nrows() == a.nrows()
            && held.ncols() == a.ncols()
            && (0..a.ncols())
                .all(|j| (0..a.nrows()).all(|i| held[(i, j)].to_bits() == a[(i, j)].to_bits()))
    };
    if let Some((held, modes)) = lock().get(&key) {
        if same(held) {
            return Ok(Arc::clone(modes));
        }
    }
    let modes = Arc::new(StructureModes::of(a)?);
    let mut map = lock();
    if map.len() >= MOST_SHARED {
        map.clear();
    }
    map.insert(key, (a.to_owned(), Arc::clone(&modes)));
    Ok(modes)
}

/// A fingerprint of the values A_a is made of (their bits, mixed word by word, then their
/// count through SipHash): a guard against a model changed in place, not a defence against
/// chosen inputs.
pub(crate) fn fingerprint(values: impl Iterator<Item = f64>) -> u64 {
    let (mut mixed, mut count) = (0x9e37_79b9_7f4a_7c15_u64, 0_u64);
    for v in values {
        mixed = (mixed ^ v.to_bits())
            .wrapping_mul(0x0000_0100_0000_01b3)
            .rotate_left(29);
        count += 1;
    }
    let mut hasher = DefaultHasher::new();
    (mixed, count).hash(&mut hasher);
    hasher.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A_a of a two-mode structure (2 x 2 blocks: 0, I; -K, -C) whose stiffness entry (0, 0)
    /// is `k`.
    fn generator(k: f64) -> Mat<f64> {
        let (stiffness, damping) = ([[k, -1.0], [-1.0, 3.0]], [[0.02, 0.0], [0.0, 0.05]]);
        Mat::from_fn(4, 4, |i, j| match (i < 2, j < 2) {
            (true, true) => 0.0,
            (true, false) => f64::from(u8::from(j - 2 == i)),
            (false, true) => -stiffness[i - 2][j],
            (false, false) => -damping[i - 2][j - 2],
        })
    }

    /// Two models (two caches) with the same matrices share one decomposition; a matrix that
    /// differs in one entry's last bit under the same fingerprint and active set gets its own,
    /// which rebuilds that matrix (V diag(l) V^-1 = A to round-off).
    #[test]
    fn models_with_the_same_matrices_share_a_decomposition_and_others_do_not() {
        let active = [true, false, true];
        let print = 0x5eed_0f5c_a1ed_u64;
        let a = generator(2.0);
        let first = StructureCache::default()
            .modes(&active, print, a.as_ref())
            .unwrap();
        let second = StructureCache::default()
            .modes(&active, print, a.as_ref())
            .unwrap();
        assert!(Arc::ptr_eq(&first, &second));
        let nudged = generator(f64::from_bits(2.0_f64.to_bits() + 1));
        let other = StructureCache::default()
            .modes(&active, print, nudged.as_ref())
            .unwrap();
        assert!(!Arc::ptr_eq(&first, &other));
        let n = nudged.nrows();
        for i in 0..n {
            for j in 0..n {
                let rebuilt: c64 = (0..n)
                    .map(|k| other.vectors[(i, k)] * other.values[k] * other.inverse[(k, j)])
                    .sum();
                assert!((rebuilt - c64::new(nudged[(i, j)], 0.0)).norm() < 1e-12);
            }
        }
    }
}
