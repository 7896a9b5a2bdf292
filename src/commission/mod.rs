//! `axisctl commission`: a written plan run over the bench, each check
//! passed or failed against the plan's thresholds, and the handover report.

pub mod figures;
pub mod plan;
pub mod report;
