//! What Model Exchange declares about a system that its [`System`] declaration does not say
//! in so many words, found by calling it (deterministically, so the XML does not change
//! between runs): whether it has an event indicator, whether [`System::project`] does
//! anything (a constrained system: step events keep it on its constraints), and which
//! states the FMU may change at an event (`reinit="true"`).
//!
//! The probe points are the start values and a perturbation of them off any constraint
//! manifold; a system whose indicator or projection is absent at both (a mode entered only
//! later) would be declared without them, so the systems here are checked by
//! `tests/model_exchange.rs`.

use super::{Layout, System, VarKind};

#[derive(Clone, Debug, PartialEq)]
pub struct Probe {
    /// 1 when the system has an event indicator ([`System::event_indicator`]), else 0.
    pub event_indicators: usize,
    /// Whether [`System::project`] moves a state off its constraints.
    pub projects: bool,
    /// Per state: whether an event may change it (the projection, or
    /// [`System::on_event`]).
    pub reinit: Vec<bool>,
}

impl Probe {
    pub fn of<M: System>(layout: &Layout) -> Probe {
        let start = |kind: VarKind| -> Vec<f64> {
            layout
                .vars
                .iter()
                .filter(|(s, _)| s.kind == kind)
                .map(|(_, v)| v.start)
                .collect()
        };
        let (x0, u, p) = (
            start(VarKind::State),
            start(VarKind::Input),
            start(VarKind::Parameter),
        );
        let n = x0.len();
        // Off the constraints by about a percent (and off zero).
        let x1: Vec<f64> = x0
            .iter()
            .enumerate()
            .map(|(i, &v)| v * (1.0 + 0.0137 * (i + 1) as f64) + 0.0173 * (i + 1) as f64)
            .collect();
        let has_indicator = [&x0, &x1]
            .iter()
            .any(|x| M::event_indicator(0.0, x, &u, &p).is_some());
        let mut reinit = vec![false; n];
        let mut projects = false;
        // At the start point (on the constraints) only a move beyond rounding counts; off
        // them, any move.
        for (x, slack) in [(&x0, 1e-9), (&x1, 0.0)] {
            let mut y = x.to_vec();
            M::project(0.0, &p, &mut y);
            for i in 0..n {
                if (y[i] - x[i]).abs() > slack * x[i].abs().max(1.0) {
                    reinit[i] = true;
                    projects = true;
                }
            }
        }
        if has_indicator {
            for x in [&x0, &x1] {
                let mut y = x.to_vec();
                if M::on_event(0.0, &mut y, &u, &p).is_ok() {
                    for i in 0..n {
                        reinit[i] |= y[i].to_bits() != x[i].to_bits();
                    }
                }
            }
        }
        if has_indicator && M::impacts() {
            reinit.fill(true);
        }
        Probe {
            event_indicators: has_indicator as usize,
            projects,
            reinit,
        }
    }
}
