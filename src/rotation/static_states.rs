//! The Campbell march's static states, kept for the speed stages (issue 39: the default case's
//! time). The Campbell stage marches the total-Lagrangian static state over its speeds, one
//! Newton step and a few chord steps each (docs/ROTATION.md, "Campbell diagram"); a speed stage
//! solving the same state at the operating speed from rest takes 4 Newton steps and 3 chord
//! steps (15 s on the default blade). So the Campbell stage (run first) writes its states to
//! `campbell/states/` (`states.json` and one `<rpm>rpm.f64` file each: the displacement on the
//! free DOFs, m, little-endian f64), and a speed stage starts from the state at its speed, or
//! the highest one below it ([`march_start`]): at the same speed the start is converged and
//! the stage assembles the tangent once. The states are a start, not a result: the speed
//! stage's state differs from the one reached from rest by less than the Newton tolerance
//! (1e-10 of the centrifugal load), and a missing, stale or unreadable file only means the
//! solve starts from rest (logged).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use nlmodes_fem::rotation::{Kinematics, StaticSolution};
use nlmodes_fem::DofMap;
use serde::{Deserialize, Serialize};

use crate::rotation::rotation_settings::RPM_TO_RAD_S;
use crate::stage_hash::fnv1a;

/// `states.json`: what the states are of.
#[derive(Debug, Serialize, Deserialize)]
struct StatesIndex {
    /// [`states_key`] of the model they were solved on.
    key: String,
    /// Number of free DOFs of each state.
    free_dofs: usize,
    /// The speeds, rpm, ascending, and each one's file (relative to the folder).
    speeds_rpm: Vec<f64>,
    files: Vec<String>,
}

/// What makes two static states comparable: the FE model (mesh, material, clamp: `fe_hash`),
/// the rotor axis (point, direction, m) and the prestress kinematics.
pub fn states_key(fe_hash: &str, axis: ([f64; 3], [f64; 3]), kinematics: &str) -> String {
    let inputs = serde_json::to_vec(&(axis, kinematics)).unwrap_or_default();
    fnv1a(&[fe_hash.as_bytes(), &inputs])
}

/// The folder of the states: `results/<case>/campbell/states/`.
pub fn states_dir(shared: &Path) -> PathBuf {
    shared.join("campbell").join("states")
}

/// Writes the total-Lagrangian `states` (any order) to `dir` under `key`; the index last, so
/// that an interrupted write leaves no index naming a missing file. Linear states are not
/// written (the linearized prestress is one linear solve: nothing to save).
pub fn write(dir: &Path, key: &str, states: &[StaticSolution]) -> Result<()> {
    let mut states: Vec<&StaticSolution> = states
        .iter()
        .filter(|s| s.kinematics == Kinematics::GreenLagrange)
        .collect();
    let Some(first) = states.first() else {
        return Ok(());
    };
    let free_dofs = first.displacement_free.len();
    states.sort_by(|a, b| a.omega.total_cmp(&b.omega));
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut index = StatesIndex {
        key: key.to_string(),
        free_dofs,
        speeds_rpm: Vec::with_capacity(states.len()),
        files: Vec::with_capacity(states.len()),
    };
    for s in states {
        let rpm = s.omega / RPM_TO_RAD_S;
        let file = format!("{rpm:.3}rpm.f64");
        let bytes: Vec<u8> = s
            .displacement_free
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        nlmodes_output::write_atomic(dir.join(&file), &bytes)?;
        index.speeds_rpm.push(rpm);
        index.files.push(file);
    }
    nlmodes_output::write_json(&dir.join("states.json"), &index)?;
    Ok(())
}

/// The state in `dir` to start the solve at `omega` (rad/s) from: the one at the highest speed
/// at most `omega` solved on a model with `key`, with `dofs`' free DOFs. `None` (logged at
/// debug level) when there is none, or it is stale or unreadable.
pub fn march_start(dir: &Path, key: &str, omega: f64, dofs: &DofMap) -> Option<StaticSolution> {
    match read_start(dir, key, omega, dofs) {
        Ok(start) => start,
        Err(e) => {
            tracing::debug!("no start from the Campbell march's states: {e:#}");
            None
        }
    }
}

