//! `mbfmu speed --symbolic`: the symbolic prototype's generated equations of motion
//! ([`crate::model::symbolic`]) against today's automatic-differentiation path and, where
//! the bench has one, the hand-written floor ([`super::floors`]), in the same run.
//!
//! - RHS: one `ẋ = f(t, x, u, p)` in `f64` at a generic state (`xᵢ = 0.3 + 0.1 i`, zero
//!   inputs, default parameters): the generated `Eom::derivatives` (and its `eom` alone,
//!   to separate forming M and rhs from the solve), `System::derivatives` (nested dual
//!   numbers today) and the floor's `rhs`.
//! - Jacobian: the 2n columns of ∂f/∂x, each one `Dual64` evaluation with the seeds set in
//!   preallocated vectors, through the generated code and through today's path alike.
//!
//! Times are the best of several ~20 ms loops (`speed::best_ns`), measured, never asserted.

use super::chain::Chain;
use super::floors::{self, Floor};
use super::speed::best_ns;
use crate::model::lagrangian::Lagrangian;
use crate::model::symbolic::{generated::*, Eom, Terms};
use crate::model::System;
use crate::systems;
use num_dual::Dual64;
use std::hint::black_box;

/// One system's costs (ns).
#[derive(Clone, Debug)]
pub struct SymbolicRow {
    pub system: &'static str,
    pub coordinates: usize,
    /// Nodes the generated code evaluates.
    pub nodes: usize,
    pub generated_rhs_ns: f64,
    /// Of which forming M, rhs, G, γ (the generated `eom` alone, without the solve).
    pub generated_eom_ns: f64,
    pub ad_rhs_ns: f64,
    pub floor_rhs_ns: Option<f64>,
    pub generated_jacobian_ns: f64,
    pub ad_jacobian_ns: f64,
}

/// `ẋ = f(x, u, p)` in dual numbers.
type DualRhs = fn(&[Dual64], &[Dual64], &[Dual64], &mut [Dual64]);

/// A floor's RHS cost at a state and parameters.
type FloorRhs = fn(&[f64], &[f64], usize) -> f64;

fn floor_rhs<F: Floor<N>, const N: usize>(x: &[f64], p: &[f64], reps: usize) -> f64 {
    let x: [f64; N] = x.try_into().expect("floor of the same size");
    best_ns(reps, || {
        black_box(F::rhs(black_box(&x), p));
    })
}

/// The 2n dual-number columns of ∂f/∂x through `f`, seeds set in place.
fn jacobian_ns(x: &[f64], u: &[f64], p: &[f64], reps: usize, f: DualRhs) -> f64 {
    let mut xd: Vec<Dual64> = x.iter().map(|&v| Dual64::from(v)).collect();
    let ud: Vec<Dual64> = u.iter().map(|&v| Dual64::from(v)).collect();
    let pd: Vec<Dual64> = p.iter().map(|&v| Dual64::from(v)).collect();
    let mut dx = vec![Dual64::from(0.0); x.len()];
    best_ns(reps, || {
        for j in 0..xd.len() {
            xd[j].eps = 1.0;
            f(black_box(&xd), &ud, &pd, &mut dx);
            black_box(&dx);
            xd[j].eps = 0.0;
        }
    })
}

/// The costs of `L` through its generated `E` and through today's path.
pub fn measure<L: Lagrangian, E: Eom<N, K>, const N: usize, const K: usize>(
    reps: usize,
    floor: Option<FloorRhs>,
) -> SymbolicRow {
    let x: Vec<f64> = (0..2 * N).map(|i| 0.3 + 0.1 * i as f64).collect();
    let u = vec![0.0; L::inputs().len()];
    let p: Vec<f64> = L::parameters().iter().map(|v| v.start).collect();
    let mut dx = vec![0.0; 2 * N];
    let generated_rhs_ns = best_ns(reps, || {
        E::derivatives(0.0, black_box(&x), &u, &p, &mut dx);
        black_box(&dx);
    });
    let mut terms = Terms::<f64, N, K>::zero();
    let (q, qd) = x.split_at(N);
    let generated_eom_ns = best_ns(reps, || {
        E::eom(0.0, black_box(q), qd, &u, &p, &mut terms);
        black_box(&terms);
    });
    let ad_rhs_ns = best_ns(reps, || {
        <L as System>::derivatives(0.0, black_box(&x), &u, &p, &mut dx);
        black_box(&dx);
    });
    SymbolicRow {
        system: L::NAME,
        coordinates: N,
        nodes: E::NODES,
        generated_rhs_ns,
        generated_eom_ns,
        ad_rhs_ns,
        floor_rhs_ns: floor.map(|f| f(&x, &p, reps)),
        generated_jacobian_ns: jacobian_ns(&x, &u, &p, reps, |x, u, p, dx| {
            E::derivatives(0.0, x, u, p, dx)
        }),
        ad_jacobian_ns: jacobian_ns(&x, &u, &p, reps, |x, u, p, dx| {
            <L as System>::derivatives(0.0, x, u, p, dx)
        }),
    }
}

