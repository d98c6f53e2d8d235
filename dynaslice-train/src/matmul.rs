//! Dense matrix products for the trainer, through the `gemm` crate.
//!
//! `gemm` was chosen over `matrixmultiply` (what nalgebra uses) because it was the faster of the
//! two on this CPU (see docs/performance.md for the measurement) and takes arbitrary strides,
//! so transposed operands cost nothing. Each call runs on the calling thread: the trainer
//! parallelises over batch chunks instead (deterministic, and no nested thread pools).

/// Whether an operand is used as stored (row-major) or transposed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Op {
    /// As stored.
    N,
    /// Transposed.
    T,
}

/// A row-major matrix view of `rows × cols` values.
///
/// Invariant, relied on by the unsafe call in [`matmul`]: `data` holds at least `rows · cols`
/// values (and that product does not overflow). The fields are private to this module, so only
/// [`Mat::new`], which checks it, makes a `Mat` elsewhere.
#[derive(Clone, Copy)]
pub(crate) struct Mat<'a> {
    data: &'a [f32],
    rows: usize,
    cols: usize,
}

impl<'a> Mat<'a> {
    /// The first `rows · cols` values of `data` as a `rows × cols` matrix.
    ///
    /// # Panics
    /// If `data` is shorter: a caller's indexing bug, never bad input.
    pub(crate) fn new(data: &'a [f32], rows: usize, cols: usize) -> Mat<'a> {
        assert!(
            rows.checked_mul(cols).is_some_and(|n| data.len() >= n),
            "matrix view {rows}x{cols} over {} values",
            data.len()
        );
        Mat { data, rows, cols }
    }

    /// (rows, cols, row stride, column stride) of op(self).
    fn shape(&self, op: Op) -> (usize, usize, isize, isize) {
        match op {
            Op::N => (self.rows, self.cols, self.cols as isize, 1),
            Op::T => (self.cols, self.rows, 1, self.cols as isize),
        }
    }
}

/// C = op(A)·op(B) (or C += op(A)·op(B) when `accumulate`), C row-major `m × n`.
pub(crate) fn matmul(c: &mut [f32], accumulate: bool, a: Mat, a_op: Op, b: Mat, b_op: Op) {
    let (m, k, a_rs, a_cs) = a.shape(a_op);
    let (k2, n, b_rs, b_cs) = b.shape(b_op);
    assert_eq!(k, k2, "inner dimensions differ");
    assert!(
        m.checked_mul(n).is_some_and(|mn| c.len() >= mn),
        "output {} < {m}x{n}",
        c.len()
    );
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        if !accumulate {
            c[..m * n].fill(0.0);
        }
        return;
    }
    // SAFETY: gemm reads op(A) (m × k) and op(B) (k × n) and writes C (m × n) through these
    // strides only. Element (i, j) of a `Mat` is at i·cols + j < rows·cols, which its slice
    // holds (the invariant `Mat::new` checks; the fields are private, so no `Mat` bypasses it),
    // and element (i, j) of C is at i·n + j < m·n <= c.len() (asserted above). m, n, k >= 1
    // here, so every `Mat`'s rows and cols are at most its slice's length: the strides fit in
    // isize.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            c.as_mut_ptr(),
            1,
            n as isize,
            accumulate,
            a.data.as_ptr(),
            a_cs,
            a_rs,
            b.data.as_ptr(),
            b_cs,
            b_rs,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn naive(a: &[f32], m: usize, k: usize, b: &[f32], n: usize) -> Vec<f32> {
        let mut c = vec![0.0; m * n];
        for i in 0..m {
            for j in 0..n {
                c[i * n + j] = (0..k).map(|p| a[i * k + p] * b[p * n + j]).sum();
            }
        }
        c
    }

    fn transpose(x: &[f32], rows: usize, cols: usize) -> Vec<f32> {
        let mut t = vec![0.0; x.len()];
        for r in 0..rows {
            for c in 0..cols {
                t[c * rows + r] = x[r * cols + c];
            }
        }
        t
    }

    #[test]
    fn all_transpose_combinations_match_the_naive_product() {
        let (m, k, n) = (7, 13, 5);
        let a: Vec<f32> = (0..m * k).map(|i| (i as f32 * 0.37).sin()).collect();
        let b: Vec<f32> = (0..k * n).map(|i| (i as f32 * 0.11).cos()).collect();
        let want = naive(&a, m, k, &b, n);
        let (at, bt) = (transpose(&a, m, k), transpose(&b, k, n));
        for (a_op, b_op) in [
            (Op::N, Op::N),
            (Op::T, Op::N),
            (Op::N, Op::T),
            (Op::T, Op::T),
        ] {
            let am = if a_op == Op::N {
                Mat::new(&a, m, k)
            } else {
                Mat::new(&at, k, m)
            };
            let bm = if b_op == Op::N {
                Mat::new(&b, k, n)
            } else {
                Mat::new(&bt, n, k)
            };
            let mut c = vec![1.0; m * n];
            matmul(&mut c, true, am, a_op, bm, b_op);
            for (got, want) in c.iter().zip(&want) {
                assert!(
                    (got - 1.0 - want).abs() < 1e-5,
                    "{a_op:?}{b_op:?}: {got} vs {want}+1"
                );
            }
            matmul(&mut c, false, am, a_op, bm, b_op);
            for (got, want) in c.iter().zip(&want) {
                assert!((got - want).abs() < 1e-5);
            }
        }
    }
}
