//! The NFourBar FMU: this binary carries only this model.
mbfmu::export_fmu!(mechanism mbfmu::systems::n_four_bar::NFourBarMechanism);
