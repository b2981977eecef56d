//! What generated equations of motion run on: the [`Eom`] trait they implement and the small
//! dense solve that turns `M q̈ + Gᵀ λ = rhs`, `G q̈ = −γ` into accelerations.
//!
//! # Why LDLᵀ without pivoting, and a Schur complement for the constraints
//!
//! M = ∂²T/∂q̇² of a kinetic energy is symmetric positive definite, so the factorisation
//! needs no pivot search: the whole solve is straight-line arithmetic on fixed-size arrays
//! (no heap, no data-dependent branch, so a dual-number evaluation differentiates exactly
//! the `f64` formula). The augmented matrix `[M Gᵀ; G 0]` is indefinite; it is solved as
//! `y = M⁻¹ rhs`, `X = M⁻¹ Gᵀ`, `(G X) λ = G y + γ`, `q̈ = y − X λ`, where `G X` is
//! positive definite when the constraints are independent. `lagrangian::solve` (partial
//! pivoting on the real part) gives the same numbers to rounding.

use crate::model::Scalar;

/// The terms of the equations of motion at a point: `M` (full), `rhs = Q + ∂L/∂q −
/// (∂²L/∂q̇∂q) q̇`, the constraint rows `G` and `γ`, holonomic rows first (`∂Φ/∂q`,
/// `q̇ᵀ ∇²Φ q̇`), then the velocity constraints' (`A(q)`, `Ȧ q̇`).
pub struct Terms<S, const N: usize, const K: usize> {
    pub m: [[S; N]; N],
    pub rhs: [S; N],
    pub g: [[S; N]; K],
    pub gamma: [S; K],
}

impl<S: Scalar, const N: usize, const K: usize> Terms<S, N, K> {
    pub fn zero() -> Self {
        let z = S::from(0.0);
        Terms {
            m: [[z; N]; N],
            rhs: [z; N],
            g: [[z; N]; K],
            gamma: [z; K],
        }
    }
}

/// What a generated type declares whatever its size: a trait without N and K, so a
/// constant can name it (the const generics of [`Eom`] cannot be inferred there).
pub trait Generated {
    /// The Lagrangian's name.
    const NAME: &'static str;
    /// Nodes of the graph the generated code evaluates (each shared subexpression once).
    const NODES: usize;
    /// How many inputs u the code reads (M and G never depend on them).
    const INPUTS: usize;
}

/// Equations of motion generated from a Lagrangian with N coordinates and K constraint
/// rows: the holonomic ones, then the velocity constraints ([`emit`](super::emit)). Only
/// [`eom`](Eom::eom) is generated; the solves are the provided methods.
pub trait Eom<const N: usize, const K: usize>: Generated {
    /// Fills `out` at `(t, q, q̇, u, p)`: straight-line code, every shared subexpression
    /// computed once.
    fn eom<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], out: &mut Terms<S, N, K>);

    /// `(q̈, λ)` of `M q̈ + Gᵀ λ = rhs`, `G q̈ = −γ` (λ empty without constraints).
    fn accelerations_and_multipliers<S: Scalar>(
        t: f64,
        q: &[S],
        qd: &[S],
        u: &[S],
        p: &[S],
    ) -> ([S; N], [S; K]) {
        let mut terms = Terms::zero();
        Self::eom(t, q, qd, u, p, &mut terms);
        solve(terms)
    }

    /// `q̈` into `qdd`.
    fn accelerations<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], qdd: &mut [S]) {
        let (a, _) = Self::accelerations_and_multipliers(t, q, qd, u, p);
        qdd.copy_from_slice(&a);
    }

    /// `ẋ = (q̇, q̈)` for `x = (q, q̇)`: the `System::derivatives` of the model.
    fn derivatives<S: Scalar>(t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let (q, qd) = x.split_at(N);
        let (a, _) = Self::accelerations_and_multipliers(t, q, qd, u, p);
        dx[..N].copy_from_slice(qd);
        dx[N..2 * N].copy_from_slice(&a);
    }
}

