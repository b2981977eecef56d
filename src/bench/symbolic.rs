//! `mbfmu speed --symbolic`: the symbolic prototype's generated equations of motion
//! ([`crate::model::symbolic`]) against today's automatic-differentiation path and, where
//! the bench has one, the hand-written floor ([`super::floors`]), in the same run.
//!
//! - RHS: one `ẋ = f(t, x, u, p)` in `f64` at a generic state (`xᵢ = 0.3 + 0.1 i`, zero
//!   inputs, default parameters): the generated `Eom::derivatives` (and its `eom` alone,
//!   to separate forming M and rhs from the solve), the automatic-differentiation path
//!   (`AutoDiff<L>`: nested dual numbers, what the FMUs ran before) and the floor's `rhs`.
//! - Jacobian: the 2n columns of ∂f/∂x, each one `Dual64` evaluation with the seeds set in
//!   preallocated vectors, through the generated code and through today's path alike.
//!
//! Times are the best of several ~20 ms loops (`speed::best_ns`), measured, never asserted.

use super::chain::Chain;
use super::floors::{self, Floor};
use super::speed::best_ns;
use crate::model::lagrangian::{AutoDiff, Lagrangian};
use crate::model::symbolic::{emit, equations, generated::*, Eom, Equations, Terms, TraceError};
use crate::model::System;
use crate::systems;
use num_dual::Dual64;
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

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
        <AutoDiff<L> as System>::derivatives(0.0, black_box(&x), &u, &p, &mut dx);
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
            <AutoDiff<L> as System>::derivatives(0.0, x, u, p, dx)
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

// ----- what is generated: the systems of the committed code and the chain sizes -----

/// One generated module: which system, its file, and what generating it took.
pub struct Generated {
    pub system: &'static str,
    /// File stem under `src/model/symbolic/generated/`, and the type it defines.
    pub module: String,
    pub type_name: String,
    pub coordinates: usize,
    pub emitted: emit::Emitted,
    /// Seconds to trace, differentiate and emit.
    pub seconds: f64,
}

type Trace = fn() -> Result<Equations, TraceError>;

/// The systems the committed generated code covers: (module, trace).
fn targets() -> Vec<(&'static str, Trace)> {
    vec![
        (
            "compound_pendulum",
            equations::<systems::CompoundPendulum> as Trace,
        ),
        ("double_pendulum", equations::<systems::DoublePendulum>),
        ("slider_crank", equations::<systems::SliderCrank>),
        (
            "slider_crank_surplus",
            equations::<systems::SliderCrankSurplus>,
        ),
        (
            "spring_rod_pendulum",
            equations::<systems::SpringRodPendulum>,
        ),
        ("nonlinear_bicycle", equations::<systems::NonlinearBicycle>),
        ("pulled_pendulum", equations::<systems::PulledPendulum>),
        ("chain_1", equations::<Chain<1>>),
        ("chain_2", equations::<Chain<2>>),
        ("chain_4", equations::<Chain<4>>),
        ("chain_8", equations::<Chain<8>>),
        ("chain_16", equations::<Chain<16>>),
        ("chain_32", equations::<Chain<32>>),
    ]
}

/// `chain_16` → `Chain16Eom`.
fn type_name(module: &str) -> String {
    let camel: String = module
        .split('_')
        .map(|w| {
            let mut c = w.chars();
            c.next()
                .map(|f| f.to_uppercase().chain(c).collect::<String>())
                .unwrap_or_default()
        })
        .collect();
    format!("{camel}Eom")
}

/// Traces, differentiates and emits one system.
pub fn generate(module: &str, trace: Trace) -> Result<Generated, TraceError> {
    let start = Instant::now();
    let eq = trace()?;
    let type_name = type_name(module);
    let doc = format!(
        "Generated by `mbfmu symbolic` from the Lagrangian of `{}`: do not edit (a test checks\n\
         it is current). M = ∂²T/∂q̇², rhs = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇, G = ∂Φ/∂q, γ = q̇ᵀ∇²Φq̇.",
        eq.name
    );
    let emitted = emit::emit(&eq, &type_name, &doc, "crate");
    Ok(Generated {
        system: eq.name,
        module: module.to_string(),
        type_name,
        coordinates: eq.n,
        emitted,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Files to write: (name, source).
pub type Files = Vec<(String, String)>;

/// Every generated module, and the files: each module's and `generated/mod.rs` listing them.
pub fn generate_all() -> Result<(Vec<Generated>, Files), TraceError> {
    let generated: Vec<Generated> = targets()
        .into_iter()
        .map(|(module, trace)| generate(module, trace))
        .collect::<Result<_, _>>()?;
    let mut files: Files = generated
        .iter()
        .map(|g| (format!("{}.rs", g.module), g.emitted.source.clone()))
        .collect();
    let mut index = String::from(
        "//! Equations of motion generated by `mbfmu symbolic` (`cargo run --bin mbfmu -- symbolic`)\n\
         //! from the systems' Lagrangians: do not edit; a test checks they are current. Not\n\
         //! formatted by rustfmt (`#[rustfmt::skip]` on `mod generated`): the generator's layout\n\
         //! is what the test compares.\n\n",
    );
    for g in &generated {
        index.push_str(&format!(
            "#[allow(clippy::approx_constant, clippy::excessive_precision)]\nmod {};\n",
            g.module
        ));
    }
    index.push('\n');
    for g in &generated {
        index.push_str(&format!("pub use {}::{};\n", g.module, g.type_name));
    }
    files.push(("mod.rs".into(), index));
    Ok((generated, files))
}

/// The chain of N = 1 … 16 and 32 links generated in memory (not written): how the code
/// and the generation time grow with N.
pub fn chain_sizes() -> Vec<Generated> {
    macro_rules! chains {
        ($($n:literal)*) => {
            vec![$(generate(concat!("chain_", $n), equations::<Chain<$n>>)),*]
        };
    }
    chains!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 32)
        .into_iter()
        .map(|g| g.expect("the chain traces"))
        .collect()
}

/// Where the generated modules live.
pub fn generated_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src/model/symbolic/generated")
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
        assert_eq!(
            row.nodes,
            <DoublePendulumEom as crate::model::symbolic::Generated>::NODES
        );
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