/// Every generated system, then the chain of N = 1, 2, 4, 8, 16, 32 links.
pub fn sweep(reps: usize) -> Vec<SymbolicRow> {
    use systems::*;
    vec![
        measure::<CompoundPendulum, CompoundPendulumEom, 1, 0>(
            reps,
            Some(floor_rhs::<floors::CompoundPendulum, 2>),
        ),
        measure::<DoublePendulum, DoublePendulumEom, 2, 0>(
            reps,
            Some(floor_rhs::<floors::DoublePendulum, 4>),
        ),
        measure::<SliderCrank, SliderCrankEom, 1, 0>(reps, None),
        measure::<SliderCrankSurplus, SliderCrankSurplusEom, 3, 2>(reps, None),
        measure::<SpringRodPendulum, SpringRodPendulumEom, 3, 0>(reps, None),
        measure::<Chain<1>, Chain1Eom, 1, 0>(reps, None),
        measure::<Chain<2>, Chain2Eom, 2, 0>(reps, None),
        measure::<Chain<4>, Chain4Eom, 4, 0>(reps, None),
        measure::<Chain<8>, Chain8Eom, 8, 0>(reps, None),
        measure::<Chain<16>, Chain16Eom, 16, 0>(reps, None),
        measure::<Chain<32>, Chain32Eom, 32, 0>(reps, None),
    ]
}

pub const CSV_HEADER: &str = "system,coordinates,nodes,generated_rhs_ns,generated_eom_ns,ad_rhs_ns,floor_rhs_ns,generated_over_floor,ad_over_generated,generated_jacobian_ns,ad_jacobian_ns\n";

/// One CSV line (see [`CSV_HEADER`]).
pub fn csv_line(r: &SymbolicRow) -> String {
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.2}"));
    format!(
        "{},{},{},{:.1},{:.1},{:.1},{},{},{:.1},{:.1},{:.1}\n",
        r.system,
        r.coordinates,
        r.nodes,
        r.generated_rhs_ns,
        r.generated_eom_ns,
        r.ad_rhs_ns,
        opt(r.floor_rhs_ns),
        opt(r.floor_rhs_ns.map(|f| r.generated_rhs_ns / f)),
        r.ad_rhs_ns / r.generated_rhs_ns,
        r.generated_jacobian_ns,
        r.ad_jacobian_ns,
    )
}

/// One markdown table row.
pub fn markdown_line(r: &SymbolicRow) -> String {
    let floor = r.floor_rhs_ns.map_or("—".into(), |f| {
        format!("{f:.0} ({:.2}×)", r.generated_rhs_ns / f)
    });
    format!(
        "| {} | {} | {} | {:.0} ({:.0}) | {:.0} ({:.0}×) | {} | {:.0} | {:.0} ({:.0}×) |",
        r.system,
        r.coordinates,
        r.nodes,
        r.generated_rhs_ns,
        r.generated_eom_ns,
        r.ad_rhs_ns,
        r.ad_rhs_ns / r.generated_rhs_ns,
        floor,
        r.generated_jacobian_ns,
        r.ad_jacobian_ns,
        r.ad_jacobian_ns / r.generated_jacobian_ns,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row is complete and its CSV line matches the header (times measured, not asserted).
    #[test]
    fn a_symbolic_row_is_complete() {
        let row = measure::<systems::DoublePendulum, DoublePendulumEom, 2, 0>(
            1,
            Some(floor_rhs::<floors::DoublePendulum, 4>),
        );
        assert_eq!((row.system, row.coordinates), ("DoublePendulum", 2));
        assert_eq!(row.nodes, DoublePendulumEom::NODES);
        let times = [
            row.generated_rhs_ns,
            row.ad_rhs_ns,
            row.floor_rhs_ns.expect("floor"),
            row.generated_jacobian_ns,
            row.ad_jacobian_ns,
        ];
        assert!(times.iter().all(|t| t.is_finite() && *t > 0.0), "{row:?}");
        assert_eq!(
            csv_line(&row).split(',').count(),
            CSV_HEADER.split(',').count()
        );
    }
}
