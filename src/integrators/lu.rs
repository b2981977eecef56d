//! nalgebra's LU decomposition with partial pivoting (`nalgebra::LU::new` and `LU::solve`),
//! step for step through nalgebra's own elimination and triangular solves, so bit for bit the
//! same, but in buffers kept between calls: no allocation once they have held this size
//! (`LU::new` takes its matrix by value and allocates its permutation every time).

use nalgebra::linalg::{gauss_step, gauss_step_swap};
use nalgebra::{ComplexField, DMatrixView, DMatrixViewMut, DVectorViewMut};

/// The factors of an n×n matrix, as `nalgebra::LU` holds them.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lu<T> {
    n: usize,
    /// L (below the diagonal, unit diagonal implied) and U, column-major as nalgebra stores
    /// a matrix.
    lu: Vec<T>,
    /// The row swaps `(i, pivot)` in the order they were made (nalgebra's
    /// `PermutationSequence`).
    swaps: Vec<(usize, usize)>,
}

impl<T: ComplexField + Copy> Lu<T> {
    /// Factorizes the n×n matrix whose entry (i, j) is `entry(i, j)`, as
    /// `LU::new(DMatrix::from_fn(n, n, entry))` does.
    pub(crate) fn factor(&mut self, n: usize, mut entry: impl FnMut(usize, usize) -> T) {
        self.n = n;
        self.lu.clear();
        self.lu.extend((0..n * n).map(|k| entry(k % n, k / n)));
        self.swaps.clear();
        // (At most n swaps: room for them all now, not as they come.)
        self.swaps.reserve(n);
        let mut matrix = DMatrixViewMut::from_slice(&mut self.lu, n, n);
        for i in 0..n {
            let piv = matrix.view_range(i.., i).icamax() + i;
            let diag = matrix[(piv, i)];
            if diag.is_zero() {
                // No non-zero entry in this column (the matrix is singular).
                continue;
            }
            if piv != i {
                self.swaps.push((i, piv));
                matrix.columns_range_mut(..i).swap_rows(i, piv);
                gauss_step_swap(&mut matrix, diag, i, piv);
            } else {
                gauss_step(&mut matrix, diag, i);
            }
        }
    }

    /// `LU::is_invertible`: no zero on U's diagonal.
    pub(crate) fn is_invertible(&self) -> bool {
        (0..self.n).all(|i| !self.lu[i * self.n + i].is_zero())
    }

    /// `b ← A⁻¹ b` in place, as `LU::solve_mut`; `false` if A is singular (then `b` holds
    /// garbage).
    pub(crate) fn solve(&self, b: &mut [T]) -> bool {
        let n = self.n;
        let lu = DMatrixView::from_slice(&self.lu, n, n);
        let mut b = DVectorViewMut::from_slice(b, n);
        for &(i, piv) in &self.swaps {
            b.swap_rows(i, piv);
        }
        let _ = lu.solve_lower_triangular_with_diag_mut(&mut b, T::one());
        lu.solve_upper_triangular_mut(&mut b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Complex, DMatrix, DVector};

    /// A matrix with entries of every size and sign, needing row swaps.
    fn entry(i: usize, j: usize) -> f64 {
        let k = (i * 7 + j * 13) % 11;
        (k as f64 - 5.3) * (1.0 + 0.37 * i as f64).powi(j as i32 % 3)
            + if i == j { 0.0 } else { 0.1 }
    }

    #[test]
    fn factors_and_solves_bit_for_bit_as_nalgebra() {
        let mut lu = Lu::default();
        for n in [1, 2, 3, 5, 8, 13] {
            lu.factor(n, entry);
            let reference = DMatrix::from_fn(n, n, entry).lu();
            assert_eq!(lu.is_invertible(), reference.is_invertible());
            let rhs = DVector::from_fn(n, |i, _| (i as f64 * 0.77).sin());
            let expected = reference.solve(&rhs).unwrap();
            let mut b = rhs.as_slice().to_vec();
            assert!(lu.solve(&mut b));
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&b), bits(expected.as_slice()), "n = {n}");
        }
        // Complex, as RADAU5 uses it.
        let centry = |i: usize, j: usize| Complex::new(entry(i, j), entry(j, i) * 0.5);
        let mut clu = Lu::default();
        clu.factor(6, centry);
        let reference = DMatrix::from_fn(6, 6, centry).lu();
        let rhs = DVector::from_fn(6, |i, _| Complex::new(i as f64, 1.0 - i as f64));
        let expected = reference.solve(&rhs).unwrap();
        let mut b = rhs.as_slice().to_vec();
        assert!(clu.solve(&mut b));
        assert_eq!(b, expected.as_slice());
        // Singular: a zero column.
        lu.factor(3, |i, j| if j == 1 { 0.0 } else { entry(i, j) });
        assert!(!lu.is_invertible());
    }
}
