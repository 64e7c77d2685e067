//! Thin safe wrappers of the PETSc objects the crate uses: each owns its handle and destroys it
//! on drop; every call goes through [`check`].

use crate::error::{DistributedError, Result};
use crate::ffi;

/// `PETSC_DEFAULT` (a macro in petscsys.h).
pub const PETSC_DEFAULT: ffi::PetscInt = -2;
/// `PETSC_DECIDE` / `PETSC_DETERMINE`.
pub const PETSC_DECIDE: ffi::PetscInt = -1;

/// Turns a PETSc error code into an error naming the call.
pub fn check(code: ffi::PetscErrorCode, call: &'static str) -> Result<()> {
    if code == 0 {
        Ok(())
    } else {
        Err(DistributedError::Petsc { call, code })
    }
}

/// The communicator of every object: PETSC_COMM_WORLD (MPI_COMM_WORLD).
pub fn comm() -> ffi::MPI_Comm {
    // SAFETY: a plain read of PETSc's global, set by PetscInitialize.
    unsafe { ffi::PETSC_COMM_WORLD }
}

/// PetscInt of an index or a count, or an error if it does not fit (Debian's PETSc has 32-bit
/// indices).
pub fn int(n: usize) -> Result<ffi::PetscInt> {
    ffi::PetscInt::try_from(n).map_err(|_| {
        DistributedError::Invalid(format!(
            "{n} does not fit PETSc's 32-bit indices (PetscInt): a PETSc built with \
             --with-64-bit-indices is needed"
        ))
    })
}

/// A PETSc matrix (sparse AIJ or dense).
pub struct Matrix(pub ffi::Mat);

impl Drop for Matrix {
    fn drop(&mut self) {
        // SAFETY: the handle is owned; MatDestroy accepts a null one.
        unsafe {
            ffi::MatDestroy(&mut self.0);
        }
    }
}

impl Matrix {
    /// Global order (rows, columns).
    pub fn size(&self) -> Result<(usize, usize)> {
        let (mut m, mut n) = (0, 0);
        check(
            unsafe { ffi::MatGetSize(self.0, &mut m, &mut n) },
            "MatGetSize",
        )?;
        Ok((m as usize, n as usize))
    }

    /// The rows this rank owns, [first, end).
    pub fn owned_rows(&self) -> Result<std::ops::Range<usize>> {
        let (mut lo, mut hi) = (0, 0);
        check(
            unsafe { ffi::MatGetOwnershipRange(self.0, &mut lo, &mut hi) },
            "MatGetOwnershipRange",
        )?;
        Ok(lo as usize..hi as usize)
    }

    /// The submatrix of `rows` x `cols` (each index set lists what this rank keeps).
    pub fn submatrix(&self, rows: &IndexSet, cols: &IndexSet) -> Result<Matrix> {
        let mut sub = std::ptr::null_mut();
        check(
            unsafe {
                ffi::MatCreateSubMatrix(
                    self.0,
                    rows.0,
                    cols.0,
                    ffi::MatReuse::MAT_INITIAL_MATRIX,
                    &mut sub,
                )
            },
            "MatCreateSubMatrix",
        )?;
        Ok(Matrix(sub))
    }

    /// Sets a flag of the matrix (MAT_SYMMETRIC, MAT_SPD, ...).
    pub fn set_option(&self, option: ffi::MatOption) -> Result<()> {
        check(
            unsafe { ffi::MatSetOption(self.0, option, ffi::PetscBool::PETSC_TRUE) },
            "MatSetOption",
        )
    }

    /// A dense matrix with the row layout of this one and `ncols` columns, zeroed.
    pub fn dense_like_rows(&self, ncols: usize) -> Result<Matrix> {
        Matrix::dense(self.owned_rows()?.len(), ncols)
    }

    /// A dense matrix with `local_rows` rows on this rank and `ncols` columns, zeroed.
    pub fn dense(local_rows: usize, ncols: usize) -> Result<Matrix> {
        let mut d = std::ptr::null_mut();
        check(
            unsafe {
                ffi::MatCreateDense(
                    comm(),
                    int(local_rows)?,
                    PETSC_DECIDE,
                    PETSC_DECIDE,
                    int(ncols)?,
                    std::ptr::null_mut(),
                    &mut d,
                )
            },
            "MatCreateDense",
        )?;
        let d = Matrix(d);
        d.assemble()?;
        Ok(d)
    }

