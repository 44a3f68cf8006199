//! Column-major blocks of directions (`n × k`, column stride ≥ n), the currency of the
//! variational equations. Kept independent of the linear-algebra crate so implementors of
//! [`super::SecondOrderSystem`] need nothing but slices.

/// A borrowed `rows × cols` column-major block with column stride `stride`.
#[derive(Debug, Clone, Copy)]
pub struct Block<'a> {
    /// The entries: column `c` is `data[c·stride .. c·stride + rows]`.
    pub data: &'a [f64],
    /// Rows: the length of one direction.
    pub rows: usize,
    /// Columns: the number of directions.
    pub cols: usize,
    /// Offset between the starts of consecutive columns (`≥ rows`).
    pub stride: usize,
}

/// The mutable counterpart of [`Block`].
#[derive(Debug)]
pub struct BlockMut<'a> {
    /// The entries: column `c` is `data[c·stride .. c·stride + rows]`.
    pub data: &'a mut [f64],
    /// Rows: the length of one direction.
    pub rows: usize,
    /// Columns: the number of directions.
    pub cols: usize,
    /// Offset between the starts of consecutive columns (`≥ rows`).
    pub stride: usize,
}

impl<'a> Block<'a> {
    /// A view of `data` as `rows × cols` with column stride `stride` (the length is checked in
    /// debug builds).
    pub fn new(data: &'a [f64], rows: usize, cols: usize, stride: usize) -> Self {
        debug_assert!(cols == 0 || data.len() >= (cols - 1) * stride + rows);
        Self {
            data,
            rows,
            cols,
            stride,
        }
    }
    /// Column `c`.
    pub fn col(&self, c: usize) -> &'a [f64] {
        &self.data[c * self.stride..c * self.stride + self.rows]
    }
}

impl<'a> BlockMut<'a> {
    /// A mutable view of `data` as `rows × cols` with column stride `stride` (the length is
    /// checked in debug builds).
    pub fn new(data: &'a mut [f64], rows: usize, cols: usize, stride: usize) -> Self {
        debug_assert!(cols == 0 || data.len() >= (cols - 1) * stride + rows);
        Self {
            data,
            rows,
            cols,
            stride,
        }
    }
    /// Column `c`, mutable.
    pub fn col_mut(&mut self, c: usize) -> &mut [f64] {
        &mut self.data[c * self.stride..c * self.stride + self.rows]
    }
}