/// `(q̈, λ)` of `E` into slices: what a [`Lagrangian`](crate::model::lagrangian::Lagrangian)'s
/// `generated_eom` hook (written by [`generated_eom!`](crate::generated_eom)) calls. `qdd`
/// takes the N accelerations; `lambda` the first `lambda.len()` multipliers (empty when
/// they are not wanted). No heap: the terms live on the stack. (Always inlined, as
/// `lagrangian::accelerations_into` is: results read back from memory right after a call
/// stall store forwarding.)
#[inline(always)]
pub fn accelerations_into<E, S, const N: usize, const K: usize>(
    t: f64,
    q: &[S],
    qd: &[S],
    u: &[S],
    p: &[S],
    qdd: &mut [S],
    lambda: &mut [S],
) where
    E: Eom<N, K>,
    S: Scalar,
{
    let (a, l) = E::accelerations_and_multipliers(t, q, qd, u, p);
    // A fixed-size copy (no memcpy call for a handful of numbers).
    let qdd: &mut [S; N] = qdd.try_into().expect("N accelerations");
    *qdd = a;
    for (o, v) in lambda.iter_mut().zip(&l) {
        *o = *v;
    }
}

/// `a == b`, usable in constants: [`generated_eom!`](crate::generated_eom) checks at
/// compile time that the generated equations are those of the system naming them.
pub const fn same_name(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// Puts a system on its generated equations of motion: one line inside its
/// `impl Lagrangian`, `crate::generated_eom!(DoublePendulumEom);`, which defines the
/// trait's hooks `generated_eom` and `generated_projection` to run the committed
/// straight-line code instead of nested dual numbers (FMU, linearisation, Jacobians,
/// projection, bench alike: every user of the type).
///
/// Why a line in the impl rather than in the catalogue or `export_fmu!`: the fast path
/// then belongs to the type itself, so `systems::DoublePendulum` means the same equations
/// everywhere (a wrapper type named in the catalogue would leave the bare type, which the
/// tests and tools name, on the slow path), and the system's file says which code it runs.
/// The generated code cannot attach itself: `model/` does not know the systems. It fails
/// to compile when the equations are another system's (their names are compared).
#[macro_export]
macro_rules! generated_eom {
    ($eom:ty) => {
        #[inline(always)]
        fn generated_eom<S: $crate::model::Scalar>(
            t: f64,
            q: &[S],
            qd: &[S],
            u: &[S],
            p: &[S],
            qdd: &mut [S],
            lambda: &mut [S],
        ) -> bool {
            const {
                assert!(
                    $crate::model::symbolic::runtime::same_name(
                        <$eom as $crate::model::symbolic::runtime::Generated>::NAME,
                        <Self as $crate::model::lagrangian::Lagrangian>::NAME,
                    ),
                    "generated equations of another system"
                )
            };
            $crate::model::symbolic::runtime::accelerations_into::<$eom, S, _, _>(
                t, q, qd, u, p, qdd, lambda,
            );
            true
        }

        fn generated_projection(p: &[f64], x: &mut [f64]) -> bool {
            use $crate::model::lagrangian::{Lagrangian, PROJECTION_ITERATIONS};
            $crate::model::symbolic::runtime::project::<$eom, _, _>(
                x,
                p,
                <Self as Lagrangian>::CONSTRAINTS,
                PROJECTION_ITERATIONS,
                |q, phi| <Self as Lagrangian>::constraints(0.0, q, p, phi),
            )
        }
    };
}

/// `(q̈, λ)` from the terms (see the module notes).
pub fn solve<S: Scalar, const N: usize, const K: usize>(t: Terms<S, N, K>) -> ([S; N], [S; K]) {
    let m = Ldlt::new(t.m);
    let mut y = t.rhs;
    m.solve(&mut y);
    if K == 0 {
        return (y, [S::from(0.0); K]);
    }
    // X = M⁻¹ Gᵀ, column by column (a row of G is a column of Gᵀ).
    let mut x = t.g;
    for column in &mut x {
        m.solve(column);
    }
    // (G X) λ = G y + γ
    let dot = |a: &[S; N], b: &[S; N]| (1..N).fold(a[0] * b[0], |s, i| s + a[i] * b[i]);
    let mut schur = [[S::from(0.0); K]; K];
    let mut lambda = t.gamma;
    for r in 0..K {
        for c in 0..=r {
            schur[r][c] = dot(&t.g[r], &x[c]);
            schur[c][r] = schur[r][c];
        }
        lambda[r] += dot(&t.g[r], &y);
    }
    Ldlt::new(schur).solve(&mut lambda);
    for (r, l) in lambda.iter().enumerate() {
        for i in 0..N {
            y[i] -= x[r][i] * *l;
        }
    }
    (y, lambda)
}

/// The smallest change `Δ` in the metric M with `G_r Δ = −d_r` for the first `active`
/// rows of G (the others ignored): `[M Gᵀ; G 0] [Δ; μ] = [0; −d]`, as [`solve`] does it.
/// `None` if the result is not finite (singular constraints).
fn correction<const N: usize, const K: usize>(
    m: &Ldlt<f64, N>,
    g: &[[f64; N]; K],
    d: &[f64; K],
    active: usize,
) -> Option<[f64; N]> {
    let dot = |a: &[f64; N], b: &[f64; N]| (0..N).fold(0.0, |s, i| s + a[i] * b[i]);
    let mut x = *g;
    for column in &mut x[..active] {
        m.solve(column);
    }
    // (G X) μ = d on the active rows; the identity on the others (μ = 0 there).
    let mut schur = [[0.0; K]; K];
    let mut mu = [0.0; K];
    for r in 0..K {
        if r >= active {
            schur[r][r] = 1.0;
            continue;
        }
        for c in 0..=r {
            schur[r][c] = dot(&g[r], &x[c]);
            schur[c][r] = schur[r][c];
        }
        mu[r] = d[r];
    }
    Ldlt::new(schur).solve(&mut mu);
    let mut delta = [0.0; N];
    for (r, l) in mu[..active].iter().enumerate() {
        for i in 0..N {
            delta[i] -= x[r][i] * l;
        }
    }
    delta.iter().all(|v| v.is_finite()).then_some(delta)
}

/// Zero inputs for [`project`]: M and G do not depend on u, but `eom` reads it.
const ZERO_INPUTS: [f64; 32] = [0.0; 32];

/// Coordinate projection of `x = (q, q̇)` on the generated M and constraint rows, the
/// same steps as `lagrangian::project_onto_constraints` (up to `iterations` Newton steps
/// onto the `holonomic` constraints Φ, evaluated by `phi`, in the kinetic metric, then q̇
/// onto all K rows), without heap. `false`: not done here (more than 32 inputs).
pub fn project<E: Eom<N, K>, const N: usize, const K: usize>(
    x: &mut [f64],
    p: &[f64],
    holonomic: usize,
    iterations: usize,
    mut phi: impl FnMut(&[f64], &mut [f64]),
) -> bool {
    let Some(u) = ZERO_INPUTS.get(..E::INPUTS) else {
        return false;
    };
    let (q, qd) = x.split_at_mut(N);
    let mut terms = Terms::<f64, N, K>::zero();
    for _ in 0..iterations {
        if holonomic == 0 {
            break;
        }
        let mut defect = [0.0; K];
        phi(q, &mut defect[..holonomic]);
        let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        if defect[..holonomic]
            .iter()
            .all(|v| v.abs() <= 4.0 * f64::EPSILON * scale)
        {
            break;
        }
        E::eom(0.0, q, qd, u, p, &mut terms);
        let Some(dq) = correction(&Ldlt::new(terms.m), &terms.g, &defect, holonomic) else {
            return true;
        };
        q.iter_mut().zip(&dq).for_each(|(qi, d)| *qi += d);
    }
    E::eom(0.0, q, qd, u, p, &mut terms);
    let defect = terms
        .g
        .map(|row| row.iter().zip(qd.iter()).map(|(a, b)| a * b).sum());
    if let Some(dv) = correction(&Ldlt::new(terms.m), &terms.g, &defect, K) {
        qd.iter_mut().zip(&dv).for_each(|(v, d)| *v += d);
    }
    true
}

/// `A = L D Lᵀ` of a symmetric positive definite matrix: unit lower L below the diagonal,
/// D on it (only the lower triangle of the input is read), and 1/D for the solves.
///
/// Right-looking (outer-product) order: each step updates the trailing triangle with
/// independent multiply-subtracts, which pipeline, rather than chaining one long dot
/// product per entry. (At N = 32 the factorisation takes ~1.8 µs, the 32 × 32 `f64`
/// arrays' copies a few hundred ns more: past N ≈ 20 the dense O(N³) solve dominates.)
pub struct Ldlt<S, const N: usize> {
    a: [[S; N]; N],
    inv_d: [S; N],
}

// Indices, as in the formulas: the rows read and written are different rows of one array.
#[allow(clippy::needless_range_loop)]
impl<S: Scalar, const N: usize> Ldlt<S, N> {
    /// Step k: `d_k = a_kk`, `w_i = a_ik` (= L_ik d_k), `L_ik = w_i / d_k`, then
    /// `a_ij −= L_ik w_j` on the trailing lower triangle.
    pub fn new(mut a: [[S; N]; N]) -> Self {
        let mut inv_d = [S::from(0.0); N];
        let mut w = [S::from(0.0); N];
        for k in 0..N {
            inv_d[k] = a[k][k].recip();
            for i in k + 1..N {
                w[i] = a[i][k];
                a[i][k] = w[i] * inv_d[k];
            }
            for i in k + 1..N {
                let row = &mut a[i];
                let l = row[k];
                for (aij, &wj) in row[k + 1..=i].iter_mut().zip(&w[k + 1..=i]) {
                    *aij -= l * wj;
                }
            }
        }
        Ldlt { a, inv_d }
    }

    /// `b ← A⁻¹ b`: `L y = b` by columns, `z = D⁻¹ y`, `Lᵀ x = z` by rows of L.
    pub fn solve(&self, b: &mut [S; N]) {
        let a = &self.a;
        for k in 0..N {
            let bk = b[k];
            for i in k + 1..N {
                b[i] -= a[i][k] * bk;
            }
        }
        for i in 0..N {
            b[i] *= self.inv_d[i];
        }
        for k in (0..N).rev() {
            let bk = b[k];
            for (bi, &lki) in b[..k].iter_mut().zip(&a[k][..k]) {
                *bi -= lki * bk;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    #[test]
    fn ldlt_solves_a_symmetric_positive_definite_system() {
        let a = [[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]];
        let x = [1.0, -2.0, 0.5];
        let mut b: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| a[i][j] * x[j]).sum());
        Ldlt::new(a).solve(&mut b);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-15, "{b:?}");
        }
    }

    #[test]
    fn the_schur_complement_solves_the_augmented_system() {
        // M = diag(2, 1, 1), one constraint q0 + q1 + q2 = 0: [M Gᵀ; G 0] [a; λ] = [r; −γ].
        let t = Terms::<f64, 3, 1> {
            m: [[2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            rhs: [1.0, 2.0, 3.0],
            g: [[1.0, 1.0, 1.0]],
            gamma: [0.5],
        };
        let (a, l) = solve(t);
        // M a + Gᵀ λ = r and G a = −γ.
        assert!((2.0 * a[0] + l[0] - 1.0).abs() < 1e-15);
        assert!((a[1] + l[0] - 2.0).abs() < 1e-15);
        assert!((a[2] + l[0] - 3.0).abs() < 1e-15);
        assert!((a[0] + a[1] + a[2] + 0.5).abs() < 1e-15);
    }

    #[test]
    fn the_solve_differentiates() {
        // d/ds of the solution of [[s, 1], [1, 2]] x = [1, 0] at s = 1 is (−4, 2).
        let s = Dual64::new(1.0, 1.0);
        let one = Dual64::from(1.0);
        let mut b = [one, Dual64::from(0.0)];
        Ldlt::new([[s, one], [one, Dual64::from(2.0)]]).solve(&mut b);
        assert!((b[0].eps + 4.0).abs() < 1e-14 && (b[1].eps - 2.0).abs() < 1e-14);
    }
}
