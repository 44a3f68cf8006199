pub mod matrix_market;
