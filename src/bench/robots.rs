//! `mbfmu speed --robots`: the generated forward dynamics of
//! [`multibody::generated`](crate::multibody::generated) (UR5, Panda, the spatial chain of
//! N = 1 … 64 links) against the interpretive [`Model::aba`] and against Pinocchio, in one
//! run.
//!
//! - RHS: one q̈ = ABA(q, q̇, τ) in `f64` at a random state (fixed seed): the generated
//!   `aba`, and `Model::aba` (the same algorithm interpreted over the model's arrays).
//! - Jacobian: ∂q̈/∂q and ∂q̈/∂q̇ (2n² numbers): the generated `aba_derivatives` (symbolic
//!   derivatives, emitted: [`Jacobian`](crate::multibody::codegen::Jacobian)) where it exists, else 2n `Dual64` columns through
//!   the generated `aba` (seeds set in place); both are reported where both exist.
//! - Pinocchio 4.1 (`benches/pinocchio_robots.py serve`, a Python child reading the same
//!   URDF files): `pin.aba` (the faster of its LOCAL and WORLD conventions) and
//!   `pin.computeABADerivatives`, each minus the same call on a model with no joint (the
//!   binding's cost), so Pinocchio's own C++ time per call.
//!
//! Repetitions alternate: one of every Rust loop, then one of every Pinocchio loop, `reps`
//! times; each figure is the best of its repetitions. Before timing, the child's `pin.aba`
//! at the timed state is compared with the generated code's q̈ (both models are the same
//! URDF; the largest relative difference is reported).

use super::speed::best_ns;
use crate::multibody::codegen::{generated_dir, spatial_chain_urdf, targets};
use crate::multibody::Model;
use crate::multibody::{derivatives, generated};
use num_dual::Dual64;
use serde_json::{json, Value};
use std::hint::black_box;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

type Aba<S> = fn(&[S], &[S], &[S], &mut [S]);
type Derivatives = fn(&[f64], &[f64], &[f64], &mut [f64], &mut [f64], &mut [f64]);

/// A committed generated module: its `aba` in `f64` and `Dual64`, its `aba_derivatives`.
pub struct Entry {
    pub module: &'static str,
    /// Operations of the generated `aba`.
    pub operations: usize,
    pub aba: Aba<f64>,
    pub aba_dual: Aba<Dual64>,
    pub derivatives: Option<Derivatives>,
}

macro_rules! entries {
    ($($m:ident $($d:ident)?),*) => {
        vec![$(Entry {
            module: stringify!($m),
            operations: generated::$m::OPERATIONS,
            aba: generated::$m::aba::<f64>,
            aba_dual: generated::$m::aba::<Dual64>,
            derivatives: None $(.or(Some(generated::$m::$d::<f64> as Derivatives)))?,
        }),*]
    };
}

/// Every committed module, in the order of [`targets`].
pub fn entries() -> Vec<Entry> {
    entries!(
        ur5 aba_derivatives,
        panda aba_derivatives,
        chain_1 aba_derivatives,
        chain_2 aba_derivatives,
        chain_4 aba_derivatives,
        chain_8 aba_derivatives,
        chain_16,
        chain_32,
        chain_64
    )
}

/// One model's costs (ns).
#[derive(Clone, Debug)]
pub struct RobotRow {
    pub model: String,
    pub nq: usize,
    pub algorithm: String,
    /// Operations of the generated `aba`.
    pub operations: usize,
    pub generated_rhs_ns: f64,
    pub interpretive_rhs_ns: f64,
    /// The Jacobian: symbolic where emitted, else analytical.
    pub jacobian_ns: f64,
    pub jacobian_method: &'static str,
    /// Generated `aba` + [`derivatives::aba_derivatives`].
    pub analytic_jacobian_ns: f64,
    /// 2n `Dual64` columns through the generated `aba`.
    pub dual_jacobian_ns: f64,
    pub pinocchio_aba_ns: f64,
    pub pinocchio_derivatives_ns: f64,
    /// Largest |q̈_generated − q̈_pinocchio| / max(|q̈_pinocchio|, 1) at the timed state.
    pub max_difference: f64,
}

