//! Links the system OpenBLAS, which exports the BLAS and LAPACK (Fortran ABI)
//! symbols used by `blas`/`lapack` and so by clarabel's PSD cone.
#![no_std]

#[link(name = "openblas")]
unsafe extern "C" {}
