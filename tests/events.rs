//! Events located inside doStep: a ball dropped on a floor bounces (coefficient of
//! restitution e) at the instant its height crosses zero, not at the next
//! communication point.

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::model::{Scalar, Scene, System, Var};

struct BouncingBall;

const G: f64 = 9.81;
const E: f64 = 0.5;

impl System for BouncingBall {
    const NAME: &'static str = "BouncingBall";
    const DESCRIPTION: &'static str = "Test model: a ball bouncing on a floor";
    const EQUATIONS: &'static [&'static str] = &["h'' = -g; at h = 0: v <- -e v"];
    fn parameters() -> Vec<Var> {
        vec![]
    }
    fn inputs() -> Vec<Var> {
        vec![]
    }
    fn states() -> Vec<Var> {
        vec![
            Var::new("h", Some("m"), 1.0, "Height"),
            Var::new("v", Some("m/s"), 0.0, "Velocity"),
        ]
    }
    fn outputs() -> Vec<Var> {
        vec![]
    }
    fn derivatives<S: Scalar>(_t: f64, x: &[S], _u: &[S], _p: &[S], dx: &mut [S]) {
        dx[0] = x[1];
        dx[1] = S::from(-G);
    }
    fn extra_outputs<S: Scalar>(_t: f64, _x: &[S], _u: &[S], _p: &[S], _y: &mut [S]) {}
    fn scenes() -> Vec<Scene> {
        vec![]
    }
    fn event_indicator(_t: f64, x: &[f64], _u: &[f64], _p: &[f64]) -> Option<f64> {
        // Falling through the floor; after the bounce (v > 0) the indicator stays positive.
        Some(if x[1] > 0.0 { 1.0 } else { x[0] })
    }
    fn on_event(_t: f64, x: &mut [f64], _u: &[f64], _p: &[f64]) -> Result<(), String> {
        x[1] *= -E;
        Ok(())
    }
}

fn run(h: f64, until: f64) -> (Vec<f64>, u64) {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<BouncingBall>()));
    let mut inst = Instance::<BouncingBall>::new(info, Logger::silent("ball"));
    inst.setup_experiment(Some(1e-10), 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let n = (until / h).round() as usize;
    for i in 0..n {
        assert_eq!(
            inst.do_step(i as f64 * h, h).unwrap(),
            StepOutcome::Completed
        );
    }
    let mut x = vec![0.0; 2];
    let vr = |n: &str| info.layout.vr_of(n).unwrap();
    inst.get_real(&[vr("h"), vr("v")], &mut x).unwrap();
    (x, inst.stats().rhs_evals)
}

#[test]
fn the_bounce_happens_inside_the_step() {
    let t1 = (2.0 / G).sqrt(); // 0.4515 s: inside the step (0.4, 0.5]
    let v1 = E * G * t1;
    let t = 0.6;
    let exact = [
        v1 * (t - t1) - 0.5 * G * (t - t1) * (t - t1),
        v1 - G * (t - t1),
    ];
    for h in [0.1, 0.3, 0.6] {
        let (x, evals) = run(h, t);
        let err = (x[0] - exact[0]).abs().max((x[1] - exact[1]).abs());
        println!(
            "communication step {h}: error {err:.2e} after the bounce ({evals} RHS evaluations)"
        );
        // The motion is quadratic (integrated exactly); the error is the located
        // event time's, ~1e-15 s times the speed.
        assert!(err < 1e-12, "h = {h}: error {err:.3e}");
    }
}
