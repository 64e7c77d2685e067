//! The `speed_sweep` stage's modules (DESIGN §1).

pub(crate) mod forced_speed;
pub(crate) mod forced_speed_casing;
pub(crate) mod forced_speed_command;
pub(crate) mod forced_speed_distortion;
pub(crate) mod forced_speed_figure;
pub(crate) mod forced_speed_output;
pub(crate) mod forced_speed_report;
pub(crate) mod forced_speed_stage;
pub(crate) mod speed_sweep_settings;
