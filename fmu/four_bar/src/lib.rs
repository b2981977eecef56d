//! The FourBar FMU: this binary carries only this model.
mbfmu::export_fmu!(mechanism mbfmu::systems::four_bar::FourBarMechanism);
