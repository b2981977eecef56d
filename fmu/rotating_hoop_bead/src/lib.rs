//! The RotatingHoopBead FMU: this binary carries only this model.
mbfmu::export_fmu!(mbfmu::systems::RotatingHoopBead);
