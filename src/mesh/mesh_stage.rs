//! The `mesh` stage of `nlmodes run`: gmsh meshes the case's `.geo` with its parameters and
//! order into `mesh.msh`. Reruns when the `.geo` file's bytes, `[mesh] parameters` or `order`
//! change.

use anyhow::{Context, Result};
use std::path::PathBuf;

use crate::case::Case;
use crate::layout::Layout;
use crate::stage::{json, Only, Stage};
use crate::stage_hash::fnv1a;

pub struct MeshStage<'a> {
    case: &'a Case,
    layout: &'a Layout,
    hash: String,
}

impl<'a> MeshStage<'a> {
    /// Reads the `.geo` file (its bytes are an input).
    pub fn new(case: &'a Case, layout: &'a Layout) -> Result<Self> {
        let geo = std::fs::read(&case.mesh.geo)
            .with_context(|| format!("cannot read the geometry {}", case.mesh.geo.display()))?;
        let hash = fnv1a(&[&geo, &json(&case.mesh.parameters), &json(&case.mesh.order)]);
        Ok(Self { case, layout, hash })
    }
}

impl Stage for MeshStage<'_> {
    fn name(&self) -> String {
        "mesh".into()
    }
    fn only(&self) -> Only {
        Only::Mesh
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        vec![self.layout.mesh()]
    }
    fn work(&self) -> Result<()> {
        let st = crate::ui::Stage::start("mesh");
        let m = &self.case.mesh;
        crate::mesh::gmsh::mesh(&m.geo, &m.parameters, m.order, &self.layout.mesh())?;
        st.done(&format!("wrote {}", self.layout.mesh().display()));
        Ok(())
    }
}
