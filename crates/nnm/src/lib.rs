//! # nnm — nonlinear normal modes
//!
//! Computes branches of periodic motions (NNMs) of conservative structures
//! `M x'' + K x + f_nl(x) = 0` by shooting with sensitivity analysis and pseudo-arclength
//! continuation, with Floquet stability (see SPEC.md for the method).
//!
//! The crate is the numerical core and does no file or terminal I/O. Its layers:
//! - [`model`]: the mechanical model and the traits through which any system plugs in;
//! - [`modes`]: linear modal analysis (the starting points of NNM branches);
//! - [`integrate`]: Runge–Kutta integration of the motion with its variational equations;
//! - [`shooting`]: the periodicity problem `H(z0, T) = z(T; z0) - z0 = 0` and its Jacobian;
//! - [`continuation`]: pseudo-arclength continuation of a branch;
//! - [`floquet`]: multipliers and stability;
//! - [`bifurcation`]: folds, branch points, period doublings and Krein collisions along a
//!   branch, located to the continuation tolerance, and branch switching;
//! - [`symmetry`]: mirror symmetry of cyclic structures and the invariant subspaces it gives;
//! - [`analysis`]: harmonics, shape change and energy localization of computed NNMs;
//! - [`reference`]: exact solutions used for validation.

pub mod analysis;
pub mod bifurcation;
pub mod continuation;
pub mod floquet;
pub mod integrate;
pub mod linalg;
pub mod model;
pub mod modes;
pub mod reference;
pub mod shooting;
pub mod symmetry;