fn read_start(dir: &Path, key: &str, omega: f64, dofs: &DofMap) -> Result<Option<StaticSolution>> {
    let index_path = dir.join("states.json");
    if !index_path.exists() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&index_path)
        .with_context(|| format!("cannot read {}", index_path.display()))?;
    let index: StatesIndex = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a states index", index_path.display()))?;
    if index.key != key || index.free_dofs != dofs.n_free() {
        return Ok(None);
    }
    let rpm = omega / RPM_TO_RAD_S;
    // The highest speed at most the target (a speed written with 3 decimals of rpm may round
    // up by 5e-4 rpm: such a state counts as at the target).
    let Some((k, &speed_rpm)) = index
        .speeds_rpm
        .iter()
        .enumerate()
        .filter(|(_, &s)| s <= rpm + 1e-3)
        .max_by(|a, b| a.1.total_cmp(b.1))
    else {
        return Ok(None);
    };
    let path = dir.join(&index.files[k]);
    let bytes = std::fs::read(&path).with_context(|| format!("cannot read {}", path.display()))?;
    if bytes.len() != 8 * index.free_dofs {
        anyhow::bail!(
            "{} holds {} bytes, expected {}",
            path.display(),
            bytes.len(),
            8 * index.free_dofs
        );
    }
    let free: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    if free.iter().any(|x| !x.is_finite()) {
        anyhow::bail!("{} holds a non-finite displacement", path.display());
    }
    let state_omega = (speed_rpm * RPM_TO_RAD_S).min(omega);
    Ok(Some(StaticSolution {
        omega: state_omega,
        kinematics: Kinematics::GreenLagrange,
        spin_softening_in_operator: true,
        displacement: dofs.try_expand(&free)?,
        displacement_free: free,
        steps: Vec::new(),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(rpm: f64, dofs: &DofMap, scale: f64) -> StaticSolution {
        let free: Vec<f64> = (0..dofs.n_free())
            .map(|i| scale * (i as f64 + 0.5).sin() * 1e-4)
            .collect();
        StaticSolution {
            omega: rpm * RPM_TO_RAD_S,
            kinematics: Kinematics::GreenLagrange,
            spin_softening_in_operator: true,
            displacement: dofs.try_expand(&free).unwrap(),
            displacement_free: free,
            steps: Vec::new(),
        }
    }

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("nlmodes-states-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    /// The state at the target speed, else the highest below it, bit for bit; none below the
    /// lowest, none under another key or DOF count, none from a truncated file.
    #[test]
    fn the_start_is_the_highest_state_at_most_the_target_bit_for_bit() {
        let dofs = DofMap::new(4, &[(0, 0), (0, 1), (0, 2)]).unwrap();
        let states = [
            state(8000.0, &dofs, 3.0),
            state(2000.0, &dofs, 1.0),
            state(5000.0, &dofs, 2.0),
        ];
        let d = dir("pick");
        write(&d, "k", &states).unwrap();
        let at =
            |rpm: f64, key: &str, dofs: &DofMap| march_start(&d, key, rpm * RPM_TO_RAD_S, dofs);
        let s = at(8000.0, "k", &dofs).expect("at 8000");
        assert_eq!(s.displacement_free, states[0].displacement_free);
        assert_eq!(s.displacement, states[0].displacement);
        assert_eq!(s.omega, 8000.0 * RPM_TO_RAD_S);
        let s = at(7000.0, "k", &dofs).expect("below 7000");
        assert_eq!(s.displacement_free, states[2].displacement_free);
        assert!((s.omega - 5000.0 * RPM_TO_RAD_S).abs() < 1e-12);
        let s = at(1e5, "k", &dofs).expect("above all");
        assert_eq!(s.displacement_free, states[0].displacement_free);
        assert!(at(1000.0, "k", &dofs).is_none(), "below the lowest");
        assert!(at(8000.0, "other", &dofs).is_none(), "another model");
        let other = DofMap::new(4, &[(0, 0)]).unwrap();
        assert!(at(8000.0, "k", &other).is_none(), "another DOF count");
        let index: StatesIndex =
            serde_json::from_str(&std::fs::read_to_string(d.join("states.json")).unwrap()).unwrap();
        std::fs::write(d.join(&index.files[2]), [0u8; 12]).unwrap();
        assert!(at(8000.0, "k", &dofs).is_none(), "a truncated file");
        let _ = std::fs::remove_dir_all(&d);
    }

    /// Linear states are not written (nothing to start from); no folder, no start.
    #[test]
    fn linear_states_are_not_kept() {
        let dofs = DofMap::new(2, &[]).unwrap();
        let mut s = state(1000.0, &dofs, 1.0);
        s.kinematics = Kinematics::Linear;
        let d = dir("linear");
        write(&d, "k", &[s]).unwrap();
        assert!(!d.exists());
        assert!(march_start(&d, "k", 2000.0 * RPM_TO_RAD_S, &dofs).is_none());
    }
}
