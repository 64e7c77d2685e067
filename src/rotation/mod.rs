//! The `rotation` stage's modules (DESIGN §1).

pub(crate) mod prestress;
pub(crate) mod rotation_mpi;
pub(crate) mod rotation_settings;
pub(crate) mod speed_stage;
pub(crate) mod static_states;
