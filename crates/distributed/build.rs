//! With the `petsc` feature: find PETSc and SLEPc through pkg-config (Debian: `PETSc.pc`,
//! `SLEPc.pc` of petsc-dev and slepc-dev) and generate the bindings of `wrapper.h` with bindgen,
//! only the functions, types and constants of PETSc, SLEPc and MPI that the crate calls.

fn main() {
    #[cfg(feature = "petsc")]
    petsc_bindings();
}

#[cfg(feature = "petsc")]
fn petsc_bindings() {
    println!("cargo:rerun-if-changed=wrapper.h");
    let mut include_paths = Vec::new();
    for name in ["PETSc", "SLEPc", "mpi"] {
        let lib = pkg_config::Config::new().probe(name).unwrap_or_else(|e| {
            panic!(
                "nlmodes-distributed: {name} not found by pkg-config ({e}); install petsc-dev \
                     and slepc-dev (scripts/deps) or build without MPI support \
                     (cargo build --no-default-features)"
            )
        });
        include_paths.extend(lib.include_paths);
    }
    let mut builder = bindgen::Builder::default()
        .header("wrapper.h")
        .allowlist_function("(Petsc|Slepc|Mat|Vec|KSP|PC|EPS|ST|IS|MPI)[A-Za-z_]*")
        .allowlist_var("(PETSC|MAT|KSP|PC|EPS|ST|MPI|ompi)_[A-Za-z_0-9]*")
        .allowlist_type("(Petsc|Mat|Vec|KSP|PC|EPS|ST|IS|MPI)[A-Za-z_]*")
        .rustified_enum("(PetscBool|InsertMode|MatAssemblyType|MatOption|EPSProblemType|EPSWhich|MatReuse|MatFactorType|PetscCopyMode|EPSConvergedReason)")
        .layout_tests(false)
        .generate_comments(false)
        .parse_callbacks(Box::new(bindgen::CargoCallbacks));
    for p in &include_paths {
        builder = builder.clang_arg(format!("-I{}", p.display()));
    }
    let bindings = builder
        .generate()
        .expect("nlmodes-distributed: bindgen could not parse the PETSc/SLEPc headers");
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    bindings
        .write_to_file(out.join("petsc_bindings.rs"))
        .expect("nlmodes-distributed: cannot write the bindings");
}