    /// MatAssemblyBegin + End (final assembly): communicates the entries set for rows owned
    /// by other ranks.
    pub fn assemble(&self) -> Result<()> {
        check(
            unsafe { ffi::MatAssemblyBegin(self.0, ffi::MatAssemblyType::MAT_FINAL_ASSEMBLY) },
            "MatAssemblyBegin",
        )?;
        check(
            unsafe { ffi::MatAssemblyEnd(self.0, ffi::MatAssemblyType::MAT_FINAL_ASSEMBLY) },
            "MatAssemblyEnd",
        )
    }

    /// The product self * b of this sparse matrix and a dense one (a new dense matrix).
    pub fn times_dense(&self, b: &Matrix) -> Result<Matrix> {
        let mut c = std::ptr::null_mut();
        check(
            unsafe {
                ffi::MatMatMult(
                    self.0,
                    b.0,
                    ffi::MatReuse::MAT_INITIAL_MATRIX,
                    PETSC_DEFAULT as f64,
                    &mut c,
                )
            },
            "MatMatMult",
        )?;
        Ok(Matrix(c))
    }

    /// y = self x.
    pub fn mult(&self, x: &Vector, y: &Vector) -> Result<()> {
        check(unsafe { ffi::MatMult(self.0, x.0, y.0) }, "MatMult")
    }

    /// A vector with the row layout of this matrix.
    pub fn row_vector(&self) -> Result<Vector> {
        let mut v = std::ptr::null_mut();
        check(
            unsafe { ffi::MatCreateVecs(self.0, std::ptr::null_mut(), &mut v) },
            "MatCreateVecs",
        )?;
        Ok(Vector(v))
    }

    /// The local rows of a dense matrix, column-major (`local rows x columns`).
    pub fn dense_local(&self) -> Result<faer::Mat<f64>> {
        let rows = self.owned_rows()?.len();
        let (_, ncols) = self.size()?;
        let (mut ptr, mut lda) = (std::ptr::null_mut(), 0);
        check(
            unsafe { ffi::MatDenseGetArray(self.0, &mut ptr) },
            "MatDenseGetArray",
        )?;
        check(
            unsafe { ffi::MatDenseGetLDA(self.0, &mut lda) },
            "MatDenseGetLDA",
        )?;
        let lda = lda as usize;
        // SAFETY: PETSc gives lda * ncols values, column-major, for the local rows.
        let local = faer::Mat::from_fn(rows, ncols, |r, c| unsafe { *ptr.add(c * lda + r) });
        check(
            unsafe { ffi::MatDenseRestoreArray(self.0, &mut ptr) },
            "MatDenseRestoreArray",
        )?;
        Ok(local)
    }

    /// Overwrites the local rows of a dense matrix with `local` (same shape).
    pub fn set_dense_local(&self, local: faer::MatRef<'_, f64>) -> Result<()> {
        let (mut ptr, mut lda) = (std::ptr::null_mut(), 0);
        check(
            unsafe { ffi::MatDenseGetArray(self.0, &mut ptr) },
            "MatDenseGetArray",
        )?;
        check(
            unsafe { ffi::MatDenseGetLDA(self.0, &mut lda) },
            "MatDenseGetLDA",
        )?;
        let lda = lda as usize;
        for c in 0..local.ncols() {
            for r in 0..local.nrows() {
                // SAFETY: within the local block PETSc gave.
                unsafe { *ptr.add(c * lda + r) = local[(r, c)] };
            }
        }
        check(
            unsafe { ffi::MatDenseRestoreArray(self.0, &mut ptr) },
            "MatDenseRestoreArray",
        )
    }
}

/// A PETSc vector.
pub struct Vector(pub ffi::Vec);

impl Drop for Vector {
    fn drop(&mut self) {
        // SAFETY: the handle is owned.
        unsafe {
            ffi::VecDestroy(&mut self.0);
        }
    }
}

