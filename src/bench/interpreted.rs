//! `mbfmu speed --robots`, second table: mimic joints and floating bases. The forward
//! dynamics the prebuilt mechanism runtime interprets (what `mbfmu build --urdf` FMUs run):
//! with mimic joints the mass matrix reduced to the independent joints (CRBA + RNEA +
//! LDLᵀ, [`Model::aba_in`]), with a floating base the articulated-body algorithm with the
//! base solved from its articulated inertia, or with mimic joints the reduced path
//! ([`Model::aba_free_in`]); against Pinocchio in the same run.
//!
//! The robots are example-robot-data's files, found by the Pinocchio child (the same
//! virtualenv). Pinocchio's figures, its own C++ time per call (the binding's cost on a
//! model with no joint taken off):
//! - `aba` of the same robot (free-flyer root where ours floats) with every joint its own
//!   coordinate: Pinocchio's `aba` refuses mimic joints, so on a robot with mimics this is
//!   a related, larger problem (n + mimics coordinates), shown for scale;
//! - with mimic joints and a fixed base, `crba` + `nonLinearEffects` of its mimic model
//!   (`mimic=True`), the work of its mimic forward dynamics less the final solve (in its
//!   favour). Pinocchio 4.1 builds no mimic model with a free-flyer root here (Talos: "The
//!   parent joint of the mimic joint is not in the kinematic tree").
//!
//! Where the generated code has a committed module for the robot
//! (`src/multibody/generated/`: `panda_mimic`, `go2_floating`, the same files), its
//! straight-line q̈ is timed too: what `--compile` makes of that robot.
//!
//! Both sides time q̈ at a random state of their own (the algorithms have no branches on
//! the state); that they compute the same q̈ is the tests' business
//! (`tests/python/test_real_robots.py`, `test_floating_base.py`: within 1.4e-13).

use super::robots::{python, script, uniform, Pinocchio};
use super::speed::best_ns;
use crate::multibody::fmu::Built;
use crate::multibody::spatial::{quat_to_matrix, Motion};
use crate::multibody::{urdf, Data, Model};
use serde_json::json;
use std::hint::black_box;
use std::path::Path;

/// The robots timed: (name, file under example-robot-data's `robots/`, floating).
pub const ROBOTS: [(&str, &str, bool); 4] = [
    ("panda (mimic)", "panda_description/urdf/panda.urdf", false),
    ("go2 (floating)", "go2_description/urdf/go2.urdf", true),
    (
        "talos_reduced (floating)",
        "talos_data/robots/talos_reduced.urdf",
        true,
    ),
    (
        "talos_full_v2 (floating, mimic)",
        "talos_data/robots/talos_full_v2.urdf",
        true,
    ),
];

/// One robot's costs (ns).
#[derive(Clone, Debug)]
pub struct InterpretedRow {
    pub model: String,
    /// Coordinates (independent joints), mimic joints, and 6 more where floating.
    pub coordinates: usize,
    pub mimics: usize,
    pub floating: bool,
    pub interpreted_ns: f64,
    pub pinocchio_aba_ns: f64,
    /// `crba` + `nonLinearEffects` of Pinocchio's mimic model (fixed base with mimics).
    pub pinocchio_mimic_ns: Option<f64>,
    /// The committed generated code's q̈, where there is a module for the robot.
    pub generated_ns: Option<f64>,
}

/// The generated code's `aba` (q̈ and, floating, the base's acceleration).
type AbaFn = fn(&[f64], &[f64], &[f64], &mut [f64]);

/// The committed generated module of a robot of [`ROBOTS`], if any.
fn generated_of(name: &str) -> Option<AbaFn> {
    use crate::multibody::generated::{go2_floating, panda_mimic};
    match name {
        "panda (mimic)" => Some(panda_mimic::aba::<f64>),
        "go2 (floating)" => Some(go2_floating::aba::<f64>),
        _ => None,
    }
}

fn model_of(robots: &Path, file: &str, floating: bool) -> Result<Model, String> {
    let path = robots.join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut mechanism = urdf::parse(&text, file).map_err(|e| e.to_string())?;
    mechanism.floating_base = floating;
    Ok(Built::new(mechanism).map_err(|e| e.to_string())?.model)
}

