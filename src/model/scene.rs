//! Scenes: named, configured experiments of a system.

/// One configured experiment: start values (of parameters, states and inputs, by
/// variable name; an input's start value is held constant, a step from t = 0), a stop
/// time, and a one-line description.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub name: &'static str,
    pub description: &'static str,
    pub start_values: Vec<(&'static str, f64)>,
    pub stop_time: f64,
}

impl Scene {
    pub fn new(name: &'static str, description: &'static str, stop_time: f64) -> Self {
        Scene {
            name,
            description,
            start_values: Vec::new(),
            stop_time,
        }
    }

    pub fn set(mut self, name: &'static str, value: f64) -> Self {
        self.start_values.push((name, value));
        self
    }
}
