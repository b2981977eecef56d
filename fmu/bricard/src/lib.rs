//! The Bricard FMU: this binary carries only this model.
mbfmu::export_fmu!(mechanism mbfmu::systems::bricard::BricardMechanism);
