//! nalgebra's matrix exponential (`Matrix::exp`: scaling and squaring with Padé
//! approximants, Al-Mohy & Higham 2009, as scipy's `expm`), step for step and so bit for
//! bit, but in buffers kept between calls: no allocation once they have held this size
//! (`Matrix::exp` allocates a dozen matrices every time). Every matrix product, norm and
//! maximum is nalgebra's own function applied to views of these buffers; the elementwise
//! sums are written out in nalgebra's order; the final solve is [`Lu`], nalgebra's LU.

use super::lu::Lu;
use nalgebra::{DMatrixView, DMatrixViewMut};

/// The buffers of one exponential of an n×n matrix, column-major as nalgebra stores it.
#[derive(Clone, Debug, Default)]
pub(crate) struct Expm {
    n: usize,
    /// The argument A; then, after [`Expm::exp`], e^A.
    a: Vec<f64>,
    /// A², A⁴, A⁶, A⁸, A¹⁰ and whether each is computed (nalgebra's `calc_a*`).
    powers: [Vec<f64>; 5],
    have: [bool; 5],
    /// The 1-norms of A⁴ … A¹⁰ to the power 1/k (nalgebra's `d*_exact`), once computed.
    d: [Option<f64>; 4],
    /// Scratch matrices (the Padé numerator and denominator, sums, the scaled powers).
    u: Vec<f64>,
    v: Vec<f64>,
    sum: Vec<f64>,
    scaled: [Vec<f64>; 4],
    /// Scratch of `ell`: |A| (or 2⁻ˢ A), its transpose, and two vectors.
    abs: Vec<f64>,
    transposed: Vec<f64>,
    vec: [Vec<f64>; 2],
    lu: Lu<f64>,
}

const A2: usize = 0;
const A4: usize = 1;
const A6: usize = 2;
const A8: usize = 3;
const A10: usize = 4;

/// `out = a · b` for n×n column-major matrices, with nalgebra's product (`mul_to` is the
/// `gemm` that `&a * &b` runs).
fn mul(n: usize, a: &[f64], b: &[f64], out: &mut [f64]) {
    let (a, b) = (
        DMatrixView::from_slice(a, n, n),
        DMatrixView::from_slice(b, n, n),
    );
    a.mul_to(&b, &mut DMatrixViewMut::from_slice(out, n, n));
}

fn one_norm(n: usize, a: &[f64]) -> f64 {
    DMatrixView::from_slice(a, n, n).one_norm()
}

/// `out = Σ terms[k].0 · terms[k].1 (+ I · identity)` elementwise, summed left to right as
/// nalgebra's `m1 * c1 + m2 * c2 + … + &ident * c` evaluates it (the identity's zeros
/// included: `x + 0` is not `x` for `x = −0`).
fn combine(n: usize, out: &mut Vec<f64>, terms: &[(&[f64], f64)], identity: Option<f64>) {
    out.clear();
    out.extend((0..n * n).map(|k| {
        let mut s = terms[0].0[k] * terms[0].1;
        for (m, c) in &terms[1..] {
            s += m[k] * c;
        }
        if let Some(c) = identity {
            s += if k % n == k / n { 1.0 } else { 0.0 } * c;
        }
        s
    }));
}

fn sized(v: &mut Vec<f64>, len: usize) -> &mut [f64] {
    v.resize(len, 0.0);
    v
}

fn factorial(k: usize) -> u128 {
    (1..=k as u128).product()
}

impl Expm {
    /// Fills the argument: entry (i, j) of the n×n matrix is `entry(i, j)`.
    pub(crate) fn set(&mut self, n: usize, mut entry: impl FnMut(usize, usize) -> f64) {
        self.n = n;
        self.a.clear();
        self.a.extend((0..n * n).map(|k| entry(k % n, k / n)));
    }

    /// Entry (i, j) of the matrix held (e^A after [`Expm::exp`]).
    pub(crate) fn get(&self, i: usize, j: usize) -> f64 {
        self.a[j * self.n + i]
    }

