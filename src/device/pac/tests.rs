//! The device layer against the simulated controller (modes it has) and a
//! fake one (modes it lacks, a silent line).
