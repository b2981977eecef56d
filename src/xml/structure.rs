//! ModelStructure dependencies, found from the exact Jacobian (dual numbers) rather
//! than declared by hand: an unknown depends on a known when its partial derivative is
//! non-zero at any of a few random points (random states, inputs, parameters and time,
//! so a parameter that happens to be zero in a scene cannot hide a dependency).

use crate::model::consistent;
use crate::model::jacobian::{directional, Direction};
use crate::model::{Layout, System, Var, VarKind, VarType};
use num_dual::Dual64;

/// `(ScalarVariable index, indices it depends on)`, 1-based as in the XML.
pub type Unknowns = Vec<(usize, Vec<usize>)>;

/// The three lists of `<ModelStructure>`.
#[derive(Clone, Debug, PartialEq)]
pub struct Dependencies {
    pub outputs: Unknowns,
    pub derivatives: Unknowns,
    pub initial_unknowns: Unknowns,
}

/// A tiny deterministic generator (SplitMix64): the XML must not change between runs.
struct SplitMix(u64);
impl SplitMix {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        lo + (hi - lo) * ((z >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// Which of the knowns (x, u, p) each state derivative and each extra output depends on.
struct Sparsity {
    /// `[unknown][known]`, unknowns = derivatives then extra outputs, knowns = x, u, p.
    nonzero: Vec<Vec<bool>>,
    /// `[known]`: whether any state constraint depends on it (x, u, p). The dependent
    /// states are solved from these at initialisation.
    constrained: Vec<bool>,
}

fn sparsity<M: System>(layout: &Layout) -> Sparsity {
    let (n, m, np, ny) = (
        layout.n_states,
        layout.n_inputs,
        layout.n_params,
        layout.n_outputs,
    );
    let n_known = n + m + np;
    let mut nonzero = vec![vec![false; n_known]; n + ny];
    let mut constrained = vec![false; n_known];
    let params: Vec<&Var> = (0..np)
        .map(|i| &layout.vars[layout.vr_of_slot(VarKind::Parameter, i) as usize].1)
        .collect();
    let mut rng = SplitMix(0x5EED);
    for _point in 0..3 {
        let t = rng.uniform(0.1, 10.0);
        let x: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let u: Vec<f64> = (0..m).map(|_| rng.uniform(-1.0, 1.0)).collect();
        // An Integer or Enumeration parameter takes a legal value (drawn alike: the other
        // parameters' draws do not move).
        let p: Vec<f64> = params
            .iter()
            .map(|var| legal(var, rng.uniform(0.5, 2.0)))
            .collect();
        for j in 0..n_known {
            let mut e = vec![0.0; n_known];
            e[j] = 1.0;
            let (dx, dy) = directional::<M>(
                &Direction {
                    t,
                    x: (&x, &e[..n]),
                    u: (&u, &e[n..n + m]),
                    p: (&p, &e[n + m..]),
                },
                ny,
            );
            for (row, v) in nonzero.iter_mut().zip(dx.iter().chain(&dy)) {
                if *v != 0.0 {
                    row[j] = true;
                }
            }
            if j < n || j >= n + m {
                let seed = |v: &[f64], dv: &[f64]| -> Vec<Dual64> {
                    v.iter().zip(dv).map(|(&a, &b)| Dual64::new(a, b)).collect()
                };
                let mut r = vec![Dual64::from(0.0); M::STATE_CONSTRAINTS];
                // The residuals are written whether or not they hold at this point (a
                // mode): the structure is that of the constrained mode.
                M::state_constraints(t, &seed(&x, &e[..n]), &seed(&p, &e[n + m..]), &mut r);
                constrained[j] |= r.iter().any(|v| v.eps != 0.0);
            }
        }
    }
    // A derivative cannot see what a discrete parameter switches: every unknown, and the
    // constraints of a constrained system, are declared to depend on it (a superset of the
    // dependencies, which FMI allows; the XML of a system without one is unchanged).
    for (i, var) in params.iter().enumerate() {
        if var.is_integer() {
            for row in nonzero.iter_mut() {
                row[n + m + i] = true;
            }
            constrained[n + m + i] = M::STATE_CONSTRAINTS > 0;
        }
    }
    Sparsity {
        nonzero,
        constrained,
    }
}

/// A legal value of `var` near the draw `r` ∈ [0.5, 2): `r` itself for a Real; for an
/// Enumeration the code at that fraction of its items; for an Integer `r` rounded, inside
/// its [min, max] (the start value when that fails).
fn legal(var: &Var, r: f64) -> f64 {
    let v = match var.ty {
        VarType::Real => return r,
        VarType::Enumeration(items) => {
            (((r - 0.5) / 1.5 * items.len() as f64) as usize).min(items.len() - 1) as f64
        }
        VarType::Integer => r
            .round()
            .clamp(var.min.unwrap_or(f64::MIN), var.max.unwrap_or(f64::MAX)),
    };
    if var.check(v).is_ok() {
        v
    } else {
        var.start
    }
}

/// The ModelStructure of `M`.
pub fn dependencies<M: System>(layout: &Layout) -> Dependencies {
    let (n, m) = (layout.n_states, layout.n_inputs);
    let sp = sparsity::<M>(layout);
    let index = |kind, i| layout.vr_of_slot(kind, i) as usize + 1;
    // Knowns at communication points: states and inputs.
    let run_known = |j: usize| -> Option<usize> {
        if j < n {
            Some(index(VarKind::State, j))
        } else if j < n + m {
            Some(index(VarKind::Input, j - n))
        } else {
            None
        }
    };
    // Knowns in initialization mode: also the parameters (initial = exact).
    let init_known = |j: usize| -> usize {
        if j < n + m {
            run_known(j).expect("state or input")
        } else {
            index(VarKind::Parameter, j - n - m)
        }
    };
    let list = |row: &[bool], known: &dyn Fn(usize) -> Option<usize>| -> Vec<usize> {
        let mut v: Vec<usize> = row
            .iter()
            .enumerate()
            .filter(|(_, nz)| **nz)
            .filter_map(|(j, _)| known(j))
            .collect();
        v.sort_unstable();
        v
    };
    // In initialization mode a dependent state is not a known: it is computed from the
    // independent states and parameters its constraints involve (their union: the
    // implicit function couples every dependent state to all of them in general).
    let dependent = consistent::dependent_states::<M>();
    let solved_from: Vec<bool> = (0..sp.constrained.len())
        .map(|j| sp.constrained[j] && !dependent.contains(&j))
        .collect();
    let init_row = |row: &[bool]| -> Vec<bool> {
        let through_dependent = dependent.iter().any(|&d| row[d]);
        row.iter()
            .enumerate()
            .map(|(j, &nz)| {
                (nz && !dependent.contains(&j)) || (through_dependent && solved_from[j])
            })
            .collect()
    };
    let init = |j| Some(init_known(j));

    let mut outputs = Vec::new();
    for i in 0..n {
        // An output that is a state depends on that state alone.
        outputs.push((index(VarKind::State, i), vec![index(VarKind::State, i)]));
    }
    for k in 0..layout.n_outputs {
        outputs.push((
            index(VarKind::Output, k),
            list(&sp.nonzero[n + k], &run_known),
        ));
    }
    let derivatives: Unknowns = (0..n)
        .map(|i| {
            (
                index(VarKind::Derivative, i),
                list(&sp.nonzero[i], &run_known),
            )
        })
        .collect();
    let mut initial_unknowns: Unknowns = (0..n)
        .map(|i| {
            let row = init_row(&sp.nonzero[i]);
            (index(VarKind::Derivative, i), list(&row, &init))
        })
        .chain((0..layout.n_outputs).map(|k| {
            let row = init_row(&sp.nonzero[n + k]);
            (index(VarKind::Output, k), list(&row, &init))
        }))
        .chain(
            dependent
                .iter()
                .map(|&d| (index(VarKind::State, d), list(&solved_from, &init))),
        )
        .collect();
    initial_unknowns.sort_by_key(|(i, _)| *i);
    Dependencies {
        outputs,
        derivatives,
        initial_unknowns,
    }
}