/// Uniform numbers in `[lo, hi)` from `seed` (xorshift64): the benchmarks' fixed states.
pub(crate) fn uniform(seed: u64) -> impl FnMut(f64, f64) -> f64 {
    let mut s = seed;
    move |lo, hi| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// The timed state of a model with `n` joints (fixed seed).
fn state(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut next = uniform(0x9e3779b97f4a7c15u64 ^ n as u64);
    let q = (0..n).map(|_| next(-1.5, 1.5)).collect();
    let qd = (0..n).map(|_| next(-1.0, 1.0)).collect();
    let tau = (0..n).map(|_| next(-5.0, 5.0)).collect();
    (q, qd, tau)
}

/// Best ns of one Rust repetition of a model: (generated RHS, interpretive RHS, symbolic
/// Jacobian if any, dual Jacobian, analytical Jacobian).
fn rust_rep(e: &Entry, model: &Model) -> (f64, f64, Option<f64>, f64, f64) {
    let n = model.nq();
    let (q, qd, tau) = state(n);
    let mut qdd = vec![0.0; n];
    let generated = best_ns(1, || {
        (e.aba)(black_box(&q), &qd, &tau, &mut qdd);
        black_box(&qdd);
    });
    let interpretive = best_ns(1, || {
        black_box(model.aba(black_box(&q), &qd, &tau));
    });
    let symbolic = e.derivatives.map(|d| {
        let (mut dq, mut dqd) = (vec![0.0; n * n], vec![0.0; n * n]);
        best_ns(1, || {
            d(black_box(&q), &qd, &tau, &mut qdd, &mut dq, &mut dqd);
            black_box((&dq, &dqd));
        })
    });
    let lift = |v: &[f64]| v.iter().map(|&x| Dual64::from(x)).collect::<Vec<_>>();
    let (mut xq, mut xqd, xtau) = (lift(&q), lift(&qd), lift(&tau));
    let mut out = vec![Dual64::from(0.0); n];
    let mut jac = vec![0.0; 2 * n * n];
    let dual = best_ns(1, || {
        for j in 0..2 * n {
            let x = if j < n { &mut xq[j] } else { &mut xqd[j - n] };
            x.eps = 1.0;
            (e.aba_dual)(black_box(&xq), &xqd, &xtau, &mut out);
            for (i, o) in out.iter().enumerate() {
                jac[i * 2 * n + j] = o.eps;
            }
            let x = if j < n { &mut xq[j] } else { &mut xqd[j - n] };
            x.eps = 0.0;
        }
        black_box(&jac);
    });
    let mut scratch = derivatives::Scratch::default();
    let (mut dq, mut dqd) = (vec![0.0; n * n], vec![0.0; n * n]);
    let analytic = best_ns(1, || {
        (e.aba)(black_box(&q), &qd, &tau, &mut qdd);
        derivatives::aba_derivatives(model, &q, &qd, &qdd, &mut scratch, &mut dq, &mut dqd);
        black_box((&dq, &dqd));
    });
    (generated, interpretive, symbolic, dual, analytic)
}

/// The Pinocchio child process.
pub(crate) struct Pinocchio {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
}

impl Pinocchio {
    pub(crate) fn start(python: &Path, script: &Path) -> Result<Pinocchio, String> {
        let mut child = Command::new(python)
            .arg(script)
            .arg("serve")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| format!("{}: {e}", python.display()))?;
        let stdin = child.stdin.take().expect("piped");
        let stdout = BufReader::new(child.stdout.take().expect("piped"));
        Ok(Pinocchio {
            child,
            stdin,
            stdout,
        })
    }

    pub(crate) fn ask(&mut self, msg: &Value) -> Result<Value, String> {
        writeln!(self.stdin, "{msg}").map_err(|e| format!("pinocchio child: {e}"))?;
        self.stdin.flush().map_err(|e| e.to_string())?;
        let mut line = String::new();
        self.stdout
            .read_line(&mut line)
            .map_err(|e| format!("pinocchio child: {e}"))?;
        if line.is_empty() {
            return Err("the pinocchio child exited (is `pin` installed? see MBFMU_PYTHON)".into());
        }
        serde_json::from_str(&line).map_err(|e| format!("pinocchio child: {e}: {line}"))
    }
}

impl Drop for Pinocchio {
    fn drop(&mut self) {
        let _ = writeln!(self.stdin, "\"quit\"");
        let _ = self.stdin.flush();
        let _ = self.child.wait();
    }
}

/// The Python that runs Pinocchio: `$MBFMU_PYTHON`, else the workspace's `.venv`, else
/// `python3`.
pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("MBFMU_PYTHON") {
        return p.into();
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python3");
    if venv.exists() {
        venv
    } else {
        "python3".into()
    }
}

/// The benchmark script.
pub fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/pinocchio_robots.py")
}

