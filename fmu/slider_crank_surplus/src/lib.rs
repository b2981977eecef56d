//! The SliderCrankSurplus FMU: this binary carries only this model.
mbfmu::export_fmu!(lagrangian mbfmu::systems::SliderCrankSurplus);
