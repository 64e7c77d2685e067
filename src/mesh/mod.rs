//! The `mesh` stage's modules (DESIGN §1).

pub(crate) mod fe_model;
pub(crate) mod gmsh;
pub(crate) mod mesh_stage;