impl Vector {
    /// A copy of the local entries.
    pub fn local(&self) -> Result<Vec<f64>> {
        let mut n = 0;
        check(
            unsafe { ffi::VecGetLocalSize(self.0, &mut n) },
            "VecGetLocalSize",
        )?;
        let mut ptr = std::ptr::null();
        check(
            unsafe { ffi::VecGetArrayRead(self.0, &mut ptr) },
            "VecGetArrayRead",
        )?;
        // SAFETY: PETSc gives the n local entries.
        let values = unsafe { std::slice::from_raw_parts(ptr, n as usize) }.to_vec();
        check(
            unsafe { ffi::VecRestoreArrayRead(self.0, &mut ptr) },
            "VecRestoreArrayRead",
        )?;
        Ok(values)
    }

    /// Overwrites the local entries.
    pub fn set_local(&self, values: &[f64]) -> Result<()> {
        let mut ptr = std::ptr::null_mut();
        check(unsafe { ffi::VecGetArray(self.0, &mut ptr) }, "VecGetArray")?;
        // SAFETY: the caller passes exactly the local length (checked by the slice copy).
        let local = unsafe { std::slice::from_raw_parts_mut(ptr, values.len()) };
        local.copy_from_slice(values);
        check(
            unsafe { ffi::VecRestoreArray(self.0, &mut ptr) },
            "VecRestoreArray",
        )
    }
}

/// A PETSc index set.
pub struct IndexSet(pub ffi::IS);

impl Drop for IndexSet {
    fn drop(&mut self) {
        // SAFETY: the handle is owned.
        unsafe {
            ffi::ISDestroy(&mut self.0);
        }
    }
}

impl IndexSet {
    /// The index set of `indices` (global numbering) on this rank.
    pub fn new(indices: &[usize]) -> Result<Self> {
        let idx = indices
            .iter()
            .map(|&i| int(i))
            .collect::<Result<Vec<_>>>()?;
        let mut is = std::ptr::null_mut();
        check(
            unsafe {
                ffi::ISCreateGeneral(
                    comm(),
                    int(idx.len())?,
                    idx.as_ptr(),
                    ffi::PetscCopyMode::PETSC_COPY_VALUES,
                    &mut is,
                )
            },
            "ISCreateGeneral",
        )?;
        Ok(IndexSet(is))
    }
}

impl Matrix {
    /// `visit(local row, column, value)` for every stored entry of this rank's rows of a
    /// sparse matrix.
    pub fn for_each_local_entry(&self, mut visit: impl FnMut(usize, usize, f64)) -> Result<()> {
        let rows = self.owned_rows()?;
        for (li, row) in rows.enumerate() {
            let row = int(row)?;
            let (mut n, mut cols, mut vals) = (0, std::ptr::null(), std::ptr::null());
            check(
                unsafe { ffi::MatGetRow(self.0, row, &mut n, &mut cols, &mut vals) },
                "MatGetRow",
            )?;
            for t in 0..n as usize {
                // SAFETY: PETSc gives n column indices and values.
                let (c, v) = unsafe { (*cols.add(t), *vals.add(t)) };
                visit(li, c as usize, v);
            }
            check(
                unsafe { ffi::MatRestoreRow(self.0, row, &mut n, &mut cols, &mut vals) },
                "MatRestoreRow",
            )?;
        }
        Ok(())
    }
}

/// The value of a string option of the PETSc options database (PETSC_OPTIONS, the command
/// line), `None` when it is not set.
pub fn option_string(name: &std::ffi::CStr) -> Result<Option<String>> {
    let mut buffer = [0 as std::os::raw::c_char; 256];
    let mut set = ffi::PetscBool::PETSC_FALSE;
    check(
        unsafe {
            ffi::PetscOptionsGetString(
                std::ptr::null_mut(),
                std::ptr::null(),
                name.as_ptr(),
                buffer.as_mut_ptr(),
                buffer.len(),
                &mut set,
            )
        },
        "PetscOptionsGetString",
    )?;
    if set != ffi::PetscBool::PETSC_TRUE {
        return Ok(None);
    }
    // SAFETY: PETSc wrote a NUL-terminated string into the buffer.
    let value = unsafe { std::ffi::CStr::from_ptr(buffer.as_ptr()) };
    Ok(Some(value.to_string_lossy().into_owned()))
}

/// Peak resident memory of this process so far (VmHWM of /proc/self/status), GB; 0 if unknown.
pub fn peak_rss_gb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kib| kib * 1024.0 / 1e9)
}