/// One call's best time (ns) of the interpreted forward dynamics at a fixed random state,
/// with a reused workspace (as the runtime's); of `generated`'s instead where given.
fn time_model(model: &Model, generated: Option<AbaFn>, reps: usize) -> f64 {
    let n = model.nq();
    let mut next = uniform(0x2545_f491_4f6c_dd1du64 ^ n as u64);
    let mut q: Vec<f64> = (0..n).map(|_| next(-1.0, 1.0)).collect();
    let mut qd: Vec<f64> = (0..n).map(|_| next(-1.0, 1.0)).collect();
    let tau: Vec<f64> = (0..n).map(|_| next(-5.0, 5.0)).collect();
    // A mimic joint's state follows the joint it mimics.
    for i in 0..n {
        if let Some(f) = &model.follows[i] {
            q[i] = f.multiplier * q[f.joint] + f.offset;
            qd[i] = f.multiplier * qd[f.joint];
        }
    }
    let mut data = Data::new(model);
    let mut qdd = vec![0.0; n];
    if model.free_base.is_some() {
        let quat = [next(-1.0, 1.0), next(-1.0, 1.0), next(-1.0, 1.0), 1.0];
        let norm = quat.iter().map(|x| x * x).sum::<f64>().sqrt();
        let quat = quat.map(|x| x / norm);
        let rotation = quat_to_matrix(&quat);
        let velocity = Motion {
            ang: [next(-1.0, 1.0), next(-1.0, 1.0), next(-1.0, 1.0)],
            lin: [next(-1.0, 1.0), next(-1.0, 1.0), next(-1.0, 1.0)],
        };
        if let Some(aba) = generated {
            // The generated layout: the base's pose and velocity after the joints'.
            let q: Vec<f64> = [&q[..], &[0.0; 3], &quat].concat();
            let qd: Vec<f64> = [&qd[..], &velocity.lin, &velocity.ang].concat();
            let mut out = vec![0.0; n + 6];
            return best_ns(reps, || {
                aba(black_box(&q), &qd, &tau, &mut out);
                black_box(&out);
            });
        }
        best_ns(reps, || {
            black_box(model.aba_free_in(
                &mut data,
                &rotation,
                &velocity,
                black_box(&q),
                &qd,
                &tau,
                &mut qdd,
            ));
        })
    } else if let Some(aba) = generated {
        best_ns(reps, || {
            aba(black_box(&q), &qd, &tau, &mut qdd);
            black_box(&qdd);
        })
    } else {
        best_ns(reps, || {
            model.aba_in(&mut data, black_box(&q), &qd, &tau, &mut qdd);
            black_box(&qdd);
        })
    }
}

/// Times [`ROBOTS`] against Pinocchio (see the module notes).
pub fn sweep(reps: usize) -> Result<Vec<InterpretedRow>, String> {
    let mut pin = Pinocchio::start(&python(), &script())?;
    let answer = pin.ask(&json!({
        "interpreted": ROBOTS.iter().map(|&(name, file, floating)| json!({
            "name": name, "file": file, "floating": floating,
        })).collect::<Vec<_>>()
    }))?;
    let robots = Path::new(
        answer["robots"]
            .as_str()
            .ok_or("pinocchio child: no robots dir")?,
    );
    let mut rows = Vec::new();
    for &(name, file, floating) in &ROBOTS {
        let model = model_of(robots, file, floating)?;
        let mimics = model.follows.iter().filter(|f| f.is_some()).count();
        let mut best = f64::INFINITY;
        let mut straight = f64::INFINITY;
        let (mut aba, mut mimic) = (f64::INFINITY, f64::INFINITY);
        for rep in 0..reps {
            eprintln!(
                "robots (interpreted): {name}, repetition {} of {reps}",
                rep + 1
            );
            best = best.min(time_model(&model, None, 1));
            if let Some(g) = generated_of(name) {
                straight = straight.min(time_model(&model, Some(g), 1));
            }
            let t = pin.ask(&json!({ "time": name }))?;
            let get = |k: &str| t[k].as_f64().map(|s| s * 1e9);
            aba = aba.min(get("aba").ok_or("pinocchio child: no aba")?);
            if let Some(m) = get("mimic") {
                mimic = mimic.min(m);
            }
        }
        rows.push(InterpretedRow {
            model: name.to_string(),
            coordinates: model.ndof() + if floating { 6 } else { 0 },
            mimics,
            floating,
            interpreted_ns: best,
            pinocchio_aba_ns: aba,
            pinocchio_mimic_ns: mimic.is_finite().then_some(mimic),
            generated_ns: straight.is_finite().then_some(straight),
        });
    }
    Ok(rows)
}

pub const MARKDOWN_HEADER: &str = "| robot | coordinates (+ mimic joints) | base | interpreted q̈ ns | generated q̈ ns | Pinocchio aba ns (every joint a coordinate) | Pinocchio mimic crba + nonLinearEffects ns | interpreted / Pinocchio | generated / Pinocchio |\n|---|---|---|---|---|---|---|---|---|";

/// One markdown row: the ratios against Pinocchio's mimic model where it has one, else its
/// `aba`.
pub fn markdown_line(r: &InterpretedRow) -> String {
    let peer = r.pinocchio_mimic_ns.unwrap_or(r.pinocchio_aba_ns);
    let or_dash = |x: Option<f64>, f: &dyn Fn(f64) -> String| x.map_or("—".to_string(), f);
    format!(
        "| {} | {}{} | {} | {:.0} | {} | {:.0} | {} | **{:.2}** | {} |",
        r.model,
        r.coordinates,
        if r.mimics > 0 {
            format!(" (+ {})", r.mimics)
        } else {
            String::new()
        },
        if r.floating { "floating" } else { "fixed" },
        r.interpreted_ns,
        or_dash(r.generated_ns, &|g| format!("{g:.0}")),
        r.pinocchio_aba_ns,
        or_dash(r.pinocchio_mimic_ns, &|m| format!("{m:.0}")),
        r.interpreted_ns / peer,
        or_dash(r.generated_ns, &|g| format!("**{:.2}**", g / peer)),
    )
}

pub const CSV_HEADER: &str =
    "robot,coordinates,mimics,floating,interpreted_ns,pinocchio_aba_ns,pinocchio_mimic_ns,generated_ns\n";

/// One CSV line (see [`CSV_HEADER`]; the mimic and generated figures empty where none).
pub fn csv_line(r: &InterpretedRow) -> String {
    let or_empty = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:.1}"));
    format!(
        "{},{},{},{},{:.1},{:.1},{},{}\n",
        r.model,
        r.coordinates,
        r.mimics,
        r.floating,
        r.interpreted_ns,
        r.pinocchio_aba_ns,
        or_empty(r.pinocchio_mimic_ns),
        or_empty(r.generated_ns),
    )
}