    /// Replaces A by e^A, as `A.exp()` computes it.
    pub(crate) fn exp(&mut self) {
        let n = self.n;
        if n == 1 {
            self.a[0] = self.a[0].exp();
            return;
        }
        self.have = [false; 5];
        self.d = [None; 4];
        // (nalgebra's helper uses the exact norms: its "loose" bounds are the tight ones.)
        let eta_1 = f64::max(self.d_tight(0), self.d_tight(1));
        if eta_1 < 1.495_585_217_958_292e-2 && self.ell(3, 1.0) == 0 {
            self.pade(3);
            return self.solve_p_q(0);
        }
        let eta_2 = f64::max(self.d_tight(0), self.d_tight(1));
        if eta_2 < 2.539_398_330_063_23e-1 && self.ell(5, 1.0) == 0 {
            self.pade(5);
            return self.solve_p_q(0);
        }
        let eta_3 = f64::max(self.d_tight(1), self.d_tight(2));
        if eta_3 < 9.504_178_996_162_932e-1 && self.ell(7, 1.0) == 0 {
            self.pade(7);
            return self.solve_p_q(0);
        }
        if eta_3 < 2.097_847_961_257_068e0 && self.ell(9, 1.0) == 0 {
            self.pade(9);
            return self.solve_p_q(0);
        }
        let eta_4 = f64::max(self.d_tight(2), self.d_tight(3));
        let eta_5 = f64::min(eta_3, eta_4);
        let theta_13 = 4.25;
        let mut s = if eta_5 == 0.0 {
            0
        } else {
            let l2 = (eta_5 / theta_13).log2().ceil();
            if l2 < 0.0 {
                0
            } else {
                l2 as u64
            }
        };
        s += self.ell(13, 2.0_f64.powf(-(s as f64)));
        self.pade13_scaled(s);
        self.solve_p_q(s);
    }

    /// A^(2k+2) (k = 0 … 4: A² … A¹⁰), computed as nalgebra's `calc_a*` computes it:
    /// A² = A·A, A⁴ = A²·A², A⁶ = A⁴·A², A⁸ = A⁶·A², A¹⁰ = A⁶·A⁴.
    fn power(&mut self, k: usize) -> &[f64] {
        if !self.have[k] {
            let n = self.n;
            let mut out = std::mem::take(&mut self.powers[k]);
            let out_ = sized(&mut out, n * n);
            if k == A2 {
                mul(n, &self.a, &self.a, out_);
            } else {
                let (l, r) = [(A2, A2), (A4, A2), (A6, A2), (A6, A4)][k - 1];
                self.power(l);
                self.power(r);
                mul(n, &self.powers[l], &self.powers[r], out_);
            }
            self.powers[k] = out;
            self.have[k] = true;
        }
        &self.powers[k]
    }

    /// ‖A^(2i+4)‖₁^(1/(2i+4)) (i = 0 … 3: nalgebra's `d4_tight` … `d10_tight`).
    fn d_tight(&mut self, i: usize) -> f64 {
        if let Some(d) = self.d[i] {
            return d;
        }
        let (power, exponent) = [
            (A4, 0.25),
            (A6, 1.0 / 6.0),
            (A8, 1.0 / 8.0),
            (A10, 1.0 / 10.0),
        ][i];
        let n = self.n;
        let d = one_norm(n, self.power(power)).powf(exponent);
        self.d[i] = Some(d);
        d
    }

