//! File formats of nnm: job files (TOML), Matrix Market matrices, Gmsh meshes, and result files
//! (CSV/JSON); a job's model written back as finite-element files (`export`). The numerical
//! core (`nnm`) knows nothing of files; this crate is the bridge.

mod error;
pub use error::FileError;
pub mod export;
pub mod gmsh;
pub mod job;
pub mod matrix_market;
pub mod output;
pub mod tensor_file;
pub mod vtk;
