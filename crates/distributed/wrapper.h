/* The PETSc, SLEPc and MPI declarations nlmodes-distributed binds (build.rs runs bindgen on it). */
#include <petscmat.h>
#include <petscksp.h>
#include <petscpc.h>
#include <slepceps.h>