    /// nalgebra's `ell(scale · A, m)`: the extra scaling the Padé approximant of degree m
    /// needs for the backward error to stay at the unit roundoff.
    fn ell(&mut self, m: usize, scale: f64) -> u64 {
        let n = self.n;
        // `scale · A` (the argument nalgebra passes), then its absolute values.
        let scaled = sized(&mut self.scaled[0], n * n);
        for (o, a) in scaled.iter_mut().zip(&self.a) {
            // (× 1 is exact: nalgebra passes A itself below degree 13.)
            *o = a * scale;
        }
        let abs = sized(&mut self.abs, n * n);
        for (o, a) in abs.iter_mut().zip(scaled.iter()) {
            *o = a.abs();
        }
        // onenorm_matrix_power_nonm(|A|, 2m + 1): v = ones; v = |A|ᵀ v, 2m + 1 times.
        let transposed = sized(&mut self.transposed, n * n);
        for i in 0..n {
            for j in 0..n {
                transposed[j * n + i] = abs[i * n + j];
            }
        }
        let [v, w] = &mut self.vec;
        let (mut v, mut w) = (sized(v, n), sized(w, n));
        v.fill(1.0);
        let m_t = DMatrixView::from_slice(transposed, n, n);
        for _ in 0..2 * m + 1 {
            m_t.mul_to(
                &DMatrixView::from_slice(v, n, 1),
                &mut DMatrixViewMut::from_slice(w, n, 1),
            );
            std::mem::swap(&mut v, &mut w);
        }
        let a_abs_onenorm = DMatrixView::from_slice(v, n, 1).max();
        if a_abs_onenorm == 0.0 {
            return 0;
        }
        let m_factorial = factorial(m);
        let choose_2m_m = factorial(2 * m) / (m_factorial * m_factorial);
        let abs_c_recip = choose_2m_m * factorial(2 * m + 1);
        let alpha = a_abs_onenorm / one_norm(n, scaled);
        let alpha = alpha / abs_c_recip as f64;
        let u = 2_f64.powf(-53.0);
        let log2_alpha_div_u = (alpha / u).log2();
        let value = (log2_alpha_div_u / (2.0 * m as f64)).ceil();
        if value > 0.0 {
            value as u64
        } else {
            0
        }
    }

    /// The Padé approximant of degree 3, 5, 7 or 9: U into `u`, V into `v`.
    fn pade(&mut self, degree: usize) {
        let b: &[f64] = match degree {
            3 => &[120.0, 60.0, 12.0, 1.0],
            5 => &[30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0],
            7 => &[
                17_297_280.0,
                8_648_640.0,
                1_995_840.0,
                277_200.0,
                25_200.0,
                1_512.0,
                56.0,
                1.0,
            ],
            _ => &[
                17_643_225_600.0,
                8_821_612_800.0,
                2_075_673_600.0,
                302_702_400.0,
                30_270_240.0,
                2_162_160.0,
                110_880.0,
                3_960.0,
                90.0,
                1.0,
            ],
        };
        // The powers A², A⁴, … the degree needs (pade5 computes A⁶ too, as nalgebra does).
        let highest = match degree {
            3 => A2,
            5 | 7 => A6,
            _ => A8,
        };
        for k in 0..=highest {
            self.power(k);
        }
        let n = self.n;
        let used = (degree - 1) / 2; // A², …, A^(degree−1)
        let p = &self.powers;
        // U = A (A^(d−1) b_d + … + A² b3 + I b1), V = A^(d−1) b_(d−1) + … + A² b2 + I b0,
        // the highest power first.
        let mut odd: [(&[f64], f64); 4] = [(&[], 0.0); 4];
        let mut even = odd;
        for (i, k) in (0..used).rev().enumerate() {
            odd[i] = (&p[k], b[2 * k + 3]);
            even[i] = (&p[k], b[2 * k + 2]);
        }
        combine(n, &mut self.sum, &odd[..used], Some(b[1]));
        combine(n, &mut self.v, &even[..used], Some(b[0]));
        mul(n, &self.a, &self.sum, sized(&mut self.u, n * n));
    }

