//! What each FMU carries to explain and check itself, computed at package time inside the
//! model's describe answer (so a user's own model gets the same): runs of the model through
//! its own FMU code ([`run`]), the FMI-LS-REF reference result ([`reference`]) and the
//! documentation page ([`page`]: equations in MathML by [`mathml`], scene plots by [`svg`]).
//! Above `fmi`, `xml`, `linearize`; below `describe`, which ships what it makes.

pub mod mathml;
pub mod page;
pub mod reference;
pub mod run;
pub mod svg;
pub mod traced;
