//! The FlyballGovernor FMU: this binary carries only this model.
mbfmu::export_fmu!(mechanism mbfmu::systems::flyball_governor::FlyballGovernorMechanism);
