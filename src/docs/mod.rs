//! What each FMU carries to explain and check itself, computed at package time inside the
//! model's describe answer (so a user's own model gets the same): runs of the model through
//! its own FMU code ([`run`]) and the FMI-LS-REF reference result ([`reference`]).
//! Above `fmi`, `xml`, `linearize`; below `describe`, which ships what it makes.

pub mod reference;
pub mod run;
