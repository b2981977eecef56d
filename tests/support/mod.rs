//! Small helpers shared by the Rust integration tests that need no FMU exported into the
//! test binary (those use `tests/common`).
#![allow(dead_code)] // each test crate uses its own part

use mbfmu::systems::slider_crank::{closure, closure_rates};

/// A small deterministic generator (xorshift64*): uniform in [lo, hi).
pub struct Rng(pub u64);

impl Rng {
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        lo + (hi - lo) * (bits as f64 / (1u64 << 53) as f64)
    }
}

/// The slider-crank's surplus state (θ, β, x, θ̇, β̇, ẋ) on its constraints, for crank
/// angle θ and rate θ̇ = `omega` (parameters `p` of `SliderCrankSurplus`).
pub fn surplus_state(theta: f64, omega: f64, p: &[f64]) -> [f64; 6] {
    let (beta, x) = closure(theta, p);
    let (bed, xd) = closure_rates(theta, omega, p);
    [theta, beta, x, omega, bed, xd]
}