    /// nalgebra's `pade13_scaled(s)`: U into `u`, V into `v`.
    fn pade13_scaled(&mut self, s: u64) {
        const B: [f64; 14] = [
            64_764_752_532_480_000.0,
            32_382_376_266_240_000.0,
            7_771_770_303_897_600.0,
            1_187_353_796_428_800.0,
            129_060_195_264_000.0,
            10_559_470_521_600.0,
            670_442_572_800.0,
            33_522_128_640.0,
            1_323_241_920.0,
            40_840_800.0,
            960_960.0,
            16_380.0,
            182.0,
            1.0,
        ];
        let n = self.n;
        let s = s as f64;
        for k in [A2, A4, A6] {
            self.power(k);
        }
        let [mb, mb2, mb4, mb6] = &mut self.scaled;
        let scale = |out: &mut Vec<f64>, m: &[f64], c: f64| {
            out.clear();
            out.extend(m.iter().map(|v| v * c));
        };
        scale(mb, &self.a, 2.0_f64.powf(-s));
        scale(mb2, &self.powers[A2], 2.0_f64.powf(-2.0 * s));
        scale(mb4, &self.powers[A4], 2.0_f64.powf(-4.0 * s));
        scale(mb6, &self.powers[A6], 2.0_f64.powf(-6.0 * s));
        let (mb2, mb4, mb6) = (&mb2[..], &mb4[..], &mb6[..]);
        // U2 = mb6 (mb6 b13 + mb4 b11 + mb2 b9); U = mb (U2 + mb6 b7 + mb4 b5 + mb2 b3 + I b1).
        combine(
            n,
            &mut self.sum,
            &[(mb6, B[13]), (mb4, B[11]), (mb2, B[9])],
            None,
        );
        mul(n, mb6, &self.sum, sized(&mut self.v, n * n));
        let u2 = std::mem::take(&mut self.v);
        let terms = [(&u2[..], 1.0), (mb6, B[7]), (mb4, B[5]), (mb2, B[3])];
        combine(n, &mut self.sum, &terms, Some(B[1]));
        mul(n, mb, &self.sum, sized(&mut self.u, n * n));
        // V2 = mb6 (mb6 b12 + mb4 b10 + mb2 b8); V = V2 + mb6 b6 + mb4 b4 + mb2 b2 + I b0.
        combine(
            n,
            &mut self.sum,
            &[(mb6, B[12]), (mb4, B[10]), (mb2, B[8])],
            None,
        );
        let mut v2 = u2;
        mul(n, mb6, &self.sum, sized(&mut v2, n * n));
        let terms = [(&v2[..], 1.0), (mb6, B[6]), (mb4, B[4]), (mb2, B[2])];
        combine(n, &mut self.v, &terms, Some(B[0]));
        self.sum = v2;
    }

    /// e^A = (V − U)⁻¹ (U + V), squared `s` times, into `a`.
    fn solve_p_q(&mut self, s: u64) {
        let n = self.n;
        let (u, v) = (&self.u, &self.v);
        self.lu.factor(n, |i, j| v[j * n + i] - u[j * n + i]);
        let x = &mut self.a;
        x.clear();
        x.extend(u.iter().zip(v).map(|(u, v)| u + v));
        for column in x.chunks_mut(n) {
            // (nalgebra's `solve(..).unwrap()` panics likewise.)
            assert!(self.lu.solve(column), "the Padé denominator is invertible");
        }
        for _ in 0..s {
            let squared = sized(&mut self.sum, n * n);
            mul(n, &self.a, &self.a, squared);
            std::mem::swap(&mut self.a, &mut self.sum);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// Matrices whose norms reach every branch: Padé 3, 5, 7, 9 and 13 with scaling.
    #[test]
    fn exponential_bit_for_bit_as_nalgebra() {
        let mut e = Expm::default();
        let mut branches = 0;
        for n in [2, 3, 4, 5, 6, 7] {
            for scale in [1e-4, 1e-2, 0.1, 0.5, 1.0, 2.0, 10.0, 300.0] {
                let entry = |i: usize, j: usize| {
                    let k = (i * 5 + j * 3 + 1) % 7;
                    scale * (k as f64 - 3.1) * if i == j { 0.7 } else { 1.3 }
                };
                let reference = DMatrix::from_fn(n, n, entry).exp();
                e.set(n, entry);
                e.exp();
                for i in 0..n {
                    for j in 0..n {
                        assert_eq!(
                            e.get(i, j).to_bits(),
                            reference[(i, j)].to_bits(),
                            "n = {n}, scale {scale}: ({i}, {j})"
                        );
                    }
                }
                branches += 1;
            }
        }
        assert_eq!(branches, 48);
        // A zero matrix and a 1×1 one.
        e.set(3, |_, _| 0.0);
        e.exp();
        assert_eq!(e.get(1, 1), 1.0);
        e.set(1, |_, _| 0.5);
        e.exp();
        assert_eq!(e.get(0, 0), 0.5f64.exp());
    }
}
