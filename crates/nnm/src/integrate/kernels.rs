//! The fused linear-combination kernel of the Runge–Kutta stages: `out = base + Σ c_t x_t`
//! over whole state or sensitivity blocks, in L1-sized chunks with an AVX2 build chosen at
//! run time (the integrator's hot loop).

/// At most this many terms in one combination (stages + 1).
pub(super) const MAX_TERMS: usize = 24;

/// The `(coefficient, block)` terms of one linear combination, on the stack.
///
/// Left uninitialised beyond `len`: filling all slots cost ~5% of a small system's
/// integration (Duffing), where a combination has only a few two-entry terms.
pub(super) struct Terms<'a> {
    terms: [std::mem::MaybeUninit<(f64, &'a [f64])>; MAX_TERMS],
    len: usize,
}

impl<'a> Terms<'a> {
    #[inline]
    pub(super) fn new() -> Self {
        Self {
            terms: [const { std::mem::MaybeUninit::uninit() }; MAX_TERMS],
            len: 0,
        }
    }
    #[inline]
    pub(super) fn push(&mut self, coefficient: f64, block: &'a [f64]) {
        self.terms[self.len].write((coefficient, block));
        self.len += 1;
    }
    #[inline]
    pub(super) fn as_slice(&self) -> &[(f64, &'a [f64])] {
        // SAFETY: the first `len` slots were written by `push`; MaybeUninit<T> has T's layout.
        unsafe { std::slice::from_raw_parts(self.terms.as_ptr().cast(), self.len) }
    }
}

/// `out = base + Σ c_t x_t` (`out += Σ c_t x_t` without a base). Short vectors (the motion
/// of systems with a few dofs) take a plain inlined loop: the kernel's dispatch, chunking and
/// grouping cost more than their arithmetic there (Duffing: +50% instructions).
#[inline]
pub(super) fn linear_combination(out: &mut [f64], base: Option<&[f64]>, terms: &[(f64, &[f64])]) {
    const SHORT: usize = 32;
    if out.len() >= SHORT {
        return linear_combination_long(out, base, terms);
    }
    if let Some(b) = base {
        out.copy_from_slice(b);
    }
    for &(c, x) in terms {
        for (o, x) in out.iter_mut().zip(x) {
            *o += c * x;
        }
    }
}

crate::linalg::multiversion! {
    /// [`linear_combination`] in chunks small enough for `out` to stay in L1 while every term
    /// streams through once, up to four terms a pass.
    fn linear_combination_long(out: &mut [f64], base: Option<&[f64]>, terms: &[(f64, &[f64])]) {
        const CHUNK: usize = 256;
        let len = out.len();
        let mut start = 0;
        while start < len {
            let end = (start + CHUNK).min(len);
            let o = &mut out[start..end];
            if let Some(b) = base {
                o.copy_from_slice(&b[start..end]);
            }
            for group in terms.chunks(4) {
                match *group {
                    [(a, x)] => crate::linalg::combine::<WIDE, true, _>(o, [a], [&x[start..end]]),
                    [(a, x), (b, y)] => crate::linalg::combine::<WIDE, true, _>(o, [a, b], [&x[start..end], &y[start..end]]),
                    [(a, x), (b, y), (c, z)] => crate::linalg::combine::<WIDE, true, _>(
                        o,
                        [a, b, c],
                        [&x[start..end], &y[start..end], &z[start..end]],
                    ),
                    [(a, x), (b, y), (c, z), (d, w)] => crate::linalg::combine::<WIDE, true, _>(
                        o,
                        [a, b, c, d],
                        [&x[start..end], &y[start..end], &z[start..end], &w[start..end]],
                    ),
                    _ => unreachable!("groups of one to four"),
                }
            }
            start = end;
        }
    }
}