/// Measures every committed model against Pinocchio (see the module notes). The chains'
/// URDFs are written to `scratch` for Pinocchio to read.
pub fn sweep(reps: usize, scratch: &Path) -> Result<Vec<RobotRow>, String> {
    // The mimic and floating modules are timed in the second table (`interpreted.rs`).
    let targets: Vec<_> = targets()
        .into_iter()
        .filter(|t| t.model.free_base.is_none() && !t.model.has_mimics())
        .collect();
    let entries = entries();
    assert_eq!(
        targets
            .iter()
            .map(|t| t.module.as_str())
            .collect::<Vec<_>>(),
        entries.iter().map(|e| e.module).collect::<Vec<_>>(),
        "the bench lists every committed module"
    );
    std::fs::create_dir_all(scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    let mut models = Vec::new();
    for t in &targets {
        let urdf = match t.module.strip_prefix("chain_") {
            Some(n) => {
                let path = scratch.join(format!("{}.urdf", t.module));
                std::fs::write(&path, spatial_chain_urdf(n.parse().expect("chain_N")))
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                path
            }
            None => generated_dir().join(format!("urdf/{}.urdf", t.module)),
        };
        let n = t.model.nq();
        let (q, qd, tau) = state(n);
        // pin.aba has no damping: it gets τ − d q̇.
        let tau_eff: Vec<f64> = (0..n)
            .map(|i| tau[i] - t.model.damping[i] * qd[i])
            .collect();
        models.push(json!({
            "name": t.module, "urdf": urdf, "q": q, "qd": qd, "tau": tau_eff,
        }));
    }
    let mut pin = Pinocchio::start(&python(), &script())?;
    let answer = pin.ask(&json!({ "models": models }))?;
    let mut rows: Vec<RobotRow> = Vec::new();
    for (t, e) in targets.iter().zip(&entries) {
        let n = t.model.nq();
        let (q, qd, tau) = state(n);
        let mut qdd = vec![0.0; n];
        (e.aba)(&q, &qd, &tau, &mut qdd);
        let theirs: Vec<f64> = answer["qdd"][t.module.as_str()]
            .as_array()
            .ok_or("pinocchio child: no q̈")?
            .iter()
            .map(|v| v.as_f64().unwrap_or(f64::NAN))
            .collect();
        let scale = theirs.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        let max_difference = qdd
            .iter()
            .zip(&theirs)
            .map(|(a, b)| (a - b).abs() / scale)
            .fold(0.0, f64::max);
        rows.push(RobotRow {
            model: t.module.clone(),
            nq: n,
            algorithm: format!("{:?}", t.algorithm),
            operations: e.operations,
            generated_rhs_ns: f64::INFINITY,
            interpretive_rhs_ns: f64::INFINITY,
            jacobian_ns: f64::INFINITY,
            jacobian_method: if e.derivatives.is_some() {
                "symbolic"
            } else {
                "analytic"
            },
            analytic_jacobian_ns: f64::INFINITY,
            dual_jacobian_ns: f64::INFINITY,
            pinocchio_aba_ns: f64::INFINITY,
            pinocchio_derivatives_ns: f64::INFINITY,
            max_difference,
        });
    }
    let interpretive: Vec<Model> = targets.iter().map(|t| t.model.clone()).collect();
    let (mut pin_aba, mut pin_der) = (
        vec![f64::INFINITY; rows.len()],
        vec![f64::INFINITY; rows.len()],
    );
    let (mut empty_aba, mut empty_der) = (f64::INFINITY, f64::INFINITY);
    for rep in 0..reps {
        eprintln!("robots: repetition {} of {reps}", rep + 1);
        for ((row, e), model) in rows.iter_mut().zip(&entries).zip(&interpretive) {
            let (g, i, s, d, a) = rust_rep(e, model);
            row.generated_rhs_ns = row.generated_rhs_ns.min(g);
            row.interpretive_rhs_ns = row.interpretive_rhs_ns.min(i);
            row.dual_jacobian_ns = row.dual_jacobian_ns.min(d);
            row.analytic_jacobian_ns = row.analytic_jacobian_ns.min(a);
            row.jacobian_ns = row.jacobian_ns.min(s.unwrap_or(a));
        }
        let times = pin.ask(&json!("rep"))?;
        let get = |name: &str, key: &str| -> Result<f64, String> {
            times[name][key]
                .as_f64()
                .map(|s| s * 1e9)
                .ok_or(format!("pinocchio child: no {key} for {name}"))
        };
        for (k, row) in rows.iter().enumerate() {
            let aba = get(&row.model, "aba")?.min(get(&row.model, "aba_world")?);
            pin_aba[k] = pin_aba[k].min(aba);
            pin_der[k] = pin_der[k].min(get(&row.model, "derivatives")?);
        }
        empty_aba = empty_aba
            .min(get("__empty__", "aba")?)
            .min(get("__empty__", "aba_world")?);
        empty_der = empty_der.min(get("__empty__", "derivatives")?);
    }
    for (k, row) in rows.iter_mut().enumerate() {
        row.pinocchio_aba_ns = pin_aba[k] - empty_aba;
        row.pinocchio_derivatives_ns = pin_der[k] - empty_der;
    }
    eprintln!(
        "robots: Pinocchio's binding overhead taken off: aba {empty_aba:.0} ns, derivatives {empty_der:.0} ns"
    );
    Ok(rows)
}

pub const CSV_HEADER: &str = "model,nq,algorithm,operations,generated_rhs_ns,interpretive_rhs_ns,pinocchio_aba_ns,rhs_over_pinocchio,jacobian_ns,jacobian_method,analytic_jacobian_ns,dual_jacobian_ns,pinocchio_derivatives_ns,jacobian_over_pinocchio,max_rel_difference\n";

/// One CSV line (see [`CSV_HEADER`]).
pub fn csv_line(r: &RobotRow) -> String {
    format!(
        "{},{},{},{},{:.1},{:.1},{:.1},{:.3},{:.1},{},{:.1},{:.1},{:.1},{:.3},{:.1e}\n",
        r.model,
        r.nq,
        r.algorithm,
        r.operations,
        r.generated_rhs_ns,
        r.interpretive_rhs_ns,
        r.pinocchio_aba_ns,
        r.generated_rhs_ns / r.pinocchio_aba_ns,
        r.jacobian_ns,
        r.jacobian_method,
        r.analytic_jacobian_ns,
        r.dual_jacobian_ns,
        r.pinocchio_derivatives_ns,
        r.jacobian_ns / r.pinocchio_derivatives_ns,
        r.max_difference,
    )
}

pub const MARKDOWN_HEADER: &str = "| model | n | algorithm (ops) | generated RHS ns | Model::aba ns | Pinocchio aba ns | RHS / Pinocchio | Jacobian ns (method) | analytical Jacobian ns | dual Jacobian ns | Pinocchio derivatives ns | Jacobian / Pinocchio |\n|---|---|---|---|---|---|---|---|---|---|---|---|";

/// One markdown table row.
pub fn markdown_line(r: &RobotRow) -> String {
    format!(
        "| {} | {} | {} ({}) | {:.0} | {:.0} | {:.0} | {:.2} | {:.0} ({}) | {:.0} | {:.0} | {:.0} | {:.2} |",
        r.model,
        r.nq,
        r.algorithm,
        r.operations,
        r.generated_rhs_ns,
        r.interpretive_rhs_ns,
        r.pinocchio_aba_ns,
        r.generated_rhs_ns / r.pinocchio_aba_ns,
        r.jacobian_ns,
        r.jacobian_method,
        r.analytic_jacobian_ns,
        r.dual_jacobian_ns,
        r.pinocchio_derivatives_ns,
        r.jacobian_ns / r.pinocchio_derivatives_ns,
    )
}

/// The chart of `csv` into `png`, by the script's `plot` mode.
pub fn plot(csv: &Path, png: &Path) -> Result<(), String> {
    let status = Command::new(python())
        .arg(script())
        .arg("plot")
        .arg(csv)
        .arg(png)
        .status()
        .map_err(|e| e.to_string())?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("the chart script failed ({status})"))
    }
}

/// A check of the benchmark's own pieces without Pinocchio: the entry table is the
/// committed modules, and the benchmark's state is the models' size.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::codegen::benchmark_model;

    #[test]
    fn the_entries_are_the_committed_modules() {
        let names: Vec<&str> = entries().iter().map(|e| e.module).collect();
        assert_eq!(names[..2], ["ur5", "panda"]);
        for e in entries() {
            let model = benchmark_model(e.module);
            let (q, qd, tau) = state(model.nq());
            let mut qdd = vec![0.0; model.nq()];
            (e.aba)(&q, &qd, &tau, &mut qdd);
            let want = model.aba(&q, &qd, &tau);
            let scale = want.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            assert!(qdd
                .iter()
                .zip(&want)
                .all(|(a, b)| (a - b).abs() <= 1e-10 * scale));
        }
    }
}
